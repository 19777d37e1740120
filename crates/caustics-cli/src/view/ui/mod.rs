//! The panels and the view area (egui): input becomes [`Action`]s on the [`Session`].

mod panels;
mod rendering;
mod view_area;

use super::session::{Action, Session, ViewMode};
use egui::TextureHandle;
use panels::side_panel;
use view_area::view_area;

/// What the panels remember between frames.
pub struct UiState {
    /// Fraction of the view area's pixels the camera renders (lower: faster frames).
    pub render_scale: f32,
    mode: Option<DragMode>,
    reference_tex: Option<(u64, TextureHandle, Option<TextureHandle>)>,
    /// The A/B split divider, 0..1 of the view width.
    split: f32,
    /// Show the light markers and the selection box.
    pub overlays: bool,
    /// The panel's "Open…" field: a scene file's path.
    open_path: String,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum DragMode {
    Grab,
    Orbit,
    Pan,
    Split,
}

impl UiState {
    pub fn new(render_scale: f32) -> UiState {
        UiState { render_scale, mode: None, reference_tex: None, split: 0.5, overlays: true, open_path: String::new() }
    }
}

fn act(session: &mut Session, a: Action) {
    // Errors are kept in `session.error` and shown in the panel.
    let _ = session.act(a);
}

/// Draw the whole window's UI for one frame. `display` is the renderer's display texture as
/// registered with egui (None before the first frame).
pub fn draw(ui: &mut egui::Ui, state: &mut UiState, session: &mut Session, display: Option<egui::TextureId>) {
    keys(ui, session);
    egui::Panel::right("side").resizable(true).default_size(330.0).show(ui, |ui| {
        egui::ScrollArea::vertical().show(ui, |ui| side_panel(ui, state, session));
    });
    egui::CentralPanel::no_frame().show(ui, |ui| view_area(ui, state, session, display));
}

fn keys(ui: &mut egui::Ui, session: &mut Session) {
    if ui.ctx().egui_wants_keyboard_input() {
        return;
    }
    let (shot, ab, diff, esc) = ui.input(|i| {
        (
            i.key_pressed(egui::Key::F12) || i.key_pressed(egui::Key::P),
            i.key_pressed(egui::Key::B),
            i.key_pressed(egui::Key::D),
            i.key_pressed(egui::Key::Escape),
        )
    });
    if shot {
        act(session, Action::ScreenshotPair);
    }
    if ab {
        let m = if session.view_mode == ViewMode::Reference { ViewMode::Gpu } else { ViewMode::Reference };
        act(session, Action::SetViewMode(m));
    }
    if diff {
        let m = if session.view_mode == ViewMode::Difference { ViewMode::Gpu } else { ViewMode::Difference };
        act(session, Action::SetViewMode(m));
    }
    if esc {
        act(session, Action::Select(None));
    }
}

/// Apply a slider's value when it is released, or at once when it changed without a drag
/// (keys, clicks): a drag does not redo the frame's light work at every step.
fn released(r: &egui::Response) -> bool {
    r.drag_stopped() || (r.changed() && !r.dragged())
}
