//! The panels and the view area (egui): input becomes [`Action`]s on the [`Session`].

use super::camera::project;
use super::pick::{self, Selection};
use super::reference::Rgba;
use super::session::{Action, Mods, Session, ViewMode};
use caustics::scene::{Light, Material, Shape};
use caustics::splat::SplatMode;
use caustics::techniques::Technique;
use egui::{Align2, Color32, FontId, PointerButton, Pos2, Rect, Sense, Stroke, StrokeKind, TextureHandle, Vec2};
use glam::{Affine3A, Vec3};

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
        UiState { render_scale, mode: None, reference_tex: None, split: 0.5, overlays: true }
    }
}

/// Photon grids offered by the panel.
const PHOTON_GRIDS: [u32; 8] = [64, 128, 256, 512, 1024, 2048, 4096, 8192];

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

fn view_area(ui: &mut egui::Ui, state: &mut UiState, session: &mut Session, display: Option<egui::TextureId>) {
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

fn side_panel(ui: &mut egui::Ui, state: &mut UiState, session: &mut Session) {
    ui.heading(format!("caustics — {}", session.scene().name));
    if let Some(e) = session.error.clone() {
        ui.colored_label(Color32::from_rgb(255, 110, 90), e);
    }
    ui.horizontal(|ui| {
        for m in ViewMode::ALL {
            if ui.selectable_label(session.view_mode == m, m.name()).clicked() {
                act(session, Action::SetViewMode(m));
            }
        }
    });
    ui.separator();
    egui::CollapsingHeader::new("Rendering").default_open(true).show(ui, |ui| rendering(ui, state, session));
    egui::CollapsingHeader::new("Selection").default_open(true).show(ui, |ui| selection(ui, session));
    egui::CollapsingHeader::new("Statistics").default_open(true).show(ui, |ui| stats(ui, session));
    egui::CollapsingHeader::new("CPU reference").default_open(true).show(ui, |ui| reference_panel(ui, session));
    egui::CollapsingHeader::new("Screenshot").default_open(true).show(ui, |ui| {
        ui.horizontal(|ui| {
            if ui.button("PNG + EXR (F12)").clicked() {
                act(session, Action::ScreenshotPair);
            }
            for ext in ["png", "exr"] {
                if ui.button(ext.to_uppercase()).clicked() {
                    let path = session.next_screenshot_stem().with_extension(ext);
                    act(session, Action::Screenshot(path));
                }
            }
        });
        if !session.status.is_empty() {
            ui.label(session.status.clone());
        }
    });
    egui::CollapsingHeader::new("Controls").default_open(false).show(ui, |ui| {
        ui.label(
            "Left drag: orbit (on a light or object: move it in the plane facing you)\n\
             Middle/right or Shift+left drag: pan · Wheel: zoom\n\
             Click: select (on nothing: deselect) · Ctrl+drag: rotate the selected object, aim the selected spot light\n\
             Drag the circle at the end of a spot light's axis: aim it\n\
             F12/P: screenshot (PNG + EXR) · B: A/B (GPU ↔ reference) · D: difference · Esc: deselect",
        );
    });
}

fn rendering(ui: &mut egui::Ui, state: &mut UiState, session: &mut Session) {
    let s = session.settings().clone();
    let mut technique = s.photons.technique;
    egui::ComboBox::from_id_salt("technique").selected_text(technique.name()).show_ui(ui, |ui| {
        for t in Technique::ALL {
            ui.selectable_value(&mut technique, t, t.name());
        }
    });
    if technique != s.photons.technique {
        act(session, Action::SetTechnique(technique));
    }
    let mut splat = s.photons.splat;
    egui::ComboBox::from_id_salt("splat").selected_text(splat.name()).show_ui(ui, |ui| {
        for m in SplatMode::ALL {
            ui.selectable_value(&mut splat, m, m.name());
        }
    });
    if splat != s.photons.splat {
        act(session, Action::SetSplat(splat));
    }
    let mut tracer = s.photons.tracer;
    egui::ComboBox::from_id_salt("tracer").selected_text(format!("{} tracer", tracer.name())).show_ui(ui, |ui| {
        for t in caustics::render::Tracer::ALL {
            ui.selectable_value(&mut tracer, t, t.name()).on_hover_text(t.describe());
        }
    });
    if tracer != s.photons.tracer {
        act(session, Action::SetTracer(tracer));
    }
    let mut surface = s.surface_caustics;
    egui::ComboBox::from_id_salt("surface_caustics")
        .selected_text(format!("surface caustics: {}", surface.name()))
        .show_ui(ui, |ui| {
            for c in caustics::settings::SurfaceCaustics::ALL {
                ui.selectable_value(&mut surface, c, c.name()).on_hover_text(c.describe());
            }
        });
    if surface != s.surface_caustics {
        let mut s2 = s.clone();
        s2.surface_caustics = surface;
        act(session, Action::SetSettings(Box::new(s2)));
    }
    let mut photons = s.photons.count;
    egui::ComboBox::from_id_salt("photons").selected_text(format!("{photons}² photons")).show_ui(ui, |ui| {
        for n in PHOTON_GRIDS {
            ui.selectable_value(&mut photons, n, format!("{n}²"));
        }
    });
    if photons != s.photons.count {
        act(session, Action::SetPhotons(photons));
    }
    let mut tol = s.adaptive.error_tolerance;
    let r = ui.add_enabled(
        s.photons.technique == Technique::AdaptiveError,
        egui::Slider::new(&mut tol, 0.0..=8.0).text("max error tolerance (texels)"),
    );
    if released(&r) {
        act(session, Action::SetTolerance(tol));
    }
    if let Some(rot) = session.renderer().environment_rotation() {
        let mut deg = rot;
        let r = ui.add(egui::Slider::new(&mut deg, -180.0..=180.0).text("environment rotation °"));
        if r.changed() {
            act(session, Action::SetEnvironmentRotation(deg));
        }
        let mut d = s.environment.lights;
        let r = ui.add(egui::Slider::new(&mut d, 1..=96).text("environment lights"));
        if released(&r) {
            let mut s2 = s.clone();
            s2.environment.lights = d;
            act(session, Action::SetSettings(Box::new(s2)));
        }
    }
    medium_and_beams(ui, session);
    let mut reflection = s.photons.reflection;
    if ui.checkbox(&mut reflection, "light reflected at glass").changed() {
        let mut s2 = s.clone();
        s2.photons.reflection = reflection;
        // (every technique: the beams' reflected and residual branches too, as the CLI's
        // photons.reflection = false)
        s2.beams.reflection = reflection;
        act(session, Action::SetSettings(Box::new(s2)));
    }
    let mut temporal = session.temporal();
    if ui.checkbox(&mut temporal, "temporal filter").changed() {
        act(session, Action::SetTemporal(temporal));
    }
    let mut on = session.budget().is_some();
    let mut target = session.budget().map_or(1000.0, |b| b.settings().target_ms);
    ui.horizontal(|ui| {
        let c = ui.checkbox(&mut on, "time budget");
        let r = ui.add_enabled(on, egui::Slider::new(&mut target, 1.0..=20000.0).logarithmic(true).suffix(" ms"));
        if c.changed() || released(&r) {
            act(session, Action::SetBudget(on.then_some(target)));
        }
    });
    if let Some(b) = session.budget() {
        let q = b.quality();
        let tol = q.tolerance.map_or(String::new(), |t| format!(", tolerance {t} texels"));
        let ms = q.frame_ms.map_or("-".into(), |m| format!("{m:.0} ms"));
        let state = if q.settled { "settled" } else { "adjusting" };
        ui.small(format!(
            "budget: {}² photons{tol}, photon frames {ms}, {state} (learns from frames that redo a light)",
            q.grid
        ));
    }
    let mut scale = state.render_scale;
    let r = ui.add(egui::Slider::new(&mut scale, 0.25..=1.0).text("render scale"));
    if r.changed() {
        state.render_scale = scale;
    }
    ui.checkbox(&mut state.overlays, "light markers, selection box");
    let cam = &session.scene().camera;
    ui.label(format!("image {}×{}", cam.width, cam.height));
}

/// The beam grids offered in the panel (cells per side of a light face).
const BEAM_GRIDS: [u32; 5] = [4, 8, 16, 32, 64];

/// Apply a slider's value when it is released, or at once when it changed without a drag
/// (keys, clicks): a drag does not redo the frame's light work at every step.
fn released(r: &egui::Response) -> bool {
    r.drag_stopped() || (r.changed() && !r.dragged())
}

/// Scenes with a participating medium: its density and phase function; with a medium or surface
/// caustics from beams: the beam settings (`caustics::beams`).
fn medium_and_beams(ui: &mut egui::Ui, session: &mut Session) {
    let medium = session.loaded_medium().cloned().zip(session.scene().medium.clone());
    if medium.is_none() && session.settings().surface_caustics != caustics::settings::SurfaceCaustics::Beams {
        return;
    }
    ui.separator();
    if let Some((m0, m)) = medium {
        medium_controls(ui, session, &m0, &m);
    }
    beam_controls(ui, session);
}

/// The medium's density (relative to the scene file, `m0`) and phase function.
fn medium_controls(
    ui: &mut egui::Ui,
    session: &mut Session,
    m0: &caustics::scene::Medium,
    m: &caustics::scene::Medium,
) {
    ui.label("medium");
    let k0 = (m0.sigma_s + m0.sigma_a).element_sum();
    let mut density = if k0 > 0.0 { (m.sigma_s + m.sigma_a).element_sum() / k0 } else { 1.0 };
    let r = ui
        .add(egui::Slider::new(&mut density, 0.0..=4.0).text("density × scene"))
        .on_hover_text("σs and σa times this (the scene file's values at 1)");
    if released(&r) {
        act(
            session,
            Action::SetMedium { sigma_s: m0.sigma_s * density, sigma_a: m0.sigma_a * density, phase: m.phase },
        );
    }
    let mut g = match m.phase {
        caustics::scene::Phase::Isotropic => 0.0,
        caustics::scene::Phase::HenyeyGreenstein { g } => g,
    };
    let r = ui
        .add(egui::Slider::new(&mut g, -0.95..=0.95).text("phase g"))
        .on_hover_text("Henyey-Greenstein anisotropy (0: isotropic, > 0: forward scattering)");
    if released(&r) {
        let phase =
            if g == 0.0 { caustics::scene::Phase::Isotropic } else { caustics::scene::Phase::HenyeyGreenstein { g } };
        act(session, Action::SetMedium { sigma_s: m.sigma_s, sigma_a: m.sigma_a, phase });
    }
    let s = session.settings().clone();
    let mut grid = s.medium.bounce_grid;
    let r = ui.add(egui::Slider::new(&mut grid, 0..=32).text("lit-surface glow")).on_hover_text(
        "The light lit surfaces and the fog exchange: virtual point lights per side of each light face (0: off)",
    );
    if released(&r) && grid != s.medium.bounce_grid {
        act(
            session,
            Action::SetSettings(Box::new(caustics::render::RenderSettings {
                medium: caustics::settings::MediumSettings { bounce_grid: grid, ..s.medium },
                ..s.clone()
            })),
        );
    }
    let mut beyond = s.medium.beyond_specular;
    let r = ui.checkbox(&mut beyond, "fog seen through glass").on_hover_text(
        "The medium along the camera rays beyond glass and mirrors: attenuation and the fog's light (off: cheaper)",
    );
    if r.changed() {
        act(
            session,
            Action::SetSettings(Box::new(caustics::render::RenderSettings {
                medium: caustics::settings::MediumSettings { beyond_specular: beyond, ..s.medium },
                ..s
            })),
        );
    }
}

/// The beams' settings: the volume caustic (scenes with a medium), the beam grid and how the
/// beams are drawn (hulls or the gather), also used by surface caustics from beams.
fn beam_controls(ui: &mut egui::Ui, session: &mut Session) {
    let s = session.settings().clone();
    let mut b = s.beams;
    if session.scene().medium.is_some() {
        ui.checkbox(&mut b.enabled, "volume caustics (beams)");
    }
    let mut changed = b.enabled != s.beams.enabled;
    let used = b.enabled || s.surface_caustics == caustics::settings::SurfaceCaustics::Beams;
    ui.add_enabled_ui(used, |ui| {
        egui::ComboBox::from_id_salt("beam_grid").selected_text(format!("beam grid {}²", b.grid)).show_ui(ui, |ui| {
            for n in BEAM_GRIDS {
                ui.selectable_value(&mut b.grid, n, format!("{n}²"));
            }
        });
        changed |= b.grid != s.beams.grid;
        egui::ComboBox::from_id_salt("beam_volume").selected_text(format!("beams drawn: {}", b.volume)).show_ui(
            ui,
            |ui| {
                for v in caustics::render::BeamVolume::ALL {
                    ui.selectable_value(&mut b.volume, v, v.name()).on_hover_text(v.describe());
                }
            },
        );
        changed |= b.volume != s.beams.volume;
        let sliders = [
            ui.add(egui::Slider::new(&mut b.levels, 0..=6).text("beam levels")),
            ui.add(egui::Slider::new(&mut b.normal_threshold_deg, 1.0..=90.0).text("normal threshold °")),
            ui.add(egui::Slider::new(&mut b.depth_threshold, 0.01..=1.0).logarithmic(true).text("depth threshold")),
            ui.add(egui::Slider::new(&mut b.energy_threshold, 0.001..=1.0).logarithmic(true).text("energy threshold")),
            ui.add(egui::Slider::new(&mut b.camera_threshold, 0.01..=1.0).logarithmic(true).text("camera threshold")),
            ui.add(egui::Slider::new(&mut b.linearity_threshold, 0.0..=1.0).text("linearity threshold")),
            ui.add(egui::Slider::new(&mut b.residual, 0.0..=0.9).text("residual branch p"))
                .on_hover_text("the residual branch's probability of reflecting at each interface (0: off)"),
            ui.add(
                egui::Slider::new(&mut b.cutoff, 0.0..=10.0)
                    .logarithmic(true)
                    .smallest_positive(1e-4)
                    .text("energy cutoff W/(m² sr)"),
            )
            .on_hover_text("diverging beams end where the rest of their light is below this radiance (0: off)"),
            ui.add(egui::Slider::new(&mut b.pixel_samples, 1..=4).text("rays per pixel side")),
            ui.add(egui::Slider::new(&mut b.surface_samples, 1..=8).text("surface points per pixel side")),
        ];
        changed |= sliders.iter().any(released);
    });
    if changed && b != s.beams {
        let mut s2 = s.clone();
        s2.beams = b;
        act(session, Action::SetSettings(Box::new(s2)));
    }
}

fn selection(ui: &mut egui::Ui, session: &mut Session) {
    let scene = session.scene().clone();
    let mut sel = session.selection;
    egui::ComboBox::from_id_salt("select")
        .selected_text(match sel {
            None => "nothing selected".to_string(),
            Some(Selection::Light(i)) => format!("light {i} ({})", scene.lights[i].kind()),
            Some(Selection::Object(i)) => format!("object {i}"),
        })
        .show_ui(ui, |ui| {
            ui.selectable_value(&mut sel, None, "nothing");
            for (i, l) in scene.lights.iter().enumerate() {
                ui.selectable_value(&mut sel, Some(Selection::Light(i)), format!("light {i} ({})", l.kind()));
            }
            for (i, o) in scene.objects.iter().enumerate() {
                let m = scene.material_names.get(o.material).cloned().unwrap_or_default();
                ui.selectable_value(
                    &mut sel,
                    Some(Selection::Object(i)),
                    format!("object {i} ({}, {m})", shape_name(&o.shape)),
                );
            }
        });
    if sel != session.selection {
        act(session, Action::Select(sel));
    }
    match sel {
        Some(Selection::Light(i)) => light_panel(ui, session, i, &scene.lights[i]),
        Some(Selection::Object(i)) => object_panel(ui, session, i),
        None => {}
    }
}

fn shape_name(s: &Shape) -> &'static str {
    match s {
        Shape::Sphere { .. } => "sphere",
        Shape::Rectangle { .. } => "rectangle",
        Shape::Cylinder { .. } => "cylinder",
        Shape::Mesh(_) => "mesh",
    }
}

fn vec3_edit(ui: &mut egui::Ui, v: &mut Vec3, speed: f32) -> bool {
    let mut changed = false;
    ui.horizontal(|ui| {
        for (label, c) in [("x", &mut v.x), ("y", &mut v.y), ("z", &mut v.z)] {
            changed |= ui.add(egui::DragValue::new(c).speed(speed).prefix(format!("{label} "))).changed();
        }
    });
    changed
}

fn light_panel(ui: &mut egui::Ui, session: &mut Session, i: usize, light: &Light) {
    let mut l = light.clone();
    let mut changed = false;
    match &mut l {
        Light::Spot { position, direction, cone_angle, falloff_start, .. } => {
            ui.label("position");
            changed |= vec3_edit(ui, position, 0.01);
            let (mut az, mut el) = pick::direction_angles(*direction);
            changed |= ui.add(egui::Slider::new(&mut az, -180.0..=180.0).text("azimuth °")).changed();
            changed |= ui.add(egui::Slider::new(&mut el, -90.0..=90.0).text("elevation °")).changed();
            *direction = pick::direction_from_angles(az, el);
            let mut cone = cone_angle.to_degrees();
            let mut fall = falloff_start.to_degrees();
            changed |= ui.add(egui::Slider::new(&mut cone, 1.0..=89.0).text("cone °")).changed();
            changed |= ui.add(egui::Slider::new(&mut fall, 0.0..=89.0).text("falloff start °")).changed();
            fall = fall.min(cone);
            *cone_angle = cone.to_radians();
            *falloff_start = fall.to_radians();
        }
        Light::Point { position, .. } => {
            ui.label("position");
            changed |= vec3_edit(ui, position, 0.01);
        }
        Light::Directional { direction, .. } => {
            let (mut az, mut el) = pick::direction_angles(*direction);
            changed |= ui.add(egui::Slider::new(&mut az, -180.0..=180.0).text("azimuth °")).changed();
            changed |= ui.add(egui::Slider::new(&mut el, -90.0..=90.0).text("elevation °")).changed();
            *direction = pick::direction_from_angles(az, el);
        }
    }
    if changed {
        act(session, Action::SetLight(i, l));
    }
}

fn object_panel(ui: &mut egui::Ui, session: &mut Session, i: usize) {
    let t = session.renderer().object_transform(i).unwrap_or(Affine3A::IDENTITY);
    let mut tr: Vec3 = t.translation.into();
    ui.label("translation (from the scene file's pose)");
    if vec3_edit(ui, &mut tr, 0.01) {
        let mut t2 = t;
        t2.translation = tr.into();
        act(session, Action::SetObjectTransform(i, t2));
    }
    ui.horizontal(|ui| {
        let centre = session.scene().objects.get(i).map(|o| pick::centre(&o.shape)).unwrap_or(Vec3::ZERO);
        for (label, yaw) in [("rotate +15°", 15f32), ("rotate −15°", -15.0)] {
            if ui.button(label).clicked() {
                let t2 = pick::rotated_about(t, centre, Vec3::Y, Vec3::X, yaw.to_radians(), 0.0);
                act(session, Action::SetObjectTransform(i, t2));
            }
        }
        if ui.button("reset").clicked() {
            act(session, Action::SetObjectTransform(i, Affine3A::IDENTITY));
        }
    });
    if let Some((m, Material::Dielectric { ior, .. })) = session.material_of(i) {
        let mut v = ior;
        let r = ui.add(egui::Slider::new(&mut v, 1.0..=2.5).text("IOR"));
        if released(&r) && v != ior {
            act(session, Action::SetIor { material: m, ior: v });
        }
    }
}

fn stats(ui: &mut egui::Ui, session: &Session) {
    match session.frame_ms {
        Some(ms) => ui.label(format!("frame {ms:.1} ms (host clock, record to GPU done)")),
        None => ui.label("frame: —"),
    };
    ui.label(format!("frames rendered: {}", session.frames()));
    let Some(s) = &session.stats else { return };
    let t = &s.technique;
    ui.label(format!(
        "photons: {} traced, {} splatted ({} {}²)",
        t.photons_traced, t.photons_splatted, t.technique, t.grid
    ));
    let redone: Vec<String> = s
        .lights_redone
        .iter()
        .enumerate()
        .map(|(i, r)| format!("{i}: {}", if *r { "redone" } else { "kept" }))
        .collect();
    ui.label(format!("lights {}", redone.join(", ")));
    for (i, f) in s.flux.iter().enumerate() {
        ui.label(format!(
            "light {i}: {:.4} W emitted onto casters, {:.4} W landed; lost {:.4} W (no exit {:.4}, TIR {:.4}, no receiver {:.4}, outside {:.4}); {:.4} W in branches not traced",
            f.emitted,
            f.landed,
            f.lost_no_exit + f.lost_tir + f.lost_no_receiver + f.lost_outside,
            f.lost_no_exit,
            f.lost_tir,
            f.lost_no_receiver,
            f.lost_outside,
            f.untraced_branches
        ));
    }
    if s.timings.is_empty() {
        ui.label("GPU pass timings: unavailable (no timestamp queries)");
    } else {
        egui::Grid::new("passes").num_columns(2).striped(true).show(ui, |ui| {
            let mut total = 0.0;
            for (name, ms) in &s.timings {
                ui.monospace(name);
                ui.monospace(format!("{ms:8.3} ms"));
                ui.end_row();
                total += ms;
            }
            ui.strong("GPU total");
            ui.monospace(format!("{total:8.3} ms"));
            ui.end_row();
        });
    }
}

fn reference_panel(ui: &mut egui::Ui, session: &mut Session) {
    let mut exp = (session.reference_settings.photons_per_light as f64).log2().round() as u32;
    let mut spp = session.reference_settings.camera_spp;
    ui.add(egui::Slider::new(&mut exp, 14..=28).text("photons 2^k per light"));
    ui.add(egui::Slider::new(&mut spp, 1..=64).text("camera samples per pixel"));
    session.reference_settings.photons_per_light = 1u64 << exp;
    session.reference_settings.camera_spp = spp;
    match session.reference_progress() {
        Some(f) => {
            ui.add(egui::ProgressBar::new(f as f32).show_percentage());
            if ui.button("cancel").clicked() {
                act(session, Action::CancelReference);
            }
        }
        None => {
            if ui.button("compute the reference of this view").clicked() {
                act(session, Action::StartReference);
            }
        }
    }
    match session.reference() {
        Some(r) => {
            ui.label(format!("reference of this view: {:.1} s", r.seconds));
            if let Some(m) = r.rel_mse {
                ui.label(format!("relative MSE of the GPU image: {m:.4}"));
            }
            if let Some((_, d)) = &r.diff {
                ui.label(format!("mean |difference| (tone-mapped): {:.2} %", d * 100.0));
            }
            match r.flip {
                Some(f) => {
                    ui.label(format!("HDR-FLIP: {f:.4}"));
                }
                None => {
                    if ui.button("HDR-FLIP against the reference").clicked() {
                        act(session, Action::ComputeFlip);
                    }
                }
            }
        }
        None => {
            ui.label(
                "A/B, split and difference views compute it automatically; it is cancelled when the view changes.",
            );
        }
    }
}
