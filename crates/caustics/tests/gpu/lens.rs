//! Thin- and thick-lens splat sizes (Wyman & Dachsbacher 2008, section 4.2) on a synthetic
//! spherical lens: a biconvex glass lens (both radii of curvature R, written as a finely
//! tessellated mesh with exact normals) under a spot light above a floor. The photons' beam
//! diameters (what the tracer stores for `splat_lens`) must match the lens equations (1), (2)
//! and (7) with the paraxial distances, and the true beam size, measured from the spacing of
//! neighbouring photons on the floor. Ray-differential sizes (`SplatMode::Differential`) must
//! match the true beam photon by photon, on the lens and on the glass ball, where the paraxial
//! lens equations do not hold (spherical aberration).
//! Without an adapter the tests skip with a printed reason, except in CI (`CI=true`).

use crate::common;
use crate::temp_scene;
use caustics::Scene;
use caustics::render::{Inspect, RenderSettings, SplatMode, render_inspect};
use caustics::settings::Emission;
use common::gpu;
use glam::Vec3;
use std::fmt::Write;

/// Lens radius of curvature (both faces), aperture radius, index, heights of lens and light.
const R: f32 = 1.0;
const APERTURE: f32 = 0.25;
const IOR: f32 = 1.5;
const LENS_Y: f32 = 1.0;
const LIGHT_Y: f32 = 3.0;
/// Photon grid and caustic map size.
const N: u32 = 256;
const M: u32 = 256;

fn sag() -> f32 {
    R - (R * R - APERTURE * APERTURE).sqrt()
}

/// OBJ text of the biconvex lens: two spherical caps meeting at the rim (y = LENS_Y), apexes at
/// LENS_Y ± sag, `rings` rings from the apex to the rim, `segs` segments around, exact normals.
fn lens_obj(rings: u32, segs: u32) -> String {
    let mut s = String::new();
    let theta_max = (APERTURE / R).asin();
    let mut base = 1u32;
    for top in [true, false] {
        let sign = if top { 1.0 } else { -1.0 };
        // Centre of the cap's sphere: below the lens for the top cap, above for the bottom one.
        let c = Vec3::new(0.0, LENS_Y + sign * (sag() - R), 0.0);
        let vert = |t: f32, p: f32| {
            let n = Vec3::new(t.sin() * p.cos(), sign * t.cos(), t.sin() * p.sin());
            (c + R * n, n)
        };
        let (apex, an) = vert(0.0, 0.0);
        writeln!(s, "v {} {} {}\nvn {} {} {}", apex.x, apex.y, apex.z, an.x, an.y, an.z).unwrap();
        for i in 1..=rings {
            let t = theta_max * i as f32 / rings as f32;
            for j in 0..segs {
                let (p, n) = vert(t, std::f32::consts::TAU * j as f32 / segs as f32);
                writeln!(s, "v {} {} {}\nvn {} {} {}", p.x, p.y, p.z, n.x, n.y, n.z).unwrap();
            }
        }
        let idx = |i: u32, j: u32| if i == 0 { base } else { base + 1 + (i - 1) * segs + j % segs };
        let mut tri = |a: u32, b: u32, c: u32| {
            // Outward winding: counter-clockwise seen from outside.
            let (b, c) = if top { (c, b) } else { (b, c) };
            writeln!(s, "f {a}//{a} {b}//{b} {c}//{c}").unwrap();
        };
        for j in 0..segs {
            tri(idx(0, 0), idx(1, j), idx(1, j + 1));
        }
        for i in 1..rings {
            for j in 0..segs {
                tri(idx(i, j), idx(i + 1, j), idx(i + 1, j + 1));
                tri(idx(i, j), idx(i + 1, j + 1), idx(i, j + 1));
            }
        }
        base += 1 + rings * segs;
    }
    s
}

fn lens_scene() -> Scene {
    let json = format!(
        r#"{{
  "schema_version": 1,
  "name": "spherical_lens",
  "camera": {{ "position": [0, 2, 3], "look_at": [0, 0.5, 0], "up": [0, 1, 0], "fov_y_deg": 40, "width": 32, "height": 32 }},
  "lights": [ {{ "type": "spot", "position": [0, {LIGHT_Y}, 0], "direction": [0, -1, 0], "cone_angle_deg": 10.0,
                 "falloff_start_deg": 9.9, "intensity": [10, 10, 10] }} ],
  "materials": {{ "floor": {{ "type": "diffuse", "albedo": 0.8 }},
                 "glass": {{ "type": "dielectric", "ior": {IOR}, "ext_ior": 1.0 }} }},
  "objects": [
    {{ "type": "mesh", "path": "lens.obj", "smooth_normals": true, "material": "glass" }},
    {{ "type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [4, 4], "material": "floor" }}
  ]
}}"#
    );
    temp_scene::load("lens", &[("lens.obj", lens_obj(96, 256))], &json)
}

/// Eq. 7 with eqs. 1 and 2 (thin lens), as a ratio to the unrefracted diameter D0.
fn thin_lens_ratio(d_front: f32, d_bg: f32) -> f32 {
    let power = (IOR - 1.0) * (1.0 / R + 1.0 / R);
    let d_image = 1.0 / (power - 1.0 / d_front);
    (d_front / (d_front + d_bg) * (d_bg - d_image) / d_image).abs()
}

/// Thick lens: focal length and principal planes of a biconvex lens of thickness t; the
/// distances are measured from the principal planes.
fn thick_lens_ratio(d_front: f32, d_bg: f32, t: f32) -> f32 {
    let (k1, k2) = (1.0 / R, -1.0 / R);
    let power = (IOR - 1.0) * (k1 - k2 + (IOR - 1.0) * t * k1 * k2 / IOR);
    let h1 = -(IOR - 1.0) * t * k2 / (IOR * power);
    let h2 = (IOR - 1.0) * t * k1 / (IOR * power);
    let (df, db) = (d_front + h1, d_bg + h2);
    let d_image = 1.0 / (power - 1.0 / df);
    (df / (df + db) * (db - d_image) / d_image).abs()
}

struct Measured {
    /// Median stored diameter over the photons measured, in caustic-map texels.
    stored: f32,
    /// Median true beam diameter: sqrt of the area of the cell's image on the floor.
    true_size: f32,
    /// Median stored / true, photon by photon, and its 10th and 90th percentiles.
    ratio: f32,
    ratio_p10: f32,
    ratio_p90: f32,
    count: usize,
}

fn quantile(v: &mut [f32], q: f32) -> f32 {
    v.sort_by(f32::total_cmp);
    v[((v.len() - 1) as f32 * q).round() as usize]
}

/// Stored diameters against the true beam over the photons of the n × n grid whose cell centre
/// lies within NDC radius `within` of the centre of the light's view and whose grid neighbours
/// (+x, +y) landed on the same face by the same path.
fn measure(ctx: &caustics::gpu::GpuContext, scene: &Scene, mode: SplatMode, within: f32, n: u32) -> Measured {
    let s = RenderSettings {
        photons: caustics::settings::PhotonSettings {
            count: n,
            caustic_map_size: M,
            splat: mode,
            emission: Emission::Basic, // One branch (the transmitted one): one photon per cell.
            reflection: false,
            internal_reflection: false,
            residual: false,
            ..Default::default()
        },
        shading: caustics::settings::ShadingSettings { shadow_map_size: 256, ..Default::default() },
        ..Default::default()
    };
    let out = render_inspect(ctx, scene, &s, Inspect { photons: true, ..Default::default() }).unwrap();
    let ph = &out.technique.photons;
    assert_eq!(ph.len(), (n * n) as usize, "one photon per grid cell");
    let (mut stored, mut truth, mut ratio) = (Vec::new(), Vec::new(), Vec::new());
    for b in caustics::splat::beam_samples(ph, n) {
        if (b.ndc[0] * b.ndc[0] + b.ndc[1] * b.ndc[1]).sqrt() <= within {
            stored.push(b.stored);
            truth.push(b.true_size);
            ratio.push(b.stored / b.true_size);
        }
    }
    Measured {
        count: stored.len(),
        stored: quantile(&mut stored, 0.5),
        true_size: quantile(&mut truth, 0.5),
        ratio: quantile(&mut ratio, 0.5),
        ratio_p10: quantile(&mut ratio, 0.1),
        ratio_p90: quantile(&mut ratio, 0.9),
    }
}

/// NDC radius of the lens's paraxial zone (40 % of the aperture) in the light's view, which
/// spans tan(10°) at unit distance.
fn paraxial() -> f32 {
    0.4 * APERTURE / ((LIGHT_Y - LENS_Y) * 10f32.to_radians().tan())
}

#[test]
fn thin_and_thick_lens_sizes_match_the_lens_equations_on_a_spherical_lens() {
    let Some(ctx) = gpu() else { return };
    let scene = lens_scene();
    // Unrefracted photon spacing on the floor: one cell of the N-grid is M / N texels of the
    // caustic map (same frustum).
    let d0 = M as f32 / N as f32;
    // Paraxial distances: light to the front apex, back apex to the floor, thickness.
    let t = 2.0 * sag();
    let d_front = LIGHT_Y - (LENS_Y + sag());
    let d_bg = LENS_Y - sag();
    let thin = measure(&ctx, &scene, SplatMode::ThinLens, paraxial(), N);
    let thick = measure(&ctx, &scene, SplatMode::ThickLens, paraxial(), N);
    let want_thin = d0 * thin_lens_ratio(d_front, d_bg);
    let want_thick = d0 * thick_lens_ratio(d_front, d_bg, t);
    println!(
        "thin: stored {:.4} (eq. 7 {:.4}), thick: stored {:.4} (eq. 7 {:.4}), true beam {:.4}; stored/true thin {:.3} thick {:.3} over {} photons",
        thin.stored, want_thin, thick.stored, want_thick, thin.true_size, thin.ratio, thick.ratio, thin.count
    );
    assert!(thin.count > 1000, "paraxial photons: {}", thin.count);
    // The stored sizes follow the equations (curvature estimated from the light-space buffers).
    assert!((thin.stored / want_thin - 1.0).abs() < 0.03, "thin lens {} vs {}", thin.stored, want_thin);
    assert!((thick.stored / want_thick - 1.0).abs() < 0.03, "thick lens {} vs {}", thick.stored, want_thick);
    // And the equations describe the true beam: the thick lens within 5 %, the thin lens within
    // its thickness error.
    assert!((thick.ratio - 1.0).abs() < 0.05, "thick lens stored / true beam {}", thick.ratio);
    assert!((thin.ratio - 1.0).abs() < 0.1, "thin lens stored / true beam {}", thin.ratio);
}

#[test]
fn ray_differential_sizes_match_the_true_beam() {
    let Some(ctx) = gpu() else { return };
    // The synthetic lens, over the whole aperture.
    let lens = measure(&ctx, &lens_scene(), SplatMode::Differential, 1.0, N);
    println!(
        "lens: stored {:.4}, true {:.4}, stored/true p10 {:.3} p50 {:.3} p90 {:.3} over {} photons",
        lens.stored, lens.true_size, lens.ratio_p10, lens.ratio, lens.ratio_p90, lens.count
    );
    assert!(lens.count > 5000, "photons through the lens: {}", lens.count);
    assert!((lens.ratio - 1.0).abs() < 0.01, "median stored / true {}", lens.ratio);
    assert!(lens.ratio_p10 > 0.99 && lens.ratio_p90 < 1.01, "{} .. {}", lens.ratio_p10, lens.ratio_p90);
    // The glass ball (a thick lens with strong spherical aberration): the lens equations are
    // off by an order of magnitude for most photons, the differentials are not. A finer grid
    // (512²): the true beam is measured by finite differences over one cell, which must be
    // small against the aberration's scale.
    let ball =
        Scene::load(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/glass_sphere.json")).unwrap();
    let d = measure(&ctx, &ball, SplatMode::Differential, 1.0, 512);
    let thick = measure(&ctx, &ball, SplatMode::ThickLens, 1.0, 512);
    println!(
        "ball: differential stored/true p10 {:.3} p50 {:.3} p90 {:.3}; thick lens p10 {:.3} p50 {:.3} p90 {:.3}; {} photons",
        d.ratio_p10, d.ratio, d.ratio_p90, thick.ratio_p10, thick.ratio, thick.ratio_p90, d.count
    );
    assert!(d.count > 10000, "photons through the ball: {}", d.count);
    assert!((d.ratio - 1.0).abs() < 0.03, "median stored / true {}", d.ratio);
    assert!(d.ratio_p10 > 0.9 && d.ratio_p90 < 1.1, "{} .. {}", d.ratio_p10, d.ratio_p90);
    assert!(thick.ratio < 0.5, "the thick-lens estimate fails on the ball: median {}", thick.ratio);
}
