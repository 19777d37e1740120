//! The view area: the rendered image (or the reference, the A/B split, the difference), pointer
//! input (grab, orbit, pan, zoom, the split divider) and the overlays.

use super::{DragMode, UiState, act};
use crate::view::camera::project;
use crate::view::pick::{self, Selection};
use crate::view::reference::Rgba;
use crate::view::session::{Action, Mods, Session, ViewMode};
use egui::{Align2, Color32, FontId, PointerButton, Pos2, Rect, Sense, Stroke, StrokeKind, Vec2};
use glam::Vec3;

pub(super) fn view_area(
    ui: &mut egui::Ui,
    state: &mut UiState,
    session: &mut Session,
    display: Option<egui::TextureId>,
) {
    let rect = ui.available_rect_before_wrap();
    let ppp = ui.ctx().pixels_per_point();
    let w = ((rect.width() * ppp * state.render_scale).round() as u32).max(16);
    let h = ((rect.height() * ppp * state.render_scale).round() as u32).max(16);
    if !session.dragging() {
        act(session, Action::Resize { width: w, height: h });
    }
    let cam = session.scene().camera.clone();
    let to_px = |p: Pos2| -> (f32, f32) {
        (
            (p.x - rect.min.x) / rect.width().max(1.0) * cam.width as f32,
            (p.y - rect.min.y) / rect.height().max(1.0) * cam.height as f32,
        )
    };
    let to_screen = |q: glam::Vec2| {
        rect.min + Vec2::new(q.x / cam.width as f32 * rect.width(), q.y / cam.height as f32 * rect.height())
    };

    // The image(s).
    let painter = ui.painter_at(rect);
    painter.rect_filled(rect, 0.0, Color32::from_gray(24));
    let full_uv = Rect::from_min_max(Pos2::ZERO, Pos2::new(1.0, 1.0));
    if let Some(r) = session.reference() {
        let stale = state.reference_tex.as_ref().is_none_or(|(v, ..)| *v != r.version);
        if stale {
            let up = |name: &str, img: &Rgba| {
                ui.ctx().load_texture(
                    name,
                    egui::ColorImage::from_rgba_unmultiplied([img.width as usize, img.height as usize], &img.pixels),
                    egui::TextureOptions::LINEAR,
                )
            };
            let diff = r.diff.as_ref().map(|(d, _)| up("difference", d));
            state.reference_tex = Some((r.version, up("reference", &r.rgba), diff));
        }
    } else {
        state.reference_tex = None;
    }
    let reference = state.reference_tex.as_ref().map(|(_, t, _)| t.id());
    let difference = state.reference_tex.as_ref().and_then(|(_, _, d)| d.as_ref().map(|d| d.id()));
    let waiting = |painter: &egui::Painter, what: &str| {
        painter.text(rect.center(), Align2::CENTER_CENTER, what, FontId::proportional(18.0), Color32::LIGHT_GRAY);
    };
    match session.view_mode {
        ViewMode::Gpu => {
            if let Some(t) = display {
                painter.image(t, rect, full_uv, Color32::WHITE);
            }
        }
        ViewMode::Reference => match reference {
            Some(t) => {
                painter.image(t, rect, full_uv, Color32::WHITE);
            }
            None => waiting(&painter, "computing the CPU reference…"),
        },
        ViewMode::Difference => match difference {
            Some(t) => {
                painter.image(t, rect, full_uv, Color32::WHITE);
            }
            None => waiting(&painter, "computing the CPU reference…"),
        },
        ViewMode::Split => {
            let x = rect.min.x + rect.width() * state.split;
            if let Some(t) = display {
                let r = Rect::from_min_max(rect.min, Pos2::new(x, rect.max.y));
                painter.image(t, r, Rect::from_min_max(Pos2::ZERO, Pos2::new(state.split, 1.0)), Color32::WHITE);
            }
            match reference {
                Some(t) => {
                    let r = Rect::from_min_max(Pos2::new(x, rect.min.y), rect.max);
                    painter.image(
                        t,
                        r,
                        Rect::from_min_max(Pos2::new(state.split, 0.0), Pos2::new(1.0, 1.0)),
                        Color32::WHITE,
                    );
                }
                None => waiting(&painter, "computing the CPU reference…"),
            }
            painter
                .line_segment([Pos2::new(x, rect.min.y), Pos2::new(x, rect.max.y)], Stroke::new(2.0, Color32::WHITE));
            painter.text(
                rect.min + Vec2::new(8.0, 8.0),
                Align2::LEFT_TOP,
                "GPU",
                FontId::proportional(14.0),
                Color32::WHITE,
            );
            painter.text(
                Pos2::new(rect.max.x - 8.0, rect.min.y + 8.0),
                Align2::RIGHT_TOP,
                "CPU reference",
                FontId::proportional(14.0),
                Color32::WHITE,
            );
        }
    }
    if state.overlays && matches!(session.view_mode, ViewMode::Gpu | ViewMode::Split) {
        overlays(&painter, session, &to_screen);
    }

    // Input.
    let resp = ui.interact(rect, ui.scope_id().with("view"), Sense::click_and_drag());
    let mods = ui.input(|i| i.modifiers);
    let origin = ui.input(|i| i.pointer.press_origin());
    let pos = resp.interact_pointer_pos();
    if resp.drag_started() {
        let split_x = rect.min.x + rect.width() * state.split;
        state.mode =
            if resp.dragged_by(PointerButton::Middle) || resp.dragged_by(PointerButton::Secondary) || mods.shift {
                Some(DragMode::Pan)
            } else if session.view_mode == ViewMode::Split && origin.is_some_and(|o| (o.x - split_x).abs() < 6.0) {
                Some(DragMode::Split)
            } else if let Some(o) = origin {
                let (x, y) = to_px(o);
                act(session, Action::Press { x, y, mods: Mods { rotate: mods.command || mods.ctrl } });
                Some(if session.dragging() { DragMode::Grab } else { DragMode::Orbit })
            } else {
                Some(DragMode::Orbit)
            };
    }
    // (A slow frame can deliver the last motion and the release in one pass: apply the motion
    // before the release.)
    if resp.dragged() || resp.drag_stopped() {
        let d = resp.drag_delta() * ppp * state.render_scale;
        match state.mode {
            Some(DragMode::Grab) => {
                if let Some(p) = pos.or_else(|| ui.input(|i| i.pointer.latest_pos())) {
                    let (x, y) = to_px(p);
                    act(session, Action::Drag { x, y });
                }
            }
            Some(DragMode::Orbit) if d != Vec2::ZERO => act(session, Action::Orbit { dx: d.x, dy: d.y }),
            Some(DragMode::Pan) if d != Vec2::ZERO => act(session, Action::Pan { dx: d.x, dy: d.y }),
            Some(DragMode::Split) => {
                if let Some(p) = pos {
                    state.split = ((p.x - rect.min.x) / rect.width().max(1.0)).clamp(0.0, 1.0);
                }
            }
            _ => {}
        }
    }
    if resp.drag_stopped() {
        state.mode = None;
        act(session, Action::Release);
    }
    if resp.clicked()
        && let Some(p) = pos
    {
        let (x, y) = to_px(p);
        act(session, Action::Press { x, y, mods: Mods::default() });
        if !session.dragging() {
            act(session, Action::Select(None));
        }
        act(session, Action::Release);
    }
    if resp.hovered() {
        let scroll = ui.input(|i| i.smooth_scroll_delta.y);
        if scroll != 0.0 {
            act(session, Action::Zoom { steps: scroll / 50.0 });
        }
    }
}

/// Light markers (spot: with its axis), and the selected object's projected bounds.
fn overlays(painter: &egui::Painter, session: &Session, to_screen: &dyn Fn(glam::Vec2) -> Pos2) {
    let scene = session.scene();
    let cam = &scene.camera;
    for (i, l) in scene.lights.iter().enumerate() {
        let Some(p) = l.position() else { continue };
        let Some((q, _)) = project(cam, p) else { continue };
        let selected = session.selection == Some(Selection::Light(i));
        let c = to_screen(q);
        let colour = if selected { Color32::WHITE } else { Color32::from_rgb(255, 210, 60) };
        painter.circle_filled(c, if selected { 6.0 } else { 4.5 }, Color32::from_rgb(255, 210, 60));
        painter.circle_stroke(c, 9.0, Stroke::new(1.5, colour));
        if let Some(h) = pick::spot_handle(scene, i)
            && let Some((q2, _)) = project(cam, h)
        {
            let e = to_screen(q2);
            painter.line_segment([c, e], Stroke::new(1.5, colour));
            painter.circle_stroke(e, 4.0, Stroke::new(1.5, colour));
        }
    }
    if let Some(Selection::Object(i)) = session.selection
        && let Some(o) = scene.objects.get(i)
    {
        let (a, b) = o.shape.bounds();
        let mut min = Pos2::new(f32::INFINITY, f32::INFINITY);
        let mut max = Pos2::new(f32::NEG_INFINITY, f32::NEG_INFINITY);
        let mut all = true;
        for k in 0..8 {
            let p = Vec3::new(
                if k & 1 == 0 { a.x } else { b.x },
                if k & 2 == 0 { a.y } else { b.y },
                if k & 4 == 0 { a.z } else { b.z },
            );
            match project(cam, p) {
                Some((q, _)) => {
                    let s = to_screen(q);
                    min = min.min(s);
                    max = max.max(s);
                }
                None => all = false,
            }
        }
        if all {
            painter.rect_stroke(
                Rect::from_min_max(min, max),
                2.0,
                Stroke::new(1.5, Color32::from_rgb(90, 200, 255)),
                StrokeKind::Outside,
            );
        }
    }
}
