//! Wide lights: a spot light with a 90° cone (a hemisphere) and a point light next to a surface,
//! drawn with the light's cube of six faces (`lightspace`), against closed forms.
//!
//! - direct light at grazing angles: a 90° spot and a point light 5 cm above a floor light it
//!   as the cosine law says, out to 85° from the normal and across the cube's seams (the shadow
//!   lookup's normal offset grows with the grazing angle; before, the floor showed rings of
//!   acne: up to 100 % dark);
//! - the caustic across the cube's seams: a 90° spot over a flat mirror lights the ceiling as its
//!   mirror image would (a point source at the light's reflection, reflectance × I cos / r²);
//!   the ceiling is seen through five faces of the light's cube, and the caustic triangles that
//!   cross a seam are spread over the faces they cover, from the dense grid, the adaptive
//!   hierarchy and the hierarchical technique's dual quads (before, the seams were lines up to 31 % off).

use crate::common;
use caustics::Scene;
use caustics::render::{RenderSettings, render};
use caustics::settings::{Emission, SplatMode};
use common::gpu;
use glam::Vec3;
use std::path::Path;

const ALBEDO: f32 = 0.8;

fn settings() -> RenderSettings {
    RenderSettings {
        photons: caustics::settings::PhotonSettings { count: 256, caustic_map_size: 256, ..Default::default() },
        shading: caustics::settings::ShadingSettings { shadow_map_size: 512, ..Default::default() },
        ..Default::default()
    }
}

/// A floor (albedo 0.8, 40 m wide) with `light` 5 cm above its centre, seen from above at an
/// angle; a small glass ball off to the side, so that the light has a caster.
fn floor_scene(light: &str) -> Scene {
    let json = format!(
        r#"{{"schema_version": 1, "name": "near_floor",
        "camera": {{"position": [0, 0.8, 0.8], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov_y_deg": 90, "width": 96, "height": 96}},
        "lights": [{light}],
        "materials": {{"floor": {{"type": "diffuse", "albedo": {ALBEDO}}}, "glass": {{"type": "dielectric", "ior": 1.5, "ext_ior": 1.0}}}},
        "objects": [{{"type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [40, 40], "material": "floor"}},
                    {{"type": "sphere", "center": [3, 0.1, 3], "radius": 0.1, "material": "glass"}}]}}"#
    );
    Scene::from_json(&json, "near_floor.json", Path::new(".")).unwrap()
}

/// The direct light's radiance on the floor against the cosine law, pixel by pixel, for pixels
/// whose floor point lies within 85° of the normal as seen from the light: the worst ratio.
fn worst_direct_ratio(scene: &Scene, light_pos: Vec3, intensity: f32) -> (f64, f64) {
    let Some(ctx) = gpu() else { return (1.0, 1.0) };
    let out = render(&ctx, scene, &settings()).unwrap();
    let cam = &scene.camera;
    let (mut lo, mut hi) = (f64::MAX, f64::MIN);
    let mut n = 0;
    for y in 0..cam.height {
        for x in 0..cam.width {
            let d = cam.ray_dir(x as f32 + 0.5, y as f32 + 0.5);
            if d.y >= -1e-3 {
                continue;
            }
            let p = cam.position + d * (-cam.position.y / d.y);
            let to_p = p - light_pos;
            let r2 = to_p.length_squared();
            let cos = light_pos.y / r2.sqrt();
            if cos < 85f32.to_radians().cos() || (p - Vec3::new(3.0, 0.0, 3.0)).length() < 0.5 {
                continue;
            }
            let expect = (ALBEDO / std::f32::consts::PI * intensity * cos / r2) as f64;
            let px = out.image.pixels[(y * cam.width + x) as usize];
            let got = (px[0] - out.caustic.pixels[(y * cam.width + x) as usize][0]) as f64;
            let ratio = got / expect;
            lo = lo.min(ratio);
            hi = hi.max(ratio);
            n += 1;
        }
    }
    assert!(n > 1500, "{n} floor pixels compared");
    (lo, hi)
}

#[test]
fn a_wide_spot_and_a_point_light_next_to_a_floor_follow_the_cosine_law() {
    if gpu().is_none() {
        return;
    }
    let spot = r#"{"type": "spot", "position": [0, 0.05, 0], "direction": [0, -1, 0], "cone_angle_deg": 90,
                   "falloff_start_deg": 90, "intensity": [2, 2, 2]}"#;
    let point = r#"{"type": "point", "position": [0, 0.05, 0], "intensity": [2, 2, 2]}"#;
    for (name, light) in [("90° spot", spot), ("point light", point)] {
        let (lo, hi) = worst_direct_ratio(&floor_scene(light), Vec3::new(0.0, 0.05, 0.0), 2.0);
        eprintln!("{name}: direct light / cosine law in [{lo:.4}, {hi:.4}]");
        assert!(lo > 0.99 && hi < 1.01, "{name}: direct light / cosine law in [{lo}, {hi}]");
    }
}

#[test]
fn a_wide_spot_over_a_mirror_lights_the_ceiling_as_its_image_across_the_seams() {
    let Some(ctx) = gpu() else { return };
    // Light 0.3 m above a mirror (reflectance 0.9), ceiling 1.2 m up: the ceiling sees the
    // light's +Y face for |x|, |z| < 0.9 m and the side faces beyond; the camera sees ±1.04 m.
    let json = r#"{"schema_version": 1, "name": "wide_mirror",
        "camera": {"position": [0, 0.6, 0], "look_at": [0, 1.2, 0], "up": [0, 0, -1], "fov_y_deg": 120, "width": 96, "height": 96},
        "lights": [{"type": "spot", "position": [0, 0.3, 0], "direction": [0, -1, 0], "cone_angle_deg": 90,
                    "falloff_start_deg": 90, "intensity": [2, 2, 2]}],
        "materials": {"ceiling": {"type": "diffuse", "albedo": 0.8}, "mirror": {"type": "mirror", "reflectance": [0.9, 0.9, 0.9]}},
        "objects": [{"type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [6, 6], "material": "mirror"},
                    {"type": "rectangle", "center": [0, 1.2, 0], "normal": [0, -1, 0], "size": [6, 6], "material": "ceiling"}]}"#;
    let scene = Scene::from_json(json, "wide_mirror.json", Path::new(".")).unwrap();
    for emission in [Emission::Basic, Emission::AdaptiveLevel, Emission::Hierarchical] {
        let mut s = settings();
        s.photons.emission = emission;
        let out = render(&ctx, &scene, &s).unwrap();
        check_mirror_image(&scene, &out.caustic, &format!("{emission:?}"), 0.03);
    }
    // Gaussian splats sized by ray differentials, spread across the seams too: within 3 %
    // except at the cube's corners, where three faces meet (measured 8.4 % there, 23 % with each
    // splat held inside its face).
    let mut s = settings();
    s.photons.splat = SplatMode::Differential;
    let out = render(&ctx, &scene, &s).unwrap();
    check_mirror_image(&scene, &out.caustic, "differential splats", 0.10);
}

/// The ceiling's caustic against the mirror image's closed form: within 3 % everywhere except
/// within 2 cm of the cube's corners (|x| = |z| = 0.9 m), and within `corner_bound` there.
fn check_mirror_image(scene: &Scene, caustic: &caustics::image_io::Image, what: &str, corner_bound: f64) {
    let cam = &scene.camera;
    let image = Vec3::new(0.0, -0.3, 0.0);
    let (mut worst, mut worst_at) = (0.0f64, (0, 0));
    let mut worst_corner = 0.0f64;
    let mut seam_px = 0;
    for y in 0..cam.height {
        for x in 0..cam.width {
            let d = cam.ray_dir(x as f32 + 0.5, y as f32 + 0.5);
            let p = cam.position + d * ((1.2 - cam.position.y) / d.y);
            let v = p - image;
            let e = 0.9 * 2.0 * (v.y / v.length()) / v.length_squared();
            let expect = (ALBEDO / std::f32::consts::PI * e) as f64;
            let got = caustic.pixels[(y * cam.width + x) as usize][0] as f64;
            let err = (got / expect - 1.0).abs();
            // Pixels within 2 cm of a seam of the light's cube (from the light at (0, 0.3, 0):
            // |x| or |z| = 0.9 on the ceiling, or |x| = |z| beyond).
            let (ax, az) = (p.x.abs(), p.z.abs());
            if (ax.max(az) - 0.9).abs() < 0.02 || (ax.max(az) > 0.9 && (ax - az).abs() < 0.02) {
                seam_px += 1;
            }
            if (ax - 0.9).abs() < 0.02 && (az - 0.9).abs() < 0.02 {
                worst_corner = worst_corner.max(err);
                continue;
            }
            if err > worst {
                worst = err;
                worst_at = (x, y);
            }
        }
    }
    eprintln!(
        "{what}: ceiling caustic / mirror image: worst relative error {worst:.4} at {worst_at:?}, {worst_corner:.4} at the cube's corners; {seam_px} pixels on seams"
    );
    assert!(seam_px > 100);
    assert!(worst < 0.03, "{what}: worst relative error {worst} at {worst_at:?}");
    assert!(worst_corner < corner_bound, "{what}: worst relative error {worst_corner} at the cube's corners");
}

/// A millimetre-sized scene: a point light 50 µm over a 3 mm floor with a 0.1 mm glass bead
/// beside it, whose shadow is what the light's view must hold. Before, the near planes of the
/// light's and the camera's views kept 1 mm even in a 3 mm scene: the bead lay in front of the
/// light's near plane and cast no shadow. The shadow's wedge behind the bead (pixels past it,
/// away from the light) against the same scene without the bead, GPU and CPU reference alike.
/// Measured on lavapipe: before 1.028 (no shadow), now 0.492; the reference 0.385. The rest of
/// the gap is not explained yet (the bead's own caustic in its shadow, or the shadow's edge at
/// this scale), so this asserts the shadow, not the reference's value.
#[test]
fn a_millimetre_scene_keeps_its_shadows() {
    let Some(ctx) = gpu() else { return };
    let scene = |bead: bool| {
        let json = format!(
            r#"{{"schema_version": 1, "name": "near_mm",
            "camera": {{"position": [0, 0.0015, 0.0006], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov_y_deg": 60, "width": 64, "height": 64}},
            "lights": [{{"type": "point", "position": [0, 5e-5, 0], "intensity": 2e-7}}],
            "materials": {{"floor": {{"type": "diffuse", "albedo": 0.75}}, "glass": {{"type": "dielectric", "ior": 1.5}}}},
            "objects": [{{"type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [0.003, 0.003], "material": "floor"}}
                        {}]}}"#,
            if bead {
                r#", {"type": "sphere", "center": [0.00025, 0.0001, 0], "radius": 0.0001, "material": "glass"}"#
            } else {
                ""
            }
        );
        Scene::from_json(&json, "<test>", Path::new(".")).unwrap()
    };
    // The wedge: right of the bead (x from 44 to 63 of 64), around its row.
    let wedge = |img: &caustics::image_io::Image| -> f64 {
        let mut sum = 0.0;
        for y in 24..40 {
            for x in 44..64 {
                let p = img.pixels[(y * img.width + x) as usize];
                sum += (p[0] + p[1] + p[2]) as f64;
            }
        }
        sum
    };
    let with = render(&ctx, &scene(true), &settings()).unwrap().image;
    let without = render(&ctx, &scene(false), &settings()).unwrap().image;
    let gpu_ratio = wedge(&with) / wedge(&without);
    let rs = caustics_reference::reference::ReferenceSettings {
        photons_per_light: 200_000,
        camera_spp: 4,
        ..Default::default()
    };
    let cpu_with = caustics_reference::reference::render(&scene(true), &rs).unwrap().image;
    let cpu_without = caustics_reference::reference::render(&scene(false), &rs).unwrap().image;
    let cpu_ratio = wedge(&cpu_with) / wedge(&cpu_without);
    eprintln!("the bead's shadow wedge keeps {gpu_ratio:.3} of the light on the GPU, {cpu_ratio:.3} in the reference");
    assert!(cpu_ratio < 0.5, "the reference's bead casts no shadow: {cpu_ratio}");
    assert!(gpu_ratio < 0.6, "the bead casts no shadow on the GPU: {gpu_ratio} (the reference: {cpu_ratio})");
}
