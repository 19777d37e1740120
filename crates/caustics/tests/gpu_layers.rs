//! Multi-layer deferred refraction for the camera: a mirror mesh (the bunny) seen through a glass
//! sphere in front of it must appear in the GPU image where the CPU reference sees it. The
//! camera's first-layer buffers hold only the sphere there; the mesh comes from the second,
//! depth-peeled layer (`raster_peel`) that `composite` marches through. (A glass bunny behind
//! the sphere is found the same way, but light that the image-space approximation loses inside
//! it — exits not found, more than three internal reflections — makes it darker than the
//! reference; a mirror isolates the layering.)
//! Without an adapter the test skips with a printed reason, except in CI (`CI=true`).

mod common;
use caustics::Scene;
use caustics::image_io::Image;
use caustics::render::{RenderSettings, render};
use caustics_reference::ImageIo as _;
use caustics_reference::reference::ReferenceSettings;
use common::gpu;
use std::path::Path;

const W: u32 = 96;

fn scene(with_bunny: bool) -> Scene {
    let bunny = r#"{ "type": "mesh", "path": "meshes/bunny.obj.gz", "smooth_normals": true,
        "transform": { "scale": 1.2, "rotate_y_deg": 0.0, "translate": [0.0, 0.55, -0.6] }, "material": "chrome" },"#;
    let json = format!(
        r#"{{
  "schema_version": 1,
  "name": "sphere_before_bunny",
  "camera": {{ "position": [0, 0.5, 3], "look_at": [0, 0.5, 0], "up": [0, 1, 0], "fov_y_deg": 40, "width": {W}, "height": {W} }},
  "lights": [ {{ "type": "spot", "position": [0.5, 3.5, 2.0], "direction": [-0.5, -3.0, -2.5], "cone_angle_deg": 40,
                 "intensity": [20, 20, 20] }} ],
  "materials": {{ "floor": {{ "type": "diffuse", "albedo": 0.7 }},
                 "wall": {{ "type": "diffuse", "albedo": [0.8, 0.3, 0.2] }},
                 "glass": {{ "type": "dielectric", "ior": 1.5 }},
                 "chrome": {{ "type": "mirror", "reflectance": [0.9, 0.9, 0.9] }} }},
  "objects": [
    {bunny}
    {{ "type": "sphere", "center": [0, 0.5, 1.0], "radius": 0.4, "material": "glass" }},
    {{ "type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [8, 8], "material": "floor" }},
    {{ "type": "rectangle", "center": [0, 1.5, -2.0], "normal": [0, 0, 1], "size": [8, 3], "material": "wall" }}
  ]
}}"#,
        bunny = if with_bunny { bunny } else { "" }
    );
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    Scene::from_json(&json, "sphere_before_bunny.json", &base).unwrap()
}

/// Mean absolute difference (r + g + b) over the pixels well inside the sphere's disc.
fn disc_difference(a: &Image, b: &Image) -> f64 {
    // Sphere at distance 2 from the camera, radius 0.4: angular radius asin(0.2); the image's
    // half-height spans tan(20°).
    let r_px = (0.2f64.asin().tan() / 20f64.to_radians().tan()) * W as f64 * 0.5;
    let c = W as f64 * 0.5;
    let (mut sum, mut n) = (0.0, 0);
    for y in 0..W {
        for x in 0..W {
            let (dx, dy) = (x as f64 + 0.5 - c, y as f64 + 0.5 - c);
            if (dx * dx + dy * dy).sqrt() < 0.85 * r_px {
                let (p, q) = (a.pixels[(y * W + x) as usize], b.pixels[(y * W + x) as usize]);
                sum += (0..3).map(|k| (p[k] as f64 - q[k] as f64).abs()).sum::<f64>();
                n += 1;
            }
        }
    }
    sum / n as f64
}

#[test]
fn a_mesh_behind_a_glass_sphere_is_seen_through_it() {
    let Some(ctx) = gpu() else { return };
    let s = RenderSettings { photons: 256, caustic_map_size: 256, shadow_map_size: 512, ..Default::default() };
    let with = render(&ctx, &scene(true), &s).unwrap();
    let without = render(&ctx, &scene(false), &s).unwrap();
    let rs = ReferenceSettings { photons_per_light: 1 << 20, camera_spp: 16, ..Default::default() };
    let cpu = caustics_reference::reference::render(&scene(true), &rs).unwrap();
    if let Ok(dir) = std::env::var("CAUSTICS_TEST_OUT") {
        let dir = Path::new(&dir);
        with.image.write(&dir.join("layers_gpu.png"), 1.0).unwrap();
        without.image.write(&dir.join("layers_gpu_without.png"), 1.0).unwrap();
        cpu.image.write(&dir.join("layers_cpu.png"), 1.0).unwrap();
    }
    let e_with = disc_difference(&with.image, &cpu.image);
    let e_without = disc_difference(&without.image, &cpu.image);
    let seen = disc_difference(&with.image, &without.image);
    println!(
        "through the sphere: GPU vs CPU {e_with:.4}, GPU without the bunny vs CPU {e_without:.4}, bunny's effect on the GPU image {seen:.4}"
    );
    // The bunny changes what the sphere shows, and the GPU image follows the CPU reference.
    assert!(seen > 0.5 * e_without, "the bunny is not visible through the sphere: {seen} vs {e_without}");
    assert!(e_with < 0.6 * e_without, "GPU {e_with} vs {e_without} without the bunny");
}
