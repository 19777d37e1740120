//! Direct light in a participating medium on the GPU (`medium_scatter`, the attenuation in
//! `shade_receivers`): exact absorption, single scattering against the CPU reference, light
//! shafts shadowed by objects, and the renderer's steady state with a medium; heterogeneous
//! media (a density grid): absorption through two slabs against the closed form, single
//! scattering in a smoke puff against the CPU reference; single scattering of a directional
//! light (a sun whose light enters the box from outside) against the CPU reference; light
//! between a lit floor and the fog (`medium_bounce`), and a floor caustic's glow in the fog,
//! against the CPU reference; multiple scattering (`medium_ms_*`) against the full reference.

use crate::common;

mod bounce;
mod direct;
mod glass;
mod multiple;

use caustics::Scene;
use caustics::render::{RenderSettings, render};
use caustics::renderer::{FrameRequest, Renderer};
use caustics::scene::DensityGrid;
use caustics_reference::reference;
use common::gpu;
use glam::Vec3;
use std::path::Path;
use std::sync::Arc;

fn scene(json: &str) -> Scene {
    Scene::from_json(json, "medium.json", Path::new(".")).unwrap_or_else(|e| panic!("{e}"))
}

fn settings() -> RenderSettings {
    RenderSettings {
        photons: caustics::settings::PhotonSettings { count: 64, caustic_map_size: 64, ..Default::default() },
        shading: caustics::settings::ShadingSettings { shadow_map_size: 512, ..Default::default() },
        // (single scattering: the tests compare with the reference's single-scattering mode)
        medium: caustics::settings::MediumSettings { multiple_photons: 0, ..Default::default() },
        ..Default::default()
    }
}

const SPOT_FOG: &str = r#""camera": { "position": [0, 0, 4], "look_at": [0, 0, 0], "fov_y_deg": 40, "width": 16, "height": 12 },
  "lights": [ { "type": "spot", "position": [0, 2, 0], "direction": [0, -1, 0], "cone_angle_deg": 20, "falloff_start_deg": 15, "intensity": [20, 30, 40] } ],
  "materials": { "black": { "type": "diffuse", "albedo": 0 }, "white": { "type": "diffuse", "albedo": 0.8 } }"#;

const ISOTROPIC: &str = r#"{ "type": "isotropic" }"#;

fn shaft_scene_with(extra: &str, phase: &str) -> Scene {
    scene(&format!(
        r#"{{ "schema_version": 1, "name": "shaft", {SPOT_FOG},
  "objects": [ {{ "type": "rectangle", "center": [0, -3, 0], "normal": [0, 1, 0], "size": [6, 6], "material": "black" }} {extra} ],
  "medium": {{ "sigma_s": [0.3, 0.2, 0.4], "sigma_a": [0.05, 0.1, 0.0], "phase": {phase},
              "bounds": {{ "min": [-3, -3.5, -3], "max": [3, 3, 5] }} }} }}"#
    ))
}

fn shaft_scene(extra: &str) -> Scene {
    shaft_scene_with(extra, ISOTROPIC)
}

fn with_grid(mut sc: Scene, g: DensityGrid) -> Scene {
    sc.medium.as_mut().unwrap().density = Some(Arc::new(g));
    sc
}

/// One frame of `r` with statistics, and its statistics.
fn frame_stats(ctx: &caustics::gpu::GpuContext, r: &mut Renderer) -> caustics::renderer::FrameStats {
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    r.encode(&mut enc, FrameRequest { stats: true }).unwrap();
    ctx.queue.submit([enc.finish()]);
    r.wait_stats().unwrap().expect("the frame asked for statistics")
}

/// `scenes/glass_sphere_fog.json` without its ball, at 32 × 32: a spot light over a floor of
/// albedo 0.8 in fog, seen from above; the top rows see only fog, the bottom rows the floor.
fn lit_floor_fog_scene() -> Scene {
    scene(
        r#"{ "schema_version": 1, "name": "lit_floor_fog",
  "camera": { "position": [0.0, 2.2, 3.6], "look_at": [0.0, 0.7, 0.0], "fov_y_deg": 38.0, "width": 32, "height": 32 },
  "lights": [ { "type": "spot", "position": [0, 4, 0], "direction": [0, -1, 0], "cone_angle_deg": 25, "falloff_start_deg": 25, "intensity": [40, 40, 40] } ],
  "materials": { "floor": { "type": "diffuse", "albedo": 0.8 } },
  "objects": [ { "type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [8, 8], "material": "floor" } ],
  "medium": { "sigma_s": [0.15, 0.15, 0.15], "sigma_a": [0.02, 0.02, 0.02], "phase": { "type": "isotropic" },
              "bounds": { "min": [-4, -1, -4], "max": [4, 4.5, 4.5] } } }"#,
    )
}

/// Sum over rows `rows` of a 32-pixel-wide image (all channels).
fn rows_sum(img: &caustics::image_io::Image, rows: std::ops::Range<u32>) -> f64 {
    rows.flat_map(|y| (0..32).map(move |x| (x, y)))
        .map(|(x, y)| img.get(x, y).iter().map(|&v| v as f64).sum::<f64>())
        .sum()
}

/// The floor around a volume caustic: a narrow spot whose light all meets a glass ball, focused
/// into ground fog; the floor caustic lands on a black square, so the white floor around it is
/// lit only by the fog's caustic light (light -> glass -> fog -> floor). `floor`: the floor's
/// albedo.
fn volume_caustic_floor_scene(floor: f32) -> Scene {
    scene(&format!(
        r#"{{ "schema_version": 1, "name": "volume_caustic_floor",
  "camera": {{ "position": [0.0, 1.6, 2.2], "look_at": [0.0, 0.0, 0.0], "fov_y_deg": 40.0, "width": 32, "height": 32 }},
  "lights": [ {{ "type": "spot", "position": [0, 4, 0], "direction": [0, -1, 0], "cone_angle_deg": 8, "falloff_start_deg": 8, "intensity": [400, 400, 400] }} ],
  "materials": {{ "floor": {{ "type": "diffuse", "albedo": {floor} }}, "black": {{ "type": "diffuse", "albedo": 0 }}, "glass": {{ "type": "dielectric", "ior": 1.5 }} }},
  "objects": [ {{ "type": "sphere", "center": [0, 0.9, 0], "radius": 0.5, "material": "glass" }},
               {{ "type": "rectangle", "center": [0, 0.002, 0], "normal": [0, 1, 0], "size": [0.5, 0.5], "material": "black" }},
               {{ "type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [8, 8], "material": "floor" }} ],
  "medium": {{ "sigma_s": [0.3, 0.3, 0.3], "sigma_a": [0.02, 0.02, 0.02], "phase": {{ "type": "isotropic" }},
              "bounds": {{ "min": [-4, -1, -4], "max": [4, 0.35, 4.5] }} }} }}"#
    ))
}
