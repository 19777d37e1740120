//! The side panel: the view modes, and its sections other than the rendering settings:
//! selection (lights, objects), statistics, the CPU reference, screenshots, controls.

use super::rendering::rendering;
use super::{UiState, act, released};
use crate::view::pick::{self, Selection};
use crate::view::session::{Action, Session, ViewMode};
use caustics::scene::{Light, Material, Shape};
use egui::Color32;
use glam::{Affine3A, Vec3};

pub(super) fn side_panel(ui: &mut egui::Ui, state: &mut UiState, session: &mut Session) {
    ui.heading(format!("caustics — {}", session.scene().name));
    if let Some(e) = session.error.clone() {
        ui.colored_label(Color32::from_rgb(255, 110, 90), e);
    }
    ui.horizontal(|ui| {
        // Open…: a scene file's path (or drop the file on the window).
        let field = ui.add(
            egui::TextEdit::singleline(&mut state.open_path)
                .hint_text("scene.json, .gltf, .glb (or drop a file)")
                .desired_width(220.0),
        );
        let enter = field.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
        if (ui.button("Open…").clicked() || enter) && !state.open_path.trim().is_empty() {
            act(session, Action::Open(std::path::PathBuf::from(state.open_path.trim())));
        }
    });
    ui.horizontal(|ui| {
        for m in ViewMode::ALL {
            if ui.selectable_label(session.view_mode == m, m.name()).clicked() {
                act(session, Action::SetViewMode(m));
            }
        }
    });
    ui.separator();
    egui::CollapsingHeader::new("Rendering").default_open(true).show(ui, |ui| rendering(ui, state, session));
    if session.animated() {
        egui::CollapsingHeader::new("Animation").default_open(true).show(ui, |ui| animation(ui, session));
    }
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

/// Play and pause the scene's waves, or pick a time.
fn animation(ui: &mut egui::Ui, session: &mut Session) {
    ui.horizontal(|ui| {
        let playing = session.playing();
        if ui.button(if playing { "⏸ pause" } else { "▶ play" }).clicked() {
            act(session, Action::Play(!playing));
        }
        let mut t = session.time();
        let slider = egui::Slider::new(&mut t, 0.0..=60.0).suffix(" s").text("time");
        if ui.add(slider).changed() {
            act(session, Action::SetTime(t));
        }
    });
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
