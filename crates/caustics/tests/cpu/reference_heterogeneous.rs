//! Heterogeneous media (a density grid, `medium.density`) in the CPU reference: ratio tracking
//! against the closed-form transmittance of a two-slab grid, delta tracking with a constant
//! grid against the homogeneous medium, single scattering in a smoke puff against a numerically
//! integrated closed form (and the single-scattering switch), determinism.

use caustics::Scene;
use caustics::scene::DensityGrid;
use caustics_reference::reference::medium::Media;
use caustics_reference::reference::sampling::PathRng;
use caustics_reference::reference::{self, ReferenceSettings};
use glam::{DVec3, Vec3};
use std::f64::consts::PI;
use std::path::Path;
use std::sync::Arc;

fn scene(json: &str) -> Scene {
    Scene::from_json(json, "media.json", Path::new(".")).unwrap_or_else(|e| panic!("{e}"))
}

fn settings(spp: u32, single: bool) -> ReferenceSettings {
    ReferenceSettings {
        photons_per_light: 1,
        camera_spp: spp,
        max_depth: 64,
        seed: 11,
        caustic_map_size: 8,
        medium_single_scattering_only: single,
        ..Default::default()
    }
}

fn with_grid(mut sc: Scene, g: DensityGrid) -> Scene {
    sc.medium.as_mut().unwrap().density = Some(Arc::new(g));
    sc
}

/// A smoke puff over the box: a Gaussian blob off centre on a thin haze, 12³ voxels.
fn puff() -> DensityGrid {
    let n = 12u32;
    let mut v = Vec::new();
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                let u = (Vec3::new(x as f32, y as f32, z as f32) + 0.5) / n as f32;
                let r2 = (u - Vec3::new(0.55, 0.6, 0.5)).length_squared();
                v.push(0.1 + 3.0 * (-r2 / 0.03).exp());
            }
        }
    }
    DensityGrid::new([n, n, n], v).unwrap()
}

/// ∫ ρ along the segment a → b (inside the box), by a fine midpoint rule.
fn optical_depth(sc: &Scene, a: DVec3, b: DVec3, n: usize) -> f64 {
    let m = sc.medium.as_ref().unwrap();
    let l = (b - a).length();
    let ds = l / n as f64;
    (0..n)
        .map(|i| {
            let x = a + (b - a) * ((i as f64 + 0.5) / n as f64);
            let inside = x.cmpge(m.bounds_min.as_dvec3()).all() && x.cmple(m.bounds_max.as_dvec3()).all();
            if inside { m.density_at(x.as_vec3()) as f64 * ds } else { 0.0 }
        })
        .sum()
}

#[test]
fn ratio_tracking_matches_the_transmittance_of_two_slabs() {
    // A grid of two voxels along z: density 0.2 in the back half, 2 in the front half,
    // trilinear between the voxel centres (a ramp over the middle half of the box). Along a
    // ray through the box the optical depth of the piecewise linear density is exact by the
    // trapezoid rule over its breakpoints; ratio tracking must average to exp(−σt τ).
    let sc = scene(
        r#"{ "schema_version": 1, "name": "slabs",
  "camera": { "position": [0, 0, 3], "look_at": [0, 0, 0], "fov_y_deg": 20, "width": 2, "height": 2 },
  "lights": [ { "type": "point", "position": [0, 0, 3], "intensity": 1 } ],
  "materials": { "black": { "type": "diffuse", "albedo": 0 } },
  "objects": [ { "type": "rectangle", "center": [0, -50, 0], "normal": [0, 1, 0], "size": [0.01, 0.01], "material": "black" } ],
  "medium": { "sigma_s": [0.2, 0.1, 0.4], "sigma_a": [0.3, 0.6, 0.1], "bounds": { "min": [-1, -1, -2], "max": [1, 1, 2] } } }"#,
    );
    let sc = with_grid(sc, DensityGrid::new([1, 1, 2], vec![0.2, 2.0]).unwrap());
    let m = sc.medium.as_ref().unwrap();
    let media = Media::new(m);
    // ρ(z): 0.2 up to z = −1 (centre of voxel 0), linear to 2 at z = 1, 2 beyond.
    let rho = |z: f64| 0.2 + 1.8 * ((z + 1.0) / 2.0).clamp(0.0, 1.0);
    let (o, d) = (Vec3::new(0.1, -0.2, 3.0), Vec3::new(0.05, 0.1, -1.0).normalize());
    // The ray enters the box at z = 2 and leaves at z = −2 (|x|, |y| stay below 1).
    let dz = -d.z as f64;
    let tau = [(-2.0, -1.0), (-1.0, 1.0), (1.0, 2.0)]
        .iter()
        .map(|&(a, b): &(f64, f64)| (rho(a) + rho(b)) * 0.5 * (b - a))
        .sum::<f64>()
        / dz;
    let mut rng = PathRng::new(5);
    let n = 400_000;
    let mut acc = DVec3::ZERO;
    let mut acc2 = DVec3::ZERO;
    for _ in 0..n {
        let t = media.transmittance(o, d, 10.0, &mut rng).as_dvec3();
        acc += t;
        acc2 += t * t;
    }
    let mean = acc / n as f64;
    let sd = ((acc2 / n as f64 - mean * mean) / n as f64).powf(0.5);
    let st = (m.sigma_s + m.sigma_a).as_dvec3();
    for c in 0..3 {
        let want = (-st[c] * tau).exp();
        println!("channel {c}: ratio tracking {} (sd {:.1e}), closed form {want}", mean[c], sd[c]);
        assert!((mean[c] - want).abs() < 4.0 * sd[c] + 1e-4, "channel {c}");
    }
    // Numerical optical depth agrees with the trapezoid value (the test's own check).
    let (a, b) = (o.as_dvec3(), (o + d * 10.0).as_dvec3());
    assert!((optical_depth(&sc, a, b, 20000) / tau - 1.0).abs() < 1e-3);
}

const SINGLE: &str = r#"{ "schema_version": 1, "name": "single",
  "camera": { "position": [0, 0, 3.5], "look_at": [0, 0, 0], "fov_y_deg": 4, "width": 1, "height": 1 },
  "lights": [ { "type": "point", "position": [0.5, 0.8, 0], "intensity": [2, 3, 4] } ],
  "materials": { "black": { "type": "diffuse", "albedo": 0 } },
  "objects": [ { "type": "rectangle", "center": [0, -50, 0], "normal": [0, 1, 0], "size": [0.01, 0.01], "material": "black" } ],
  "medium": { "sigma_s": [0.3, 0.2, 0.5], "sigma_a": [0.1, 0.05, 0.0], "phase": { "type": "hg", "g": 0.4 },
              "bounds": { "min": [-2, -2, -4], "max": [2, 2, 4] } } }"#;

#[test]
fn a_constant_grid_renders_the_homogeneous_medium() {
    // Density 0.5 with twice the coefficients is the homogeneous medium: delta and ratio
    // tracking against the analytic transmittance and free flight, single and multiple
    // scattering, within the two estimates' noise.
    let homo = scene(SINGLE);
    let mut doubled = homo.clone();
    {
        let m = doubled.medium.as_mut().unwrap();
        m.sigma_s *= 2.0;
        m.sigma_a *= 2.0;
    }
    let het = with_grid(doubled, DensityGrid::new([2, 3, 2], vec![0.5; 12]).unwrap());
    for single in [true, false] {
        // Multiple scattering is noisier per path: four times the paths.
        let s = settings(if single { 1 << 16 } else { 1 << 18 }, single);
        let (a, b) = (reference::render(&homo, &s).unwrap(), reference::render(&het, &s).unwrap());
        let (pa, pb) = (a.image.get(0, 0), b.image.get(0, 0));
        let (va, vb) = (a.nocaustic_variance.get(0, 0), b.nocaustic_variance.get(0, 0));
        for c in 0..3 {
            let sd = (va[c] + vb[c]).sqrt();
            println!("single {single} channel {c}: homogeneous {} grid {} (sd {sd:.2e})", pa[c], pb[c]);
            assert!((pa[c] - pb[c]).abs() < 4.0 * sd, "single {single} channel {c}");
            assert!(sd < 0.03 * pa[c], "the test resolves 3 %");
        }
    }
}

/// Single scattering from the point light along the pixel's camera rays, integrated
/// numerically in the density grid: the pixel mean of
/// ∫ ρ(x) σs · phase · I/r² · exp(−σt (τ(x → light) + τ(camera → x))) ds.
fn single_scattering_closed_form(sc: &Scene, g: f64) -> [f64; 3] {
    let m = sc.medium.as_ref().unwrap();
    let caustics::scene::Light::Point { position: lp, intensity } = sc.lights[0] else { panic!() };
    let st = (m.sigma_s + m.sigma_a).as_dvec3();
    let (n_sub, n_s) = (4, 1500);
    let mut acc = [0.0f64; 3];
    for sy in 0..n_sub {
        for sx in 0..n_sub {
            let d = sc.camera.ray_dir((sx as f32 + 0.5) / n_sub as f32, (sy as f32 + 0.5) / n_sub as f32).as_dvec3();
            let o = sc.camera.position.as_dvec3();
            // The camera lies in the box; the ray leaves it through z = −4.
            let smax = (m.bounds_min.z as f64 - o.z) / d.z;
            let ds = smax / n_s as f64;
            let mut tau_cam = 0.0;
            for i in 0..n_s {
                let x = o + d * ((i as f64 + 0.5) * ds);
                let rho = m.density_at(x.as_vec3()) as f64;
                tau_cam += rho * ds * 0.5;
                let to = lp.as_dvec3() - x;
                let r = to.length();
                let tau_l = optical_depth(sc, x, lp.as_dvec3(), 150);
                let c = d.dot(to / r);
                let phase = (1.0 - g * g) / (4.0 * PI * (1.0 + g * g - 2.0 * g * c).powf(1.5));
                for k in 0..3 {
                    acc[k] += rho * m.sigma_s[k] as f64 * phase * intensity[k] as f64 / (r * r)
                        * (-st[k] * (tau_l + tau_cam)).exp()
                        * ds;
                }
                tau_cam += rho * ds * 0.5;
            }
        }
    }
    acc.map(|v| v / (n_sub * n_sub) as f64)
}

#[test]
fn single_scattering_in_a_smoke_puff_matches_the_closed_form() {
    let sc = with_grid(scene(SINGLE), puff());
    let want = single_scattering_closed_form(&sc, 0.4);
    let single = reference::render(&sc, &settings(1 << 17, true)).unwrap();
    let multi = reference::render(&sc, &settings(1 << 14, false)).unwrap();
    let (p, pv, pm) = (single.image.get(0, 0), single.nocaustic_variance.get(0, 0), multi.image.get(0, 0));
    for c in 0..3 {
        let err = p[c] as f64 - want[c];
        let sd = (pv[c] as f64).sqrt();
        println!(
            "channel {c}: {} vs closed form {} (sd {sd:.2e}, {:.3}); multiple {}",
            p[c],
            want[c],
            err / want[c],
            pm[c]
        );
        // 4 standard deviations of the reference plus the quadrature's error (1500 × 150
        // midpoint steps through the puff: under 0.3 %).
        assert!(err.abs() < 4.0 * sd + 3e-3 * want[c], "channel {c}");
        assert!(sd < 0.02 * want[c], "the test resolves 2 %");
        assert!(pm[c] as f64 > want[c] * 0.97, "multiple scattering adds light");
    }
    // The puff matters: the homogeneous haze alone (density 0.1 everywhere) is far dimmer.
    let haze = with_grid(scene(SINGLE), DensityGrid::new([1, 1, 1], vec![0.1]).unwrap());
    let h = single_scattering_closed_form(&haze, 0.4);
    assert!(want[1] > 2.0 * h[1], "{} vs {}", want[1], h[1]);
}

#[test]
fn heterogeneous_media_are_deterministic() {
    // A glass ball over a floor in the puff, with caustic photons through the medium: the
    // same image whatever the thread count.
    let sc = scene(
        r#"{ "schema_version": 1, "name": "puff",
  "camera": { "position": [0, 1.2, 3], "look_at": [0, 0.6, 0], "fov_y_deg": 40, "width": 12, "height": 8 },
  "lights": [ { "type": "spot", "position": [0, 2.6, 0], "direction": [0, -1, 0], "cone_angle_deg": 30, "intensity": 20 } ],
  "materials": { "glass": { "type": "dielectric", "ior": 1.5 }, "floor": { "type": "diffuse", "albedo": 0.7 } },
  "objects": [ { "type": "sphere", "center": [0, 0.9, 0], "radius": 0.4, "material": "glass" },
               { "type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [6, 6], "material": "floor" } ],
  "medium": { "sigma_s": 0.4, "sigma_a": 0.05, "bounds": { "min": [-3, -0.5, -3], "max": [3, 3, 4] } } }"#,
    );
    let sc = with_grid(sc, puff());
    let s = ReferenceSettings { photons_per_light: 50_000, camera_spp: 2, ..settings(2, false) };
    let render = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| reference::render(&sc, &s).unwrap())
    };
    let (a, b) = (render(1), render(3));
    assert_eq!(a.image.pixels, b.image.pixels);
    assert_eq!(a.caustic.pixels, b.caustic.pixels);
    assert!(a.caustic.pixels.iter().flatten().any(|&v| v > 0.0));
}

#[test]
fn scattering_in_a_grid_without_absorption_conserves_the_photon_flux() {
    // Caustic photons through a glass ball fall into a puff (σa = 0) below it, inside a closed
    // diffuse sphere: delta tracking with multiple scattering neither creates nor loses flux,
    // so all the flux leaving the ball reaches the sphere, puff or not.
    let json = |medium: &str| {
        format!(
            r#"{{ "schema_version": 1, "name": "flux",
  "camera": {{ "position": [0, 0, 4], "look_at": [0, 0, 0], "fov_y_deg": 40, "width": 8, "height": 8 }},
  "lights": [ {{ "type": "spot", "position": [0, 2, 0], "direction": [0, -1, 0], "cone_angle_deg": 20, "intensity": 10 }} ],
  "materials": {{ "glass": {{ "type": "dielectric", "ior": 1.5 }}, "wall": {{ "type": "diffuse", "albedo": 0.5 }} }},
  "objects": [ {{ "type": "sphere", "center": [0, 0, 0], "radius": 0.5, "material": "glass" }},
               {{ "type": "sphere", "center": [0, 0, 0], "radius": 6, "material": "wall" }} ]
  {medium} }}"#
        )
    };
    let fog = r#", "medium": { "sigma_s": [0.6, 1.0, 1.6], "sigma_a": 0, "phase": { "type": "hg", "g": 0.3 },
                  "bounds": { "min": [-3, -3, -3], "max": [3, -0.6, 3] } }"#;
    let total = |sc: &Scene, single: bool| {
        let s = ReferenceSettings { max_depth: 1000, photons_per_light: 300_000, ..settings(1, single) };
        let d = reference::caustic_deposits(sc, &s, 0).unwrap();
        d.iter().fold(DVec3::ZERO, |a, d| a + d.flux.as_dvec3())
    };
    let vacuum = total(&scene(&json("")), false);
    let puffed = with_grid(scene(&json(fog)), puff());
    let multi = total(&puffed, false);
    let single = total(&puffed, true);
    println!("deposited flux: vacuum {vacuum:?}, puff {multi:?}, puff single scattering {single:?}");
    for c in 0..3 {
        assert!((multi[c] / vacuum[c] - 1.0).abs() < 0.02, "channel {c}");
        assert!(single[c] < 0.9 * vacuum[c], "channel {c}: the puff scatters");
    }
}
