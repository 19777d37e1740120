//! Beer–Lambert absorption inside dielectrics on the GPU: the tinted block's caustic (its
//! light through the glass, on the floor in its shadow) against the clear block's per channel,
//! and the whole picture against the CPU reference.

use crate::common;

use caustics::image_io::Image;
use caustics::render::{Emission, RenderSettings, Technique, Tracer};
use caustics::scene::{Material, Scene};
use caustics_reference::metrics::energy_ratio;
use caustics_reference::reference::{self, CausticPaths, ReferenceSettings};
use common::gpu;
use glam::Vec3;

/// The catalogue's tinted block at 64 × 64, and its absorption coefficient (1/m).
fn tinted_block() -> (Scene, Vec3) {
    let mut sc =
        Scene::load(std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/tinted_block.json")))
            .unwrap();
    sc.camera.width = 64;
    sc.camera.height = 64;
    let sigma = sc.materials.iter().map(Material::absorption).find(|a| a.max_element() > 0.0).unwrap();
    (sc, sigma)
}

/// The block's thickness (m): light straight down crosses this much glass.
const THICK: f32 = 0.2;

/// The same scene with clear glass.
fn cleared(sc: &Scene) -> Scene {
    let mut c = sc.clone();
    for m in &mut c.materials {
        if let Material::Dielectric { absorption, .. } = m {
            *absorption = Vec3::ZERO;
        }
    }
    c
}

/// Per channel: the sum of `a` over the pixels where the camera's ray through the pixel centre
/// meets the block (its box), over the same sum of `b`.
fn through_block_ratio(sc: &Scene, a: &Image, b: &Image) -> [f64; 3] {
    let (lo, hi) = (Vec3::new(-0.3, 0.25, -0.3), Vec3::new(0.3, 0.45, 0.3));
    let cam = &sc.camera;
    let (mut num, mut den) = ([0.0f64; 3], [0.0f64; 3]);
    for y in 0..cam.height {
        for x in 0..cam.width {
            let d = cam.ray_dir(x as f32 + 0.5, y as f32 + 0.5);
            let (t0, t1) = ((lo - cam.position) / d, (hi - cam.position) / d);
            if t0.min(t1).max_element() < t0.max(t1).min_element() {
                let i = (y * cam.width + x) as usize;
                for c in 0..3 {
                    num[c] += a.pixels[i][c] as f64;
                    den[c] += b.pixels[i][c] as f64;
                }
            }
        }
    }
    [0, 1, 2].map(|c| num[c] / den[c])
}

/// Per channel: the sum of `a` over the pixels where `mask` has light, over the same sum of `mask`.
fn region_ratio(a: &Image, mask: &Image) -> [f64; 3] {
    let peak = mask.pixels.iter().map(|p| p[0]).fold(0.0f32, f32::max);
    let (mut num, mut den) = ([0.0f64; 3], [0.0f64; 3]);
    for (p, q) in a.pixels.iter().zip(&mask.pixels) {
        if q[0] > 0.05 * peak {
            for c in 0..3 {
                num[c] += p[c] as f64;
                den[c] += q[c] as f64;
            }
        }
    }
    [0, 1, 2].map(|c| num[c] / den[c])
}

/// The caustic under the block (the camera's caustic-only image: the floor it sees directly)
/// through tinted glass over through clear glass is exp(−σ d) per channel within 2 %, for the
/// exact tracer (the default), the image-space tracer and the adaptive emission. The light reaches the floor
/// within 10° of the vertical: paths inside at most 1.006 d.
#[test]
fn caustic_through_tinted_block_is_beer_lambert() {
    let Some(ctx) = gpu() else { return };
    let (sc, sigma) = tinted_block();
    let clear = cleared(&sc);
    let mut image_space = RenderSettings::default();
    image_space.photons.tracer = Tracer::ImageSpace;
    let mut adaptive = RenderSettings::default();
    Technique::Photons(Emission::AdaptiveError).apply(&mut adaptive);
    for (name, mut s) in
        [("default", RenderSettings::default()), ("image-space", image_space), ("adaptive-error", adaptive)]
    {
        s.photons.count = 1024;
        let a = caustics::render::render(&ctx, &sc, &s).unwrap();
        let b = caustics::render::render(&ctx, &clear, &s).unwrap();
        let r = region_ratio(&a.caustic, &b.caustic);
        eprintln!("{name}: caustic ratio tinted / clear {r:.4?}");
        for c in 0..3 {
            let e = (-(sigma[c] * THICK) as f64).exp();
            assert!((r[c] / e - 1.0).abs() < 0.02, "{name}: channel {c}: {:.4} vs exp(-σd) {e:.4}", r[c]);
        }
    }
}

/// The tinted block against the CPU reference (every path class): the energy of the picture
/// within 3 %, and the caustic region's colour (tinted over clear, per channel, GPU against the
/// reference's own ratio) within 2 %. Measured on lavapipe: energy 0.987 (the clear block
/// 0.975); caustic ratio GPU [0.904, 0.605, 0.300], reference [0.902, 0.601, 0.297]. Printed,
/// not checked yet: the pixels seen through the block, tinted over clear, GPU [0.856, 0.479,
/// 0.199] against the reference's [0.855, 0.495, 0.230] (the GPU's composite lacks some of the
/// untinted light there, as its lower energy on the clear block says).
#[test]
fn tinted_block_matches_reference() {
    let Some(ctx) = gpu() else { return };
    let (sc, _) = tinted_block();
    let clear = cleared(&sc);
    let rs = ReferenceSettings {
        photons_per_light: 1 << 20,
        camera_spp: 16,
        caustic_paths: CausticPaths::All,
        ..Default::default()
    };
    let mut s = RenderSettings::default();
    s.photons.count = 1024;
    let cpu = reference::render(&sc, &rs).unwrap();
    let cpu_clear = reference::render(&clear, &rs).unwrap();
    let g = caustics::render::render(&ctx, &sc, &s).unwrap();
    let g_clear = caustics::render::render(&ctx, &clear, &s).unwrap();
    let energy = energy_ratio(&g.image, &cpu.image, None).unwrap();
    let energy_clear = energy_ratio(&g_clear.image, &cpu_clear.image, None).unwrap();
    let rg = region_ratio(&g.caustic, &g_clear.caustic);
    let rc = region_ratio(&cpu.caustic, &g_clear.caustic);
    let rc_clear = region_ratio(&cpu_clear.caustic, &g_clear.caustic);
    let (vg, vc) =
        (through_block_ratio(&sc, &g.image, &g_clear.image), through_block_ratio(&sc, &cpu.image, &cpu_clear.image));
    eprintln!("tinted block: energy GPU / CPU {energy:.4} (clear block {energy_clear:.4})");
    eprintln!("seen through the block, tinted / clear: GPU {vg:.4?}, CPU {vc:.4?}");
    eprintln!("caustic ratio tinted / clear: GPU {rg:.4?}, CPU {:.4?}", [0, 1, 2].map(|c| rc[c] / rc_clear[c]));
    assert!((energy - 1.0).abs() < 0.03, "energy {energy}");
    for c in 0..3 {
        let cpu_ratio = rc[c] / rc_clear[c];
        assert!((rg[c] / cpu_ratio - 1.0).abs() < 0.02, "channel {c}: GPU {:.4}, CPU {cpu_ratio:.4}", rg[c]);
    }
}

/// Beams draw the glass clear: a scene with absorption under them says so.
#[test]
fn beams_warn_that_they_ignore_absorption() {
    let (sc, _) = tinted_block();
    let mut s = RenderSettings::default();
    assert_eq!(s.absorption_warning(&sc), None);
    Technique::Beams.apply(&mut s);
    let w = s.absorption_warning(&sc).expect("a warning under beams");
    assert!(w.contains("absorption is ignored by beams/caustic spheres") && w.contains("tinted_block.json"), "{w}");
    assert_eq!(s.absorption_warning(&cleared(&sc)), None);
    // Caustic spheres serve directional lights: none here, then one.
    let mut s = RenderSettings::default();
    Technique::CausticSpheres.apply(&mut s);
    assert_eq!(s.absorption_warning(&sc), None);
    let mut sun = sc.clone();
    sun.lights.push(caustics::scene::Light::Directional { direction: Vec3::NEG_Y, irradiance: Vec3::ONE });
    let w = s.absorption_warning(&sun).expect("a warning under caustic spheres");
    assert!(w.contains("from caustic spheres"), "{w}");
}
