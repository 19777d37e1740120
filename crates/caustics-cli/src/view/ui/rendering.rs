//! The side panel's "Rendering" section: technique, splat, tracer, photons, temporal filter,
//! time budget, render scale, and the participating medium's and beams' settings.

use super::{UiState, act, released};
use crate::view::session::{Action, Session};
use caustics::settings::Emission;
use caustics::splat::SplatMode;

/// Photon grids offered by the panel.
const PHOTON_GRIDS: [u32; 8] = [64, 128, 256, 512, 1024, 2048, 4096, 8192];

pub(super) fn rendering(ui: &mut egui::Ui, state: &mut UiState, session: &mut Session) {
    let s = session.settings().clone();
    let mut technique = s.photons.emission;
    egui::ComboBox::from_id_salt("technique").selected_text(technique.name()).show_ui(ui, |ui| {
        for t in Emission::ALL {
            ui.selectable_value(&mut technique, t, t.name());
        }
    });
    if technique != s.photons.emission {
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
    let mut surface = s.sources.local;
    egui::ComboBox::from_id_salt("surface_caustics")
        .selected_text(format!("surface caustics: {}", surface.name()))
        .show_ui(ui, |ui| {
            for c in caustics::settings::LocalSource::ALL {
                ui.selectable_value(&mut surface, c, c.name()).on_hover_text(c.describe());
            }
        });
    let mut distant = s.sources.distant;
    egui::ComboBox::from_id_salt("distant_caustics")
        .selected_text(format!("directional lights: {}", distant.name()))
        .show_ui(ui, |ui| {
            for c in caustics::settings::DistantSource::ALL {
                ui.selectable_value(&mut distant, c, c.name()).on_hover_text(c.describe());
            }
        });
    if (surface, distant) != (s.sources.local, s.sources.distant) {
        let mut s2 = s.clone();
        (s2.sources.local, s2.sources.distant) = (surface, distant);
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
        s.photons.emission == Emission::AdaptiveError,
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
    let mut bounce = s.indirect.active();
    let r = ui.checkbox(&mut bounce, "light that bounces").on_hover_text(
        "Diffuse interreflection: light reaching a surface after bouncing off another, from a cache photons fill \
         (indirect.photons, refined over indirect.history frames; off: the first diffuse hit only)",
    );
    if r.changed() {
        let mut s2 = s.clone();
        s2.indirect.photons = if bounce { caustics::settings::indirect::VIEWER_PHOTONS } else { 0 };
        s2.indirect.history = if bounce { caustics::settings::indirect::VIEWER_HISTORY } else { 1 };
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

/// Scenes with a participating medium: its density and phase function; with a medium or surface
/// caustics from beams: the beam settings (`caustics::beams`).
fn medium_and_beams(ui: &mut egui::Ui, session: &mut Session) {
    let medium = session.loaded_medium().cloned().zip(session.scene().medium.clone());
    if medium.is_none() && session.settings().sources.local != caustics::settings::LocalSource::Beams {
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
    let mut multiple = s.medium.multiple_photons > 0;
    let r = ui.checkbox(&mut multiple, "multiple scattering").on_hover_text(
        "Light scattered twice or more in the fog, from a grid photons fill (off: single scattering only, cheaper)",
    );
    if r.changed() {
        let multiple_photons =
            if multiple { caustics::settings::MediumSettings::default().multiple_photons } else { 0 };
        act(
            session,
            Action::SetSettings(Box::new(caustics::render::RenderSettings {
                medium: caustics::settings::MediumSettings { multiple_photons, ..s.medium },
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
    let mut volume = s.sources.volume == caustics::settings::VolumeSource::Beams;
    if session.scene().medium.is_some() {
        ui.checkbox(&mut volume, "volume caustics (beams)");
    }
    let mut changed = volume != (s.sources.volume == caustics::settings::VolumeSource::Beams);
    let used = volume || s.sources.local == caustics::settings::LocalSource::Beams;
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
    let mut s2 = s.clone();
    s2.beams = b;
    use caustics::settings::VolumeSource;
    s2.sources.volume = if volume { VolumeSource::Beams } else { VolumeSource::None };
    if changed && s2 != s {
        act(session, Action::SetSettings(Box::new(s2)));
    }
}
