//! Diffuse surfaces inside refractive volumes (a pool's floor under water, a stone on it, a
//! pebble inside a glass ball): lit by the photons that refracted in and seen by camera rays
//! that refracted in, against the CPU reference.

use crate::common;

use caustics::render::RenderSettings;
use caustics::scene::Scene;
use caustics_reference::metrics::{Mask, energy_ratio, hdr_flip};
use caustics_reference::reference::{self, CausticPaths, ReferenceSettings};
use common::gpu;

fn pool(camera: [f32; 3], look_at: [f32; 3]) -> Scene {
    let mut sc =
        Scene::load(std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/pool.json"))).unwrap();
    sc.camera.width = 64;
    sc.camera.height = 64;
    sc.camera.position = camera.into();
    sc.camera.look_at = look_at.into();
    sc
}

/// 8 × 8 box averages (the reference's noise is per pixel; the comparison is of the picture).
pub(crate) fn boxed(img: &caustics::image_io::Image) -> caustics::image_io::Image {
    let (w, h) = (img.width / 8, img.height / 8);
    let mut out = caustics::image_io::Image::new(w, h);
    for y in 0..h {
        for x in 0..w {
            let mut s = [0.0f32; 3];
            for dy in 0..8 {
                for dx in 0..8 {
                    let p = img.pixels[((y * 8 + dy) * img.width + x * 8 + dx) as usize];
                    for c in 0..3 {
                        s[c] += p[c] / 64.0;
                    }
                }
            }
            out.pixels[(y * w + x) as usize] = s;
        }
    }
    out
}

fn measure(name: &str, sc: &Scene) -> Option<(f64, f64)> {
    measure_with(name, sc, RenderSettings::default())
}

fn measure_with(name: &str, sc: &Scene, mut s: RenderSettings) -> Option<(f64, f64)> {
    let ctx = gpu()?;
    let rs = ReferenceSettings {
        photons_per_light: 1_000_000,
        camera_spp: 16,
        caustic_paths: CausticPaths::All,
        ..Default::default()
    };
    let cpu = reference::render(sc, &rs).unwrap();
    s.photons.count = 1024;
    // The light the water traps and sends back down (interreflection, src/indirect/).
    s.indirect.photons = 1 << 18;
    let gpu_out = caustics::render::render(&ctx, sc, &s).unwrap();
    let (a, b) = (boxed(&gpu_out.image), boxed(&cpu.image));
    let flip = hdr_flip(&a, &b, None::<&Mask>).unwrap().mean;
    let energy = energy_ratio(&gpu_out.image, &cpu.image, None).unwrap();
    eprintln!("{name}: GPU vs CPU reference (full), 8x8 HDR-FLIP {flip:.3}, energy {energy:.4}");
    Some((flip, energy))
}

/// The floor and the stone under the pool's water, from above and from the side, and a pebble
/// inside a glass ball, against the CPU reference in full mode (every bounce), 8 × 8-averaged
/// at 64 × 64. Before camera rays inside a dielectric looked for the surfaces in it, everything
/// under the water was black (energy 0.39 of the reference on the room of water).
/// With the interreflection cache on (the light the water traps and sends back down; the
/// reference gathers it since 2026-12-08, `docs/reference-renderer.md`). Measured on lavapipe
/// (HDR-FLIP, energy): from above 0.072, 0.986 (without the cache against the reference
/// before it had that light: 0.125, 0.943); from the side 0.192, 0.879 (0.255, 0.819); the
/// pebble 0.252, 0.905 (0.279, 0.882). From above meets the target (HDR-FLIP 0.10,
/// energy within 3 %); the other two not yet: the image-space search cannot see what the
/// camera does not (the stone's far side, the floor behind it), and the pebble is magnified
/// less than through the exact lens.
#[test]
fn surfaces_under_water_are_lit_and_seen() {
    let cases = [
        ("pool from above", pool([0.0, 2.4, 3.0], [0.0, 0.1, 0.0]), 0.1, 0.97),
        ("pool from the side", pool([0.2, 0.25, 3.2], [0.0, 0.15, 0.0]), 0.25, 0.85),
        ("pebble in a glass ball", ball_pebble(), 0.3, 0.87),
    ];
    for (name, sc, max_flip, min_energy) in cases {
        let Some((flip, energy)) = measure(name, &sc) else { return };
        assert!(flip <= max_flip, "{name}: 8x8 HDR-FLIP {flip}");
        assert!((min_energy..=1.03).contains(&energy), "{name}: energy {energy}");
    }
}

fn ball_pebble() -> Scene {
    let mut ball =
        Scene::from_json(include_str!("../data/ball_pebble.json"), "<test>", std::path::Path::new(".")).unwrap();
    ball.camera.width = 64;
    ball.camera.height = 64;
    ball
}

/// A camera under water (`camera_inside`): the pool's floor and stone seen directly, and the
/// water's surface seen from below, where the floor is reflected (totally beyond 49°), against
/// the CPU reference in full mode. Before, the surface from below was black: the composite
/// entered the water where the ray was leaving it. Measured on lavapipe at 64² (8 × 8 HDR-FLIP,
/// energy, the upper half's energy, where the surface is): before 0.708, 0.500, 0.015; then
/// 0.247, 0.864, 0.890; with the interreflection cache against the reference that gathers the
/// water's trapped light (2026-12-08) 0.213, 0.949, 0.862. Still missing (not the target yet):
/// reflected points the camera does not see (black).
#[test]
fn a_camera_under_water_sees_the_surface_from_below() {
    let sc = pool([-0.6, 0.2, 0.7], [0.3, 0.3, -0.6]);
    let Some(ctx) = gpu() else { return };
    let rs = ReferenceSettings { photons_per_light: 1_000_000, camera_spp: 16, ..Default::default() };
    let cpu = reference::render(&sc, &rs).unwrap();
    let mut s = RenderSettings::default();
    s.photons.count = 1024;
    s.indirect.photons = 1 << 18;
    let g = caustics::render::render(&ctx, &sc, &s).unwrap();
    let upper = |img: &caustics::image_io::Image| -> f64 {
        let n = (img.width * img.height / 2) as usize;
        img.pixels[..n].iter().map(|p| (p[0] + p[1] + p[2]) as f64).sum()
    };
    let top = upper(&g.image) / upper(&cpu.image);
    let flip = hdr_flip(&boxed(&g.image), &boxed(&cpu.image), None::<&Mask>).unwrap().mean;
    let energy = energy_ratio(&g.image, &cpu.image, None).unwrap();
    eprintln!("pool from under water: 8x8 HDR-FLIP {flip:.3}, energy {energy:.4}, upper half {top:.4}");
    assert!(top > 0.8, "the surface seen from below is dark: {top} of the reference's light in the upper half");
    assert!(flip <= 0.25, "8x8 HDR-FLIP {flip}");
    assert!((0.92..=1.03).contains(&energy), "energy {energy}");
}

/// The surface caustic from beams (`sources.local = beams`) under water: a beam whose last
/// segment runs inside the water to the pool's floor lights it (in scenes without a medium).
/// Before, beam_trace dropped every landing inside a dielectric and everything under the water
/// was black with beams. Measured on lavapipe, the pool from above at 64², 8 × 8-averaged,
/// against the CPU reference in full mode, with the interreflection cache: HDR-FLIP 0.071,
/// energy 0.985 (basic caustic maps on the same view: 0.072, 0.986); bounds as for the caustic
/// maps' case above.
#[test]
fn beams_light_the_pool_floor_under_water() {
    let sc = pool([0.0, 2.4, 3.0], [0.0, 0.1, 0.0]);
    let mut s = RenderSettings::default();
    s.sources.local = caustics::settings::LocalSource::Beams;
    let Some((flip, energy)) = measure_with("pool from above, beams", &sc, s) else { return };
    assert!(flip <= 0.1, "8x8 HDR-FLIP {flip}");
    assert!((0.97..=1.03).contains(&energy), "energy {energy}");
}
