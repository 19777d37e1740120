//! The environment light on the GPU: the background where camera rays hit nothing, and what
//! mirrors reflect of it, against the CPU lookup. (Diffuse lighting from
//! the environment is not rendered on the GPU yet.)

mod common;
use caustics::Scene;
use caustics::render::{RenderSettings, render};
use caustics::scene::Environment;
use common::gpu;
use glam::Vec3;
use std::path::Path;
use std::sync::Arc;

/// A smooth sky (so a pixel centre and a pixel's box filter agree) with a brighter patch.
fn sky() -> Environment {
    let (w, h) = (256u32, 128u32);
    let t = (0..w * h)
        .map(|i| {
            let (u, v) = ((i % w) as f32 / w as f32, (i / w) as f32 / h as f32);
            let s = (u * std::f32::consts::TAU).sin() * 0.5 + 0.5;
            Vec3::new(0.2 + 0.8 * (1.0 - v), 0.3 + 0.5 * s, 0.4 + v * s)
        })
        .collect();
    Environment::from_texels(w, h, t, 35.0).unwrap()
}

fn scene(objects: &str) -> Scene {
    let json = format!(
        r#"{{ "schema_version": 1, "name": "env",
          "camera": {{ "position": [0, 0.3, 3], "look_at": [0, 0.5, 0], "fov_y_deg": 50, "width": 64, "height": 48 }},
          "lights": [ {{ "type": "environment", "path": "envmaps/city.exr" }} ],
          "materials": {{ "mirror": {{ "type": "mirror", "reflectance": [0.9, 0.8, 0.7] }},
                         "floor": {{ "type": "diffuse", "albedo": 0.5 }} }},
          "objects": [ {objects} ] }}"#
    );
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let mut s = Scene::from_json(&json, "env.json", &base).unwrap();
    s.environment = Some(Arc::new(sky()));
    s
}

fn settings() -> RenderSettings {
    RenderSettings { photons: 64, caustic_map_size: 64, shadow_map_size: 256, ..Default::default() }
}

#[test]
fn camera_rays_that_miss_show_the_environment() {
    let Some(ctx) = gpu() else { return };
    let s = scene(
        r#"{ "type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [2, 2], "material": "floor" }"#,
    );
    let env = s.environment.clone().unwrap();
    let out = render(&ctx, &s, &settings()).unwrap();
    let cam = &s.camera;
    let mut sky_pixels = 0;
    for y in 0..cam.height {
        for x in 0..cam.width {
            let d = cam.ray_dir(x as f32 + 0.5, y as f32 + 0.5);
            // Rays above the horizon miss the floor.
            if d.y <= 0.0 {
                continue;
            }
            let want = env.lookup(d);
            let got = Vec3::from_array(out.image.get(x, y));
            assert!((got - want).abs().max_element() <= 2e-3 * want.max_element(), "({x}, {y}): {got} vs {want}");
            sky_pixels += 1;
        }
    }
    assert!(sky_pixels > 1000, "{sky_pixels}");
}

#[test]
fn a_mirror_ball_reflects_the_environment() {
    // Each pixel well inside the ball against the exact reflection of its centre ray (the GPU
    // reflects off the tessellated ball's interpolated normals: a few per cent).
    let Some(ctx) = gpu() else { return };
    let s = scene(r#"{ "type": "sphere", "center": [0, 0.5, 0], "radius": 0.6, "material": "mirror" }"#);
    let env = s.environment.clone().unwrap();
    let out = render(&ctx, &s, &settings()).unwrap();
    let cam = &s.camera;
    let centre = Vec3::new(0.0, 0.5, 0.0);
    let (mut n, mut sum_gpu, mut sum_cpu) = (0, Vec3::ZERO, Vec3::ZERO);
    for y in 0..cam.height {
        for x in 0..cam.width {
            let d = cam.ray_dir(x as f32 + 0.5, y as f32 + 0.5);
            let oc = cam.position - centre;
            let b = oc.dot(d);
            let disc = b * b - (oc.length_squared() - 0.6 * 0.6);
            if disc < 0.1 {
                continue; // outside or near the silhouette
            }
            let p = cam.position + d * (-b - disc.sqrt());
            let nrm = (p - centre).normalize();
            let r = d - 2.0 * d.dot(nrm) * nrm;
            let want = Vec3::new(0.9, 0.8, 0.7) * env.lookup(r);
            let got = Vec3::from_array(out.image.get(x, y));
            assert!((got - want).abs().max_element() < 0.05 * want.max_element(), "({x}, {y}): {got} vs {want}");
            sum_gpu += got;
            sum_cpu += want;
            n += 1;
        }
    }
    assert!(n > 100, "{n}");
    assert!(((sum_gpu / sum_cpu) - Vec3::ONE).abs().max_element() < 0.01, "{sum_gpu} vs {sum_cpu}");
}
