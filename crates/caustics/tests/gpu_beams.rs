//! Volume caustics by adaptive beam tracing (`caustics::beams`): the beams' area function, the
//! single-scattering gather against closed forms and an independent CPU integration, splitting
//! and tiling, the ball lens's focus, flux conservation, and the GPU against the CPU reference.
//! Surface caustics from beams (`LocalSource::Beams`): the beams' flux onto a floor, the
//! photon caustic map on the same frame, no double counting, shadowed receivers, determinism.

mod common;

use caustics::Scene;
use caustics::beams::{self, Beam};
use caustics::render::{RenderSettings, render};
use caustics::settings::BeamSettings;
use common::gpu;
use glam::Vec3;
use std::path::Path;

fn scene(json: &str) -> Scene {
    Scene::from_json(json, "beams.json", Path::new(".")).unwrap_or_else(|e| panic!("{e}"))
}

/// A camera at (0, yc, 3) looking along -z, w x h pixels, in a medium (σs, σa per channel,
/// isotropic) filling a large box; nothing else (the gather needs no surfaces).
fn side_view(yc: f32, w: u32, h: u32, fov: f32, sigma_s: f32, sigma_a: f32) -> Scene {
    scene(&format!(
        r#"{{ "schema_version": 1, "name": "side",
  "camera": {{ "position": [0, {yc}, 3], "look_at": [0, {yc}, 0], "fov_y_deg": {fov}, "width": {w}, "height": {h} }},
  "lights": [ {{ "type": "point", "position": [0, 5, 0], "intensity": 1 }} ],
  "materials": {{ "black": {{ "type": "diffuse", "albedo": 0 }} }},
  "objects": [ {{ "type": "rectangle", "center": [0, -50, 0], "normal": [0, 1, 0], "size": [0.01, 0.01], "material": "black" }} ],
  "medium": {{ "sigma_s": {sigma_s}, "sigma_a": {sigma_a}, "phase": {{ "type": "isotropic" }},
              "bounds": {{ "min": [-10, -10, -10], "max": [10, 10, 10] }} }} }}"#
    ))
}

/// A beam going down (-y) from a horizontal base triangle at height 1 (centroid on the y axis,
/// circumradius r), its edges aimed at the point `focus` below the centroid (f > 0: converging
/// to a point f below the base; f < 0: diverging from a point |f| above; None: parallel).
fn vertical_beam(r: f32, focus: Option<f32>, flux: f32, length: f32) -> Beam {
    let base = |k: f32| {
        let a = k * std::f32::consts::TAU / 3.0 + 0.3;
        Vec3::new(r * a.cos(), 1.0, r * a.sin())
    };
    let vertices = [base(0.0), base(1.0), base(2.0)];
    let dirs = vertices.map(|v| match focus {
        None => Vec3::NEG_Y,
        Some(f) => (Vec3::new(0.0, 1.0 - f, 0.0) - v).normalize() * f.signum(),
    });
    let ends = dirs.map(|d| length / -d.y);
    Beam {
        vertices,
        pre: [0.0; 3],
        dirs,
        ends,
        flux: Vec3::splat(flux),
        level: 0,
        land: u32::MAX,
        branch: 0,
        layer: 0,
        part: 0,
        clip: [0.0; 3],
    }
}

const SIGMA_S: f32 = 0.5;

/// The radiance the beams scatter toward the camera, integrated on the CPU along each pixel
/// centre's ray (fine steps; point-in-beam by the cross-section's barycentrics, fluence
/// Φ / (A(y) cos θ), transmittance exp(-σt (s + t))): independent of the GPU's intersection.
fn cpu_gather(sc: &Scene, beams: &[Beam], sigma_t: f32) -> Vec<f32> {
    let cam = &sc.camera;
    let mut out = vec![0.0; (cam.width * cam.height) as usize];
    for y in 0..cam.height {
        for x in 0..cam.width {
            let d = cam.ray_dir(x as f32 + 0.5, y as f32 + 0.5);
            let mut acc = 0.0f64;
            for b in beams {
                let n = b.normal();
                let steps = 20000;
                let (t0, t1) = (2.0f32, 4.0f32);
                let dt = (t1 - t0) / steps as f32;
                for i in 0..steps {
                    let t = t0 + (i as f32 + 0.5) * dt;
                    let p = cam.position + d * t;
                    let h = (p - b.vertices[0]).dot(n);
                    if h < 0.0 {
                        continue;
                    }
                    let [q0, q1, q2] = b.section(h);
                    let e = |a: Vec3, c: Vec3| (c - a).cross(p - a).dot(n);
                    let (e0, e1, e2) = (e(q1, q2), e(q2, q0), e(q0, q1));
                    let s = e0 + e1 + e2;
                    if s == 0.0 || e0 * s < 0.0 || e1 * s < 0.0 || e2 * s < 0.0 {
                        continue;
                    }
                    let w = [e0 / s, e1 / s, e2 / s];
                    let yend: f32 = (0..3).map(|k| w[k] * b.ends[k] * n.dot(b.dirs[k])).sum();
                    if h > yend {
                        continue;
                    }
                    let dl = (b.dirs[0] * w[0] + b.dirs[1] * w[1] + b.dirs[2] * w[2]).normalize();
                    let base = b.vertices[0] * w[0] + b.vertices[1] * w[1] + b.vertices[2] * w[2];
                    let fluence = b.flux.x / (b.area(h) * n.dot(dl));
                    let tr = (-sigma_t * ((p - base).length() + t)).exp();
                    acc += f64::from(SIGMA_S * 0.25 / std::f32::consts::PI * fluence * tr * dt);
                }
            }
            out[(y * cam.width + x) as usize] = acc as f32;
        }
    }
    out
}

/// The gather by the pixel centre's ray alone (no footprint integral): what the closed forms and
/// `cpu_gather` compute, exactly.
fn settings() -> BeamSettings {
    BeamSettings { samples: 8, pixel_samples: 1, footprint: 0.0, ..Default::default() }
}

fn sum(img: &caustics::image_io::Image) -> f64 {
    img.pixels.iter().map(|p| f64::from(p[0])).sum()
}

#[test]
fn area_function_of_parallel_converging_and_diverging_beams() {
    // A(y) on the CPU: constant, A0 (1 - y/f)^2, A0 (1 + y/g)^2.
    let a0 = vertical_beam(0.1, None, 1.0, 1.0).area(0.0);
    for y in [0.0f32, 0.2, 0.5, 0.9] {
        let par = vertical_beam(0.1, None, 1.0, 1.0).area(y);
        let conv = vertical_beam(0.1, Some(1.5), 1.0, 1.0).area(y);
        let div = vertical_beam(0.1, Some(-0.8), 1.0, 1.0).area(y);
        let want_c = a0 * (1.0 - y / 1.5).powi(2);
        let want_d = a0 * (1.0 + y / 0.8).powi(2);
        println!("y {y}: parallel {par} converging {conv} ({want_c}) diverging {div} ({want_d})");
        assert!((par / a0 - 1.0).abs() < 1e-5);
        assert!((conv / want_c - 1.0).abs() < 1e-4);
        assert!((div / want_d - 1.0).abs() < 1e-4);
    }
    // The GPU's gather (its own A(y), from the edge functions) against the CPU integration.
    let Some(ctx) = gpu() else { return };
    let sc = side_view(0.6, 24, 24, 12.0, SIGMA_S, 0.1);
    // (focus 0.5: through a focus inside the beam, where 1/A(y) has its pole)
    for focus in [None, Some(1.5), Some(-0.8), Some(0.5)] {
        let b = [vertical_beam(0.1, focus, 1.0, 1.0)];
        let g = beams::gather(&ctx, &sc, &b, &settings()).unwrap();
        let c = cpu_gather(&sc, &b, SIGMA_S + 0.1);
        let (sg, sc_): (f64, f64) = (sum(&g), c.iter().map(|&v| f64::from(v)).sum());
        let worst = g
            .pixels
            .iter()
            .zip(&c)
            .filter(|(_, c)| **c > 0.05 * sc_ as f32 / 24.0)
            .map(|(g, c)| (g[0] / c - 1.0).abs())
            .fold(0.0f32, f32::max);
        // Measured: sums within 0.05 %, pixels within 0.4 % (the CPU's steps). Through the
        // focus (0.5): the sum within 0.05 % (it was 12x before the gather's inside test was
        // made robust at focal planes), one pixel near the focus differs by 9 % (not explained
        // yet: the CPU's steps at 5x finer gave the same): only the sum is asserted there.
        println!("{focus:?}: GPU sum {sg:.5} CPU {sc_:.5}, worst pixel {worst:.4}");
        assert!((sg / sc_ - 1.0).abs() < 0.01, "{focus:?}");
        if focus != Some(0.5) {
            assert!(worst < 0.02, "{focus:?}");
        }
    }
}

/// The pixel values of `beams` integrated over each pixel's footprint on the CPU, in beam space
/// and independently of the GPU's lines: stratified points of the beam's volume (uniform in the
/// barycentric measure by the square-root map, `n` x `n` cells; `steps` heights), each carrying
/// σs p Φ T dμ dy / (cos θ dist² z³ pix_area) into the pixel it projects to (1 / A(y) cancels:
/// the point fills A(y) dμ dy).
fn cpu_footprint(sc: &Scene, beams: &[Beam], sigma_t: f32, n: usize, steps: usize) -> Vec<f64> {
    let cam = &sc.camera;
    let (w, h) = (cam.width as usize, cam.height as usize);
    let t = f64::from((cam.fov_y_deg.to_radians() * 0.5).tan());
    let pix_area = (2.0 * t * f64::from(cam.aspect()) / w as f64) * (2.0 * t / h as f64);
    let fwd = cam.forward().as_dvec3();
    let cp = cam.position.as_dvec3();
    let mut out = vec![0.0f64; w * h];
    for b in beams {
        let nrm = b.normal();
        let ymax = (0..3).map(|k| b.ends[k] * nrm.dot(b.dirs[k])).fold(0.0f32, f32::max);
        let dy = f64::from(ymax) / steps as f64;
        for i in 0..n {
            for j in 0..n {
                let (u, v) = ((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
                let su = u.sqrt();
                let wt = [1.0 - su, su * (1.0 - v), su * v];
                let dl = (0..3).map(|k| b.dirs[k].as_dvec3() * wt[k]).sum::<glam::DVec3>().normalize();
                let cos_t = nrm.as_dvec3().dot(dl);
                let yend: f64 = (0..3).map(|k| wt[k] * f64::from(b.ends[k] * nrm.dot(b.dirs[k]))).sum();
                let base: glam::DVec3 = (0..3).map(|k| b.vertices[k].as_dvec3() * wt[k]).sum();
                let sd: glam::DVec3 = (0..3).map(|k| (b.dirs[k] / nrm.dot(b.dirs[k])).as_dvec3() * wt[k]).sum();
                let dmu = 1.0 / (n * n) as f64;
                for s in 0..steps {
                    let y = (s as f64 + 0.5) * dy;
                    if y > yend {
                        break;
                    }
                    let x = base + sd * y;
                    let Some((px, py)) = project(sc, x.as_vec3()) else { continue };
                    if !(px >= 0.0 && py >= 0.0 && (px as usize) < w && (py as usize) < h) {
                        continue;
                    }
                    let to = x - cp;
                    let dist = to.length();
                    let z = to.dot(fwd) / dist;
                    let tr = (-f64::from(sigma_t) * ((x - base).length() + dist)).exp();
                    let val = f64::from(SIGMA_S * b.flux.x) * 0.25 / std::f64::consts::PI * tr * dmu * dy
                        / (cos_t * dist * dist * z * z * z * pix_area);
                    out[py as usize * w + px as usize] += val;
                }
            }
        }
    }
    out
}

#[test]
fn a_beam_through_its_focus_matches_the_footprint_integral_of_each_pixel() {
    let Some(ctx) = gpu() else { return };
    // A beam focused to a point 0.5 m below its base (0.17 m sides, so at the focus its section
    // is far thinner than a pixel: 9 x 9 pixels of 2.3 cm at 3 m), seen from the side with the
    // focus 0.9 pixel below the image's centre row. The pixel rays hit or miss the focus's
    // hourglass (the light there, Φ / A(y), is singular); the footprint integral does not.
    let (w, h) = (9, 9);
    let sigma_a = 0.1;
    let sc = side_view(0.52, w, h, 4.0, SIGMA_S, sigma_a);
    let beam = [vertical_beam(0.1, Some(0.5), 1.0, 1.0)];
    let t = std::time::Instant::now();
    let want = cpu_footprint(&sc, &beam, SIGMA_S + sigma_a, 160, 1200);
    println!("CPU footprint integral: {:.1} s", t.elapsed().as_secs_f64());
    let total: f64 = want.iter().sum();
    let peak = want.iter().cloned().fold(0.0, f64::max);
    let report = |name: &str, b: BeamSettings| -> (f64, f64) {
        let g = beams::gather(&ctx, &sc, &beam, &b).unwrap();
        let (mut worst, mut at) = (0.0f64, 0);
        for (i, &v) in want.iter().enumerate() {
            let got = f64::from(g.pixels[i][0]);
            // (relative to the brightest pixel)
            let err = (got - v).abs() / peak;
            if err > worst {
                (worst, at) = (err, i);
            }
        }
        let ratio = sum(&g) / total;
        if std::env::var_os("FOOT_TABLE").is_some() {
            for y in 0..h as usize {
                let row: Vec<String> = (0..w as usize)
                    .map(|x| format!("{:.3}/{:.3}", g.pixels[y * w as usize + x][0], want[y * w as usize + x]))
                    .collect();
                println!("  {}", row.join(" "));
            }
        }
        println!(
            "{name}: sum / CPU {ratio:.4}, worst pixel ({}, {}) {:.4} (GPU {:.5}, CPU {:.5})",
            at % w as usize,
            at / w as usize,
            worst,
            g.pixels[at][0],
            want[at]
        );
        (worst, ratio)
    };
    let rays = |n: u32| BeamSettings { footprint: 0.0, pixel_samples: n, ..settings() };
    let foot = |k: f32, lines: u32| BeamSettings { footprint: k, footprint_lines: lines, ..settings() };
    let (old1, _) = report("pixel centre (footprint off)", rays(1));
    let (old3, _) = report("3 x 3 rays (footprint off)", rays(3));
    let (f4, r4) = report("footprint 2 px, 4 x 4 lines", foot(2.0, 4));
    let (f2, r2) = report("footprint 2 px, 2 x 2 lines (default)", foot(2.0, 2));
    let (f8, r8) = report("footprint 8 px, 4 x 4 lines", foot(8.0, 4));
    // Measured (worst pixel's error over the peak pixel; sum over the CPU's): the pixel centre
    // 32 (the focus pixel 34x its value), 3 x 3 rays 6.4; the footprint integral 0.037 with
    // 4 x 4 lines, 0.130 with 2 x 2 (the default; in the top row, where the section is 1.5
    // pixels wide: the lines' spacing), sums within 0.11 %. Bounds set after measuring.
    assert!(old1 > 5.0 && old3 > 1.0, "the rays were expected to be far off: {old1} {old3}");
    assert!(f4 < 0.05 && f2 < 0.15 && f8 < 0.05, "{f4} {f2} {f8}");
    for r in [r4, r2, r8] {
        assert!((r - 1.0).abs() < 0.003, "sum {r}");
    }
    // Split 1 -> 4 and 1 -> 16 (the children are thin over more of their length, and their
    // lines lie elsewhere): the sum is kept; the pixels change by about the lines' spacing
    // (measured: sums within 2e-4, pixels by 0.032 of the peak; bounds set after measuring).
    let f = foot(2.0, 4);
    let parent = beams::gather(&ctx, &sc, &beam, &f).unwrap();
    let children = beam[0].split();
    let grandchildren: Vec<Beam> = children.iter().flat_map(|c| c.split()).collect();
    for (name, list) in [("1 -> 4", children.to_vec()), ("1 -> 16", grandchildren)] {
        let g = beams::gather(&ctx, &sc, &list, &f).unwrap();
        let d =
            g.pixels.iter().zip(&parent.pixels).map(|(a, b)| f64::from((a[0] - b[0]).abs())).fold(0.0, f64::max) / peak;
        println!("split {name}: sum / parent {:.5}, max diff / peak {d:.4}", sum(&g) / sum(&parent));
        assert!((sum(&g) / sum(&parent) - 1.0).abs() < 1e-3 && d < 0.05, "{name}: {d}");
    }
}

#[test]
fn collimated_beam_matches_the_closed_form_and_a_double_count_fails() {
    let Some(ctx) = gpu() else { return };
    // A parallel beam down the y axis seen from the side at height 0.5: the camera's centre
    // row is horizontal, so each of its pixels sees σs p Φ/A exp(-σt s) times the integral
    // of exp(-σt t) over its chord through the beam's triangle (s = 0.5 m below the base).
    let (w, h) = (31, 3);
    let sigma_a = 0.2;
    let st = SIGMA_S + sigma_a;
    let sc = side_view(0.5, w, h, 1.0, SIGMA_S, sigma_a);
    let beam = vertical_beam(0.1, None, 2.0, 1.0);
    let single = beams::gather(&ctx, &sc, &[beam], &settings()).unwrap();
    let double = beams::gather(&ctx, &sc, &[beam, beam], &settings()).unwrap();
    let a = beam.area(0.0);
    let cam = &sc.camera;
    let y = 1;
    let mut worst = 0.0f32;
    let mut worst_double = f32::MAX;
    let mut lit = 0;
    for x in 0..w {
        let d = cam.ray_dir(x as f32 + 0.5, y as f32 + 0.5);
        assert!(d.y.abs() < 1e-6);
        // The chord through the triangle in the plane y = 0.5 (the beam's section), in 2D.
        let tri = beam.section(0.5);
        let o = cam.position;
        let mut ts: Vec<f32> = Vec::new();
        for k in 0..3 {
            let (p, q) = (tri[k], tri[(k + 1) % 3]);
            // o + t d = p + u (q - p), in x and z.
            let e = q - p;
            let den = d.x * -e.z - d.z * -e.x;
            if den.abs() < 1e-12 {
                continue;
            }
            let r = p - o;
            let t = (r.x * -e.z - r.z * -e.x) / den;
            let u = (d.x * r.z - d.z * r.x) / den;
            if (0.0..=1.0).contains(&u) {
                ts.push(t);
            }
        }
        let want = if ts.len() >= 2 {
            let (t0, t1) = (ts.iter().cloned().fold(f32::MAX, f32::min), ts.iter().cloned().fold(f32::MIN, f32::max));
            let entry = 0.0; // the camera is inside the box
            let integral = ((-st * (t0 - entry)).exp() - (-st * (t1 - entry)).exp()) / st;
            SIGMA_S * 0.25 / std::f32::consts::PI * 2.0 / a * (-st * 0.5f32).exp() * integral
        } else {
            0.0
        };
        let got = single.get(x, y)[0];
        if want > 0.0 {
            lit += 1;
            let err = (got / want - 1.0).abs();
            println!("x {x}: GPU {got:.6} closed form {want:.6} ({err:.2e})");
            worst = worst.max(err);
            worst_double = worst_double.min((double.get(x, y)[0] / want - 1.0).abs());
        } else {
            assert!(got.abs() < 1e-6 * single.get(w / 2, y)[0], "x {x}: light outside the beam ({got})");
        }
    }
    println!("collimated: {lit} lit pixels, worst relative error {worst:.2e}; double counted: best {worst_double:.3}");
    assert!(lit >= 5);
    // Measured: 1e-4 (the chord ends on the pixel centre's ray are exact; the midpoint rule
    // integrates the smooth transmittance).
    assert!(worst < 2e-3);
    // The same beam counted twice is off by 100 % in every pixel: the test would catch it.
    assert!(worst_double > 0.9);
}

#[test]
fn splitting_a_beam_leaves_the_image_unchanged_and_children_tile() {
    let Some(ctx) = gpu() else { return };
    let sc = side_view(0.6, 32, 32, 10.0, SIGMA_S, 0.05);
    for focus in [None, Some(1.2), Some(-0.8)] {
        let parent = vertical_beam(0.15, focus, 1.0, 1.0);
        let children = parent.split();
        let grandchildren: Vec<Beam> = children.iter().flat_map(|c| c.split()).collect();
        let s = settings();
        let p = beams::gather(&ctx, &sc, &[parent], &s).unwrap();
        let c = beams::gather(&ctx, &sc, &children, &s).unwrap();
        let g = beams::gather(&ctx, &sc, &grandchildren, &s).unwrap();
        let peak = p.pixels.iter().map(|v| v[0]).fold(0.0f32, f32::max);
        let diff = |a: &caustics::image_io::Image| {
            a.pixels.iter().zip(&p.pixels).map(|(a, b)| (a[0] - b[0]).abs()).fold(0.0f32, f32::max) / peak
        };
        let mut many = vec![parent];
        for _ in 0..5 {
            many = many.iter().flat_map(|c| c.split()).collect();
        }
        let m = beams::gather(&ctx, &sc, &many, &s).unwrap();
        println!("{focus:?}: 1024 beams / 1: sum ratio {:.4}", sum(&m) / sum(&p));
        let (dc, dg) = (diff(&c), diff(&g));
        // Measured: 1e-6 to 1e-5 of the peak: children tile their parent without gaps or
        // overlaps (a pixel whose ray runs along a shared side gets each part once).
        println!("{focus:?}: peak {peak:.4}, split 1->4 max diff {dc:.2e}, 1->16 {dg:.2e}");
        assert!(peak > 0.0);
        assert!(dc < 1e-3 && dg < 1e-3, "{focus:?}: {dc} {dg}");
        assert!((sum(&c) / sum(&p) - 1.0).abs() < 1e-4);
        // The box filter (3 x 3 rays per pixel) keeps the sum (the beam is many pixels wide).
        let boxed = beams::gather(&ctx, &sc, &[parent], &BeamSettings { pixel_samples: 3, ..s }).unwrap();
        println!("{focus:?}: sum with 3 x 3 rays per pixel / with 1: {:.4}", sum(&boxed) / sum(&p));
        assert!((sum(&boxed) / sum(&p) - 1.0).abs() < 0.02);
    }
}

/// A glass ball (radius 0.5, IOR 1.5, centre at height 1.5) under a spot light 2.5 m above its
/// centre, in fog, over a black floor; the camera looks at it from the side.
fn ball_in_fog(falloff_start: f32, w: u32, h: u32) -> Scene {
    scene(&format!(
        r#"{{ "schema_version": 1, "name": "ball_fog",
  "camera": {{ "position": [0, 1.0, 3.2], "look_at": [0, 0.9, 0], "fov_y_deg": 40, "width": {w}, "height": {h} }},
  "lights": [ {{ "type": "spot", "position": [0, 4, 0], "direction": [0, -1, 0], "cone_angle_deg": 14, "falloff_start_deg": {falloff_start}, "intensity": [20, 20, 20] }} ],
  "materials": {{ "black": {{ "type": "diffuse", "albedo": 0 }}, "glass": {{ "type": "dielectric", "ior": 1.5 }} }},
  "objects": [ {{ "type": "sphere", "center": [0, 1.5, 0], "radius": 0.5, "material": "glass" }},
               {{ "type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [8, 8], "material": "black" }} ],
  "medium": {{ "sigma_s": 0.3, "sigma_a": 0.05, "phase": {{ "type": "isotropic" }},
              "bounds": {{ "min": [-4, -0.1, -4], "max": [4, 4.5, 4] }} }} }}"#
    ))
}

fn render_settings(b: BeamSettings) -> RenderSettings {
    RenderSettings {
        photons: caustics::settings::PhotonSettings { count: 64, caustic_map_size: 64, ..Default::default() },
        shading: caustics::settings::ShadingSettings { shadow_map_size: 256, ..Default::default() },
        beams: b,
        ..Default::default()
    }
}

#[test]
fn a_ball_lens_focuses_into_the_fog_at_its_paraxial_focus() {
    let Some(ctx) = gpu() else { return };
    // A ball lens (both principal planes at its centre) has the focal length f = nR/(2(n - 1))
    // from its centre: collimated light focuses there, light from a point at distance s from
    // the centre at s' = 1/(1/f - 1/s). The spot is 20 m above the centre (nearly collimated).
    let mut sc = ball_in_fog(14.0, 16, 16);
    let s_light = 20.0f32;
    if let caustics::scene::Light::Spot { position, .. } = &mut sc.lights[0] {
        *position = Vec3::new(0.0, 1.5 + s_light, 0.0);
    }
    let out = render(&ctx, &sc, &render_settings(BeamSettings { reflection: false, ..Default::default() })).unwrap();
    let (stats, list) = &out.beams[0];
    println!("{stats:?}");
    assert!(stats.beams > 100 && stats.overflow == 0);
    let (n, r, centre) = (1.5f32, 0.5f32, 1.5f32);
    let f = n * r / (2.0 * (n - 1.0));
    let want = 1.0 / (1.0 / f - 1.0 / s_light);
    // Near-axis beams (base centroid within 0.04 m of the axis, on the exit side, paraxial):
    // where their cross-section is smallest, below the centre.
    let mut found = Vec::new();
    for b in list {
        let c = (b.vertices[0] + b.vertices[1] + b.vertices[2]) / 3.0;
        // (and paraxial in direction too, within 6° of the axis: the beams of light that grazed
        // the silhouette, now shrunk and kept, also leave the ball near its bottom, steeply)
        let dir = (b.dirs[0] + b.dirs[1] + b.dirs[2]).normalize();
        if c.y > centre || Vec3::new(c.x, 0.0, c.z).length() > 0.04 || -dir.y < 6f32.to_radians().cos() {
            continue;
        }
        let best = (0..=2000)
            .map(|i| i as f32 * 0.001)
            .fold((0.0f32, f32::MAX), |acc, y| if b.area(y) < acc.1 { (y, b.area(y)) } else { acc });
        found.push(centre - (c + b.normal() * best.0).y);
    }
    assert!(found.len() >= 4, "{} near-axis beams", found.len());
    let mean = found.iter().sum::<f32>() / found.len() as f32;
    println!(
        "ball lens: {} near-axis beams focus {mean:.4} m below the centre (paraxial {want:.4}; f = nR/(2(n-1)) = {f})",
        found.len()
    );
    assert!((mean / want - 1.0).abs() < 0.02);
}

/// Unpolarised Fresnel reflectance (as shared/common.wgsl), eta = n_t / n_i.
fn fresnel(cos_i: f64, eta: f64) -> f64 {
    let s2 = (1.0 - cos_i * cos_i) / (eta * eta);
    if s2 >= 1.0 {
        return 1.0;
    }
    let ct = (1.0 - s2).sqrt();
    let rs = (cos_i - eta * ct) / (cos_i + eta * ct);
    let rp = (eta * cos_i - ct) / (eta * cos_i + ct);
    0.5 * (rs * rs + rp * rp)
}

/// The light of `ball_in_fog`'s uniform spot onto the ball from the light directions α in
/// [`from` · α_max, α_max] (α from the axis, α_max the ball's half angle; `from` 0: all of it),
/// and that light times the Fresnel factors of the three traced branches: transmitted out (two
/// interfaces, equal Fresnel factors by reciprocity: (1 - F)²), reflected at the first surface
/// (F), reflected once inside ((1 - F) F (1 - F): inside a sphere every interface meets the ray
/// at the refraction angle), and of the residual branch: reflected twice or more inside
/// (the sum over k >= 2 of (1 - F) F^k (1 - F) = (1 - F) F²). Per ring of directions the
/// incidence angle follows from sin θi = D sin α / R.
fn fresnel_flux(from: f64) -> (f64, [f64; 4]) {
    let (i, d, r, n) = (20.0f64, 2.5f64, 0.5f64, 1.5f64);
    let amax = (r / d).asin();
    let a0 = from * amax;
    let steps = 200_000;
    let (mut onto, mut out) = (0.0, [0.0; 4]);
    for k in 0..steps {
        let a = a0 + (k as f64 + 0.5) / steps as f64 * (amax - a0);
        let dw = 2.0 * std::f64::consts::PI * a.sin() * (amax - a0) / steps as f64;
        let si = (d * a.sin() / r).min(1.0);
        let f = fresnel((1.0 - si * si).sqrt(), n);
        onto += i * dw;
        out[0] += i * (1.0 - f) * (1.0 - f) * dw;
        out[1] += i * f * dw;
        out[2] += i * (1.0 - f) * f * (1.0 - f) * dw;
        out[3] += i * (1.0 - f) * f * f * dw;
    }
    (onto, out)
}

/// The beams' flux per branch (`Beam::branch`: transmitted, reflected at the first surface,
/// reflected once inside, two at a second dielectric, residual) of one render with every branch
/// traced, the last-level triangles lost, and the residual branch's deviation
/// (`residual_sigma`). (The reflected branches also refine the triangles, so a render without
/// them has other transmitted beams: the branches are told apart by their id, not by
/// subtracting renders.)
fn flux_per_branch(ctx: &caustics::gpu::GpuContext, sc: &Scene, b: BeamSettings) -> ([f64; 6], u32, f64) {
    let out = render(ctx, sc, &render_settings(BeamSettings { reflection: true, ..b })).unwrap();
    let (stats, list) = &out.beams[0];
    println!("{stats:?}");
    let mut sums = [0.0f64; 6];
    for beam in list {
        sums[beam.branch as usize] += f64::from(beam.flux.x);
    }
    (sums, stats.inconsistent, residual_sigma(list))
}

/// A bound on the standard deviation of the residual branch's (5) summed flux (first channel,
/// layer 0), a random estimate: twice the root of its beams' summed squared fluxes (the beams
/// of one triangle share its random choices; by Cauchy-Schwarz over its at most 4 parts, twice
/// the independent beams' deviation bounds theirs).
fn residual_sigma(list: &[Beam]) -> f64 {
    2.0 * list.iter().filter(|b| b.branch == 5 && b.layer == 0).map(|b| f64::from(b.flux.x).powi(2)).sum::<f64>().sqrt()
}

#[test]
fn total_beam_flux_is_the_flux_onto_the_ball_times_fresnel() {
    let Some(ctx) = gpu() else { return };
    // A uniform spot (no falloff inside the ball's cone): the flux of every branch's beams
    // against the light onto the ball times its Fresnel factors (`fresnel_flux`).
    let sc = ball_in_fog(14.0, 8, 8);
    let (onto, want) = fresnel_flux(0.0);
    for (name, b) in [("adaptive 16+3", BeamSettings::default()), ("regular 64", BeamSettings::regular(64))] {
        let (got, lost, sigma) = flux_per_branch(&ctx, &sc, b);
        let rel: Vec<String> = (0..3).map(|k| format!("{:+.2} %", (got[k] / want[k] - 1.0) * 100.0)).collect();
        println!(
            "{name}: onto the ball {onto:.4} W; beams TT {:.4} R {:.4} TRT {:.4} W; Fresnel {:.4} {:.4} {:.4} W; beams / Fresnel - 1: {}; triangles lost {lost}",
            got[0],
            got[1],
            got[2],
            want[0],
            want[1],
            want[2],
            rel.join(", ")
        );
        for k in 0..3 {
            // Never more than the light onto the ball times the Fresnel factors (the quadrature
            // and the shrink add no light; 0.5 % for the quadrature's error), at most 2 % lost
            // at the silhouette. Measured (2026-12-03): adaptive 16² + 3: TT -1.17 %, R +0.25 %,
            // TRT -0.60 % (58 last-level triangles lost); regular 64²: -0.52 %, -0.04 %,
            // -0.74 % (12 lost). Since the parts' flux is corrected by the triangle's samples
            // (2026-12-05): -0.38 %, +0.05 %, -0.04 %; -0.30 %, -0.01 %, +0.01 %; none lost.
            // Before the per-branch bookkeeping and the reflected branches' shrink and
            // quadrature: R + TRT -18.5 % (regular 64²).
            assert!(
                got[k] <= want[k] * 1.005 && got[k] >= want[k] * 0.98,
                "{name}: branch {k}: {} vs {}",
                got[k],
                want[k]
            );
        }
        // The residual branch: the light reflected twice or more inside the ball, a random
        // estimate (its choices drawn per triangle), within three of its deviations, which is
        // small against the light.
        println!(
            "{name}: residual {:.5} W (sigma {sigma:.5}), reflected twice or more inside {:.5} W: {:+.1} %",
            got[5],
            want[3],
            (got[5] / want[3] - 1.0) * 100.0
        );
        // (a deviation below a third of the light, so that a missing residual branch fails)
        assert!(sigma < want[3] / 3.0, "{name}: the residual's deviation {sigma} W of {} W", want[3]);
        assert!(
            (got[5] - want[3]).abs() < 3.0 * sigma,
            "{name}: residual {} W vs {} W (sigma {sigma})",
            got[5],
            want[3]
        );
    }
}

#[test]
fn reflected_silhouette_shrink_conserves_the_fresnel_flux() {
    let Some(ctx) = gpu() else { return };
    // A coarse regular grid (32², no refinement): every triangle over the ball's silhouette is
    // at the last level, where its reflected edges disagree (some miss the ball) and it is
    // shrunk to the part on the ball. Reflection is strongest there: the outermost 1/64 of the
    // ball's half angle (a quarter of a cell: the face is fitted to the ball, a 32² cell is
    // 1/16 of its radius) holds 18 % of the reflected light, so dropping or halving those
    // triangles shows. Measured (2026-12-03): R +0.28 %, TRT -1.37 %; regular 64² -0.04 %,
    // -0.74 %; since the parts' flux is corrected by the triangle's samples (2026-12-05):
    // -0.06 %, +0.02 % (the triangle's 16 samples alone, without the region's own light:
    // R +0.84 %). At 16² now R -0.28 %, TRT +0.52 % (before: -7.3 %, -2.0 %;
    // docs/beams.md, "Beams: accuracy").
    let sc = ball_in_fog(14.0, 8, 8);
    let (_, want) = fresnel_flux(0.0);
    let (_, band) = fresnel_flux(1.0 - 1.0 / 64.0);
    let (got, lost, _) = flux_per_branch(&ctx, &sc, BeamSettings::regular(32));
    println!(
        "regular 32: R {:+.2} %, TRT {:+.2} % of the Fresnel integral; the outermost 1/64 of the angle holds R {:.1} %, TRT {:.1} %; triangles lost {lost}",
        (got[1] / want[1] - 1.0) * 100.0,
        (got[2] / want[2] - 1.0) * 100.0,
        band[1] / want[1] * 100.0,
        band[2] / want[2] * 100.0
    );
    for k in 1..3 {
        assert!(band[k] / want[k] > 0.05, "the silhouette band is a sensitive test");
        assert!(got[k] <= want[k] * 1.005 && got[k] >= want[k] * 0.98, "branch {k}: {} vs {}", got[k], want[k]);
    }
}

/// `ball_in_fog`'s ball (centre 1.5 m, radius 0.5 m) over a second glass ball on the axis
/// (centre 0.35 m, radius 0.3 m, wholly in the first one's shadow): the first focuses the spot's
/// light 0.75 m below its centre, and the light spreads from there onto the second (the light
/// between two casters: the beams' layer 1).
fn two_balls_in_fog(w: u32, h: u32) -> Scene {
    let mut sc = ball_in_fog(14.0, w, h);
    let glass = sc.objects[0].material;
    sc.objects.push(caustics::scene::Object {
        shape: caustics::scene::Shape::Sphere { center: Vec3::new(0.0, 0.35, 0.0), radius: 0.3 },
        material: glass,
        caustic_caster: true,
    });
    sc
}

/// An independent trace of `two_balls_in_fog`'s light in a meridional plane (both balls are
/// centred on the spot's axis, so a ray through the axis stays in its plane): the fraction of
/// the light toward angle `a` from the axis that branch `br` carries on its last segment and
/// on the segment before it between two specular objects (layer 1), by the rules of
/// beam_refine's `trace_edge` (branch br >= 1 reflects at interaction br - 1 and transmits
/// elsewhere; a branch's layer 1 only where it reflected before it).
fn two_balls_trace(a: f64, br: u32) -> (f64, f64) {
    use glam::DVec2;
    let balls = [(DVec2::new(0.0, 1.5), 0.5f64), (DVec2::new(0.0, 0.35), 0.3f64)];
    let n_glass = 1.5f64;
    let hit = |o: DVec2, d: DVec2| -> Option<(f64, usize)> {
        let mut best: Option<(f64, usize)> = None;
        for (k, (c, r)) in balls.iter().enumerate() {
            let oc = o - *c;
            let b = oc.dot(d);
            let disc = b * b - (oc.length_squared() - r * r);
            if disc < 0.0 {
                continue;
            }
            for t in [-b - disc.sqrt(), -b + disc.sqrt()] {
                if t > 1e-9 && best.is_none_or(|(bt, _)| t < bt) {
                    best = Some((t, k));
                    break;
                }
            }
        }
        best
    };
    let (mut o, mut d) = (DVec2::new(0.0, 4.0), DVec2::new(a.sin(), -a.cos()));
    let (mut w, mut w1) = (1.0f64, 0.0f64);
    let mut inside = false;
    for depth in 0..16u32 {
        let Some((t, k)) = hit(o, d) else {
            // (leaves the scene or lands on the floor: the last segment)
            return if br == 0 || br - 1 < depth { (w, w1) } else { (0.0, 0.0) };
        };
        if depth > 0 && !inside {
            w1 = if br == 0 || br - 1 < depth { w } else { 0.0 };
        }
        let p = o + d * t;
        let nrm = (p - balls[k].0) / balls[k].1;
        let (n_face, eta) = if d.dot(nrm) < 0.0 { (nrm, 1.0 / n_glass) } else { (-nrm, n_glass) };
        let cos_i = -d.dot(n_face);
        let f = fresnel(cos_i, 1.0 / eta);
        if br >= 1 && depth == br - 1 {
            w *= f;
            d -= 2.0 * d.dot(n_face) * n_face;
        } else {
            w *= 1.0 - f;
            let k2 = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
            d = (d * eta + n_face * (eta * cos_i - k2.sqrt())).normalize();
            inside = !inside;
        }
        o = p + d * 1e-9;
    }
    (0.0, 0.0)
}

#[test]
fn second_caster_layer_carries_the_light_between_two_balls() {
    let Some(ctx) = gpu() else { return };
    // The beams of the light between the two balls (layer 1) against an independent meridional
    // trace (`two_balls_trace`) of the uniform spot's light: per branch and layer, the flux of
    // the beams against the light onto the first ball times the fractions each branch carries.
    // Layer-1 beams start on the first ball and end on the second, and light nothing
    // (`land`); a branch reflected at the second ball has no layer-1 beam of its own (the light
    // before the reflection is branch 0's: counting it again was measured as twice the light
    // between the balls).
    let sc = two_balls_in_fog(8, 8);
    let (i, d, r) = (20.0f64, 2.5f64, 0.5f64);
    let amax = (r / d).asin();
    let steps = 100_000;
    // want[branch][layer]
    let mut want = [[0.0f64; 2]; 5];
    for s in 0..steps {
        let a = (s as f64 + 0.5) / steps as f64 * amax;
        let dw = 2.0 * std::f64::consts::PI * a.sin() * amax / steps as f64;
        for (br, w) in want.iter_mut().enumerate() {
            let (l0, l1) = two_balls_trace(a, br as u32);
            w[0] += i * l0 * dw;
            w[1] += i * l1 * dw;
        }
    }
    let out = render(&ctx, &sc, &render_settings(BeamSettings { reflection: true, ..Default::default() })).unwrap();
    let (stats, list) = &out.beams[0];
    println!("{stats:?}");
    assert!(stats.overflow == 0 && stats.between_casters > 100);
    let mut got = [[0.0f64; 2]; 6];
    for b in list {
        got[b.branch as usize][b.layer as usize] += f64::from(b.flux.x);
    }
    let mut lines = Vec::new();
    for br in 0..5 {
        for layer in 0..2 {
            let (g, w) = (got[br][layer], want[br][layer]);
            lines.push(format!(
                "branch {br} layer {layer}: {g:.4} W of {w:.4} W ({:+.2} %)",
                (g / w.max(1e-30) - 1.0) * 100.0
            ));
        }
    }
    println!("two balls, adaptive 16² + 3: {}; triangles lost {}", lines.join("; "), stats.inconsistent);
    // Layer-1 beams run from one ball to the other (their light starts on a ball's surface:
    // their bases there, or moved along their edges off an oblique one, outside both, or back
    // inside the ball they leave with the surface points' clip heights), end on a ball, and
    // light nothing.
    let balls = [(Vec3::new(0.0, 1.5, 0.0), 0.5f32), (Vec3::new(0.0, 0.35, 0.0), 0.3f32)];
    let on_ball = |p: Vec3| balls.iter().any(|(c, r)| ((p - *c).length() - r).abs() < 2e-3);
    let outside = |p: Vec3| balls.iter().all(|(c, r)| (p - *c).length() > r - 2e-3);
    for b in list.iter().filter(|b| b.layer == 1) {
        assert_eq!(b.land, u32::MAX, "a layer-1 beam lights no surface");
        let n = b.normal();
        for k in 0..3 {
            let start = b.vertices[k] + b.dirs[k] * (b.clip[k] / n.dot(b.dirs[k]));
            let end = b.vertices[k] + b.dirs[k] * b.ends[k];
            assert!(outside(start) && on_ball(end), "layer-1 edge from {start} to {end}");
        }
    }
    // Every branch and layer within the bounds of the one-ball test (no light added, 0.5 % for
    // the quadratures; at most 2 % lost at silhouettes, here the second ball's too), but the
    // light reflected at the second ball (3, 0): it is brightest where it grazes that ball,
    // where some beams' bases are too oblique to build and are dropped (counted in
    // `BeamStats::grazing`). Measured (2026-12-03, lavapipe): branch 0 -1.52 % (last segment)
    // and -0.05 % (between the balls); 1: +0.42 %; 2: -0.28 %; 3: -2.95 % and +0.01 %; 4:
    // +0.06 % and -0.05 %; no triangle lost, 42 grazing beams dropped. Since the parts take
    // their share of the triangle's samples and degenerate ones are thin beams (2026-12-05):
    // -0.50 % and -0.01 %; +0.04 %; -0.04 %; -0.16 % and +0.02 %; -0.00 % and +0.04 %; none
    // dropped. Before the minority
    // parts of shrunk triangles were kept, branch 0's last segment was -2.14 % and branch 3's
    // -6.20 %; before a branch's layer 1 needed its reflection before it, branch 3 and 4 had
    // layer-1 beams of branch 0's light (the volume caustic between the balls was twice the
    // CPU reference's).
    for br in 0..5 {
        for layer in 0..2 {
            let (g, w) = (got[br][layer], want[br][layer]);
            let low = if (br, layer) == (3, 0) { 0.96 } else { 0.98 };
            if w == 0.0 {
                assert_eq!(g, 0.0, "branch {br} layer {layer}: {g} W where the trace has none");
            } else {
                assert!(g <= w * 1.005 && g >= w * low, "branch {br} layer {layer}: {g} vs {w}");
            }
        }
    }
    // The light between the balls is layer 1 of the transmitted branch and of the branches
    // reflected at the second ball (back up into the first); none of the first ball's own.
    assert!(want[0][1] > 0.8 * want[0][0] && want[3][1] > 0.0 && want[1][1] == 0.0);
}

// The issue's target (mean HDR-FLIP 0.1, energy within 5 %) on this scene (48 x 40, the ball
// masked), default settings (adaptive 16² + 3, the footprint integral, every branch's
// silhouette shrunk, the reflected branches' Fresnel quadrature), against the single-scattering
// reference at 2^27 photons (REF_PHOTONS to change; itself HDR-FLIP 0.043, energy +0.02 % from
// the noise-free line integral `line_integral_reference`): measured 2026-12-03 HDR-FLIP
// 0.0698, energy -1.17 % (against the line integral 0.0644) with the linearity criterion
// (12674 beams). Before it 0.0882, -1.47 % (line integral 0.0806), once every path of a shrunk
// silhouette triangle was kept (0.0951, -1.56 % before that; 0.0983, -1.86 % before the gather took
// the beam's flux direction); 2026-12-05, the pixels ending at their surface's tangent plane:
// 0.0566, -0.23 % (line integral 0.0485), 13583 beams. At 2^25 photons the reference's
// own noise (0.056 from the line integral) adds to the comparison: 0.102. Regular 64²
// (BEAM_CONFIGS=all): 0.0967 against the line integral before that change (0.092 after). Ignored for its time (the reference,
// some 70 s on two cores; the beams some 25 s on lavapipe); run it with `--ignored` (it prints
// the figures; BEAM_DUMP=DIR writes the images).
#[test]
#[ignore = "slow (a 2^27-photon CPU reference): volume caustic against the reference, HDR-FLIP 0.057, energy -0.2 % (target 0.1, 5 %)"]
fn gpu_beams_match_the_cpu_reference_in_fog() {
    use caustics_reference::metrics::{energy, hdr_flip};
    use caustics_reference::reference;
    let Some(ctx) = gpu() else { return };
    let (w, h) = (48, 40);
    let sc = ball_in_fog(14.0, w, h);
    // Pixels that see the ball (dilated by a pixel's width): the reference does not render
    // a volume caustic seen through glass.
    let mask = ball_mask(&sc);
    // 2^27 photons (at 2^25 the reference against itself with another seed gave HDR-FLIP
    // 0.066: its noise is a floor under the comparison).
    let photons = std::env::var("REF_PHOTONS").ok().and_then(|v| v.parse().ok()).unwrap_or(1u64 << 27);
    let rs = common::single_scattering_reference(photons, 1, 5);
    let t = std::time::Instant::now();
    let r = reference::render(&sc, &rs).unwrap();
    // The reference's own error: against the noise-free line integral.
    let lines = line_integral_reference(&sc, 100);
    let line = to_image(&(0..(w * h) as usize).map(|i| lines.iter().map(|c| c[i]).sum()).collect::<Vec<f64>>(), w, h);
    println!(
        "reference ({photons} photons): {:.1} s; against the line integral HDR-FLIP {:.4}, energy {:+.2} %",
        t.elapsed().as_secs_f64(),
        hdr_flip(&r.caustic, &line, Some(&mask)).unwrap().mean,
        (energy(&r.caustic, Some(&mask)) / energy(&line, Some(&mask)) - 1.0) * 100.0
    );
    let configs: Vec<(&str, BeamSettings)> = match std::env::var("BEAM_CONFIGS") {
        Ok(f) if f == "all" => {
            vec![("adaptive 16+3", BeamSettings::default()), ("regular 64", BeamSettings::regular(64))]
        }
        _ => vec![("adaptive 16+3", BeamSettings::default())],
    };
    for (name, b) in configs {
        let t = std::time::Instant::now();
        let g = render(&ctx, &sc, &render_settings(b)).unwrap();
        let ms = t.elapsed().as_secs_f64() * 1e3;
        let flip = hdr_flip(&g.caustic, &r.caustic, Some(&mask)).unwrap().mean;
        let (eg, er) = (energy(&g.caustic, Some(&mask)), energy(&r.caustic, Some(&mask)));
        println!(
            "{name}: {} beams, HDR-FLIP {flip:.4}, energy GPU {eg:.5} reference {er:.5} ({:+.2} %), {ms:.0} ms; against the line integral HDR-FLIP {:.4}",
            g.beams[0].0.beams,
            (eg / er - 1.0) * 100.0,
            hdr_flip(&g.caustic, &line, Some(&mask)).unwrap().mean
        );
        if std::env::var_os("BEAM_DUMP").is_some() {
            let dir = std::path::PathBuf::from(std::env::var_os("BEAM_DUMP").unwrap());
            caustics_reference::io::ImageIo::write(&g.caustic, &dir.join(format!("gpu_{}.exr", b.levels)), 1.0)
                .unwrap();
            caustics_reference::io::ImageIo::write(&r.caustic, &dir.join("reference.exr"), 1.0).unwrap();
        }
        assert!(flip < 0.1, "{name}: HDR-FLIP {flip}");
        assert!((eg / er - 1.0).abs() < 0.05, "{name}: energy {eg} vs {er}");
    }
}

/// `beam_raster` draws the beams it is given as an independent integrator does: the CPU's
/// quadrature of the same beams (`reference::beam_splat`: 8² lines per beam, 64 points each,
/// the first surfaces from 4 × 4 rays per pixel) on the ball in fog (every branch, the ball
/// masked), row by row: energy within 0.5 %, rows within 1 %. Measured: energy 1.0001, rows within 0.5 %; with the sub-pixel rays and
/// footprint ending at the plane facing the camera (before 2026-12-05) the row where the shaft
/// meets the floor has 0.917 of the light and fails.
#[test]
fn beam_raster_draws_its_beams_as_the_cpu_integrates_them() {
    use caustics_reference::reference::beam_splat::{BeamSplat, lines};
    let Some(ctx) = gpu() else { return };
    let (w, h) = (48, 40);
    let sc = ball_in_fog(14.0, w, h);
    let mask = ball_mask(&sc);
    let out = render(&ctx, &sc, &render_settings(BeamSettings::default())).unwrap();
    let beams = &out.beams[0].1;
    let splat = BeamSplat::new(&sc).unwrap().beams(beams, &lines(8), 64, false);
    let row =
        |y: u32, f: &dyn Fn(u32) -> f64| -> f64 { (0..w).filter(|&x| mask.include[(y * w + x) as usize]).map(f).sum() };
    let (mut gpu_all, mut cpu_all, mut worst) = (0.0, 0.0, (0u32, 1.0f64));
    let total: f64 = splat.iter().sum();
    for y in 0..h {
        let g = row(y, &|x| f64::from(out.caustic.get(x, y)[0]));
        let c = row(y, &|x| splat[(y * w + x) as usize]);
        (gpu_all, cpu_all) = (gpu_all + g, cpu_all + c);
        // (rows that hold at least 1 % of the light)
        if c > 0.01 * total && (g / c - 1.0).abs() > (worst.1 - 1.0).abs() {
            worst = (y, g / c);
        }
    }
    println!("{} beams: GPU / CPU energy {:.4}, worst row {} {:.4}", beams.len(), gpu_all / cpu_all, worst.0, worst.1);
    assert!((gpu_all / cpu_all - 1.0).abs() < 0.005, "energy {}", gpu_all / cpu_all);
    assert!((worst.1 - 1.0).abs() < 0.01, "row {}: {}", worst.0, worst.1);
}

/// The list of a deep hierarchy holds every kept beam once: 16² + 4 levels and 32² + 3 keep the
/// same beams but for the first two levels' (the same finest grid), so their transmitted flux
/// agrees. `beam_order` once walked the hierarchy's 8.4 M slot entries in one workgroup, and
/// lavapipe's loop limit cut each thread's walk short: 16² + 4 listed one beam five times,
/// +1.26 % flux, a bright line along the ball's axis (docs/benchmarks.md, "Beams: the list of a
/// deep hierarchy").
#[test]
fn a_deep_hierarchys_list_holds_every_beam_once() {
    let Some(ctx) = gpu() else { return };
    let sc = ball_in_fog(14.0, 8, 8);
    let run = |grid: u32, levels: u32| {
        let b = BeamSettings { grid, levels, reflection: false, ..Default::default() };
        let out = render(&ctx, &sc, &render_settings(b)).unwrap();
        let (stats, list) = out.beams[0].clone();
        assert_eq!(stats.overflow, 0);
        assert_eq!(list.len() as u32, stats.kept_per_level.iter().sum::<u32>(), "{stats:?}");
        // (geometry and flux: triangles that share a corner can each make a thin beam along
        // its edge, the same geometry with another flux)
        let mut keys: Vec<[[u32; 3]; 3]> =
            list.iter().map(|b| [b.vertices[0], b.dirs[1], b.flux].map(|v| v.to_array().map(f32::to_bits))).collect();
        keys.sort_unstable();
        let repeated = keys.windows(2).filter(|w| w[0] == w[1]).count();
        assert_eq!(repeated, 0, "{grid}² + {levels}: a beam listed more than once");
        list.iter().map(|b| f64::from(b.flux.x)).sum::<f64>()
    };
    let (deep, wide) = (run(16, 4), run(32, 3));
    println!("transmitted flux: 16² + 4 {deep:.6} W, 32² + 3 {wide:.6} W");
    assert!((deep / wide - 1.0).abs() < 1e-4, "{deep} vs {wide}");
}

#[test]
fn beams_are_deterministic_create_nothing_after_the_first_frame_and_bad_settings_are_named() {
    use caustics::renderer::Renderer;
    let Some(ctx) = gpu() else { return };
    let sc = ball_in_fog(14.0, 16, 12);
    let s = render_settings(BeamSettings::default());
    // Same input, same bits (the beams are summed in hierarchy order, not atomics' order).
    let a = render(&ctx, &sc, &s).unwrap();
    let b = render(&ctx, &sc, &s).unwrap();
    assert!(a.caustic.pixels.iter().any(|p| p[0] > 0.0));
    assert_eq!(a.image.pixels, b.image.pixels);
    assert_eq!(a.beams[0].1, b.beams[0].1);
    // The renderer's steady state: nothing created after the first frame.
    let mut r = Renderer::with_context(ctx.clone(), sc.clone(), s.clone()).unwrap();
    let frame = common::created_by_a_frame;
    assert!(frame(&mut r) > 0);
    assert_eq!(frame(&mut r), 0);
    // Nor does the driver keep memory per frame: lavapipe (Mesa 22.3) compiled and kept a shader
    // variant at every bind of a chunk whose constants were uniforms, some 1.8 GB a frame at the
    // default capacity (docs/beams.md, "Beams: memory"). Four full frames must not add a
    // gigabyte (the binary's other tests, run alongside, peak at some 0.6 GB in all).
    match resident_mb() {
        Some(before) => {
            for _ in 0..4 {
                r.invalidate();
                assert_eq!(frame(&mut r), 0);
                ctx.device.poll(wgpu::PollType::wait_indefinitely()).unwrap();
            }
            let grown = resident_mb().unwrap().saturating_sub(before);
            assert!(grown < 1024, "four beam frames kept {grown} MB");
        }
        None => eprintln!("memory per frame not checked: no /proc/self/status"),
    }
    // Bad beam settings: an error naming the field.
    for (bad, field) in [
        (BeamSettings { grid: 0, ..Default::default() }, "beams.grid"),
        (BeamSettings { levels: 9, ..Default::default() }, "beams.levels"),
        (BeamSettings { chunk_scale: 1025, ..Default::default() }, "beams.chunk_scale"),
        (BeamSettings { energy_threshold: -1.0, ..Default::default() }, "beams.energy_threshold"),
        (BeamSettings { residual: 1.0, ..Default::default() }, "beams.residual"),
        (BeamSettings { residual: f32::NAN, ..Default::default() }, "beams.residual"),
        (BeamSettings { cutoff: -1e-4, ..Default::default() }, "beams.cutoff"),
        (BeamSettings { cutoff: f32::INFINITY, ..Default::default() }, "beams.cutoff"),
    ] {
        let Err(e) = render(&ctx, &sc, &render_settings(bad)) else { panic!("{field}: no error") };
        let e = e.to_string();
        assert!(e.contains(field), "{e}");
    }
    // A capacity whose beam records exceed the adapter's storage-binding limit: named, not a
    // validation panic (lavapipe's limit is 128 MiB; 2^22 beams need 576 MiB).
    let most = BeamSettings { capacity: 1 << 22, ..Default::default() };
    let need = u64::from(most.capacity) * std::mem::size_of::<caustics::gpu::types::BeamGpu>() as u64;
    if need > ctx.device.limits().max_storage_buffer_binding_size {
        let Err(e) = render(&ctx, &sc, &render_settings(most)) else { panic!("beams.capacity: no error") };
        assert!(e.to_string().contains("beams.capacity"), "{e}");
    }
}

/// Larger chunks (`BeamSettings::chunk_scale`, 16 by default on GPUs) change only the order of
/// the sums: the volume caustic (gathered, `BeamVolume::Gather`) and the surface caustic from
/// beams of chunks twice lavapipe's size (half the dispatches) match those of its size to float
/// rounding.
#[test]
fn larger_chunks_change_only_the_order_of_the_sums() {
    let Some(ctx) = gpu() else { return };
    // The volume caustic in fog, and the surface caustic from beams on a lit floor.
    let (fog, floor) = (ball_in_fog(14.0, 24, 20), ball_at_45(24, 20, true));
    let run = |sc: &Scene, scale: u32| {
        let volume = caustics::render::BeamVolume::Gather;
        let b = BeamSettings { levels: 2, chunk_scale: scale, volume, ..Default::default() };
        let s = RenderSettings { beams: b, ..surface_settings(caustics::settings::LocalSource::Beams) };
        let g = render(&ctx, sc, &s).unwrap();
        assert!(g.beams[0].0.beams > 1000, "{} beams: too few to fill several chunks", g.beams[0].0.beams);
        // Chunk passes recorded (each is timed where the adapter has timestamp queries).
        let passes = g.timings.iter().filter(|(n, _)| n == "beam_gather" || n == "beam_surface").count();
        (g.caustic, passes)
    };
    for sc in [&fog, &floor] {
        let ((a, p1), (b, p2)) = (&run(sc, 1), &run(sc, 2));
        if ctx.timestamps {
            assert!(*p2 > 0 && 2 * p2 <= p1 + 2, "{p1} chunk passes, then {p2} with chunks twice as large");
        }
        let (sa, sb) = (sum(a), sum(b));
        assert!(sa > 0.0);
        assert!((sa / sb - 1.0).abs() < 1e-5, "sums {sa} and {sb}");
        let peak = a.pixels.iter().map(|p| p[0]).fold(0.0f32, f32::max);
        let worst = a.pixels.iter().zip(&b.pixels).map(|(p, q)| (p[0] - q[0]).abs()).fold(0.0f32, f32::max);
        assert!(worst <= 1e-5 * peak, "a pixel differs by {worst} (peak {peak})");
    }
}

/// The beams' hulls (`BeamVolume::Hulls`: beam_hull, beam_raster) add, per pixel and beam, what
/// the gather adds: the same images to the rounding of the sums' order, from the side (the
/// footprint integral of thin beams, several rays per pixel), with the camera inside the cone
/// under the ball (beams reaching behind the camera: their hulls cut in front of it, or the
/// whole image; beams through the focus near the camera: their hulls split there), and close
/// up (beams crossing the image's edges); and enough of the hulls' fragments add light. A hull missing a pixel a beam reaches, or covering one twice, would
/// differ by that beam's light there. The surface caustic from beams likewise (beam_surface
/// against beam_surface_raster). The same bits from run to run, and nothing created after a
/// renderer's first frame.
#[test]
fn hulls_draw_what_the_gather_adds() {
    use caustics::render::BeamVolume;
    use caustics::renderer::{FrameRequest, Renderer};
    let Some(ctx) = gpu() else { return };
    if !ctx.device.features().contains(wgpu::Features::FLOAT32_BLENDABLE) {
        let e = render(
            &ctx,
            &ball_in_fog(14.0, 8, 6),
            &render_settings(BeamSettings { volume: BeamVolume::Hulls, ..Default::default() }),
        );
        assert!(e.is_err_and(|e| e.to_string().contains("beams.volume")));
        eprintln!("hulls not checked: {} has no float32 blending", ctx.info.name);
        return;
    }
    // (small: the gather's cost is pixels times beams, and lavapipe is slow)
    let side = ball_in_fog(14.0, 32, 24);
    // Inside the cone below the focus (y 0.75), looking across it and down at the floor.
    let mut inside = side.clone();
    inside.camera.position = Vec3::new(0.0, 0.5, 0.0);
    inside.camera.look_at = Vec3::new(1.0, 0.2, 0.3);
    // Close up: the cone fills and leaves the image.
    let mut close = side.clone();
    close.camera.position = Vec3::new(0.0, 0.7, 0.8);
    close.camera.look_at = Vec3::new(0.0, 0.6, 0.0);
    // The least fraction of the hulls' fragments that must add light (the hulls' tightness:
    // before hulls reaching behind the camera were cut at it, 0.21, 0.022 and 0.071; with the
    // cut 0.64, 0.14 and 0.60; with the hulls that would still cover the whole image split at
    // the beams' foci 0.64, 0.43 and 0.59: inside the cone the convex hulls of the beams
    // through the focus held the camera).
    for (name, sc, b, lit_fill) in [
        ("side, 2x2 rays", &side, BeamSettings { levels: 2, pixel_samples: 2, ..Default::default() }, 0.4),
        ("inside the cone", &inside, BeamSettings { levels: 1, ..Default::default() }, 0.3),
        ("close up", &close, BeamSettings { levels: 1, ..Default::default() }, 0.4),
    ] {
        let gather = render(&ctx, sc, &render_settings(BeamSettings { volume: BeamVolume::Gather, ..b })).unwrap();
        let hs = render_settings(BeamSettings { volume: BeamVolume::Hulls, ..b });
        let hulls = render(&ctx, sc, &hs).unwrap();
        let (a, h) = (&gather.caustic, &hulls.caustic);
        let (sa, sh) = (sum(a), sum(h));
        let peak = a.pixels.iter().map(|p| p[0]).fold(0.0f32, f32::max);
        let worst = a.pixels.iter().zip(&h.pixels).map(|(p, q)| (p[0] - q[0]).abs()).fold(0.0f32, f32::max);
        let lit = a.pixels.iter().filter(|p| p[0] > 1e-3 * peak).count();
        let st = &hulls.beams[0].0;
        println!(
            "{name}: {} beams, gather {sa:.6e}, hulls {sh:.6e} ({:+.2e}), worst pixel {:.2e} of the peak, {lit} lit pixels, {} hull fragments ({} lit)",
            gather.beams[0].0.beams,
            sh / sa - 1.0,
            worst / peak,
            st.hull_fragments,
            st.hull_lit_fragments
        );
        assert!(sa > 0.0 && lit > 300, "{name}: too little volume caustic to compare");
        assert!((sh / sa - 1.0).abs() < 1e-5, "{name}: sums {sa} (gather) and {sh} (hulls)");
        assert!(worst <= 1e-5 * peak, "{name}: a pixel differs by {worst} (peak {peak})");
        assert!(
            f64::from(st.hull_lit_fragments) >= lit_fill * f64::from(st.hull_fragments),
            "{name}: {} of {} hull fragments lit",
            st.hull_lit_fragments,
            st.hull_fragments
        );
        // The full image too (the volume caustic is added to both).
        let full = gather.image.pixels.iter().zip(&hulls.image.pixels).map(|(p, q)| (p[0] - q[0]).abs());
        assert!(full.fold(0.0f32, f32::max) <= 1e-5 * peak, "{name}: the full images differ");
        let again = render(&ctx, sc, &hs).unwrap();
        assert_eq!(again.image.pixels, hulls.image.pixels, "{name}: hulls are not the same bits twice");
    }
    // The surface caustic from beams (beam_surface against beam_surface_raster), on a floor
    // under a tilted spot, with a table the beams stop at, and in the fog.
    let surf =
        |b: BeamSettings| RenderSettings { beams: b, ..surface_settings(caustics::settings::LocalSource::Beams) };
    let mut fog = side.clone();
    fog.camera.position = Vec3::new(0.0, 2.5, 2.2);
    fog.camera.look_at = Vec3::new(0.0, 0.0, 0.0);
    let floor = ball_at_45(32, 24, true);
    let mut white = floor.clone();
    white.medium = fog.medium.clone();
    for (name, sc) in [("floor and table", &floor), ("floor in fog", &white), ("fog from above", &fog)] {
        let b = BeamSettings { levels: 1, ..Default::default() };
        let gather = render(&ctx, sc, &surf(BeamSettings { volume: BeamVolume::Gather, ..b })).unwrap();
        let hulls = render(&ctx, sc, &surf(BeamSettings { volume: BeamVolume::Hulls, ..b })).unwrap();
        let (a, h) = (&gather.caustic, &hulls.caustic);
        let (sa, sh) = (sum(a), sum(h));
        let peak = a.pixels.iter().map(|p| p[0]).fold(0.0f32, f32::max);
        let worst = a.pixels.iter().zip(&h.pixels).map(|(p, q)| (p[0] - q[0]).abs()).fold(0.0f32, f32::max);
        println!(
            "surface, {name}: {} beams, gather {sa:.6e}, hulls {sh:.6e} ({:+.2e}), worst pixel {:.2e} of the peak, {} hull fragments ({} lit)",
            gather.beams[0].0.beams,
            sh / sa - 1.0,
            worst / peak,
            hulls.beams[0].0.hull_fragments,
            hulls.beams[0].0.hull_lit_fragments
        );
        assert!(sa > 0.0 && hulls.beams[0].0.hull_fragments > 0 && gather.beams[0].0.hull_fragments == 0);
        assert!((sh / sa - 1.0).abs() < 1e-5, "surface, {name}: sums {sa} (gather) and {sh} (hulls)");
        assert!(worst <= 1e-5 * peak, "surface, {name}: a pixel differs by {worst} (peak {peak})");
        // (the hulls of the beams' ends: 0.18, 0.51 and 0.42 of the fragments lit; of the whole
        // beams 0.09, 0.33 and 0.29; before the cut at the camera 0.09, 0.033 and 0.028)
        let st = &hulls.beams[0].0;
        assert!(
            f64::from(st.hull_lit_fragments) >= 0.12 * f64::from(st.hull_fragments),
            "surface, {name}: {} of {} hull fragments lit",
            st.hull_lit_fragments,
            st.hull_fragments
        );
    }
    // The renderer's steady state with hulls: nothing created after the first frame.
    let hs = render_settings(BeamSettings { levels: 2, volume: BeamVolume::Hulls, ..Default::default() });
    let mut r = Renderer::with_context(ctx.clone(), side.clone(), hs).unwrap();
    let mut frame = || {
        let before = r.created();
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        r.encode(&mut enc, FrameRequest { stats: false }).unwrap();
        let created = (r.created() - before).total();
        ctx.queue.submit([enc.finish()]);
        r.invalidate();
        created
    };
    assert!(frame() > 0);
    assert_eq!(frame(), 0);
}

/// This process's resident memory in MB (Linux only).
fn resident_mb() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let kb = status.lines().find_map(|l| l.strip_prefix("VmRSS:"))?.trim().trim_end_matches("kB").trim();
    Some(kb.parse::<u64>().ok()? / 1024)
}

/// A beam whose base is oblique to its edges is rebased across them (`make_beam`): its edges
/// extended back behind the surface it leaves, with the heights of the surface points
/// (`Beam::clip`). A prism falling from a tilted base (parallel edges: its sections parallel to
/// the base and across the edges hold the same light) against the same prism rebased to a
/// horizontal base through its highest vertex: the clipped beam draws the same image, by the
/// pixels' rays and by the footprint integral; without its clip heights it also lights the
/// wedge above the tilted surface (the test fails if the clip is ignored). Split 1 -> 4, the
/// rebased beam draws the same image (`Beam::split` carries the clip heights, `Beam::to_gpu`
/// lifts the base of a piece whose clip heights are all above it).
#[test]
fn a_rebased_beam_keeps_the_light_at_the_surface_it_leaves() {
    let Some(ctx) = gpu() else { return };
    // (the camera sees the beam from its base at heights 0.88 to 1.12 down to 0.4)
    let sc = side_view(0.9, 24, 24, 20.0, SIGMA_S, 0.1);
    let r = 0.15f32;
    // (base tilted about z: height 1 - 0.8 x; its highest vertex is not the first, so the
    // record rotates its vertices: `Beam::to_gpu`)
    let vertices: [Vec3; 3] = std::array::from_fn(|k| {
        let a = k as f32 * std::f32::consts::TAU / 3.0 + 0.3;
        Vec3::new(r * a.cos(), 1.0 - 0.8 * r * a.cos(), r * a.sin())
    });
    // (a parallel vertical beam of flux 1 W, its base tilted, its edges ending at height 0.2)
    let tilted = Beam { vertices, ends: vertices.map(|v| v.y - 0.2), ..vertical_beam(r, None, 1.0, 1.0) };
    let top = vertices.iter().map(|v| v.y).fold(f32::MIN, f32::max);
    // (the extension above each surface point is inside the object: not in the light's path)
    let rebased = Beam {
        vertices: vertices.map(|v| Vec3::new(v.x, top, v.z)),
        pre: vertices.map(|v| -(top - v.y)),
        ends: [top - 0.2; 3],
        clip: vertices.map(|v| top - v.y),
        ..tilted
    };
    let unclipped = Beam { clip: [0.0; 3], ..rebased };
    for (name, s) in
        [("rays", settings()), ("footprint", BeamSettings { footprint: 16.0, footprint_lines: 4, ..settings() })]
    {
        let a = beams::gather(&ctx, &sc, &[tilted], &s).unwrap();
        let b = beams::gather(&ctx, &sc, &[rebased], &s).unwrap();
        let c = beams::gather(&ctx, &sc, &[unclipped], &s).unwrap();
        // Split 1 -> 4, the clip heights carried (pieces whose lowest clip height is above
        // their base: `Beam::to_gpu` starts them there).
        let d = beams::gather(&ctx, &sc, &rebased.split(), &s).unwrap();

        let worst = a.pixels.iter().zip(&b.pixels).map(|(p, q)| (p[0] - q[0]).abs()).fold(0.0f32, f32::max);
        let peak = a.pixels.iter().map(|p| p[0]).fold(0.0f32, f32::max);
        let worst_split = b.pixels.iter().zip(&d.pixels).map(|(p, q)| (p[0] - q[0]).abs()).fold(0.0f32, f32::max);
        println!(
            "{name}: rebased / tilted {:.5}, worst pixel {:.2e} of the peak; without the clip {:.4}; split / rebased {:.5}, worst pixel {:.2e}",
            sum(&b) / sum(&a),
            worst / peak,
            sum(&c) / sum(&a),
            sum(&d) / sum(&b),
            worst_split / peak
        );
        // (per pixel by the rays only: the footprint integral's lines sample each piece's
        // footprint apart, so its pixels move with any split, clipped or not: the tilted beam's
        // split 0.135 of the peak, measured)
        assert!((sum(&d) / sum(&b) - 1.0).abs() < 2e-3, "{name}: split");
        assert!(name != "rays" || worst_split < 0.02 * peak, "{name}: split");
        assert!(sum(&a) > 0.0);
        assert!((sum(&b) / sum(&a) - 1.0).abs() < 2e-3, "{name}");
        assert!(worst < 0.02 * peak, "{name}");
        assert!(sum(&c) / sum(&a) > 1.03, "{name}: the wedge above the surface should be lit without the clip");
    }
}

/// Thousands of beams over one pixel: every one is gathered (lavapipe stops a long loop of one
/// invocation: the gather runs in chunks of the list).
#[test]
fn many_overlapping_beams_sum_like_one() {
    let Some(ctx) = gpu() else { return };
    let sc = side_view(0.6, 16, 16, 10.0, SIGMA_S, 0.05);
    let one = vertical_beam(0.15, Some(1.2), 1.0, 1.0);
    let p = beams::gather(&ctx, &sc, &[one], &settings()).unwrap();
    for n in [100usize, 4000] {
        let copy = Beam { flux: one.flux / n as f32, ..one };
        let m = beams::gather(&ctx, &sc, &vec![copy; n], &settings()).unwrap();
        println!("{n} copies: sum ratio {:.4}", sum(&m) / sum(&p));
        assert!((sum(&m) / sum(&p) - 1.0).abs() < 1e-3);
        let mut last = vec![Beam { flux: Vec3::ZERO, ..one }; n];
        last[n - 1] = one;
        let l = beams::gather(&ctx, &sc, &last, &settings()).unwrap();
        let mut first = vec![Beam { flux: Vec3::ZERO, ..one }; n];
        first[0] = one;
        let f = beams::gather(&ctx, &sc, &first, &settings()).unwrap();
        println!("{n}: only the last lit {:.4}, only the first {:.4}", sum(&l) / sum(&p), sum(&f) / sum(&p));
        assert!((sum(&l) / sum(&p) - 1.0).abs() < 1e-4 && (sum(&f) / sum(&p) - 1.0).abs() < 1e-4);
    }
    // Beams through their focus (the footprint integral's thin parts, its lines' loops) in the
    // pixels around the focus: every copy counted too.
    let sc = side_view(0.52, 9, 9, 4.0, SIGMA_S, 0.1);
    let thin = vertical_beam(0.1, Some(0.5), 1.0, 1.0);
    let s = BeamSettings { footprint: 2.0, footprint_lines: 4, ..settings() };
    let p = beams::gather(&ctx, &sc, &[thin], &s).unwrap();
    let n = 4000;
    let m = beams::gather(&ctx, &sc, &vec![Beam { flux: thin.flux / n as f32, ..thin }; n], &s).unwrap();
    println!("{n} thin copies: sum ratio {:.5}", sum(&m) / sum(&p));
    assert!((sum(&m) / sum(&p) - 1.0).abs() < 1e-3);
}

/// Path classes of the light leaving the glass ball: reflected at the first surface (R),
/// refracted in and out (TT), with one internal reflection (TRT), with more (T R..R T).
const PATH_CLASSES: [&str; 4] = ["R", "TT", "TRT", "TR+RT"];

/// The single-scattered volume caustic of [`ball_in_fog`], integrated on the CPU independently
/// of the reference's random photons and of the beams: `rings` x `4 rings` stratified light
/// rays onto the ball (equal solid angle), every branch of the exact Fresnel split followed
/// (weights, not sampling) up to 6 interactions, and each ray leaving the ball integrated
/// along its length (midpoint steps of 5 mm) into the pixel it projects to: σs Φ ds T phase /
/// (d² A_pix cos³ θc), T the transmittance from the light along the path and to the camera,
/// points hidden from the camera by the ball dropped. One image per path class.
fn line_integral_reference(sc: &Scene, rings: usize) -> Vec<Vec<f64>> {
    let cam = &sc.camera;
    let (w, h) = (cam.width as usize, cam.height as usize);
    let (lp, centre, r, n) = (glam::DVec3::new(0.0, 4.0, 0.0), glam::DVec3::new(0.0, 1.5, 0.0), 0.5f64, 1.5f64);
    let (ss, st, i0) = (0.3f64, 0.35f64, 20.0f64);
    let (lo, hi) = (glam::DVec3::new(-4.0, -0.1, -4.0), glam::DVec3::new(4.0, 4.5, 4.0));
    let tan_y = (f64::from(cam.fov_y_deg).to_radians() * 0.5).tan();
    let tan_x = tan_y * f64::from(cam.aspect());
    let pix_area = (2.0 * tan_x / w as f64) * (2.0 * tan_y / h as f64);
    let (cp, fwd, right, up) =
        (cam.position.as_dvec3(), cam.forward().as_dvec3(), cam.right().as_dvec3(), cam.true_up().as_dvec3());
    let hit_sphere = |o: glam::DVec3, d: glam::DVec3| -> Option<(f64, f64)> {
        let oc = o - centre;
        let b = oc.dot(d);
        let disc = b * b - (oc.length_squared() - r * r);
        (disc > 0.0).then(|| (-b - disc.sqrt(), -b + disc.sqrt()))
    };
    let mut imgs = vec![vec![0.0f64; w * h]; PATH_CLASSES.len()];
    let splat = |imgs: &mut Vec<Vec<f64>>, class: usize, o: glam::DVec3, d: glam::DVec3, pre: f64, flux: f64| {
        // To the floor (y = 0) or the box's side.
        let mut t_end = f64::INFINITY;
        for k in 0..3 {
            if d[k] != 0.0 {
                t_end = t_end.min(((if d[k] > 0.0 { hi[k] } else { lo[k] }) - o[k]) / d[k]);
            }
        }
        if d.y < 0.0 {
            t_end = t_end.min(-o.y / d.y);
        }
        let ds = 0.005;
        let steps = (t_end / ds).ceil() as usize;
        let ds = t_end / steps as f64;
        for s in 0..steps {
            let t = (s as f64 + 0.5) * ds;
            let x = o + d * t;
            let to = cp - x;
            let dist = to.length();
            let dir = to / dist;
            if let Some((a, b)) = hit_sphere(x, dir)
                && b > 0.0
                && a < dist
            {
                continue;
            }
            let v = -dir;
            let z = v.dot(fwd);
            if z <= 1e-9 {
                continue;
            }
            let sx = v.dot(right) / z / tan_x;
            let sy = v.dot(up) / z / tan_y;
            let px = (sx + 1.0) * 0.5 * w as f64;
            let py = (1.0 - sy) * 0.5 * h as f64;
            if !(px >= 0.0 && py >= 0.0 && px < w as f64 && py < h as f64) {
                continue;
            }
            let tr = (-st * (pre + t + dist)).exp();
            let val = ss * flux * ds * tr * 0.25 / std::f64::consts::PI / (dist * dist * pix_area * z * z * z);
            imgs[class][py as usize * w + px as usize] += val;
        }
    };
    // The light's rays onto the ball: cos α uniform in [cos αmax, 1], φ uniform.
    let amax = (r / (lp - centre).length()).asin();
    let (na, nphi) = (rings, 4 * rings);
    let domega = 2.0 * std::f64::consts::PI * (1.0 - amax.cos()) / (na * nphi) as f64;
    for ia in 0..na {
        let ca = 1.0 - (1.0 - amax.cos()) * (ia as f64 + 0.5) / na as f64;
        let sa = (1.0 - ca * ca).sqrt();
        for ip in 0..nphi {
            let phi = (ip as f64 + 0.5) / nphi as f64 * std::f64::consts::TAU;
            let d = glam::DVec3::new(sa * phi.cos(), -ca, sa * phi.sin());
            let Some((t0, _)) = hit_sphere(lp, d) else { continue };
            // Branches: (origin, direction, inside, weight, internal reflections, interactions).
            let mut stack = vec![(lp + d * t0, d, false, i0 * domega, 0u32, 0u32)];
            let pre = t0;
            while let Some((p, d, inside, wgt, refl, depth)) = stack.pop() {
                if depth >= 6 || wgt < 1e-12 {
                    continue;
                }
                let nrm = (p - centre).normalize() * if inside { -1.0 } else { 1.0 };
                let cos_i = -d.dot(nrm);
                let eta = if inside { 1.0 / n } else { n };
                let f = fresnel(cos_i, eta);
                let rd = d + nrm * (2.0 * cos_i);
                // Reflected.
                if inside {
                    let (_, t1) = hit_sphere(p, rd).unwrap_or((0.0, 0.0));
                    stack.push((p + rd * t1, rd, true, wgt * f, refl + 1, depth + 1));
                } else {
                    splat(&mut imgs, 0, p, rd, pre, wgt * f);
                }
                // Transmitted.
                if f < 1.0 {
                    let k = 1.0 / eta;
                    let ct = (1.0 - k * k * (1.0 - cos_i * cos_i)).sqrt();
                    let td = (d * k + nrm * (k * cos_i - ct)).normalize();
                    if inside {
                        let class = match refl {
                            0 => 1,
                            1 => 2,
                            _ => 3,
                        };
                        splat(&mut imgs, class, p, td, pre, wgt * (1.0 - f));
                    } else {
                        let (_, t1) = hit_sphere(p, td).unwrap_or((0.0, 0.0));
                        stack.push((p + td * t1, td, true, wgt * (1.0 - f), refl, depth + 1));
                    }
                }
            }
        }
    }
    imgs
}

fn ball_mask(sc: &Scene) -> caustics_reference::metrics::Mask {
    let cam = &sc.camera;
    let (w, h) = (cam.width, cam.height);
    let mut mask = caustics_reference::metrics::Mask::all(w, h);
    for y in 0..h {
        for x in 0..w {
            let mut hit = false;
            for (dx, dy) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0), (0.5, 0.5)] {
                let d = cam.ray_dir(x as f32 + dx, y as f32 + dy);
                let oc = cam.position - Vec3::new(0.0, 1.5, 0.0);
                let b = oc.dot(d);
                hit |= b * b - (oc.length_squared() - 0.25) > 0.0 && b < 0.0;
            }
            mask.include[(y * w + x) as usize] = !hit;
        }
    }
    mask
}

/// The mean absolute error of `a` against `b` over the mask's pixels, relative to `b`'s mean
/// (first channel).
fn rel_l1(
    a: &caustics::image_io::Image,
    b: &caustics::image_io::Image,
    mask: &caustics_reference::metrics::Mask,
) -> f64 {
    let (mut d, mut t) = (0.0f64, 0.0f64);
    for (i, (p, q)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        if mask.include[i] {
            d += (f64::from(p[0]) - f64::from(q[0])).abs();
            t += f64::from(q[0]);
        }
    }
    d / t
}

fn to_image(px: &[f64], w: u32, h: u32) -> caustics::image_io::Image {
    let mut img = caustics::image_io::Image::new(w, h);
    for y in 0..h {
        for x in 0..w {
            let v = px[(y * w + x) as usize] as f32;
            img.set(x, y, [v, v, v]);
        }
    }
    img
}

/// Diagnostic (run with `--ignored --nocapture`): the volume caustic's error split by path
/// class, by image row and by beam and pixel sampling.
#[test]
#[ignore = "diagnostic: prints the error decomposition"]
fn beam_error_decomposition() {
    use caustics_reference::metrics::{energy, hdr_flip};
    use caustics_reference::reference::{self, ReferenceSettings};
    let Some(ctx) = gpu() else { return };
    let k: u32 = std::env::var("SIZE_K").ok().and_then(|v| v.parse().ok()).unwrap_or(1);
    let (w, h) = (48 * k, 40 * k);
    let sc = ball_in_fog(14.0, w, h);
    let mask = ball_mask(&sc);
    let t = std::time::Instant::now();
    let rings: usize = std::env::var("RINGS").ok().and_then(|v| v.parse().ok()).unwrap_or(100);
    let lines = line_integral_reference(&sc, rings);
    println!("line reference ({rings} rings): {:.1} s", t.elapsed().as_secs_f64());
    let total: Vec<f64> = (0..(w * h) as usize).map(|i| lines.iter().map(|c| c[i]).sum()).collect();
    let line_all = to_image(&total, w, h);
    let el = energy(&line_all, Some(&mask));
    for (c, name) in PATH_CLASSES.iter().enumerate() {
        let e = energy(&to_image(&lines[c], w, h), Some(&mask));
        println!("class {name}: energy {e:.5} ({:.2} % of all)", e / el * 100.0);
    }
    // LINE_CHECK: the line integral against itself at twice the rings (its own convergence).
    if std::env::var_os("LINE_CHECK").is_some() {
        let fine = line_integral_reference(&sc, 2 * rings);
        let fine: Vec<f64> = (0..(w * h) as usize).map(|i| fine.iter().map(|c| c[i]).sum()).collect();
        let fine = to_image(&fine, w, h);
        println!(
            "line integral {rings} rings vs {} rings: HDR-FLIP {:.4}, energy {:+.3} %",
            2 * rings,
            hdr_flip(&line_all, &fine, Some(&mask)).unwrap().mean,
            (el / energy(&fine, Some(&mask)) - 1.0) * 100.0
        );
    }
    let tt = to_image(&lines[1], w, h);
    let r_only: Vec<f64> = (0..(w * h) as usize).map(|i| lines[0][i] + lines[2][i] + lines[3][i]).collect();
    let r_only = to_image(&r_only, w, h);
    if std::env::var_os("NO_REF").is_none() {
        let rs = common::single_scattering_reference(
            std::env::var("REF_PHOTONS").ok().and_then(|v| v.parse().ok()).unwrap_or(1 << 22),
            1,
            5,
        );
        let r = reference::render(&sc, &rs).unwrap();
        let r2 = reference::render(&sc, &ReferenceSettings { seed: 6, ..rs }).unwrap();
        let er = energy(&r.caustic, Some(&mask));
        println!(
            "reference vs line integral: energy {:+.2} %, HDR-FLIP {:.4}; reference seed 5 vs 6: HDR-FLIP {:.4}, energy {:+.2} %",
            (er / el - 1.0) * 100.0,
            hdr_flip(&r.caustic, &line_all, Some(&mask)).unwrap().mean,
            hdr_flip(&r2.caustic, &r.caustic, Some(&mask)).unwrap().mean,
            (energy(&r2.caustic, Some(&mask)) / er - 1.0) * 100.0
        );
        let row = |img: &caustics::image_io::Image, y: u32| -> f64 {
            (0..w).filter(|&x| mask.include[(y * w + x) as usize]).map(|x| f64::from(img.get(x, y)[0])).sum()
        };
        let rows: Vec<String> = (0..h)
            .filter(|&y| row(&line_all, y) > 0.0)
            .map(|y| format!("{y}:{:.2}", row(&r.caustic, y) / row(&line_all, y)))
            .collect();
        println!("  rows (reference / line): {}", rows.join(" "));
        if std::env::var_os("ONLY_REF").is_some() {
            return;
        }
    }
    // PIXEL_SAMPLES=n: only the regular 32² grid with n x n rays per pixel (the pixel
    // footprint's convergence at a small cost).
    let only_px: Option<u32> = std::env::var("PIXEL_SAMPLES").ok().and_then(|v| v.parse().ok());
    let configs: Vec<(&str, BeamSettings)> = if let Some(n) = only_px {
        vec![("regular 32, PIXEL_SAMPLES rays", BeamSettings { pixel_samples: n, ..BeamSettings::regular(32) })]
    } else {
        let rays = |b: BeamSettings, n: u32| BeamSettings { footprint: 0.0, pixel_samples: n, ..b };
        let foot = |b: BeamSettings, k: f32, lines: u32| BeamSettings { footprint: k, footprint_lines: lines, ..b };
        let ad = BeamSettings::default();
        vec![
            ("adaptive 16+3", ad),
            ("adaptive 16+3 foot1 l2", foot(ad, 1.0, 2)),
            ("adaptive 16+4", BeamSettings { levels: 4, ..ad }),
            ("adaptive 16+3 foot4 l4", foot(ad, 4.0, 4)),
            ("adaptive 16+3 rays1", rays(ad, 1)),
            ("adaptive 16+3 rays3", rays(ad, 3)),
            ("regular 64", BeamSettings::regular(64)),
            ("regular 32", BeamSettings::regular(32)),
            ("regular 16", BeamSettings::regular(16)),
            ("regular 128", BeamSettings::regular(128)),
            ("adaptive 16+3 lin0", BeamSettings { linearity_threshold: 0.0, ..ad }),
            ("adaptive 16+3 lin0.05", BeamSettings { linearity_threshold: 0.05, ..ad }),
            ("adaptive 16+3 lin0.2", BeamSettings { linearity_threshold: 0.2, ..ad }),
            ("adaptive 16+3 lin0.3", BeamSettings { linearity_threshold: 0.3, ..ad }),
            ("adaptive 16+2 lin0.1", BeamSettings { levels: 2, ..ad }),
            ("adaptive 16+2 lin0.05", BeamSettings { levels: 2, linearity_threshold: 0.05, ..ad }),
            ("adaptive 24+2", BeamSettings { grid: 24, levels: 2, ..ad }),
            ("adaptive 12+3", BeamSettings { grid: 12, levels: 3, ..ad }),
            ("adaptive 32+2", BeamSettings { grid: 32, levels: 2, ..ad }),
            ("regular 64 rays3", rays(BeamSettings::regular(64), 3)),
            ("regular 32 rays3", rays(BeamSettings::regular(32), 3)),
        ]
    };
    // SWEEP=grid:levels:linearity:energy[:reflection[:cutoff]],...: these configurations instead.
    let sweep: Vec<(String, BeamSettings)> = std::env::var("SWEEP")
        .ok()
        .map(|v| {
            v.split(',')
                .map(|c| {
                    let f: Vec<f32> = c.split(':').map(|x| x.parse().unwrap()).collect();
                    let b = BeamSettings {
                        grid: f[0] as u32,
                        levels: f[1] as u32,
                        linearity_threshold: f[2],
                        energy_threshold: f[3],
                        reflection: f.get(4).is_none_or(|&r| r != 0.0),
                        cutoff: f.get(5).copied().unwrap_or(0.0),
                        ..BeamSettings::default()
                    };
                    (format!("sweep {c}"), b)
                })
                .collect()
        })
        .unwrap_or_default();
    let configs: Vec<(&str, BeamSettings)> =
        if sweep.is_empty() { configs } else { sweep.iter().map(|(n, b)| (n.as_str(), *b)).collect() };
    // BEAM_CONFIGS=a,b: only the configurations whose names contain one of these (=name: is it).
    let configs: Vec<(&str, BeamSettings)> = match std::env::var("BEAM_CONFIGS") {
        Ok(f) => configs
            .into_iter()
            .filter(|(n, _)| f.split(',').any(|p| p.strip_prefix('=').map_or(n.contains(p), |p| *n == p)))
            .collect(),
        Err(_) => configs,
    };
    for (name, b) in configs {
        let t = std::time::Instant::now();
        let on = render(&ctx, &sc, &render_settings(b)).unwrap();
        let ms = t.elapsed().as_secs_f64() * 1e3;
        // NO_SPLIT: all classes only (no second render without the reflected branches).
        if std::env::var_os("NO_SPLIT").is_some() {
            // (without the reflected branches: against the transmitted class)
            let line_all = if b.reflection { line_all.clone() } else { tt.clone() };
            println!(
                "{name}: {} beams {:?} ({} cut, {} fragments), {ms:.0} ms; all vs line all: L1 {:.4} FLIP {:.4} energy {:+.2} %",
                on.beams[0].0.beams,
                on.beams[0].0.kept_per_level,
                on.beams[0].0.cut,
                on.beams[0].0.hull_fragments,
                rel_l1(&on.caustic, &line_all, &mask),
                hdr_flip(&on.caustic, &line_all, Some(&mask)).unwrap().mean,
                (energy(&on.caustic, Some(&mask)) / energy(&line_all, Some(&mask)) - 1.0) * 100.0
            );
            if let Some(dir) = std::env::var_os("BEAM_DUMP") {
                let dir = std::path::PathBuf::from(dir);
                let tag = name.replace(' ', "_");
                caustics_reference::io::ImageIo::write(&on.caustic, &dir.join(format!("all_{tag}.exr")), 1.0).unwrap();
                // Raw little-endian f32 (red channel; the mask as 0 / 1) for scripts.
                let raw = |img: &caustics::image_io::Image| -> Vec<u8> {
                    img.pixels.iter().flat_map(|p| p[0].to_le_bytes()).collect()
                };
                std::fs::write(dir.join(format!("all_{tag}.f32")), raw(&on.caustic)).unwrap();
                std::fs::write(dir.join("all_line.f32"), raw(&line_all)).unwrap();
                let m: Vec<u8> =
                    mask.include.iter().flat_map(|&i| (if i { 1.0f32 } else { 0.0 }).to_le_bytes()).collect();
                std::fs::write(dir.join("mask.f32"), m).unwrap();
                caustics_reference::io::ImageIo::write(&line_all, &dir.join("all_line.exr"), 1.0).unwrap();
            }
            continue;
        }
        let off = render(&ctx, &sc, &render_settings(BeamSettings { reflection: false, ..b })).unwrap();
        let mut refl = off.caustic.clone();
        for (o, (a, t)) in refl.pixels.iter_mut().zip(on.caustic.pixels.iter().zip(&off.caustic.pixels)) {
            *o = [a[0] - t[0], a[1] - t[1], a[2] - t[2]];
        }
        let e = |a: &caustics::image_io::Image, b: &caustics::image_io::Image| {
            (energy(a, Some(&mask)) / energy(b, Some(&mask)) - 1.0) * 100.0
        };
        println!(
            "{name}: {} beams, {ms:.0} ms; all vs line all: FLIP {:.4} energy {:+.2} %; TT beams vs TT: FLIP {:.4} energy {:+.2} %; reflected beams vs R + TRT + rest: energy {:+.2} %",
            on.beams[0].0.beams,
            hdr_flip(&on.caustic, &line_all, Some(&mask)).unwrap().mean,
            e(&on.caustic, &line_all),
            hdr_flip(&off.caustic, &tt, Some(&mask)).unwrap().mean,
            e(&off.caustic, &tt),
            e(&refl, &r_only),
        );
        // Per-row energy of the transmitted light (masked), beams / line integral.
        let row = |img: &caustics::image_io::Image, y: u32| -> f64 {
            (0..w).filter(|&x| mask.include[(y * w + x) as usize]).map(|x| f64::from(img.get(x, y)[0])).sum()
        };
        let rows: Vec<String> = (0..h)
            .filter(|&y| row(&tt, y) > 0.0)
            .map(|y| format!("{y}:{:.2}", row(&off.caustic, y) / row(&tt, y)))
            .collect();
        println!("  TT rows (beams / line): {}", rows.join(" "));
        if let Some(dir) = std::env::var_os("BEAM_DUMP") {
            let dir = std::path::PathBuf::from(dir);
            let tag = name.replace(' ', "_");
            caustics_reference::io::ImageIo::write(&off.caustic, &dir.join(format!("tt_{tag}.exr")), 1.0).unwrap();
            caustics_reference::io::ImageIo::write(&refl, &dir.join(format!("refl_{tag}.exr")), 1.0).unwrap();
            caustics_reference::io::ImageIo::write(&r_only, &dir.join("refl_line.exr"), 1.0).unwrap();
            caustics_reference::io::ImageIo::write(&tt, &dir.join("tt_line.exr"), 1.0).unwrap();
            caustics_reference::io::ImageIo::write(&line_all, &dir.join("all_line.exr"), 1.0).unwrap();
        }
    }
}

/// The linearity criterion (`BeamSettings::linearity_threshold`): without it the adaptive
/// hierarchy kept coarse beams near the ball's rim whose light lands up to a section's width
/// off its true place. Against the noise-free line integral (`ball_in_fog`, 48 x 40, ball
/// masked), the relative mean absolute error per pixel measured on lavapipe: 0.0392 without it
/// (10838 beams), 0.0243 with the default 0.05 (12674 beams), regular 64² 0.0203 (13858).
/// With every branch and the residual (13583 beams), 0.0231; since beams with an oblique base
/// are rebased across their edges from a cosine of 0.95 (`make_beam`, 2026-12-05), 0.0169
/// (0.0346 without the criterion; regular 64²: 0.0164); since the pixels end at their first
/// surface's tangent plane (2026-12-05), 0.0139 (0.0324 without).
/// Bounds: with it below 0.016 (the plane facing the camera, 0.0169, fails it) and below 0.75
/// of the error without it, with no more beams than regular 64² has (13858); the rows where the
/// shaft meets the floor within 1.5 % of the line integral (0.993 … 0.998; with the plane
/// facing the camera row 35 has 0.914).
#[test]
fn the_linearity_criterion_puts_the_rims_light_in_place() {
    let Some(ctx) = gpu() else { return };
    let k: u32 = std::env::var("SIZE_K").ok().and_then(|v| v.parse().ok()).unwrap_or(1);
    let (w, h) = (48 * k, 40 * k);
    let sc = ball_in_fog(14.0, w, h);
    let mask = ball_mask(&sc);
    let lines = line_integral_reference(&sc, 100);
    let line = to_image(&(0..(w * h) as usize).map(|i| lines.iter().map(|c| c[i]).sum()).collect::<Vec<f64>>(), w, h);
    let ad = BeamSettings::default();
    assert!(ad.linearity_threshold > 0.0);
    let on = render(&ctx, &sc, &render_settings(ad)).unwrap();
    let off = render(&ctx, &sc, &render_settings(BeamSettings { linearity_threshold: 0.0, ..ad })).unwrap();
    let (e_on, e_off) = (rel_l1(&on.caustic, &line, &mask), rel_l1(&off.caustic, &line, &mask));
    let (n_on, n_off) = (on.beams[0].0.beams, off.beams[0].0.beams);
    println!(
        "per-pixel error against the line integral: {e_on:.4} ({n_on} beams) with it, {e_off:.4} ({n_off} beams) without"
    );
    assert!(e_on < 0.016 && e_on < 0.75 * e_off, "{e_on} vs {e_off}");
    assert!(n_on > n_off && n_on <= 13858, "{n_on} beams ({n_off} without)");
    // Where the shaft meets the floor (seen 17° from above), each pixel row's light against the
    // line integral's: the pixels end at their floor point's tangent plane.
    let floor_row = project(&sc, Vec3::ZERO).unwrap().1 as u32;
    let row = |img: &caustics::image_io::Image, y: u32| -> f64 {
        (0..w).filter(|&x| mask.include[(y * w + x) as usize]).map(|x| f64::from(img.get(x, y)[0])).sum()
    };
    for y in floor_row.saturating_sub(2 * k)..(floor_row + 2 * k).min(h) {
        let r = row(&on.caustic, y) / row(&line, y);
        println!("row {y} (the floor under the ball at {floor_row}): beams / line integral {r:.4}");
        assert!((r - 1.0).abs() < 0.015, "row {y}: {r}");
    }
}

/// The energy criterion's convergence (the beam's base over its smallest section before its
/// end, capped at 100) sees every focus. A ball lens focuses all its transmitted light onto the
/// axis; a beam whose corners lie at different distances from the axis has two focal lines
/// (its sections change orientation in between), and between them its section can be as large
/// as its base: the ends and the extremum of the section's quadratic alone made its convergence
/// 1 to 3, and at low energy thresholds a ring of 32² beams about the axis (exit points 0.16 to
/// 0.18 m from it) was never split (16² + 3 kept 578 beams at level 1 at a threshold of 0.005,
/// 384 at 0.001). Their relative flux (4.4e-4 of the face's at level 1) times the capped
/// convergence is 0.044: at 0.005 every such beam is split, at levels 0 and 1 none is kept
/// (lavapipe: 16² + 2 keeps 0, 0 and 4732 beams; before, 106, 272 and 1948).
#[test]
fn the_energy_criterion_sees_a_focal_line_inside_a_beam() {
    let Some(ctx) = gpu() else { return };
    let sc = ball_in_fog(14.0, 16, 16);
    let b = BeamSettings {
        grid: 16,
        levels: 2,
        energy_threshold: 0.005,
        linearity_threshold: 0.0,
        reflection: false,
        ..BeamSettings::default()
    };
    let out = render(&ctx, &sc, &render_settings(b)).unwrap();
    let kept = &out.beams[0].0.kept_per_level;
    println!("beams kept per level: {kept:?}");
    assert!(kept[2] > 1000, "{kept:?}");
    assert_eq!(kept[0] + kept[1], 0, "beams kept at levels 0 and 1: {kept:?}");
}

/// The energy cutoff (`BeamSettings::cutoff`, the paper's section 4.3): on the ball in fog
/// (every branch, 24 × 20), against the same render without it, beam by beam (the base and
/// directions identify a beam; a cut changes only its ends): a cut beam ends at one section
/// above its last focus, all three edges shortened, and the light of the part it lost, seen
/// along the beam (σs p flux ∫ dy / (cos A(y)) from the new end to the farthest old one, by
/// quadrature on the CPU), is at most the cutoff; a dropped beam's light along all of it is too.
/// Only beams whose section grows are cut (none of the thin prisms), the image loses light and
/// gains none (every pixel within 0.6 % above its uncut value: the midpoint rule on the shortened
/// pieces of the camera rays, 0.28 % measured), the caustic's energy within 1 % at 10⁻⁴
/// W/(m² sr) (0.11 % measured; the largest lost tail 0.835 of the cutoff), and the hulls shade
/// fewer fragments. With surface caustics from beams no beam landing on an object is cut (its
/// end lights it).
#[test]
fn the_energy_cutoff_drops_only_diverging_tails_below_it() {
    let Some(ctx) = gpu() else { return };
    let sc = ball_in_fog(14.0, 24, 20);
    let cutoff = 1e-4f32;
    let full = render(&ctx, &sc, &render_settings(BeamSettings::default())).unwrap();
    let cut = render(&ctx, &sc, &render_settings(BeamSettings { cutoff, ..BeamSettings::default() })).unwrap();
    let key = |b: &Beam| [b.vertices, b.dirs].map(|vs| vs.map(|v| v.to_array().map(f32::to_bits)));
    let by_key: std::collections::HashMap<_, &Beam> = full.beams[0].1.iter().map(|b| (key(b), b)).collect();
    // (σs of the scene, the isotropic phase function)
    let sigma_p = 0.3 / (4.0 * std::f64::consts::PI);
    let tail = |b: &Beam, from: f64| -> f64 {
        let n = b.normal();
        let cos = b.dirs.iter().map(|d| f64::from(n.dot(*d))).fold(1.0, f64::min);
        let to = (0..3).map(|k| f64::from(b.ends[k] * n.dot(b.dirs[k]))).fold(0.0, f64::max);
        let steps = 4000;
        let dy = (to - from) / steps as f64;
        let integral: f64 =
            (0..steps).map(|i| dy / f64::from(b.area((from + (i as f64 + 0.5) * dy) as f32)).max(1e-30)).sum();
        sigma_p * f64::from(b.flux.max_element()) * integral / cos
    };
    let (mut shortened, mut worst) = (0, 0.0f64);
    let mut kept = std::collections::HashSet::new();
    for b in &cut.beams[0].1 {
        let f = by_key.get(&key(b)).unwrap_or_else(|| panic!("a beam of the cut render is not in the full one"));
        kept.insert(key(b));
        if b.ends == f.ends {
            continue;
        }
        shortened += 1;
        let n = b.normal();
        let h = [0, 1, 2].map(|k| b.ends[k] * n.dot(b.dirs[k]));
        assert!(b.ends.iter().zip(&f.ends).all(|(c, u)| c < u), "not all edges cut: {:?} of {:?}", b.ends, f.ends);
        assert!((h[1] - h[0]).abs() < 1e-4 * h[0] && (h[2] - h[0]).abs() < 1e-4 * h[0], "end heights {h:?}");
        assert!(f.area(h[0]) > f.area(0.0), "a cut beam that does not diverge: {:?}", f);
        let lost = tail(f, f64::from(h[0]));
        worst = worst.max(lost / f64::from(cutoff));
        assert!(lost <= f64::from(cutoff) * 1.001, "a cut tail holds {lost} W/(m² sr), cutoff {cutoff}");
    }
    let dropped: Vec<&&Beam> = by_key.iter().filter(|(k, _)| !kept.contains(*k)).map(|(_, b)| b).collect();
    for b in &dropped {
        let lost = tail(b, 0.0);
        worst = worst.max(lost / f64::from(cutoff));
        assert!(lost <= f64::from(cutoff) * 1.001, "a dropped beam holds {lost} W/(m² sr)");
    }
    let stats = &cut.beams[0].0;
    let (e_full, e_cut) = (sum(&full.caustic), sum(&cut.caustic));
    let brightest = full.caustic.pixels.iter().map(|p| p[0]).fold(0.0f32, f32::max);
    // (a shortened piece of a camera ray inside a beam gets the midpoint rule's points closer
    // together: its quadrature differs from that of the longer piece by up to 0.28 % of a pixel)
    let over = full
        .caustic
        .pixels
        .iter()
        .zip(&cut.caustic.pixels)
        .map(|(u, c)| (c[0] - u[0]) / (u[0] + 1e-6 * brightest))
        .fold(0.0f32, f32::max);
    println!(
        "cutoff {cutoff}: {shortened} beams shortened, {} dropped ({} counted), the largest lost tail {worst:.3} of the cutoff; caustic energy {:.5}; fragments {} -> {}",
        dropped.len(),
        stats.cut,
        e_cut / e_full,
        full.beams[0].0.hull_fragments,
        stats.hull_fragments
    );
    assert_eq!(stats.cut as usize, shortened + dropped.len());
    assert!(shortened > 100, "{shortened} beams cut");
    assert!(over <= 0.006, "a pixel gained {over} of its light");
    assert!(e_cut < e_full && e_cut > 0.99 * e_full, "caustic energy {e_cut} against {e_full}");
    assert!(stats.hull_fragments < full.beams[0].0.hull_fragments);
    // Surface caustics from beams: a beam landing on an object keeps its end.
    let s = |c: f32| RenderSettings {
        sources: caustics::settings::SourceSettings {
            local: caustics::settings::LocalSource::Beams,
            ..Default::default()
        },
        ..render_settings(BeamSettings { cutoff: c, ..BeamSettings::default() })
    };
    let (sf, sc_cut) = (render(&ctx, &sc, &s(0.0)).unwrap(), render(&ctx, &sc, &s(cutoff)).unwrap());
    let landing: std::collections::HashMap<_, &Beam> =
        sf.beams[0].1.iter().filter(|b| b.land != u32::MAX && b.layer == 0).map(|b| (key(b), b)).collect();
    let mut landed_kept = 0;
    for b in sc_cut.beams[0].1.iter().filter(|b| b.land != u32::MAX && b.layer == 0) {
        assert_eq!(Some(&b.ends), landing.get(&key(b)).map(|f| &f.ends), "a beam lighting the floor was cut");
        landed_kept += 1;
    }
    assert_eq!(landed_kept, landing.len());
    assert!(sc_cut.beams[0].0.cut > 0, "no beam leaving the scene was cut");
}

/// A glass ball (R 0.5, IOR 1.5, centre 1.5 m up) lit at 45° by a uniform spot 4.24 m away, no
/// medium; the ball focuses the light onto the floor (albedo 0.5) around (1.5, 0, 0). The
/// camera looks straight down at that part of the floor from 4 m (40°: the ball is out of view,
/// so the caustic-only image is the floor's caustic and nothing else). With `table`, a small
/// diffuse square (object 2) at 0.3 m over the floor catches part of the caustic.
fn ball_at_45(w: u32, h: u32, table: bool) -> Scene {
    let table = if table {
        r#", { "type": "rectangle", "center": [1.5, 0.3, 0], "normal": [0, 1, 0], "size": [0.5, 0.5], "material": "floor" }"#
    } else {
        ""
    };
    scene(&format!(
        r#"{{ "schema_version": 1, "name": "ball_45",
  "camera": {{ "position": [1.8, 4, 0], "look_at": [1.8, 0, 0], "up": [0, 0, -1], "fov_y_deg": 40, "width": {w}, "height": {h} }},
  "lights": [ {{ "type": "spot", "position": [-3, 4.5, 0], "direction": [1, -1, 0], "cone_angle_deg": 10, "falloff_start_deg": 10, "intensity": [20, 20, 20] }} ],
  "materials": {{ "floor": {{ "type": "diffuse", "albedo": 0.5 }}, "glass": {{ "type": "dielectric", "ior": 1.5 }} }},
  "objects": [ {{ "type": "sphere", "center": [0, 1.5, 0], "radius": 0.5, "material": "glass" }},
               {{ "type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [12, 12], "material": "floor" }}{table} ] }}"#
    ))
}

fn surface_settings(sc: caustics::settings::LocalSource) -> RenderSettings {
    RenderSettings {
        photons: caustics::settings::PhotonSettings {
            count: 256,
            caustic_map_size: 256,
            ..render_settings(BeamSettings::default()).photons
        },
        sources: caustics::settings::SourceSettings { local: sc, ..Default::default() },
        ..render_settings(BeamSettings::default())
    }
}

/// Where world point p projects in the camera's image (pixels), if in front of it.
fn project(sc: &Scene, p: Vec3) -> Option<(f32, f32)> {
    let cam = &sc.camera;
    let q = p - cam.position;
    let z = q.dot(cam.forward());
    if z <= 0.0 {
        return None;
    }
    let t = (cam.fov_y_deg.to_radians() * 0.5).tan();
    let sx = q.dot(cam.right()) / z / (t * cam.aspect());
    let sy = q.dot(cam.true_up()) / z / t;
    Some(((sx + 1.0) * 0.5 * cam.width as f32, (1.0 - sy) * 0.5 * cam.height as f32))
}

/// The floor area (y = 0) pixel (x, y) sees: its corner rays' quad (shoelace in x, z).
fn floor_footprint(sc: &Scene, x: u32, y: u32) -> f64 {
    let cam = &sc.camera;
    let corner = |dx: f32, dy: f32| {
        let d = cam.ray_dir(x as f32 + dx, y as f32 + dy);
        let p = cam.position + d * (-cam.position.y / d.y);
        glam::DVec2::new(f64::from(p.x), f64::from(p.z))
    };
    let q = [corner(0.0, 0.0), corner(1.0, 0.0), corner(1.0, 1.0), corner(0.0, 1.0)];
    0.5 * (0..4).map(|i| q[i].perp_dot(q[(i + 1) % 4])).sum::<f64>().abs()
}

#[test]
fn surface_caustic_from_beams_carries_the_beams_flux_onto_the_floor() {
    use caustics::settings::LocalSource;
    let Some(ctx) = gpu() else { return };
    let sc = ball_at_45(48, 48, false);
    let out = render(&ctx, &sc, &surface_settings(LocalSource::Beams)).unwrap();
    let (stats, list) = &out.beams[0];
    println!("{stats:?}");
    assert!(stats.beams > 100 && stats.overflow == 0);
    // The irradiance the image shows (L = albedo / π E on the floor), over the floor area each
    // pixel sees.
    let cam = &sc.camera;
    let mut shown = 0.0f64;
    for y in 0..cam.height {
        for x in 0..cam.width {
            let l = f64::from(out.caustic.get(x, y)[0]);
            shown += l * std::f64::consts::PI / 0.5 * floor_footprint(&sc, x, y);
        }
    }
    // The flux of the beams that land on the floor (object 1) inside the camera's view: the
    // beams whose three edge ends it sees, and of those it sees in part, the fraction of their
    // end triangle (on the floor, where their light lands) that projects into the image
    // (32 x 32 points spread evenly over the triangle).
    let in_view = |p: Vec3| {
        project(&sc, p).is_some_and(|(px, py)| px > 0.0 && py > 0.0 && px < cam.width as f32 && py < cam.height as f32)
    };
    let (mut inside, mut partial, mut floor) = (0.0f64, 0.0f64, 0.0f64);
    for b in list.iter().filter(|b| b.land == 1) {
        floor += f64::from(b.flux.x);
        let ends: [Vec3; 3] = std::array::from_fn(|i| b.vertices[i] + b.dirs[i] * b.ends[i]);
        let seen = ends.iter().filter(|&&e| in_view(e)).count();
        if seen == 3 {
            inside += f64::from(b.flux.x);
        } else if seen > 0 {
            let n = 32;
            let (mut hit, mut all) = (0, 0);
            for i in 0..n {
                for j in 0..n - i {
                    let (u, v) = ((i as f32 + 1.0 / 3.0) / n as f32, (j as f32 + 1.0 / 3.0) / n as f32);
                    let p = ends[0] + (ends[1] - ends[0]) * u + (ends[2] - ends[0]) * v;
                    all += 1;
                    hit += usize::from(in_view(p));
                }
            }
            partial += f64::from(b.flux.x) * hit as f64 / all as f64;
        }
    }
    let want = inside + partial;
    println!(
        "beams onto the floor {floor:.5} W, in view {want:.5} W ({inside:.5} W of beams seen whole); the image shows {shown:.5} W ({:+.2} %)",
        (shown / want - 1.0) * 100.0
    );
    // Most of the caustic lies in view (the test would say little otherwise).
    assert!(inside > 0.6 * floor, "{inside} {partial} {floor}");
    // Flux conservation: Φ / A(y) · cos_r / cos_b over a beam's footprint is its flux where the
    // beam is thin (its edges nearly parallel over the footprint); the 4 × 4 points per pixel
    // sample the beams' edges. Bound: 2 %.
    assert!((shown / want - 1.0).abs() < 0.02, "{shown} vs {want}");
    // Counted twice, it would be off by 100 %: the bound catches that.
    assert!((2.0 * shown / want - 1.0).abs() > 0.02);
}

#[test]
fn surface_caustic_from_beams_matches_the_photon_map_and_replaces_it() {
    use caustics::settings::LocalSource;
    let Some(ctx) = gpu() else { return };
    let sc = ball_at_45(48, 48, false);
    let photons = render(&ctx, &sc, &surface_settings(LocalSource::Photons)).unwrap();
    let from_beams = render(&ctx, &sc, &surface_settings(LocalSource::Beams)).unwrap();
    // No double counting: with beams the light's photon stage traces nothing (its map is not
    // added), and the direct light is the same bits.
    println!("photons traced: {} (photons), {} (beams)", photons.photons_traced, from_beams.photons_traced);
    assert!(photons.photons_traced > 0);
    assert_eq!(from_beams.photons_traced, 0);
    let direct = |o: &caustics::render::GpuRender| -> Vec<f32> {
        o.image.pixels.iter().zip(&o.caustic.pixels).map(|(a, c)| a[0] - c[0]).collect()
    };
    let (dp, db) = (direct(&photons), direct(&from_beams));
    let worst_direct = dp.iter().zip(&db).map(|(a, b)| (a - b).abs() / a.abs().max(1e-3)).fold(0.0f32, f32::max);
    println!("direct light (image - caustic): worst relative difference {worst_direct:.2e}");
    assert!(worst_direct < 1e-4);
    // The caustic region: pixels where either is above 2 % of the photon map's peak.
    let (p, b) = (&photons.caustic.pixels, &from_beams.caustic.pixels);
    let peak = p.iter().map(|v| v[0]).fold(0.0f32, f32::max);
    let region: Vec<usize> = (0..p.len()).filter(|&i| p[i][0].max(b[i][0]) > 0.02 * peak).collect();
    let sp: f64 = region.iter().map(|&i| f64::from(p[i][0])).sum();
    let sb: f64 = region.iter().map(|&i| f64::from(b[i][0])).sum();
    let l1: f64 = region.iter().map(|&i| f64::from((p[i][0] - b[i][0]).abs())).sum::<f64>() / sp;
    // The bright core (above 20 % of the peak) apart: there both are smooth.
    let core: Vec<usize> = region.iter().copied().filter(|&i| p[i][0] > 0.2 * peak).collect();
    let cp: f64 = core.iter().map(|&i| f64::from(p[i][0])).sum();
    let l1_core: f64 = core.iter().map(|&i| f64::from((p[i][0] - b[i][0]).abs())).sum::<f64>() / cp;
    println!(
        "caustic region {} pixels: beams / photons {:.4}, relative L1 difference {l1:.4}; core {} pixels: L1 {l1_core:.4}",
        region.len(),
        sb / sp,
        core.len()
    );
    assert!(region.len() > 50 && core.len() > 10);
    // Bounds: the two estimate the same light (the photon map also has the paths beams do not
    // follow, reflected inside more than once: under 1 % here); sums within 3 % (measured
    // -2.8 % with the spot's spill face, which gives the photon map the light past the spot's
    // view; +0.8 % without it: surface_caustic_energy_against_the_cpu_reference has both
    // against the CPU reference). Per pixel (relative L1, measured 0.19 over the region): the beams' affine model
    // turns the ball's rim light, spread far over the floor, into long thin beams (radial
    // streaks, docs/beams.md "Surface caustics from beams"), so the bound over the
    // region is 0.25, and over the core, where the mapping is smooth, tighter (0.15).
    assert!((sb / sp - 1.0).abs() < 0.03, "sums {sb} {sp}");
    assert!(l1 < 0.25, "L1 {l1}");
    assert!(l1_core < 0.15, "core L1 {l1_core}");
    // Both at once would double the caustic: 100 % off, far outside the bound.
    assert!(((sb + sp) / sp - 1.0).abs() > 0.5);
}

#[test]
fn surface_caustic_from_beams_stops_at_the_receiver_the_beams_land_on() {
    use caustics::settings::LocalSource;
    let Some(ctx) = gpu() else { return };
    // A small table under the caustic: the beams that land on it light it, not the floor
    // under it (the floor there is in the table's shadow), and the same holds for photons.
    let sc = ball_at_45(48, 48, true);
    let out = render(&ctx, &sc, &surface_settings(LocalSource::Beams)).unwrap();
    let photons = render(&ctx, &sc, &surface_settings(LocalSource::Photons)).unwrap();
    let on_table = out.beams[0].1.iter().filter(|b| b.land == 2).count();
    println!("beams landing on the table: {on_table}");
    assert!(on_table > 10);
    // The floor in the table's shadow that the camera sees (the table hides x 1.21 to 1.75):
    // from the ball's focus near (0.64, 0.86, 0) through the table's edges, the shadow spans
    // x 1.58 to 2.34 on the floor; sample x 1.95 to 2.2, |z| < 0.12, which the caustic lights
    // without the table.
    let bare = render(&ctx, &ball_at_45(48, 48, false), &surface_settings(LocalSource::Beams)).unwrap();
    let cam = &sc.camera;
    let (mut shadowed, mut lit_table) = (Vec::new(), 0.0f32);
    for y in 0..cam.height {
        for x in 0..cam.width {
            let d = cam.ray_dir(x as f32 + 0.5, y as f32 + 0.5);
            let pt = cam.position + d * ((0.3 - cam.position.y) / d.y);
            let pf = cam.position + d * (-cam.position.y / d.y);
            if (pt.x - 1.5).abs() < 0.25 && pt.z.abs() < 0.25 {
                lit_table = lit_table.max(out.caustic.get(x, y)[0]);
            } else if (pf.x - 2.075).abs() < 0.125 && pf.z.abs() < 0.12 {
                shadowed.push((out.caustic.get(x, y)[0], photons.caustic.get(x, y)[0], bare.caustic.get(x, y)[0]));
            }
        }
    }
    let worst_beams = shadowed.iter().map(|v| v.0).fold(0.0f32, f32::max);
    let worst_photons = shadowed.iter().map(|v| v.1).fold(0.0f32, f32::max);
    let least_bare = shadowed.iter().map(|v| v.2).fold(f32::MAX, f32::min);
    println!(
        "table's brightest caustic pixel {lit_table:.4}; {} floor pixels in its shadow: brightest {worst_beams:.2e} (beams), {worst_photons:.2e} (photons); without the table at least {least_bare:.2e}",
        shadowed.len()
    );
    assert!(lit_table > 0.0 && shadowed.len() >= 4);
    // The region is lit without the table (else the test would show nothing), dark with it.
    assert!(least_bare > 0.05 * lit_table, "{least_bare} vs {lit_table}");
    assert!(worst_beams < 1e-3 * lit_table, "{worst_beams} vs {lit_table}");
}

#[test]
fn surface_caustic_from_beams_is_deterministic_and_creates_nothing_after_the_first_frame() {
    use caustics::renderer::Renderer;
    use caustics::settings::LocalSource;
    let Some(ctx) = gpu() else { return };
    // In fog: the surface caustic and the volume caustic from the same beams.
    let sc = ball_in_fog(14.0, 16, 12);
    let s = RenderSettings {
        sources: caustics::settings::SourceSettings { local: LocalSource::Beams, ..Default::default() },
        ..render_settings(BeamSettings::default())
    };
    let a = render(&ctx, &sc, &s).unwrap();
    let b = render(&ctx, &sc, &s).unwrap();
    assert!(a.caustic.pixels.iter().any(|p| p[0] > 0.0));
    assert_eq!(a.image.pixels, b.image.pixels);
    assert_eq!(a.caustic.pixels, b.caustic.pixels);
    // The floor's surface caustic is there (the black floor of ball_in_fog has albedo 0: a
    // white one here).
    let mut white = sc.clone();
    for m in white.materials.iter_mut() {
        if let caustics::scene::Material::Diffuse { albedo } = m {
            *albedo = Vec3::splat(0.5);
        }
    }
    let with_floor = render(&ctx, &white, &s).unwrap();
    let without = render(
        &ctx,
        &white,
        &RenderSettings {
            sources: caustics::settings::SourceSettings { volume: caustics::settings::VolumeSource::None, ..s.sources },
            ..s.clone()
        },
    )
    .unwrap();
    let (sw, so) = (sum(&with_floor.caustic), sum(&without.caustic));
    println!("caustic image sum: surface + volume {sw:.4}, surface only (--no-beams) {so:.4}");
    assert!(so > 0.0 && sw > so);
    let mut r = Renderer::with_context(ctx.clone(), sc.clone(), s.clone()).unwrap();
    let frame = common::created_by_a_frame;
    assert!(frame(&mut r) > 0);
    assert_eq!(frame(&mut r), 0);
}

/// The issue's "three beam budgets" (run with `--ignored --nocapture`; BUDGET_IMAGE=PATH writes
/// the images side by side, BUDGET_REPS=n renders each n times for the timings): adaptive
/// 16² + 2, 3, 4 levels against regular 32², 64², 128² on `ball_in_fog` (48 × 40, the ball
/// masked), error against the line integral and against the CPU reference (2^25 photons,
/// single scattering), host ms per render in one run.
#[test]
#[ignore = "measurement: the three beam budgets (docs/benchmarks.md)"]
fn beam_budgets() {
    use caustics_reference::metrics::{energy, hdr_flip};
    use caustics_reference::reference;
    let Some(ctx) = gpu() else { return };
    let k: u32 = std::env::var("SIZE_K").ok().and_then(|v| v.parse().ok()).unwrap_or(1);
    let (w, h) = (48 * k, 40 * k);
    let sc = ball_in_fog(14.0, w, h);
    let mask = ball_mask(&sc);
    let lines = line_integral_reference(&sc, 100);
    let total: Vec<f64> = (0..(w * h) as usize).map(|i| lines.iter().map(|c| c[i]).sum()).collect();
    let line = to_image(&total, w, h);
    let photons = std::env::var("REF_PHOTONS").ok().and_then(|v| v.parse().ok()).unwrap_or(1 << 25);
    let rs = common::single_scattering_reference(photons, 1, 5);
    let r = reference::render(&sc, &rs).unwrap();
    let (el, er) = (energy(&line, Some(&mask)), energy(&r.caustic, Some(&mask)));
    println!(
        "reference ({photons} photons) vs line integral: HDR-FLIP {:.4}, energy {:+.2} %",
        hdr_flip(&r.caustic, &line, Some(&mask)).unwrap().mean,
        (er / el - 1.0) * 100.0
    );
    let reps: usize = std::env::var("BUDGET_REPS").ok().and_then(|v| v.parse().ok()).unwrap_or(1);
    let ad = BeamSettings::default();
    let configs = [
        ("adaptive 16+2", BeamSettings { levels: 2, ..ad }),
        ("adaptive 16+3", ad),
        ("adaptive 16+4", BeamSettings { levels: 4, ..ad }),
        ("regular 32", BeamSettings::regular(32)),
        ("regular 64", BeamSettings::regular(64)),
        ("regular 128", BeamSettings::regular(128)),
        // (base grids of 24 and 12: docs/benchmarks.md, "Beams: the speed target")
        ("adaptive 24+1", BeamSettings { grid: 24, levels: 1, ..ad }),
        ("adaptive 24+2", BeamSettings { grid: 24, levels: 2, ..ad }),
        ("adaptive 12+3", BeamSettings { grid: 12, levels: 3, ..ad }),
    ];
    // BUDGET_CONFIGS=a,b: only the configurations whose names contain one of these (no image).
    let only = std::env::var("BUDGET_CONFIGS").ok();
    let configs: Vec<(&str, BeamSettings)> = configs
        .into_iter()
        .filter(|(n, _)| only.as_ref().is_none_or(|f| f.split(',').any(|p| n.contains(p))))
        .collect();
    let mut images = Vec::new();
    println!(
        "| grid | beams | HDR-FLIP vs line | energy vs line | HDR-FLIP vs reference | energy vs reference | ms (each run) | GPU ms refine / volume (last run) |"
    );
    println!("| --- | ---: | ---: | ---: | ---: | ---: | --- | --- |");
    for (name, b) in configs {
        let mut ms = Vec::new();
        let mut out = None;
        for _ in 0..reps {
            let t = std::time::Instant::now();
            let g = render(&ctx, &sc, &render_settings(b)).unwrap();
            ms.push(format!("{:.0}", t.elapsed().as_secs_f64() * 1e3));
            out = Some(g);
        }
        let g = out.unwrap();
        let eg = energy(&g.caustic, Some(&mask));
        // GPU ms of the beam passes (timestamp queries, all dispatches; "-" without them).
        // (the volume caustic: the gather, or the hulls' three passes)
        let pass = |ps: &[&str]| {
            let v: Vec<f64> = g.timings.iter().filter(|(n, _)| ps.contains(&n.as_str())).map(|(_, ms)| *ms).collect();
            if v.is_empty() { "-".to_string() } else { format!("{:.0}", v.iter().sum::<f64>()) }
        };
        println!(
            "| {name} | {} | {:.3} | {:+.1} % | {:.3} | {:+.1} % | {} | {} / {} |",
            g.beams[0].0.beams,
            hdr_flip(&g.caustic, &line, Some(&mask)).unwrap().mean,
            (eg / el - 1.0) * 100.0,
            hdr_flip(&g.caustic, &r.caustic, Some(&mask)).unwrap().mean,
            (eg / er - 1.0) * 100.0,
            ms.join(", "),
            pass(&["beam_refine"]),
            pass(&["beam_gather", "beam_hull", "beam_raster", "beam_resolve"])
        );
        images.push(g.caustic);
    }
    if let Some(path) = std::env::var_os("BUDGET_IMAGE").filter(|_| images.len() >= 6) {
        // Top row: line integral, adaptive 16+2, 16+3, 16+4; bottom row: reference, regular
        // 32², 64², 128²; one exposure (the line integral's 98th percentile to white), the
        // ball's pixels dark.
        let mut v: Vec<f32> = line.pixels.iter().map(|p| p[0]).collect();
        v.sort_by(f32::total_cmp);
        let scale = 1.0 / v[v.len() * 98 / 100].max(1e-12);
        let tiles = [&line, &images[0], &images[1], &images[2], &r.caustic, &images[3], &images[4], &images[5]];
        let mut out = caustics::image_io::Image::new(4 * w + 3, 2 * h + 1);
        for (k, t) in tiles.iter().enumerate() {
            let (ox, oy) = ((k as u32 % 4) * (w + 1), (k as u32 / 4) * (h + 1));
            for y in 0..h {
                for x in 0..w {
                    let c = if mask.include[(y * w + x) as usize] { t.get(x, y)[0] * scale } else { 0.0 };
                    out.set(ox + x, oy + y, [c, c, c]);
                }
            }
        }
        for y in 0..out.height {
            for x in 0..out.width {
                if x % (w + 1) == w || y % (h + 1) == h {
                    out.set(x, y, [1.0, 1.0, 1.0]);
                }
            }
        }
        caustics_reference::io::write_display_png(&out, std::path::Path::new(&path)).unwrap();
    }
}

/// The surface caustic's energy on the floor against the CPU reference (first-diffuse caustic
/// paths, 4 M photons), for the photon map with and without the spot's spill face and for the
/// beams. Measured on lavapipe (16 M reference photons): photons with the spill face 0.991 of
/// the reference, without it 0.951 (light refracted and reflected past the spot's view), beams
/// 0.963 (they land anywhere, but lack 3.7 %: not located yet; the flux test finds about 1.5 %
/// of it in the silhouettes and the untraced internal reflections). Bounds: the photon map
/// within 2 % with the spill face and short by more than 2 % without it; the beams within 5 %
/// (issue 14's energy bound for the volume caustic).
#[test]
fn surface_caustic_energy_against_the_cpu_reference() {
    use caustics::settings::LocalSource;
    let Some(ctx) = gpu() else { return };
    let sc = ball_at_45(48, 48, false);
    let rs = caustics_reference::reference::ReferenceSettings {
        photons_per_light: 4_000_000,
        camera_spp: 1,
        caustic_map_size: 8,
        caustic_paths: caustics_reference::reference::CausticPaths::FirstDiffuse,
        ..Default::default()
    };
    let cpu = caustics_reference::reference::render(&sc, &rs).unwrap();
    let total = |img: &caustics::image_io::Image| -> f64 { img.pixels.iter().map(|p| f64::from(p[0])).sum() };
    let reference = total(&cpu.caustic);
    assert!(reference > 0.0);
    let ratio = |s: RenderSettings| total(&render(&ctx, &sc, &s).unwrap().caustic) / reference;
    let spill = ratio(surface_settings(LocalSource::Photons));
    let no_spill = ratio(RenderSettings {
        shading: caustics::settings::ShadingSettings {
            spill_faces: caustics::render::SpillFaces::Off,
            ..surface_settings(LocalSource::Photons).shading
        },
        ..surface_settings(LocalSource::Photons)
    });
    let beams = ratio(surface_settings(LocalSource::Beams));
    println!(
        "caustic energy / CPU reference: photons {spill:.4}, without the spill face {no_spill:.4}, beams {beams:.4}"
    );
    assert!((spill - 1.0).abs() < 0.02, "photon map with the spill face: {spill}");
    assert!(no_spill < 0.98, "without the spill face the light past the spot's view is lost: {no_spill}");
    assert!((beams - 1.0).abs() < 0.05, "beams: {beams}");
}

/// The ball in fog with the medium's density grid `g` over its box.
fn with_grid(mut sc: Scene, g: caustics::scene::DensityGrid) -> Scene {
    sc.medium.as_mut().unwrap().density = Some(std::sync::Arc::new(g));
    sc
}

/// Sum of the red channel and the relative L1 difference of `a` against `b` over the pixels
/// where `b` exceeds 2 % of its peak.
fn l1_over_region(a: &caustics::image_io::Image, b: &caustics::image_io::Image) -> (f64, f64, f64) {
    let peak = b.pixels.iter().map(|p| p[0]).fold(0.0f32, f32::max);
    let r: Vec<usize> = (0..b.pixels.len()).filter(|&i| b.pixels[i][0] > 0.02 * peak).collect();
    let sb: f64 = r.iter().map(|&i| f64::from(b.pixels[i][0])).sum();
    let l1: f64 = r.iter().map(|&i| f64::from((a.pixels[i][0] - b.pixels[i][0]).abs())).sum::<f64>() / sb;
    let sum = |im: &caustics::image_io::Image| im.pixels.iter().map(|p| f64::from(p[0])).sum::<f64>();
    (sum(a), sum(b), l1)
}

/// Heterogeneous media in the beams (issue 14 item 5): with a density grid, the beams scatter
/// with the density times sigma_s and attenuate by the grid's optical depths (toward the base,
/// up to it through the light's path, and toward the camera). Two closed cases:
/// - a constant grid of density 0.5 is the homogeneous medium of half the coefficients;
/// - a grid that is 1 above the ball lens' focus and 0 below it is the homogeneous medium in
///   the box cut at the focus (up to the grid's trilinear ramp over one voxel, 0.05 m).
///
/// And the grid is not ignored: the cut grid removes the cone below the focus.
#[test]
fn beams_in_a_density_grid_match_the_equivalent_homogeneous_media() {
    use caustics::scene::DensityGrid;
    let Some(ctx) = gpu() else { return };
    // Two levels (some 5000 beams): the grid's march makes every beam cost a pixel some 32
    // lookups, and lavapipe is slow.
    let s = render_settings(BeamSettings { levels: 2, ..Default::default() });
    let caustic = |sc: &Scene| render(&ctx, sc, &s).unwrap().caustic;
    let base = ball_in_fog(14.0, 48, 40);
    // Constant density 0.5 against half the coefficients.
    let half_grid = caustic(&with_grid(base.clone(), DensityGrid::new([2, 2, 2], vec![0.5; 8]).unwrap()));
    let mut half = base.clone();
    {
        let m = half.medium.as_mut().unwrap();
        m.sigma_s *= 0.5;
        m.sigma_a *= 0.5;
    }
    let half_h = caustic(&half);
    let (a, b, l1) = l1_over_region(&half_grid, &half_h);
    println!("constant grid 0.5: volume caustic {a:.5e} vs homogeneous half {b:.5e}, relative L1 {l1:.2e}");
    assert!(b > 0.0);
    assert!((a / b - 1.0).abs() < 1e-3 && l1 < 1e-3, "constant grid: {a} vs {b}, L1 {l1}");
    // The cut: the focus of the ball lens (R 0.5, n 1.5, centre y 1.5) at y = 0.75; the box
    // spans y -0.1 .. 4.5 in 92 voxels of 0.05 m.
    let (y0, y1, n) = (-0.1f32, 4.5f32, 92u32);
    let cut = 0.75f32;
    let data: Vec<f32> = (0..n)
        .map(|j| {
            let y = y0 + (j as f32 + 0.5) / n as f32 * (y1 - y0);
            if y > cut { 1.0 } else { 0.0 }
        })
        .collect();
    let cut_grid = caustic(&with_grid(base.clone(), DensityGrid::new([1, n, 1], data).unwrap()));
    let mut cut_box = base.clone();
    cut_box.medium.as_mut().unwrap().bounds_min.y = cut;
    let cut_h = caustic(&cut_box);
    let full = caustic(&base);
    let (a, b, l1) = l1_over_region(&cut_grid, &cut_h);
    let (_, f, _) = l1_over_region(&full, &full);
    println!("grid cut at the focus: {a:.5e} vs the box cut there {b:.5e} (uncut {f:.5e}), relative L1 {l1:.3}");
    assert!((a / b - 1.0).abs() < 0.03, "cut grid {a} vs cut box {b}");
    assert!(l1 < 0.1, "cut grid vs cut box: relative L1 {l1}");
    assert!(a < 0.8 * f, "the grid must remove the cone below the focus: {a} vs uncut {f}");
}

/// The flux (W, first channel) of a scene's first light that leaves its specular objects on the
/// transmitted branch (every dielectric interface transmitting with weight 1 − F, total internal
/// reflection followed, as `beam_refine`'s branch 0) and reaches a diffuse surface or leaves the
/// scene: what the transmitted beams of the paths' last segments carry in all, and of it what
/// lands on object `land`. Traced on the CPU (`caustics_reference::reference::branch`) over n²
/// stratified directions of the light's cone.
fn transmitted_flux(sc: &Scene, n: u32, max_depth: u32, land: u32) -> (f64, f64) {
    use caustics_reference::reference::branch::{Fate, trace};
    let [all, on] = over_spot(sc, n, |accel, o, d, w, acc: &mut [f64; 2]| {
        let p = trace(sc, accel, o, d, max_depth);
        if p.fate == Fate::Caustic {
            acc[0] += w * f64::from(p.weight);
            if p.land == land {
                acc[1] += w * f64::from(p.weight);
            }
        }
    });
    (all, on)
}

/// The flux (W, first channel) the transmitted branch of `sc`'s first light carries across the
/// medium from one specular object to the next on the segment before its last (what its layer-1
/// beams carry: the last segment outside dielectrics before the final one, from a specular
/// interaction on), over `n`² stratified directions of the light's cone.
fn layer1_flux(sc: &Scene, n: u32, max_depth: u32) -> f64 {
    use caustics_reference::reference::branch::{Fate, trace_segments};
    let [flux] = over_spot(sc, n, |accel, o, d, w, acc: &mut [f64; 1]| {
        let mut segs = Vec::new();
        let p = trace_segments(sc, accel, o, d, max_depth, &mut segs);
        if p.fate != Fate::Caustic {
            return;
        }
        let outside: Vec<usize> = (1..segs.len()).filter(|&k| !segs[k].inside).collect();
        if let [.., k, _] = outside[..] {
            acc[0] += w * f64::from(segs[k].weight);
        }
    });
    flux
}

/// Sums over `n`² stratified directions of the cone of `sc`'s first light: `ray` gets the
/// scene's BVH, each direction's origin and unit direction, its share of the light's flux (W,
/// first channel) and the accumulators.
fn over_spot<const K: usize>(
    sc: &Scene,
    n: u32,
    ray: impl Fn(&caustics_reference::reference::geometry::Accel, Vec3, Vec3, f64, &mut [f64; K]) + Sync,
) -> [f64; K] {
    use caustics_reference::reference::emit::Emitter;
    use caustics_reference::reference::geometry::Accel;
    use rayon::prelude::*;
    let accel = Accel::new(sc);
    let em = Emitter::full(&sc.lights[0], Vec3::ZERO, 10.0);
    (0..n)
        .into_par_iter()
        .map(|j| {
            let mut acc = [0.0f64; K];
            for i in 0..n {
                let u = glam::Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                let Some(e) = em.sample(u) else { continue };
                ray(&accel, e.origin, e.dir, f64::from(e.flux_n.x) / f64::from(n * n), &mut acc);
            }
            acc
        })
        .reduce(|| [0.0; K], |a, b| std::array::from_fn(|k| a[k] + b[k]))
}

/// A mesh caster (`scenes/glass_dragon_fog.json`: the glass dragon, 100k triangles, in fog) at
/// 8 × 8 pixels: every last-level triangle whose corners take different paths gets its parts'
/// beams, and the transmitted beams carry the transmitted light. Each part is its own group of
/// `beam_shrink` threads; when `beam_refine` found them all in one thread per triangle, that
/// thread traced more edges through the dragon's BVH than lavapipe runs a shader's loops for
/// (some 65536 iterations in all; past them its loops end early), and 1517 of the 6148
/// last-level triangles lost their light. Half the dragon's light takes other paths within a
/// last-level triangle than its corners: a part weighted by its own area carried 0.57 of the
/// transmitted light; corrected by the triangle's samples (`beam_shrink`'s `part_flux`), 0.99
/// (docs/benchmarks.md, "Beams on a mesh caster: the deficit found").
#[test]
fn a_mesh_casters_silhouette_triangles_all_get_their_parts() {
    let Some(ctx) = gpu() else { return };
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/glass_dragon_fog.json");
    let mut sc = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    (sc.camera.width, sc.camera.height) = (8, 8);
    let out = render(&ctx, &sc, &render_settings(BeamSettings::default())).unwrap();
    let (stats, list) = &out.beams[0];
    println!("{stats:?}");
    let last = *stats.visited_per_level.last().unwrap();
    assert!(last > 4000, "last-level triangles {last}: the dragon's silhouette should fill the last level");
    assert!(
        (stats.inconsistent as f64) < 0.005 * last as f64,
        "{} of {last} last-level triangles lost their light",
        stats.inconsistent
    );
    // Parts of the same triangle exist (the dragon's corners take different paths everywhere).
    assert!(list.iter().filter(|b| b.part > 0).count() > 1000);
    assert_eq!(stats.overflow, 0);
    // Every kept beam has its own place in the hierarchy (none overwrote another's): all are
    // listed.
    assert_eq!(stats.kept_per_level.iter().sum::<u32>(), stats.beams, "kept beams missing from the list");
    // Parts and orphans' beams whose samples leave them no light are dropped, not drawn (on
    // the 96² dragon 3128 of 83812 beams were).
    assert!(stats.dark > 0, "the dragon's parts all carry light?");
    assert!(list.iter().all(|b| b.flux.max_element() > 0.0), "a beam without light is listed");
    // The transmitted branch's last segments against the CPU's (2.53 W; 0.1 % at 400²), and of
    // it the light on the floor (object 1): light on a path none of a triangle's corners takes
    // goes to a beam that lands where it does (beam_shrink's orphans). Shared equally among the
    // corners' parts, it put 4.6 % too much on the floor (taken from the light leaving the
    // scene sideways and upward).
    // Measured (2026-12-05, lavapipe): 2.506 W, 0.991; on the floor 1.842 of 1.846 W, 0.998
    // (the equal share: 1.046, failing).
    let t0: Vec<_> = list.iter().filter(|b| b.branch == 0 && b.layer == 0).collect();
    let beams: f64 = t0.iter().map(|b| f64::from(b.flux.x)).sum();
    let floor: f64 = t0.iter().filter(|b| b.land == 1).map(|b| f64::from(b.flux.x)).sum();
    let (cpu, cpu_floor) = transmitted_flux(&sc, 400, RenderSettings::default().photons.max_depth, 1);
    println!("transmitted beams {beams:.4} W, CPU {cpu:.4} W: {:.4}", beams / cpu);
    println!("on the floor {floor:.4} W, CPU {cpu_floor:.4} W: {:.4}", floor / cpu_floor);
    assert!((beams / cpu - 1.0).abs() < 0.03, "transmitted beams carry {beams} W of {cpu} W");
    assert!(
        (floor / cpu_floor - 1.0).abs() < 0.02,
        "transmitted beams put {floor} W on the floor, the CPU {cpu_floor} W"
    );
    // The transmitted light between two parts of the dragon (layer 1) against the CPU's. The
    // triangles none of whose corners crosses between two parts on a path of their own while
    // their paths differ get an orphans-only part on layer 1 too: without it (before
    // 2026-12-06) the layer-1 beams carried 0.690 of 0.788 W (0.876). Measured (lavapipe):
    // 0.783 W, 0.99.
    let l1: f64 = list.iter().filter(|b| b.branch == 0 && b.layer == 1).map(|b| f64::from(b.flux.x)).sum();
    let cpu_l1 = layer1_flux(&sc, 400, RenderSettings::default().photons.max_depth);
    println!("transmitted layer 1: beams {l1:.4} W, CPU {cpu_l1:.4} W: {:.4}", l1 / cpu_l1);
    assert!((l1 / cpu_l1 - 1.0).abs() < 0.03, "transmitted layer-1 beams carry {l1} W of {cpu_l1} W");
    // Parts whose own beam would be degenerate get a thin one: almost none is dropped.
    assert!(stats.grazing < 100, "{} beams dropped as grazing", stats.grazing);
    // Every branch's last segments against the CPU's full path tree (`branch_flux`). The
    // branches reflected at the third and fourth interactions lost 11 % and 20 % of their light
    // when a triangle none of whose corners is on a caustic path of the branch was dropped (on
    // the dragon the light inside it crosses the dragon more often than at its corners); with
    // orphans-only parts (beam_refine's PART_ORPHANS) they carry 0.952 and 0.956 (measured
    // 2026-12-05, lavapipe; reflected at interactions 0 and 1: 0.980, 0.974).
    let cpu = branch_flux(&sc, 400, RenderSettings::default().photons.max_depth);
    let got: Vec<f64> = (0..6u32)
        .map(|br| list.iter().filter(|b| b.branch == br && b.layer == 0).map(|b| f64::from(b.flux.x)).sum())
        .collect();
    for br in 0..6 {
        println!("branch {br}: beams {:.4} W, CPU {:.4} W: {:.4}", got[br], cpu[br], got[br] / cpu[br]);
    }
    for br in 1..5 {
        let r = got[br] / cpu[br];
        assert!((0.93..1.01).contains(&r), "branch {br}: beams carry {} W of the CPU's {} W", got[br], cpu[br]);
    }
    // The residual branch (5): the light reflected partially where no fixed branch follows it
    // (at the fifth interaction or later, or twice or more; 6 % of the dragon's caustic light),
    // its Fresnel choices drawn at random per triangle. Against the CPU, within three standard
    // deviations of its estimate (`residual_sigma`), which must be below a third of the light
    // (so that a missing residual branch fails). Measured (2026-12-05, lavapipe): 0.2033 W of
    // 0.1958 W (1.039), sigma 0.0118 W; without the orphans-only parts 0.753 (failing).
    let sigma = residual_sigma(list);
    let (gpu_res, cpu_res) = (got[5], cpu[5]);
    let cpu_all: f64 = cpu.iter().sum();
    println!(
        "residual branch: {gpu_res:.4} W (sigma {sigma:.4}), {} beams; CPU {cpu_res:.4} W of {cpu_all:.4} W",
        stats.residual
    );
    assert!(cpu_res > 0.04 * cpu_all, "the dragon's residual light {cpu_res} W of {cpu_all} W");
    assert!(sigma < cpu_res / 3.0, "the residual estimate's deviation {sigma} W of {cpu_res} W");
    assert!(
        (gpu_res - cpu_res).abs() < 3.0 * sigma,
        "residual beams carry {gpu_res} W, the CPU {cpu_res} W (sigma {sigma})"
    );
    assert_eq!(list.iter().filter(|b| b.branch == 5).count() as u32, stats.residual);
}

/// The CPU's caustic light of the spot of `sc` per beam branch (first channel, W, `n`² stratified
/// directions of its cone; the full path tree, `reference::branch::tree`): no partial
/// reflection, one at interaction 0 … 3, and the residual branch's (`residual_owns`, with the
/// five fixed branches of a scene whose light crosses the medium between specular objects).
fn branch_flux(sc: &Scene, n: u32, max_depth: u32) -> [f64; 6] {
    use caustics_reference::reference::branch::{residual_owns, tree};
    over_spot(sc, n, |accel, o, d, w, acc: &mut [f64; 6]| {
        tree(sc, accel, o, d, max_depth, 1e-7, &mut |l| {
            let k = if residual_owns(l.chosen, l.count, 5) {
                5
            } else if l.count == 0 {
                0
            } else {
                1 + l.chosen.trailing_zeros() as usize
            };
            acc[k] += w * l.weight;
        });
    })
}
