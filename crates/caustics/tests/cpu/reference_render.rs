//! The reference renderer's outputs: shapes, units, the light-space caustic maps; and a speed
//! report (`cargo test --release -p caustics --test reference_render -- --ignored --nocapture`).

use caustics::Scene;
use caustics::lightspace::LightView;
use caustics_reference::reference::{self, ReferenceSettings};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

#[test]
fn outputs_have_the_right_shapes_and_add_up() {
    let mut scene = Scene::default_scene();
    scene.camera.width = 40;
    scene.camera.height = 30;
    let s = ReferenceSettings {
        photons_per_light: 50_000,
        camera_spp: 2,
        max_depth: 16,
        seed: 1,
        caustic_map_size: 16,
        medium_single_scattering_only: false,
        ..Default::default()
    };
    let o = reference::render(&scene, &s).unwrap();
    for img in [&o.image, &o.caustic, &o.nocaustic, &o.caustic_variance, &o.nocaustic_variance] {
        assert_eq!((img.width, img.height), (40, 30));
        assert!(img.pixels.iter().flatten().all(|c| c.is_finite() && *c >= 0.0));
    }
    for ((f, c), n) in o.image.pixels.iter().zip(&o.caustic.pixels).zip(&o.nocaustic.pixels) {
        for k in 0..3 {
            assert!((f[k] - (c[k] + n[k])).abs() <= 1e-6 * f[k].abs().max(1.0));
        }
    }
    assert_eq!(o.caustic_maps.len(), 1);
    assert_eq!(o.caustic_maps[0].len(), LightView::new(&scene, &scene.lights[0]).faces.len());
    assert!(o.caustic_maps[0].iter().all(|m| m.width == 16 && m.height == 16));
    assert_eq!(o.stats.photon_paths, 50_000);
    assert_eq!(o.stats.camera_paths, 40 * 30 * 2);
    assert!(o.stats.rays > 0 && o.stats.rays_per_second > 0.0);
}

#[test]
fn caustic_map_irradiance_integrates_to_the_deposited_flux() {
    // Spot light above a glass ball over the floor y = 0: summing irradiance × texel footprint
    // on the floor over the map gives back the flux of the photons' first diffuse hits.
    let scene = Scene::load(&root().join("scenes/glass_sphere.json")).unwrap();
    let size = 256;
    let s = ReferenceSettings {
        photons_per_light: 1_000_000,
        camera_spp: 1,
        max_depth: 32,
        seed: 2,
        caustic_map_size: size,
        medium_single_scattering_only: false,
        ..Default::default()
    };
    let maps = reference::caustic_maps(&scene, &s).unwrap();
    let view = LightView::new(&scene, &scene.lights[0]);
    let mut flux = 0.0f64;
    let mut peak = (0.0f32, 0u32, 0u32);
    for (f, m) in maps[0].iter().enumerate() {
        for y in 0..size {
            for x in 0..size {
                let e = m.get(x, y)[1];
                if e == 0.0 {
                    continue;
                }
                if e > peak.0 {
                    peak = (e, x, y);
                }
                let (o, d) = view.texel_ray(f, x as f32 + 0.5, y as f32 + 0.5, size);
                let t = -o.y / d.y;
                let p = o + d * t;
                flux += (e * view.texel_area(f, p, glam::Vec3::Y, size)) as f64;
            }
        }
    }
    let deposits = reference::caustic_deposits(&scene, &s, 0).unwrap();
    // (Light reflected off the ball lands partly outside the spot's frustum, off the map.)
    let on_floor: f64 = deposits
        .iter()
        .filter(|d| d.position.y.abs() < 1e-3 && view.project(d.position, size).is_some())
        .map(|d| d.flux.y as f64)
        .sum();
    println!("map flux {flux:.5} W, deposited {on_floor:.5} W, peak {peak:?}");
    assert!((flux / on_floor - 1.0).abs() < 0.002);
    // The focus is on the spot's axis: the map's centre.
    assert!((peak.1 as i32 - size as i32 / 2).abs() <= 2 && (peak.2 as i32 - size as i32 / 2).abs() <= 2, "{peak:?}");
}

/// Rays and photon paths per second on the glass bunny, 1 and 2 threads.
#[test]
#[ignore]
fn speed_glass_bunny() {
    let scene = Scene::load(&root().join("scenes/glass_bunny.json")).unwrap();
    let s = ReferenceSettings { photons_per_light: 4_000_000, camera_spp: 16, ..Default::default() };
    for threads in [1, 2] {
        let o = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| reference::render(&scene, &s).unwrap());
        println!("{}", o.stats);
        println!(
            "  photon pass: {:.2} M rays/s; camera pass: {:.2} M rays/s",
            o.stats.photon_rays as f64 / o.stats.photon_seconds / 1e6,
            (o.stats.rays - o.stats.photon_rays) as f64 / o.stats.camera_seconds / 1e6
        );
    }
}
