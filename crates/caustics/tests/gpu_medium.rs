//! Direct light in a participating medium on the GPU (`medium_scatter`, the attenuation in
//! `shade_receivers`): exact absorption, single scattering against the CPU reference, light
//! shafts shadowed by objects, and the renderer's steady state with a medium; heterogeneous
//! media (a density grid): absorption through two slabs against the closed form, single
//! scattering in a smoke puff against the CPU reference; single scattering of a directional
//! light (a sun whose light enters the box from outside) against the CPU reference; light
//! between a lit floor and the fog (`medium_bounce`), and a floor caustic's glow in the fog,
//! against the CPU reference.

mod common;

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
        ..Default::default()
    }
}

/// A point light beside the camera and a lit diffuse wall 4 m away, with `medium` appended.
fn absorb_json(medium: &str) -> String {
    format!(
        r#"{{ "schema_version": 1, "name": "absorb",
  "camera": {{ "position": [0, 0, 0], "look_at": [0, 0, -1], "fov_y_deg": 40, "width": 16, "height": 12 }},
  "lights": [ {{ "type": "point", "position": [0.5, 0.3, 0], "intensity": 5 }} ],
  "materials": {{ "wall": {{ "type": "diffuse", "albedo": 0.5 }} }},
  "objects": [ {{ "type": "rectangle", "center": [0, 0, -4], "normal": [0, 0, 1], "size": [20, 20], "material": "wall" }} ]
  {medium} }}"#
    )
}

/// A purely absorbing medium (σs = 0) filling the view.
const ABSORBING: &str = r#", "medium": { "sigma_s": 0, "sigma_a": [0.1, 0.2, 0.05], "bounds": { "min": [-5, -5, -10], "max": [5, 5, 1] } }"#;

#[test]
fn absorbing_medium_attenuates_by_the_camera_and_light_paths() {
    let Some(ctx) = gpu() else { return };
    // A point light beside the camera, a lit diffuse wall 4 m away, σs = 0: every pixel is the
    // vacuum pixel times exp(−σa (d_camera + d_light)).
    let json = absorb_json;
    let vacuum = scene(&json(""));
    let fog = scene(&json(ABSORBING));
    let a = render(&ctx, &vacuum, &settings()).unwrap();
    let b = render(&ctx, &fog, &settings()).unwrap();
    let sa = [0.1f32, 0.2, 0.05];
    let lp = Vec3::new(0.5, 0.3, 0.0);
    let mut worst = 0.0f32;
    for y in 0..12 {
        for x in 0..16 {
            let d = fog.camera.ray_dir(x as f32 + 0.5, y as f32 + 0.5);
            let t = 4.0 / -d.z;
            let dl = (d * t - lp).length();
            let (pa, pb) = (a.image.get(x, y), b.image.get(x, y));
            // Measured: worst relative error 4.8e-7.
            for c in 0..3 {
                assert!(pa[c] > 0.0);
                let want = (-sa[c] * (t + dl)).exp();
                let err = (pb[c] / pa[c] / want - 1.0).abs();
                worst = worst.max(err);
                assert!(err < 0.01, "pixel ({x}, {y}) channel {c}: {} vs {want}", pb[c] / pa[c]);
            }
        }
    }
    println!("absorption: worst relative error {worst:.2e}");
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

#[test]
fn single_scattering_from_a_spot_matches_the_reference() {
    let Some(ctx) = gpu() else { return };
    for phase in [ISOTROPIC, r#"{ "type": "hg", "g": 0.5 }"#] {
        let sc = shaft_scene_with("", phase);
        let g = render(
            &ctx,
            &sc,
            &RenderSettings {
                medium: caustics::settings::MediumSettings { steps: 256, ..settings().medium },
                ..settings()
            },
        )
        .unwrap();
        let rs = common::single_scattering_reference(1, 1 << 16, 3);
        let r = reference::render(&sc, &rs).unwrap();
        let mut worst = 0.0f32;
        // Pixels inside the beam, away from its edge (the GPU takes the pixel centre, the
        // reference the box filter): the two centre columns, rows 3..9.
        for y in 3..9 {
            for x in [7, 8] {
                let (pg, pr, v) = (g.image.get(x, y), r.nocaustic.get(x, y), r.nocaustic_variance.get(x, y));
                for c in 0..3 {
                    let err = (pg[c] / pr[c] - 1.0).abs();
                    println!("({x}, {y}) {c}: GPU {} reference {} (sd {:.1e}), {err:.3}", pg[c], pr[c], v[c].sqrt());
                    worst = worst.max(err);
                }
            }
        }
        // Measured: worst 0.032 isotropic (pixel (8, 4), 2.6 reference standard deviations:
        // 1.3 % noise at 65536 paths per pixel; most pixels under 0.015), 0.031 with g = 0.5.
        println!("single scattering {phase}: worst relative difference {worst:.3}");
        assert!(worst < 0.06, "{phase}: {worst}");
        // Outside the beam (top corners): no in-scattering.
        assert!(g.image.get(0, 0).iter().all(|&v| v == 0.0));
        // The caustic-only image holds no medium light.
        assert!(g.caustic.pixels.iter().flatten().all(|&v| v == 0.0));
    }
}

#[test]
fn an_object_in_the_beam_shadows_the_shaft() {
    let Some(ctx) = gpu() else { return };
    let open = render(&ctx, &shaft_scene(""), &settings()).unwrap();
    let blocker = r#", { "type": "sphere", "center": [0, 1, 0], "radius": 0.1, "material": "white" }"#;
    let shadowed = render(&ctx, &shaft_scene(blocker), &settings()).unwrap();
    // Below the sphere, on the beam's axis (x = 0 lies between columns 7 and 8): the shadow's
    // cone; beside it (column 10, about 0.55 m off the axis at the beam's depth) lit.
    for y in [7, 8, 9] {
        let axis = |i: &caustics::image_io::Image| (i.get(7, y)[1] + i.get(8, y)[1]) * 0.5;
        let (a, b) = (axis(&shadowed.image), axis(&open.image));
        let (sa, sb) = (shadowed.image.get(10, y)[1], open.image.get(10, y)[1]);
        println!("row {y}: axis {a} (open {b}), side {sa} (open {sb})");
        assert!(a < 0.85 * b, "row {y}: the shadow darkens the shaft behind the sphere");
        assert!(a / b < 0.9 * (sa / sb), "row {y}: the shadow side is darkened, the lit side not");
        assert!(sa > 0.97 * sb, "row {y}: beside the shadow the shaft is lit");
    }
}

/// A slanted directional light (a sun) in fog over a black floor, a black roof over part of
/// the box casting a shadow into the fog; the camera inside the box. Everything the camera
/// sees is single-scattered light of the sun.
fn sun_fog_scene() -> Scene {
    scene(
        r#"{ "schema_version": 1, "name": "sun_fog",
  "camera": { "position": [0, 0, 4], "look_at": [0, 0, 0], "fov_y_deg": 40, "width": 16, "height": 12 },
  "lights": [ { "type": "directional", "direction": [0.3, -1, 0.2], "irradiance": [1, 1.5, 2] } ],
  "materials": { "black": { "type": "diffuse", "albedo": 0 } },
  "objects": [ { "type": "rectangle", "center": [0, -3, 0], "normal": [0, 1, 0], "size": [6, 6], "material": "black" },
               { "type": "rectangle", "center": [-1.5, 1.5, 0], "normal": [0, 1, 0], "size": [3, 8], "material": "black" } ],
  "medium": { "sigma_s": [0.3, 0.2, 0.4], "sigma_a": [0.05, 0.1, 0.0], "phase": { "type": "hg", "g": 0.3 },
              "bounds": { "min": [-3, -3.5, -3], "max": [3, 3, 5] } } }"#,
    )
}

#[test]
fn single_scattering_from_a_directional_light_matches_the_reference() {
    let Some(ctx) = gpu() else { return };
    // The sun's light enters the box from the vacuum above it: the transmittance of its path
    // is the part of the line back toward the sun inside the box; the roof's shadow falls into
    // the fog (the orthographic shadow map). The scene format accepts a directional light with
    // a medium.
    let sc = sun_fog_scene();
    let g = render(
        &ctx,
        &sc,
        &RenderSettings {
            shading: caustics::settings::ShadingSettings { shadow_map_size: 1024, ..settings().shading },
            medium: caustics::settings::MediumSettings { steps: 256, ..settings().medium },
            ..settings()
        },
    )
    .unwrap();
    let rs = common::single_scattering_reference(1, 1 << 14, 3);
    let r = reference::render(&sc, &rs).unwrap();
    let (mut sum_g, mut sum_r) = ([0f64; 3], [0f64; 3]);
    let (mut errs, mut lit, mut dark) = (Vec::new(), 0, 0);
    let peak = r.nocaustic.pixels.iter().map(|p| p[1]).fold(0.0f32, f32::max);
    let mut shadow_leak = 0.0f32;
    for y in 0..12 {
        for x in 0..16 {
            let (pg, pr) = (g.image.get(x, y), r.nocaustic.get(x, y));
            for c in 0..3 {
                sum_g[c] += pg[c] as f64;
                sum_r[c] += pr[c] as f64;
            }
            // Per pixel away from the shadow's edge (the GPU takes the pixel's centre, the
            // reference its box): the pixel and its 4 neighbours within 30 % of each other; in
            // the roof's full shadow both are 0.
            if pr[1] <= 0.0 {
                // The shadow map's one-texel offset toward the light lifts points just under
                // the roof above it: a little light there.
                assert!(pg[1] < 0.02 * peak, "({x}, {y}): GPU {pg:?} in the reference's full shadow");
                shadow_leak = shadow_leak.max(pg[1] / peak);
                continue;
            }
            let near = [(-1i32, 0i32), (1, 0), (0, -1), (0, 1)].iter().all(|&(dx, dy)| {
                let (nx, ny) = (x as i32 + dx, y as i32 + dy);
                if nx < 0 || ny < 0 || nx >= 16 || ny >= 12 {
                    return true;
                }
                let q = g.image.get(nx as u32, ny as u32)[1];
                (q / pg[1] - 1.0).abs() < 0.3
            });
            if near {
                errs.push((pg[1] / pr[1] - 1.0).abs());
            }
            if pg[1] > 0.8 * g.image.get(15, 11)[1] { lit += 1 } else { dark += 1 }
        }
    }
    errs.sort_by(f32::total_cmp);
    let (median, worst) = (errs[errs.len() / 2], errs[errs.len() - 1]);
    let energy: Vec<f64> = (0..3).map(|c| sum_g[c] / sum_r[c]).collect();
    println!(
        "sun in fog: energy GPU/reference {energy:?}; {} smooth pixels: median {median:.4}, worst {worst:.4}; lit {lit}, shadowed {dark}; GPU in the reference's full shadow up to {shadow_leak:.4} of the peak",
        errs.len()
    );
    for e in &energy {
        assert!((e - 1.0).abs() < 0.03, "energy {energy:?}");
    }
    assert!(median < 0.03 && worst < 0.08, "median {median}, worst {worst}");
    // The roof's shadow is in the image (and the sunlit part).
    assert!(lit > 10 && dark > 10, "lit {lit}, shadowed {dark}");
    assert!(g.caustic.pixels.iter().flatten().all(|&v| v == 0.0));
}

#[test]
fn a_renderer_with_a_medium_creates_nothing_after_its_first_frame() {
    let Some(ctx) = gpu() else { return };
    // The shaft over a black floor, and a lit floor (the `medium_bounce` passes), two lights.
    for mut sc in [shaft_scene(""), lit_floor_fog_scene()] {
        let second = sc.lights[0].clone();
        sc.lights.push(second);
        let mut r = Renderer::with_context(ctx.clone(), sc, settings()).unwrap();
        assert!(common::created_by_a_frame(&mut r) > 0);
        assert_eq!(common::created_by_a_frame(&mut r), 0);
        r.invalidate();
        assert_eq!(common::created_by_a_frame(&mut r), 0);
    }
}

fn with_grid(mut sc: Scene, g: DensityGrid) -> Scene {
    sc.medium.as_mut().unwrap().density = Some(Arc::new(g));
    sc
}

#[test]
fn absorption_through_a_density_grid_matches_the_closed_form() {
    let Some(ctx) = gpu() else { return };
    // The absorbing scene of the first test with a grid of two voxels along z (density 0.3 at
    // the back, 1.7 at the front of the box z ∈ [−10, 1], trilinear between the voxel centres
    // z = −7.25 and −1.75): the optical depth of a straight segment is the trapezoid integral of
    // the piecewise linear density, exact; the GPU marches 256 steps per segment.
    let json = absorb_json;
    let vacuum = scene(&json(""));
    let fog = with_grid(scene(&json(ABSORBING)), DensityGrid::new([1, 1, 2], vec![0.3, 1.7]).unwrap());
    let s = RenderSettings {
        medium: caustics::settings::MediumSettings { steps: 256, light_steps: 256, ..settings().medium },
        ..settings()
    };
    let a = render(&ctx, &vacuum, &s).unwrap();
    let b = render(&ctx, &fog, &s).unwrap();
    // ρ(z), and ∫ρ dz between two depths (exact for the piecewise linear ρ).
    let rho = |z: f64| 0.3 + 1.4 * ((z + 7.25) / 5.5).clamp(0.0, 1.0);
    let integral = |z0: f64, z1: f64| {
        let (lo, hi) = (z0.min(z1), z0.max(z1));
        let mut pts = vec![lo, hi];
        pts.extend([-7.25, -1.75].into_iter().filter(|&z| z > lo && z < hi));
        pts.sort_by(f64::total_cmp);
        pts.windows(2).map(|w| (rho(w[0]) + rho(w[1])) * 0.5 * (w[1] - w[0])).sum::<f64>()
    };
    let sa = [0.1f64, 0.2, 0.05];
    let lp = Vec3::new(0.5, 0.3, 0.0);
    let mut worst = 0.0f64;
    for y in 0..12 {
        for x in 0..16 {
            let d = fog.camera.ray_dir(x as f32 + 0.5, y as f32 + 0.5);
            let t = 4.0 / -d.z;
            let p = d * t;
            // Optical depth along a segment = ∫ρ dz · (length / |Δz|).
            let tau_cam = integral(0.0, -4.0) * t as f64 / 4.0;
            let tau_l = integral(0.0, -4.0) * (p - lp).length() as f64 / 4.0;
            let (pa, pb) = (a.image.get(x, y), b.image.get(x, y));
            for c in 0..3 {
                let want = (-sa[c] * (tau_cam + tau_l)).exp();
                let err = (pb[c] as f64 / pa[c] as f64 / want - 1.0).abs();
                worst = worst.max(err);
                assert!(err < 1e-3, "pixel ({x}, {y}) channel {c}: {} vs {want}", pb[c] / pa[c]);
            }
        }
    }
    println!("absorption through the grid: worst relative error {worst:.2e}");
}

/// A smoke puff over the shaft scene's box: a Gaussian blob on the beam's axis, off centre,
/// on a thin haze (10 × 12 × 10 voxels).
fn puff() -> DensityGrid {
    let dims = [10u32, 12, 10];
    let mut v = Vec::new();
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let u = (Vec3::new(x as f32, y as f32, z as f32) + 0.5)
                    / Vec3::new(dims[0] as f32, dims[1] as f32, dims[2] as f32);
                // The box is [−3, 3] × [−3.5, 3] × [−3, 5]: the blob's centre near (0.3, 0, 0).
                let r2 = (u - Vec3::new(0.55, 0.55, 0.37)).length_squared();
                v.push(0.2 + 2.5 * (-r2 / 0.01).exp());
            }
        }
    }
    DensityGrid::new(dims, v).unwrap()
}

#[test]
fn single_scattering_in_a_smoke_puff_matches_the_reference() {
    let Some(ctx) = gpu() else { return };
    let sc = with_grid(shaft_scene_with("", r#"{ "type": "hg", "g": 0.3 }"#), puff());
    let g = render(
        &ctx,
        &sc,
        &RenderSettings {
            medium: caustics::settings::MediumSettings { steps: 256, light_steps: 64, ..settings().medium },
            ..settings()
        },
    )
    .unwrap();
    let rs = common::single_scattering_reference(1, 1 << 15, 3);
    let r = reference::render(&sc, &rs).unwrap();
    // Pixels in the beam away from its edge (rows 3..9 of the centre columns), through the puff
    // and beside it. The bound: 4 standard deviations of the reference's pixel plus 3 % for the
    // pixel footprint (the GPU takes the pixel centre, the reference the box filter: up to
    // 2 % on the homogeneous shaft, `single_scattering_from_a_spot_matches_the_reference`) and
    // the ray march.
    let mut worst = 0.0f32;
    for y in 3..9 {
        for x in [7, 8] {
            let (pg, pr, v) = (g.image.get(x, y), r.nocaustic.get(x, y), r.nocaustic_variance.get(x, y));
            for c in 0..3 {
                let sd = v[c].sqrt();
                let err = (pg[c] - pr[c]).abs();
                println!("({x}, {y}) {c}: GPU {} reference {} (sd {sd:.1e}), {:.3}", pg[c], pr[c], err / pr[c]);
                worst = worst.max(err / pr[c]);
                assert!(sd < 0.02 * pr[c], "the reference resolves 2 %");
                assert!(err < 4.0 * sd + 0.03 * pr[c], "pixel ({x}, {y}) channel {c}");
            }
        }
    }
    println!("single scattering in the puff: worst relative difference {worst:.3}");
    // The puff makes the shaft uneven: brighter through the blob than the haze alone gives.
    let haze = with_grid(
        shaft_scene_with("", r#"{ "type": "hg", "g": 0.3 }"#),
        DensityGrid::new([1, 1, 1], vec![0.2]).unwrap(),
    );
    let h = render(
        &ctx,
        &haze,
        &RenderSettings {
            medium: caustics::settings::MediumSettings { steps: 256, light_steps: 64, ..settings().medium },
            ..settings()
        },
    )
    .unwrap();
    let (a, b) = (g.image.get(8, 5)[1], h.image.get(8, 5)[1]);
    assert!(a > 1.5 * b, "through the puff {a}, haze alone {b}");
}

#[test]
fn a_renderer_with_a_density_grid_creates_nothing_after_its_first_frame() {
    let Some(ctx) = gpu() else { return };
    let sc = with_grid(shaft_scene(""), puff());
    let mut r = Renderer::with_context(ctx.clone(), sc, settings()).unwrap();
    assert!(common::created_by_a_frame(&mut r) > 0);
    assert_eq!(common::created_by_a_frame(&mut r), 0);
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

/// A lit-floor scene (`lit_floor_fog_scene` and its variants) against the single-scattering
/// reference: for `medium_bounce_grid` 16 and 0, the GPU's fog rows (0..12, no surface in
/// view) and floor rows (18..32) over the reference's; `check` sees each render.
fn lit_floor_ratios(
    ctx: &caustics::gpu::GpuContext,
    sc: &Scene,
    label: &str,
    mut check: impl FnMut(u32, &caustics::output::GpuRender),
) -> Vec<(f64, f64)> {
    let r = reference::render(sc, &common::single_scattering_reference(1, 1024, 5)).unwrap();
    let (fog_r, floor_r) = (rows_sum(&r.image, 0..12), rows_sum(&r.image, 18..32));
    let mut ratios = Vec::new();
    for grid in [16, 0] {
        let g = render(
            ctx,
            sc,
            &RenderSettings {
                medium: caustics::settings::MediumSettings { bounce_grid: grid, ..settings().medium },
                ..settings()
            },
        )
        .unwrap();
        let (fog, floor) = (rows_sum(&g.image, 0..12) / fog_r, rows_sum(&g.image, 18..32) / floor_r);
        println!("{label}, medium_bounce_grid {grid}: GPU / reference: fog rows {fog:.4}, floor rows {floor:.4}");
        ratios.push((fog, floor));
        check(grid, &g);
    }
    ratios
}

#[test]
fn light_between_a_lit_floor_and_the_fog_matches_the_reference() {
    let Some(ctx) = gpu() else { return };
    // The reference with single scattering counts every path with one scattering event in the
    // medium: light -> floor -> fog -> camera (the fog glows over the lit floor) and light ->
    // fog -> floor -> camera (the shaft lights the floor around it), and light -> floor -> fog
    // -> floor -> camera (the glow lights the floor back), which `medium_bounce` and
    // `medium_bounce_surfaces` add (from the surface VPLs, the shaft emitters and the glow
    // emitters). Regions: the fog rows (0..12, no surface in view) and the floor rows (18..32).
    let sc = lit_floor_fog_scene();
    let ratios = lit_floor_ratios(&ctx, &sc, "even fog", |grid, g| {
        // No caster: nothing in the caustic-only image.
        assert!(g.caustic.pixels.iter().flatten().all(|&v| v == 0.0));
        // The same bits in a second render (the VPLs' sums run in a fixed order).
        let again = render(
            &ctx,
            &sc,
            &RenderSettings {
                medium: caustics::settings::MediumSettings { bounce_grid: grid, ..settings().medium },
                ..settings()
            },
        )
        .unwrap();
        assert!(again.image.pixels == g.image.pixels, "grid {grid}: a second render differs");
    });
    // Settings out of range are input errors naming the field.
    for bad in [
        RenderSettings {
            medium: caustics::settings::MediumSettings { bounce_grid: 65, ..settings().medium },
            ..settings()
        },
        RenderSettings {
            medium: caustics::settings::MediumSettings { bounce_steps: 0, ..settings().medium },
            ..settings()
        },
    ] {
        let Err(e) = render(&ctx, &sc, &bad) else { panic!("a setting out of range was accepted") };
        assert!(e.to_string().contains("medium.bounce_"), "{e}");
    }
    // Measured (lavapipe): with the passes fog 0.999, floor 0.996; without them fog 0.788,
    // floor 0.802. The floor rows were 0.944 before the glow's light on the floor (light ->
    // floor -> fog -> floor, `medium_bounce_glow`; 0.969 with half its blocks and slices),
    // 0.978 before the emitters' near-field layer gain (`layer_gain`,
    // shaders/shared/medium_bounce.wgsl; 0.990 with it on the surfaces' emitters only).
    let (with, without) = (ratios[0], ratios[1]);
    assert!((with.0 - 1.0).abs() < 0.02, "fog rows: {}", with.0);
    assert!(with.1 > 0.985 && with.1 < 1.01, "floor rows: {}", with.1);
    // Without the passes the test fails: the fog's glow is missing.
    assert!(without.0 < 0.9 && without.1 < 0.88, "without the passes: {without:?}");
}

#[test]
fn a_spot_shaft_needs_few_steps() {
    let Some(ctx) = gpu() else { return };
    // `medium_scatter` integrates a spot light's single scattering over the part of each
    // camera ray inside its cone (`cone_clip`): no jump at the shaft's edge is left for the
    // midpoint rule, so a few steps give what many do, the shaft's edge included (a rule across
    // the edge leaves bands). The shaft scene has no object: its integrand is smooth inside.
    let sc = shaft_scene("");
    let fine = render(
        &ctx,
        &sc,
        &RenderSettings {
            medium: caustics::settings::MediumSettings { steps: 512, ..settings().medium },
            ..settings()
        },
    )
    .unwrap();
    let peak = fine.image.pixels.iter().map(|p| p[1]).fold(0.0f32, f32::max);
    let mut worsts = Vec::new();
    for steps in [4, 8, 16, 32] {
        let coarse = render(
            &ctx,
            &sc,
            &RenderSettings { medium: caustics::settings::MediumSettings { steps, ..settings().medium }, ..settings() },
        )
        .unwrap();
        let mut worst = 0.0f32;
        let mut at = 0;
        for (i, (a, b)) in coarse.image.pixels.iter().zip(&fine.image.pixels).enumerate() {
            if b[1] > 0.01 * peak && (a[1] / b[1] - 1.0).abs() > worst {
                worst = (a[1] / b[1] - 1.0).abs();
                at = i;
            }
        }
        println!("{steps} steps against 512: worst relative difference {worst:.2e} at ({}, {})", at % 16, at / 16);
        worsts.push(worst);
    }
    // Measured (lavapipe): 4, 8, 16, 32 steps: 0.116, 0.018, 0.0064, 0.0018 (the rest is the
    // 1/r^2 peak near the light). Across the edge (without `cone_clip`): 1.00, 2.10, 0.99, 0.12.
    assert!(worsts[2] < 0.01 && worsts[3] < 0.004, "{worsts:?}");
}

/// A glass ball that takes all of a narrow spot's light and focuses it onto a floor of albedo
/// 0.8, in fog below the ball only (the box's top at y = 0.35, under the ball): the floor is lit
/// by the caustic alone, so all the light in the fog is caustic; the camera inside the box looks
/// along the floor.
fn caustic_glow_scene() -> Scene {
    scene(
        r#"{ "schema_version": 1, "name": "caustic_glow",
  "camera": { "position": [0.0, 0.3, 3.6], "look_at": [0.0, 0.1, 0.0], "fov_y_deg": 40.0, "width": 32, "height": 32 },
  "lights": [ { "type": "spot", "position": [0, 4, 0], "direction": [0, -1, 0], "cone_angle_deg": 8, "falloff_start_deg": 8, "intensity": [400, 400, 400] } ],
  "materials": { "floor": { "type": "diffuse", "albedo": 0.8 }, "glass": { "type": "dielectric", "ior": 1.5 } },
  "objects": [ { "type": "sphere", "center": [0, 0.9, 0], "radius": 0.5, "material": "glass" },
               { "type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [8, 8], "material": "floor" } ],
  "medium": { "sigma_s": [0.3, 0.3, 0.3], "sigma_a": [0.02, 0.02, 0.02], "phase": { "type": "isotropic" },
              "bounds": { "min": [-4, -1, -4], "max": [4, 0.35, 4.5] } } }"#,
    )
}

#[test]
fn light_between_a_lit_floor_and_layered_fog_matches_the_reference() {
    let Some(ctx) = gpu() else { return };
    // The lit floor under ground fog: a density grid, 2.2 at the floor falling to 0.25 at 1.5 m
    // and above (the gathers march the grid from each VPL to the point it lights).
    let dims = [4u32, 22, 4];
    let mut v = Vec::new();
    for _z in 0..dims[2] {
        for y in 0..dims[1] {
            for _x in 0..dims[0] {
                // Voxel centres over y in [-1, 4.5].
                let h = -1.0 + (y as f32 + 0.5) / dims[1] as f32 * 5.5;
                v.push(0.25 + 1.95 * (1.0 - (h / 1.5).clamp(0.0, 1.0)));
            }
        }
    }
    let sc = with_grid(lit_floor_fog_scene(), DensityGrid::new(dims, v).unwrap());
    let ratios = lit_floor_ratios(&ctx, &sc, "layered fog", |_, _| {});
    // Measured (lavapipe): with the passes fog 1.005, floor 0.988; without them 0.794, 0.780.
    // The floor rows were 0.923 before the glow's light on the floor (`medium_bounce_glow`),
    // 0.960 before the emitters' near-field layer gain; what remains is larger than in the even
    // fog: the dense layer's glow is nearer the floor, where the emitters' bins are coarsest.
    let (with, without) = (ratios[0], ratios[1]);
    assert!((with.0 - 1.0).abs() < 0.02 && with.1 > 0.975 && with.1 < 1.02, "{ratios:?}");
    assert!(without.0 < 0.85 && without.1 < 0.85, "{ratios:?}");
}

#[test]
fn the_floor_caustics_glow_in_the_fog_matches_the_reference() {
    let Some(ctx) = gpu() else { return };
    // The floor caustic's light scattered into the fog (light -> glass -> floor -> fog ->
    // camera) is caustic light: `medium_bounce` adds it to both images from the caustic map's
    // share of the VPLs' flux. Rows 13..18 see the fog over the caustic (the volume caustic
    // below the ball, from the beams, and the glow); the rows below see the floor, which the
    // reference also lights with the floor caustic's glow (light -> glass -> floor -> fog ->
    // floor), the GPU does not (docs/media.md; the fog's caustic light on the floor,
    // light -> glass -> fog -> floor, is `medium_bounce_beams`', tested below).
    let sc = caustic_glow_scene();
    let rs = common::single_scattering_reference(1 << 20, 256, 7);
    let r = reference::render(&sc, &rs).unwrap();
    let rows = |img: &caustics::image_io::Image| rows_sum(img, 13..18);
    let want = rows(&r.caustic);
    let mut ratios = Vec::new();
    for grid in [16, 0] {
        let g = render(
            &ctx,
            &sc,
            &RenderSettings {
                medium: caustics::settings::MediumSettings { bounce_grid: grid, ..settings().medium },
                ..settings()
            },
        )
        .unwrap();
        // No direct light reaches the floor or the fog: without the VPLs the full image is the
        // caustic one below the ball (whose lower half reflects the glowing fog into the full
        // image: the caustic-only image is zero where the camera sees glass). With them the
        // floor also has the fog's caustic light (`medium_bounce_beams`), which is not the
        // caustic map's (the caustic-only image holds first diffuse hits only).
        let w = g.image.width as usize;
        let below = 13 * w..;
        let full_minus_caustic: f64 = g.image.pixels[below.clone()]
            .iter()
            .zip(&g.caustic.pixels[below])
            .map(|(a, b)| (a[1] - b[1]).abs() as f64)
            .sum();
        if grid == 0 {
            assert!(full_minus_caustic <= 1e-6 * rows(&g.caustic), "grid {grid}: {full_minus_caustic}");
        }
        ratios.push(rows(&g.caustic) / want);
    }
    println!("fog rows over the caustic, GPU / reference: {:.4} with the glow, {:.4} without", ratios[0], ratios[1]);
    // Measured (lavapipe): 0.988 with the glow, 0.719 without (0.983 before the emitters'
    // near-field gain, 0.997 with it before the photons carried their path's transmittance;
    // another seed then: 0.985, 0.728).
    assert!((ratios[0] - 1.0).abs() < 0.03, "{ratios:?}");
    assert!(ratios[1] < 0.8, "{ratios:?}");
    // The surface caustic from the beams (the lights' caustic maps empty): the beams' landing
    // light makes the VPLs' caustic share (`medium_bounce_beams`, `emit_landing`), so the glow
    // it adds is the photon map's. (These rows also see the floor caustic at the horizon, which
    // the two draw differently: their glows are compared, not their images.)
    let beams = |grid| RenderSettings {
        medium: caustics::settings::MediumSettings { bounce_grid: grid, ..settings().medium },
        sources: caustics::settings::SourceSettings {
            local: caustics::settings::LocalSource::Beams,
            ..Default::default()
        },
        ..settings()
    };
    let glow = (rows(&render(&ctx, &sc, &beams(16)).unwrap().caustic)
        - rows(&render(&ctx, &sc, &beams(0)).unwrap().caustic))
        / want;
    let photon_glow = ratios[0] - ratios[1];
    println!("the glow over the caustic (of the reference's rows): beams {glow:.4}, photon map {photon_glow:.4}");
    // Measured (lavapipe): beams 0.267, photon map 0.268 (0.252 and 0.257 before the
    // emitters' near-field gain; before the landing emitters the beams' glow was 0).
    assert!((glow / photon_glow - 1.0).abs() < 0.05, "beams {glow}, photon map {photon_glow}");
}

#[test]
fn a_camera_move_keeps_the_lights_vpls_and_matches_a_fresh_renderer() {
    let Some(ctx) = gpu() else { return };
    // The lit floor in fog: a frame, the spot moved (its maps and VPLs made again), then the
    // camera moved (no light redone: the VPLs are kept, their passes not recorded). The image
    // is a fresh renderer's, bit for bit.
    let sc = lit_floor_fog_scene();
    let frame = |r: &mut Renderer| {
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        r.encode(&mut enc, FrameRequest { stats: true }).unwrap();
        ctx.queue.submit([enc.finish()]);
        r.wait_stats().unwrap().expect("the frame asked for statistics")
    };
    let mut light = sc.lights[0].clone();
    if let caustics::scene::Light::Spot { position, .. } = &mut light {
        *position += Vec3::new(0.3, 0.0, -0.2);
    }
    let mut cam = sc.camera.clone();
    cam.position += Vec3::new(-0.5, 0.3, 0.2);
    let mut r = Renderer::with_context(ctx.clone(), sc.clone(), settings()).unwrap();
    frame(&mut r);
    r.set_light(0, light.clone()).unwrap();
    let moved = frame(&mut r);
    assert_eq!(moved.lights_redone, [true]);
    r.set_camera(cam.clone()).unwrap();
    let kept = frame(&mut r);
    assert_eq!(kept.lights_redone, [false]);
    // Where the adapter has timestamps: the VPLs were made in the second frame, not the third.
    let timed = |f: &caustics::renderer::FrameStats, pass: &str| f.timings.iter().any(|(n, _)| n == pass);
    if !moved.timings.is_empty() {
        assert!(timed(&moved, "medium_bounce_lights") && timed(&moved, "medium_bounce"));
        assert!(!timed(&kept, "medium_bounce_lights") && !timed(&kept, "medium_bounce_shafts"));
        assert!(timed(&kept, "medium_bounce") && timed(&kept, "medium_bounce_surfaces"));
    }
    let image = r.read_image().unwrap();
    let mut fresh = Renderer::with_context(ctx.clone(), sc, settings()).unwrap();
    fresh.set_light(0, light).unwrap();
    fresh.set_camera(cam).unwrap();
    frame(&mut fresh);
    let want = fresh.read_image().unwrap();
    assert!(image.pixels == want.pixels, "the image differs from a fresh renderer's");
    // And the glow is in it: without the passes the image is darker.
    let mut off = Renderer::with_context(
        ctx.clone(),
        r.scene().clone(),
        RenderSettings {
            medium: caustics::settings::MediumSettings { bounce_grid: 0, ..settings().medium },
            ..settings()
        },
    )
    .unwrap();
    frame(&mut off);
    let sum = |img: &caustics::image_io::Image| img.pixels.iter().flatten().map(|&v| v as f64).sum::<f64>();
    assert!(sum(&off.read_image().unwrap()) < 0.95 * sum(&image));
    // With a glass ball: the beams, their emitters (made every frame, their sums cleared) and
    // the segments beyond the ball follow the camera; the image is a fresh renderer's too.
    let sc = volume_caustic_floor_scene(0.8);
    let mut r = Renderer::with_context(ctx.clone(), sc.clone(), settings()).unwrap();
    frame(&mut r);
    let mut cam = sc.camera.clone();
    cam.position += Vec3::new(0.4, -0.2, 0.3);
    r.set_camera(cam.clone()).unwrap();
    assert_eq!(frame(&mut r).lights_redone, [false]);
    let mut fresh = Renderer::with_context(ctx.clone(), sc, settings()).unwrap();
    fresh.set_camera(cam).unwrap();
    frame(&mut fresh);
    assert!(r.read_image().unwrap().pixels == fresh.read_image().unwrap().pixels, "with the ball: differs");
}

/// A spot's shaft in fog behind a glass ball, clear of it (the cone passes 0.17 m behind the
/// ball), over a black floor: the camera sees the shaft beside the ball and, magnified, through
/// it.
fn behind_glass_scene() -> Scene {
    scene(
        r#"{ "schema_version": 1, "name": "shaft_behind_glass",
  "camera": { "position": [0, 1, 3], "look_at": [0, 1, 0], "fov_y_deg": 30, "width": 32, "height": 32 },
  "lights": [ { "type": "spot", "position": [0, 4, -1.3], "direction": [0, -1, 0], "cone_angle_deg": 10, "falloff_start_deg": 10, "intensity": [30, 30, 30] } ],
  "materials": { "black": { "type": "diffuse", "albedo": 0 }, "glass": { "type": "dielectric", "ior": 1.5 } },
  "objects": [ { "type": "sphere", "center": [0, 1, 0], "radius": 0.5, "material": "glass" },
               { "type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [8, 8], "material": "black" } ],
  "medium": { "sigma_s": [0.3, 0.25, 0.2], "sigma_a": [0.05, 0.05, 0.1], "phase": { "type": "isotropic" },
              "bounds": { "min": [-3, -1, -3], "max": [3, 5, 4] } } }"#,
    )
}

/// Sums of the pixels within 8 pixels of the image's centre (inside the ball's disk, which is
/// about 10 pixels in radius) and of the others.
fn disk_and_rest(img: &caustics::image_io::Image) -> (f64, f64) {
    let (mut disk, mut rest) = (0.0, 0.0);
    for y in 0..img.height {
        for x in 0..img.width {
            let (dx, dy) = (x as f32 + 0.5 - 16.0, y as f32 + 0.5 - 16.0);
            let v: f64 = img.get(x, y).iter().map(|&c| f64::from(c)).sum();
            if dx * dx + dy * dy < 64.0 { disk += v } else { rest += v }
        }
    }
    (disk, rest)
}

#[test]
fn the_fog_behind_a_glass_ball_is_seen_through_it() {
    let Some(ctx) = gpu() else { return };
    // `composite` keeps the segments its refracted and reflected rays travel in the medium
    // beyond the ball and attenuates what they see; `medium_scatter` adds the shaft's single
    // scattering along them. In even fog and in fog thickening with height (a density grid:
    // the transmittances and the scattering marched through it).
    let dims = [4u32, 12, 4];
    let mut v = Vec::new();
    for _z in 0..dims[2] {
        for y in 0..dims[1] {
            for _x in 0..dims[0] {
                v.push(0.4 + 0.15 * y as f32);
            }
        }
    }
    let layered = with_grid(behind_glass_scene(), DensityGrid::new(dims, v).unwrap());
    for (label, sc) in [("even fog", behind_glass_scene()), ("layered fog", layered)] {
        let r = reference::render(&sc, &common::single_scattering_reference(1, 1024, 7)).unwrap();
        let g = render(&ctx, &sc, &settings()).unwrap();
        let ((gd, gr), (rd, rr)) = (disk_and_rest(&g.image), disk_and_rest(&r.image));
        println!("{label}: GPU / reference: through the ball {:.4}, beside it {:.4}", gd / rd, gr / rr);
        // Measured (lavapipe): even fog 0.997 through the ball, 0.994 beside it; layered
        // 0.992, 1.003. Before the segments were kept (and with them off) the ball showed the
        // black floor behind it, 0.000 of the reference's light through it (0.663 beside it:
        // the ring of the ball's disk outside the 8 pixels).
        assert!((gd / rd - 1.0).abs() < 0.03, "{label}: through the ball {}", gd / rd);
        assert!((gr / rr - 1.0).abs() < 0.03, "{label}: beside the ball {}", gr / rr);
        let again = render(&ctx, &sc, &settings()).unwrap();
        assert!(again.image.pixels == g.image.pixels, "{label}: a second render differs");
        // Switched off, the test fails: the ball shows the black floor behind it.
        let off = render(
            &ctx,
            &sc,
            &RenderSettings {
                medium: caustics::settings::MediumSettings { beyond_specular: false, ..settings().medium },
                ..settings()
            },
        )
        .unwrap();
        let off_ratio = disk_and_rest(&off.image).0 / rd;
        println!("{label}: without the segments, through the ball {off_ratio:.4}");
        assert!(off_ratio < 0.1, "{label}: {off_ratio}");
    }
}

/// A volume caustic seen through glass: a narrow spot whose light all meets a glass ball
/// focuses into fog; a second, smaller glass ball between it and the camera shows the cone
/// upside down (light -> glass -> fog -> glass -> camera). Black floor.
fn volume_caustic_through_glass_scene() -> Scene {
    scene(
        r#"{ "schema_version": 1, "name": "volume_caustic_through_glass",
  "camera": { "position": [0, 0.45, 3.2], "look_at": [0, 0.45, 0], "fov_y_deg": 30, "width": 32, "height": 32 },
  "lights": [ { "type": "spot", "position": [0, 4, 0], "direction": [0, -1, 0], "cone_angle_deg": 8, "falloff_start_deg": 8, "intensity": [400, 400, 400] } ],
  "materials": { "black": { "type": "diffuse", "albedo": 0 }, "glass": { "type": "dielectric", "ior": 1.5 } },
  "objects": [ { "type": "sphere", "center": [0, 0.9, 0], "radius": 0.5, "material": "glass" },
               { "type": "sphere", "center": [0, 0.45, 1.6], "radius": 0.35, "material": "glass" },
               { "type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [8, 8], "material": "black" } ],
  "medium": { "sigma_s": [0.3, 0.3, 0.3], "sigma_a": [0.02, 0.02, 0.02], "phase": { "type": "isotropic" },
              "bounds": { "min": [-4, -1, -4], "max": [4, 4.5, 4.5] } } }"#,
    )
}

#[test]
fn the_volume_caustic_seen_through_glass_matches_the_reference() {
    let Some(ctx) = gpu() else { return };
    // `beam_gather` adds the beams' light along the segments `composite` keeps beyond the
    // small ball; the reference gathers its photon beams along its camera paths through it
    // (`reference::photon_beams`). Caustic-only images over the cone's image (rows 6..15,
    // columns 11..21: the cone seen through the small ball only; below it the cone is seen
    // through both balls, where the GPU keeps too few segments), and row by row.
    let sc = volume_caustic_through_glass_scene();
    let r = reference::render(&sc, &common::single_scattering_reference(1 << 12, 16, 5)).unwrap();
    let g = render(&ctx, &sc, &settings()).unwrap();
    let region = |img: &caustics::image_io::Image, y: u32| -> f64 {
        (11..21).map(|x| img.get(x, y).iter().map(|&v| f64::from(v)).sum::<f64>()).sum()
    };
    let (mut gs, mut rs) = (0.0, 0.0);
    for y in 6..15 {
        let (a, b) = (region(&g.caustic, y), region(&r.caustic, y));
        println!("row {y}: GPU {a:.4}, reference {b:.4}");
        gs += a;
        rs += b;
    }
    println!("the cone through the ball, GPU / reference: {:.4}", gs / rs);
    // Measured (lavapipe): 0.988 (rows 0.42 to 1.36 of the reference's: the GPU gathers along
    // one ray per pixel, the reference over the pixel; at 64 x 64 the rows agree better).
    assert!((gs / rs - 1.0).abs() < 0.05, "{}", gs / rs);
    // Without the segments the cone is not seen through the ball.
    let off = render(
        &ctx,
        &sc,
        &RenderSettings {
            medium: caustics::settings::MediumSettings { beyond_specular: false, ..settings().medium },
            ..settings()
        },
    )
    .unwrap();
    let off_sum: f64 = (6..15).map(|y| region(&off.caustic, y)).sum();
    assert!(off_sum < 0.05 * rs, "{off_sum} vs {rs}");
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

#[test]
fn the_volume_caustic_lights_the_floor_around_it_as_the_reference_does() {
    let Some(ctx) = gpu() else { return };
    // `medium_bounce_beams` bins the light the beams scatter into point emitters that
    // `medium_bounce_surfaces` lights the floor with. The floor's share of each image is the
    // image less the same scene's with a black floor (the GPU's: less its image without the
    // emitters, `medium_bounce_grid` 0, which is the same there: nothing else lights the white
    // floor). Rows 8.. (the ball is above them: the reference does not render the floor seen
    // through it, light -> glass -> fog -> floor -> glass -> camera).
    let rows = |img: &caustics::image_io::Image| rows_sum(img, 8..32);
    let rs = common::single_scattering_reference(1 << 22, 64, 11);
    // Even fog, and fog thinning with height (a density grid over the box's y in [-1, 0.35]:
    // 0.84 at the floor, 0.5 at the box's top; the beams' transmittances and the emitters'
    // flux read it).
    let dims = [2u32, 9, 2];
    let mut v = Vec::new();
    for _z in 0..dims[2] {
        for y in 0..dims[1] {
            for _x in 0..dims[0] {
                v.push(2.0 - 1.5 * y as f32 / 8.0);
            }
        }
    }
    let grid = DensityGrid::new(dims, v).unwrap();
    for label in ["even fog", "layered fog"] {
        let with = |sc: Scene| if label == "even fog" { sc } else { with_grid(sc, grid.clone()) };
        let (lit, dark) = (with(volume_caustic_floor_scene(0.8)), with(volume_caustic_floor_scene(0.0)));
        let want =
            rows(&reference::render(&lit, &rs).unwrap().image) - rows(&reference::render(&dark, &rs).unwrap().image);
        let g = render(&ctx, &lit, &settings()).unwrap();
        let without = render(
            &ctx,
            &lit,
            &RenderSettings {
                medium: caustics::settings::MediumSettings { bounce_grid: 0, ..settings().medium },
                ..settings()
            },
        )
        .unwrap();
        let got = rows(&g.image) - rows(&without.image);
        println!("{label}: the floor's light from the volume caustic, GPU / reference: {:.4}", got / want);
        // Measured (lavapipe): even fog 1.033 (at 64 x 64 with 2^24 photons, 256 paths per
        // pixel: 1.025), layered 1.009. Without the emitters the floor is black: 0 of the
        // reference's.
        assert!((got / want - 1.0).abs() < 0.06, "{label}: {}", got / want);
        // The emitters' sums are fixed-point: the same bits in a second render.
        let again = render(&ctx, &lit, &settings()).unwrap();
        assert!(again.image.pixels == g.image.pixels, "{label}: a second render differs");
    }
}
