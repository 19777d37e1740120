//! GPU tests of the splat modes (issue 5): flux conservation, caustic triangles on a glass slab,
//! error against the CPU reference on the sphere scene, thin-lens sizes on a spherical lens.
//! Without an adapter they skip with a printed reason, except in CI (`CI=true`), where they fail.

use crate::common;
use caustics::Scene;
use caustics::render::{GpuRender, RenderSettings, SplatMode, render};
use caustics::settings::Emission;
use common::gpu;
use std::path::Path;

fn small(mut s: Scene, w: u32) -> Scene {
    s.camera.height = s.camera.height * w / s.camera.width;
    s.camera.width = w;
    s
}

fn settings(n: u32, m: u32, splat: SplatMode) -> RenderSettings {
    // The transmitted branch only, so that every technique traces the same photons and the
    // splats are compared on one smooth photon map (the exact tracer's residual pass is random).
    RenderSettings {
        photons: caustics::settings::PhotonSettings {
            count: n,
            caustic_map_size: m,
            splat,
            reflection: false,
            internal_reflection: false,
            residual: false,
            ..Default::default()
        },
        shading: caustics::settings::ShadingSettings { shadow_map_size: 256, ..Default::default() },
        ..Default::default()
    }
}

/// Flux in the caustic map (fixed-point units, r + g + b; the scale is the same for every mode).
fn map_flux(out: &GpuRender) -> f64 {
    out.caustic_flux_bits.iter().flatten().map(|&b| b as f64).sum()
}

#[test]
fn every_mode_conserves_the_caustic_flux() {
    let Some(ctx) = gpu() else { return };
    let s = small(Scene::default_scene(), 32);
    let fixed = render(&ctx, &s, &settings(256, 256, SplatMode::Fixed)).unwrap();
    let reference = map_flux(&fixed);
    assert!(reference > 0.0);
    for t in [Emission::Basic, Emission::Hierarchical, Emission::AdaptiveLevel] {
        for mode in SplatMode::ALL {
            let out = render(
                &ctx,
                &s,
                &RenderSettings {
                    photons: caustics::settings::PhotonSettings { emission: t, ..settings(256, 256, mode).photons },
                    ..settings(256, 256, mode)
                },
            )
            .unwrap();
            let r = map_flux(&out) / reference;
            eprintln!("{t} {mode}: map flux / fixed splats' {r:.6}, landed {:.4} W", out.flux[0].landed);
            assert!((r - 1.0).abs() < 0.01, "{t} {mode}: map flux ratio {r}");
        }
    }
}

/// A glass slab (two parallel faces) under a directional light: the caustic under it is uniform.
/// Caustic triangles reproduce it without noise although the photon grid (200²) and the caustic
/// map (256²) do not line up, where fixed splats show the grid's moiré; so do the adaptive
/// hierarchy's cell quads.
#[test]
fn caustic_triangles_on_a_glass_slab_are_uniform() {
    let Some(ctx) = gpu() else { return };
    let json = r#"{"schema_version":1,"name":"slab","camera":{"position":[0,3,3],"look_at":[0,0,0],"fov_y_deg":40,"width":32,"height":32},
        "lights":[{"type":"directional","direction":[0,-1,0],"irradiance":10}],
        "materials":{"floor":{"type":"diffuse","albedo":0.5},"glass":{"type":"dielectric","ior":1.5}},
        "objects":[{"type":"rectangle","center":[0,1.0,0],"normal":[0,1,0],"size":[1.2,1.2],"material":"glass"},
                   {"type":"rectangle","center":[0,0.9,0],"normal":[0,-1,0],"size":[1.2,1.2],"material":"glass"},
                   {"type":"rectangle","center":[0,0,0],"normal":[0,1,0],"size":[6,6],"material":"floor"}]}"#;
    let s = Scene::from_json(json, "slab", Path::new(".")).unwrap();
    let cv = |mode, technique, n| {
        let out = render(
            &ctx,
            &s,
            &RenderSettings {
                photons: caustics::settings::PhotonSettings { emission: technique, ..settings(n, 256, mode).photons },
                ..settings(n, 256, mode)
            },
        )
        .unwrap();
        let map = &out.caustic_maps[0][0];
        // The texels well inside the slab's footprint (its light view: the middle of the map).
        let lum = map.luminance();
        let mut v = Vec::new();
        for y in 0..256usize {
            for x in 0..256usize {
                let l = lum[y * 256 + x] as f64;
                if l > 0.0 {
                    v.push((x, y, l));
                }
            }
        }
        let (x0, x1) = (v.iter().map(|p| p.0).min().unwrap(), v.iter().map(|p| p.0).max().unwrap());
        let (y0, y1) = (v.iter().map(|p| p.1).min().unwrap(), v.iter().map(|p| p.1).max().unwrap());
        let inner: Vec<f64> =
            v.iter().filter(|p| p.0 > x0 + 8 && p.0 + 8 < x1 && p.1 > y0 + 8 && p.1 + 8 < y1).map(|p| p.2).collect();
        let mean = inner.iter().sum::<f64>() / inner.len() as f64;
        let var = inner.iter().map(|l| (l - mean).powi(2)).sum::<f64>() / inner.len() as f64;
        (var.sqrt() / mean, inner.len())
    };
    let (tri, texels) = cv(SplatMode::Triangles, Emission::Basic, 200);
    let (fixed, _) = cv(SplatMode::Fixed, Emission::Basic, 200);
    // The adaptive hierarchy's cell quads (a power-of-two grid).
    let (quads, quad_texels) = cv(SplatMode::Triangles, Emission::AdaptiveLevel, 256);
    eprintln!(
        "glass slab: coefficient of variation over {texels} texels: triangles {tri:.2e}, fixed splats {fixed:.2e}; \
         adaptive-level cell quads {quads:.2e} over {quad_texels} texels"
    );
    assert!(quads < 1e-3, "cell quads: coefficient of variation {quads}");
    assert!(texels > 300, "the slab's caustic covers {texels} texels");
    assert!(tri < 1e-3, "caustic triangles: coefficient of variation {tri}");
    assert!(tri < 0.1 * fixed, "triangles {tri} vs fixed {fixed}");
}

/// Every mode's caustic map against the CPU reference's on the glass sphere scene: no worse than
/// fixed splats (relative RMSE after the 3x3 box filter of metrics::map_agreement, and HDR-FLIP).
#[test]
fn every_mode_is_no_worse_than_fixed_splats_on_the_sphere() {
    let Some(ctx) = gpu() else { return };
    let s = small(Scene::default_scene(), 32);
    let rs = caustics_reference::reference::ReferenceSettings {
        photons_per_light: 2_000_000,
        caustic_map_size: 256,
        ..Default::default()
    };
    let reference = caustics_reference::reference::caustic_maps(&s, &rs).unwrap().remove(0).remove(0);
    let err = |mode| {
        let out = render(&ctx, &s, &settings(256, 256, mode)).unwrap();
        let map = &out.caustic_maps[0][0];
        let a = caustics_reference::metrics::map_agreement(map, &reference);
        let flip = caustics_reference::metrics::hdr_flip(map, &reference, None).unwrap().mean;
        eprintln!("{mode}: {a}, mean HDR-FLIP {flip:.4}");
        (a.rel_rmse, flip)
    };
    let fixed = err(SplatMode::Fixed);
    let errs: Vec<_> = SplatMode::ALL.into_iter().skip(1).map(|m| (m, err(m))).collect();
    // Measured on lavapipe (256² photons, 256² map): fixed RMSE 0.709 FLIP 0.775; triangles
    // 0.009 / 0.756; thin- and thick-lens 0.387 / 0.791; multires 0.899 / 0.752. Multi-resolution
    // splatting blurs the focal peak (the paper notes it over-blurs), which the peak-dominated
    // RMSE punishes; the lens sizes' FLIP is 2 % above fixed splats'. Held: each mode is no
    // worse on at least one metric, triangles on both.
    for (mode, e) in errs {
        let (rmse_ok, flip_ok) = (e.0 <= fixed.0 * 1.02, e.1 <= fixed.1 * 1.02);
        assert!(rmse_ok || flip_ok, "{mode}: {e:?} vs fixed {fixed:?}");
        if mode == SplatMode::Triangles {
            assert!(rmse_ok && flip_ok, "{mode}: {e:?} vs fixed {fixed:?}");
        }
    }
}

/// Fraction of `map`'s energy (luminance) on texels farther than `r` texels (Chebyshev) from
/// every texel where `reference` has light: light carried into a gap where none arrives.
fn leak_fraction(map: &caustics::image_io::Image, reference: &caustics::image_io::Image, r: usize) -> f64 {
    let (w, h) = (reference.width as usize, reference.height as usize);
    let (lum, rl) = (map.luminance(), reference.luminance());
    // Distance transform by separable max filters of the "lit" mask (a dilation by r).
    let lit: Vec<bool> = rl.iter().map(|&l| l > 0.0).collect();
    let mut rows = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            rows[y * w + x] = (x.saturating_sub(r)..(x + r + 1).min(w)).any(|i| lit[y * w + i]);
        }
    }
    let mut near = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            near[y * w + x] = (y.saturating_sub(r)..(y + r + 1).min(h)).any(|j| rows[j * w + x]);
        }
    }
    let total: f64 = lum.iter().map(|&l| l as f64).sum();
    let dark: f64 = lum.iter().zip(&near).filter(|(_, n)| !**n).map(|(&l, _)| l as f64).sum();
    dark / total
}

/// Caustic triangles fall back to Gaussian splats as wide as a photon's beam (up to 12 texels)
/// where quads are rejected (silhouettes, different paths, long edges). Those splats must not
/// carry light into the gaps where the CPU reference (2 M photons) has none: the shadows beside
/// the focused light of a glass ball and of the glass bunny. Fixed splats of the same photons
/// (1-texel Gaussians, cut at 3 sigma) are the baseline: no light beyond 4 texels.
/// Measured on lavapipe (256² photons, 256² map), the fraction of the map's energy farther than
/// 4 texels from any lit reference texel: 0 for both modes on both scenes, with the fallback
/// capped at 6, 12 or 24 texels; beyond 2 texels, bunny: fixed 2.4e-4, triangles 1.4e-4.
#[test]
fn triangle_fallback_splats_do_not_spread_light_into_gaps() {
    let Some(ctx) = gpu() else { return };
    let bunny = Scene::load(Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/glass_bunny.json"))).unwrap();
    for (name, s) in [("glass ball", small(Scene::default_scene(), 32)), ("glass bunny", small(bunny, 32))] {
        let rs = caustics_reference::reference::ReferenceSettings {
            photons_per_light: 2_000_000,
            caustic_map_size: 256,
            ..Default::default()
        };
        let reference = caustics_reference::reference::caustic_maps(&s, &rs).unwrap().remove(0).remove(0);
        let leak = |mode| {
            let out = render(&ctx, &s, &settings(256, 256, mode)).unwrap();
            let map = &out.caustic_maps[0][0];
            let (near, far) = (leak_fraction(map, &reference, 2), leak_fraction(map, &reference, 4));
            eprintln!("{name} {mode}: energy beyond 2 texels of the reference's light {near:.2e}, beyond 4 {far:.2e}");
            (near, far)
        };
        let fixed = leak(SplatMode::Fixed);
        let tri = leak(SplatMode::Triangles);
        assert!(fixed.1 < 1e-6, "{name}: fixed splats beyond 4 texels {}", fixed.1);
        assert!(tri.1 < 1e-6, "{name}: triangles carry {} of their energy into the reference's dark", tri.1);
        assert!(tri.0 <= fixed.0 + 1e-4, "{name}: triangles {} vs fixed {} beyond 2 texels", tri.0, fixed.0);
    }
}
