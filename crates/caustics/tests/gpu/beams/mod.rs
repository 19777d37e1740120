//! Volume caustics by adaptive beam tracing (`caustics::beams`): the beams' area function, the
//! single-scattering gather against closed forms and an independent CPU integration, splitting
//! and tiling, the ball lens's focus, flux conservation, and the GPU against the CPU reference.
//! Surface caustics from beams (`LocalSource::Beams`): the beams' flux onto a floor, the
//! photon caustic map on the same frame, no double counting, shadowed receivers, determinism.

use crate::common;

mod flux;
mod gather;
mod pipeline;
mod surface;
mod volume;

use crate::shared::fresnel;
use caustics::Scene;
use caustics::beams::{self, Beam};
use caustics::render::{RenderSettings, render};
use caustics::settings::BeamSettings;
use common::gpu;
use glam::Vec3;
use std::path::Path;

fn scene(json: &str) -> Scene {
    Scene::from_json(json, "beams.json", Path::new(".")).unwrap_or_else(|e| panic!("{e}"))
}

fn sum(img: &caustics::image_io::Image) -> f64 {
    img.pixels.iter().map(|p| f64::from(p[0])).sum()
}

/// A glass ball (radius 0.5, IOR 1.5, centre at height 1.5) under a spot light 2.5 m above its
/// centre, in fog, over a black floor; the camera looks at it from the side.
fn ball_in_fog(falloff_start: f32, w: u32, h: u32) -> Scene {
    scene(&format!(
        r#"{{ "schema_version": 1, "name": "ball_fog",
  "camera": {{ "position": [0, 1.0, 3.2], "look_at": [0, 0.9, 0], "fov_y_deg": 40, "width": {w}, "height": {h} }},
  "lights": [ {{ "type": "spot", "position": [0, 4, 0], "direction": [0, -1, 0], "cone_angle_deg": 14, "falloff_start_deg": {falloff_start}, "intensity": [20, 20, 20] }} ],
  "materials": {{ "black": {{ "type": "diffuse", "albedo": 0 }}, "glass": {{ "type": "dielectric", "ior": 1.5 }} }},
  "objects": [ {{ "type": "sphere", "center": [0, 1.5, 0], "radius": 0.5, "material": "glass" }},
               {{ "type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [8, 8], "material": "black" }} ],
  "medium": {{ "sigma_s": 0.3, "sigma_a": 0.05, "phase": {{ "type": "isotropic" }},
              "bounds": {{ "min": [-4, -0.1, -4], "max": [4, 4.5, 4] }} }} }}"#
    ))
}

fn render_settings(b: BeamSettings) -> RenderSettings {
    RenderSettings {
        photons: caustics::settings::PhotonSettings { count: 64, caustic_map_size: 64, ..Default::default() },
        shading: caustics::settings::ShadingSettings { shadow_map_size: 256, ..Default::default() },
        beams: b,
        // (single scattering: the tests compare with the reference's single-scattering mode)
        medium: caustics::settings::MediumSettings { multiple_photons: 0, ..Default::default() },
        ..Default::default()
    }
}

/// A glass ball (R 0.5, IOR 1.5, centre 1.5 m up) lit at 45° by a uniform spot 4.24 m away, no
/// medium; the ball focuses the light onto the floor (albedo 0.5) around (1.5, 0, 0). The
/// camera looks straight down at that part of the floor from 4 m (40°: the ball is out of view,
/// so the caustic-only image is the floor's caustic and nothing else). With `table`, a small
/// diffuse square (object 2) at 0.3 m over the floor catches part of the caustic.
fn ball_at_45(w: u32, h: u32, table: bool) -> Scene {
    let table = if table {
        r#", { "type": "rectangle", "center": [1.5, 0.3, 0], "normal": [0, 1, 0], "size": [0.5, 0.5], "material": "floor" }"#
    } else {
        ""
    };
    scene(&format!(
        r#"{{ "schema_version": 1, "name": "ball_45",
  "camera": {{ "position": [1.8, 4, 0], "look_at": [1.8, 0, 0], "up": [0, 0, -1], "fov_y_deg": 40, "width": {w}, "height": {h} }},
  "lights": [ {{ "type": "spot", "position": [-3, 4.5, 0], "direction": [1, -1, 0], "cone_angle_deg": 10, "falloff_start_deg": 10, "intensity": [20, 20, 20] }} ],
  "materials": {{ "floor": {{ "type": "diffuse", "albedo": 0.5 }}, "glass": {{ "type": "dielectric", "ior": 1.5 }} }},
  "objects": [ {{ "type": "sphere", "center": [0, 1.5, 0], "radius": 0.5, "material": "glass" }},
               {{ "type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [12, 12], "material": "floor" }}{table} ] }}"#
    ))
}

fn surface_settings(sc: caustics::settings::LocalSource) -> RenderSettings {
    RenderSettings {
        photons: caustics::settings::PhotonSettings {
            count: 256,
            caustic_map_size: 256,
            ..render_settings(BeamSettings::default()).photons
        },
        sources: caustics::settings::SourceSettings { local: sc, ..Default::default() },
        ..render_settings(BeamSettings::default())
    }
}

/// Where world point p projects in the camera's image (pixels), if in front of it.
fn project(sc: &Scene, p: Vec3) -> Option<(f32, f32)> {
    let cam = &sc.camera;
    let q = p - cam.position;
    let z = q.dot(cam.forward());
    if z <= 0.0 {
        return None;
    }
    let t = (cam.fov_y_deg.to_radians() * 0.5).tan();
    let sx = q.dot(cam.right()) / z / (t * cam.aspect());
    let sy = q.dot(cam.true_up()) / z / t;
    Some(((sx + 1.0) * 0.5 * cam.width as f32, (1.0 - sy) * 0.5 * cam.height as f32))
}
