//! Analytic optics and sampling tests of the CPU reference renderer.

use caustics::Scene;
use caustics::scene::Light;
use caustics_reference::reference::emit::Emitter;
use caustics_reference::reference::sampling::sobol_2d;
use caustics_reference::reference::{self, Deposit, ReferenceSettings};
use glam::Vec3;
use std::f32::consts::PI;
use std::fmt::Write as _;
use std::path::PathBuf;

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("caustics-ref-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Write an OBJ with optional per-vertex normals.
fn write_obj(path: &std::path::Path, v: &[Vec3], n: Option<&[Vec3]>, f: &[[u32; 3]]) {
    let mut s = String::new();
    for p in v {
        writeln!(s, "v {} {} {}", p.x, p.y, p.z).unwrap();
    }
    if let Some(n) = n {
        for q in n {
            writeln!(s, "vn {} {} {}", q.x, q.y, q.z).unwrap();
        }
    }
    for t in f {
        if n.is_some() {
            writeln!(s, "f {0}//{0} {1}//{1} {2}//{2}", t[0] + 1, t[1] + 1, t[2] + 1).unwrap();
        } else {
            writeln!(s, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1).unwrap();
        }
    }
    std::fs::write(path, s).unwrap();
}

/// Axis-aligned box, faces counter-clockwise seen from outside.
fn write_box(path: &std::path::Path, lo: Vec3, hi: Vec3) {
    let v: Vec<Vec3> = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 1 != 0 { hi.x } else { lo.x },
                if i & 2 != 0 { hi.y } else { lo.y },
                if i & 4 != 0 { hi.z } else { lo.z },
            )
        })
        .collect();
    let quads = [[0, 4, 6, 2], [1, 3, 7, 5], [0, 1, 5, 4], [2, 6, 7, 3], [0, 2, 3, 1], [4, 5, 7, 6]];
    let mut f = Vec::new();
    for q in quads {
        f.push([q[0], q[1], q[2]]);
        f.push([q[0], q[2], q[3]]);
    }
    // Check the winding: every face normal points away from the centre.
    let c = (lo + hi) * 0.5;
    for t in &f {
        let [a, b, d] = t.map(|i| v[i as usize]);
        assert!((b - a).cross(d - a).dot(a - c) > 0.0);
    }
    write_obj(path, &v, None, &f);
}

fn scene(json: &str, dir: &std::path::Path) -> Scene {
    Scene::from_json(json, "<test>", dir).unwrap()
}

fn settings(photons: u64) -> ReferenceSettings {
    ReferenceSettings {
        photons_per_light: photons,
        camera_spp: 1,
        max_depth: 64,
        seed: 1,
        caustic_map_size: 64,
        medium_single_scattering_only: false,
        ..Default::default()
    }
}

fn total(d: &[Deposit], f: impl Fn(&Deposit) -> bool) -> f64 {
    d.iter().filter(|x| f(x)).map(|x| x.flux.x as f64).sum()
}

const CAM: &str = r#""camera": { "position": [0, 5, 5], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov_y_deg": 40, "width": 32, "height": 32 }"#;

#[test]
fn glass_slab_transmits_fresnel_squared() {
    let dir = tmpdir("slab");
    write_box(&dir.join("slab.obj"), Vec3::new(-1.0, 0.95, -1.0), Vec3::new(1.0, 1.05, 1.0));
    let s = scene(
        &format!(
            r#"{{ "schema_version": 1, "name": "slab", {CAM},
            "lights": [ {{ "type": "directional", "direction": [0, -1, 0], "irradiance": 1.0 }} ],
            "materials": {{ "floor": {{ "type": "diffuse", "albedo": 0.5 }}, "glass": {{ "type": "dielectric", "ior": 1.5, "ext_ior": 1.0 }} }},
            "objects": [
              {{ "type": "mesh", "path": "slab.obj", "smooth_normals": false, "material": "glass" }},
              {{ "type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [20, 20], "material": "floor" }} ] }}"#
        ),
        &dir,
    );
    let seed: u64 = std::env::var("SEED").map(|s| s.parse().unwrap()).unwrap_or(1);
    let d = reference::caustic_deposits(&s, &ReferenceSettings { seed, ..settings(1 << 20) }, 0).unwrap();
    let area = 4.0; // slab top, irradiance 1
    let first = total(&d, |x| x.specular_bounces == 2) / area;
    let all = total(&d, |_| true) / area;
    let r = 0.04f64;
    println!(
        "first pass {first:.5} (expected {:.5}), all orders {all:.5} (expected {:.5})",
        (1.0 - r).powi(2),
        (1.0 - r) / (1.0 + r)
    );
    assert!((first / 0.9216 - 1.0).abs() < 0.005, "first-pass transmission {first}");
    assert!((all / ((1.0 - r) / (1.0 + r)) - 1.0).abs() < 0.005, "total transmission {all}");
}

#[test]
fn parabolic_mirror_focuses_parallel_light() {
    let dir = tmpdir("parabola");
    // Rim at 0.6 m, below the focus: every reflected ray climbs to the focal card at 28° or
    // more (a rim level with the focus would send rays along the card's plane).
    let (f, rim) = (0.5f32, 0.6f32);
    let (rings, segs) = (64u32, 256u32);
    let mut v = vec![Vec3::ZERO];
    let mut n = vec![Vec3::Y];
    for i in 1..=rings {
        let r = rim * i as f32 / rings as f32;
        for j in 0..segs {
            let a = 2.0 * PI * j as f32 / segs as f32;
            let (x, z) = (r * a.cos(), r * a.sin());
            v.push(Vec3::new(x, (x * x + z * z) / (4.0 * f), z));
            n.push(Vec3::new(-x / (2.0 * f), 1.0, -z / (2.0 * f)).normalize());
        }
    }
    let idx = |i: u32, j: u32| if i == 0 { 0 } else { 1 + (i - 1) * segs + j % segs };
    let mut tris = Vec::new();
    for i in 0..rings {
        for j in 0..segs {
            // Counter-clockwise seen from above (+y).
            if i == 0 {
                tris.push([0, idx(1, j + 1), idx(1, j)]);
            } else {
                tris.push([idx(i, j), idx(i, j + 1), idx(i + 1, j + 1)]);
                tris.push([idx(i, j), idx(i + 1, j + 1), idx(i + 1, j)]);
            }
        }
    }
    write_obj(&dir.join("parabola.obj"), &v, Some(&n), &tris);
    let card = 0.1f32;
    let s = scene(
        &format!(
            r#"{{ "schema_version": 1, "name": "parabola", {CAM},
            "lights": [ {{ "type": "directional", "direction": [0, -1, 0], "irradiance": 1.0 }} ],
            "materials": {{ "card": {{ "type": "diffuse", "albedo": 0.5 }}, "mirror": {{ "type": "mirror", "reflectance": 0.9 }} }},
            "objects": [
              {{ "type": "mesh", "path": "parabola.obj", "smooth_normals": true, "material": "mirror" }},
              {{ "type": "rectangle", "center": [0, {f}, 0], "normal": [0, -1, 0], "size": [{card}, {card}], "material": "card" }} ] }}"#
        ),
        &dir,
    );
    let d = reference::caustic_deposits(&s, &settings(1 << 20), 0).unwrap();
    let on_card: Vec<&Deposit> = d.iter().filter(|x| x.object == 1 && x.dir.y > 0.0).collect();
    let w: f64 = on_card.iter().map(|x| x.flux.x as f64).sum();
    let c = on_card.iter().fold(glam::DVec3::ZERO, |a, x| a + x.position.as_dvec3() * x.flux.x as f64) / w;
    let rms = (on_card.iter().map(|x| (x.position.as_dvec3() - c).length_squared() * x.flux.x as f64).sum::<f64>() / w)
        .sqrt();
    // Flux: reflectance × the light falling on the mirror outside the card's shadow.
    let poly_area = 0.5 * (rim * rim) as f64 * segs as f64 * (2.0 * std::f64::consts::PI / segs as f64).sin();
    let expected = 0.9 * (poly_area - (card * card) as f64);
    let all = total(&d, |_| true);
    println!("focus centroid {c:?}, rms radius {rms:.5}, flux on card {w:.5} of {all:.5}, expected {expected:.5}");
    assert!(c.x.abs() < 1e-3 && c.z.abs() < 1e-3, "{c:?}");
    assert!(rms < 1e-3 * f as f64, "rms spot radius {rms}");
    assert!(w / all > 0.99);
    assert!((all / expected - 1.0).abs() < 0.005, "reflected flux {all} vs {expected}");
}

#[test]
fn ball_lens_focuses_at_paraxial_focal_distance() {
    let dir = tmpdir("ball");
    let (n, r) = (1.5f64, 0.5f64);
    let s = scene(
        &format!(
            r#"{{ "schema_version": 1, "name": "ball", {CAM},
            "lights": [ {{ "type": "directional", "direction": [0, -1, 0], "irradiance": 1.0 }} ],
            "materials": {{ "floor": {{ "type": "diffuse", "albedo": 0.5 }}, "glass": {{ "type": "dielectric", "ior": {n}, "ext_ior": 1.0 }} }},
            "objects": [
              {{ "type": "sphere", "center": [0, 1, 0], "radius": {r}, "material": "glass" }},
              {{ "type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [20, 20], "material": "floor" }} ] }}"#
        ),
        &dir,
    );
    let d = reference::caustic_deposits(&s, &settings(1 << 21), 0).unwrap();
    // Where each twice-refracted photon crossed the axis (the y axis through the centre).
    let mut cross = Vec::new();
    for x in d.iter().filter(|x| x.specular_bounces == 2 && x.dir.y < 0.0) {
        let p = x.position.as_dvec3();
        let dv = x.dir.as_dvec3();
        let h2 = dv.x * dv.x + dv.z * dv.z;
        let sin = h2.sqrt();
        if sin > 0.0 && sin < 0.03 {
            let s = -(p.x * dv.x + p.z * dv.z) / h2;
            cross.push((sin, 1.0 - (p.y + s * dv.y)));
        }
    }
    let paraxial = n * r / (2.0 * (n - 1.0));
    let mean = cross.iter().map(|c| c.1).sum::<f64>() / cross.len() as f64;
    println!("{} paraxial photons, focus {mean:.5} from the centre (expected {paraxial})", cross.len());
    assert!(cross.len() > 1000);
    assert!((mean / paraxial - 1.0).abs() < 0.005, "focus at {mean}, expected {paraxial}");
    // Spherical aberration: marginal rays focus closer than paraxial ones.
    let d2 = reference::caustic_deposits(&s, &settings(1 << 16), 0).unwrap();
    let marginal: Vec<f64> = d2
        .iter()
        .filter(|x| x.specular_bounces == 2 && x.dir.y < 0.0)
        .filter_map(|x| {
            let (p, dv) = (x.position.as_dvec3(), x.dir.as_dvec3());
            let h2 = dv.x * dv.x + dv.z * dv.z;
            (h2.sqrt() > 0.3).then(|| 1.0 - (p.y - (p.x * dv.x + p.z * dv.z) / h2 * dv.y))
        })
        .collect();
    assert!(marginal.iter().all(|&m| m < paraxial));
}

#[test]
fn deposited_flux_equals_emitted_flux_times_fresnel() {
    // A point light and a glass ball inside a closed diffuse box: every photon that reaches the
    // ball ends on a wall (no absorption), so the caustic flux is I × the ball's solid angle.
    let dir = tmpdir("flux");
    let walls = r#"
      { "type": "rectangle", "center": [0, -2, 0], "normal": [0, 1, 0], "size": [4, 4], "material": "wall" },
      { "type": "rectangle", "center": [0, 2, 0], "normal": [0, -1, 0], "size": [4, 4], "material": "wall" },
      { "type": "rectangle", "center": [-2, 0, 0], "normal": [1, 0, 0], "size": [4, 4], "material": "wall", "u_axis": [0, 0, 1] },
      { "type": "rectangle", "center": [2, 0, 0], "normal": [-1, 0, 0], "size": [4, 4], "material": "wall", "u_axis": [0, 0, 1] },
      { "type": "rectangle", "center": [0, 0, -2], "normal": [0, 0, 1], "size": [4, 4], "material": "wall" },
      { "type": "rectangle", "center": [0, 0, 2], "normal": [0, 0, -1], "size": [4, 4], "material": "wall" }"#;
    let make = |obj: &str| {
        scene(
            &format!(
                r#"{{ "schema_version": 1, "name": "flux", "camera": {{ "position": [0, 0, 1.9], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov_y_deg": 60, "width": 16, "height": 16 }},
                "lights": [ {{ "type": "point", "position": [0, 1, 0], "intensity": 2.0 }} ],
                "materials": {{ "wall": {{ "type": "diffuse", "albedo": 0.5 }}, "glass": {{ "type": "dielectric", "ior": 1.5, "ext_ior": 1.0 }},
                               "mirror": {{ "type": "mirror", "reflectance": 0.9 }},
                               "gold": {{ "type": "conductor", "eta": [0.143, 0.374, 1.442], "k": [3.983, 2.385, 1.603] }} }},
                "objects": [ {obj}, {walls} ] }}"#
            ),
            &dir,
        )
    };
    let d = reference::caustic_deposits(
        &make(r#"{ "type": "sphere", "center": [0, -0.5, 0], "radius": 0.5, "material": "glass" }"#),
        &settings(1 << 20),
        0,
    )
    .unwrap();
    let omega = 2.0 * std::f64::consts::PI * (1.0 - (1.0 - (0.5f64 / 1.5).powi(2)).sqrt());
    let got = total(&d, |_| true);
    println!("glass ball: deposited {got:.6}, emitted toward it {:.6}", 2.0 * omega);
    assert!((got / (2.0 * omega) - 1.0).abs() < 0.005);
    // A mirror square facing the light from 1 m: reflectance × I × its solid angle.
    let sq = r#"{ "type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [0.6, 0.6], "material": "mirror" }"#;
    let d = reference::caustic_deposits(&make(sq), &settings(1 << 20), 0).unwrap();
    let (a, dd) = (0.6f64, 1.0f64);
    let omega = 4.0 * (a * a / ((a * a + 4.0 * dd * dd) * (a * a + 4.0 * dd * dd)).sqrt()).asin();
    let got = total(&d, |_| true);
    println!("mirror: deposited {got:.6}, expected {:.6}", 0.9 * 2.0 * omega);
    assert!((got / (0.9 * 2.0 * omega) - 1.0).abs() < 0.005);
}

#[test]
fn emission_matches_each_light_definition() {
    let n = 1u64 << 18;
    let bins = 32usize;
    // Spot: flux per angular bin = I ∫ f(θ) 2π sin θ dθ.
    let (cone, start) = (30f32.to_radians(), 20f32.to_radians());
    let spot = Light::Spot {
        position: Vec3::ZERO,
        direction: Vec3::new(0.0, -1.0, 0.0),
        cone_angle: cone,
        falloff_start: start,
        intensity: Vec3::splat(3.0),
        profile: Default::default(),
    };
    let em = Emitter::full(&spot, Vec3::ZERO, 10.0);
    let mut hist = vec![0f64; bins];
    let mut sum = 0.0;
    for i in 0..n {
        if let Some(e) = em.sample(sobol_2d(i, 5)) {
            let th = (-e.dir.y).clamp(-1.0, 1.0).acos();
            let b = ((th / cone * bins as f32) as usize).min(bins - 1);
            hist[b] += e.flux_n.x as f64 / n as f64;
            sum += e.flux_n.x as f64 / n as f64;
        }
    }
    let profile =
        |th: f64| if th <= start as f64 { 1.0 } else { ((cone as f64 - th) / (cone - start) as f64).max(0.0) };
    let mut chi2 = 0.0;
    for (b, h) in hist.iter().enumerate() {
        let (t0, t1) = (b as f64 / bins as f64 * cone as f64, (b + 1) as f64 / bins as f64 * cone as f64);
        let m = 200;
        let exp: f64 = (0..m)
            .map(|k| {
                let t = t0 + (k as f64 + 0.5) / m as f64 * (t1 - t0);
                3.0 * profile(t) * 2.0 * std::f64::consts::PI * t.sin() * (t1 - t0) / m as f64
            })
            .sum();
        if exp > 1e-4 {
            assert!((h / exp - 1.0).abs() < 0.01, "spot bin {b}: {h} vs {exp}");
            chi2 += (h - exp).powi(2) / exp;
        }
    }
    let total = em.domain_flux().x as f64;
    println!("spot: total {sum:.6} vs {total:.6}, chi2-like {chi2:.3e}");
    assert!((sum / total - 1.0).abs() < 1e-3);

    // Point: isotropic, total 4π I; counts uniform in cos θ and φ (chi-square, 64 cells).
    let point = Light::Point { position: Vec3::ZERO, intensity: Vec3::splat(2.0) };
    let em = Emitter::full(&point, Vec3::ZERO, 10.0);
    let mut cells = vec![0f64; 64];
    let mut sum = 0.0;
    let mut rng = caustics_reference::reference::sampling::PathRng::new(9);
    let m = 1u64 << 16;
    for _ in 0..m {
        let e = em.sample(rng.next_2d()).unwrap();
        let ct = ((e.dir.y + 1.0) * 4.0) as usize;
        let ph = ((e.dir.z.atan2(e.dir.x) + PI) / (2.0 * PI) * 8.0) as usize;
        cells[ct.min(7) * 8 + ph.min(7)] += 1.0;
        sum += e.flux_n.x as f64 / m as f64;
    }
    let expect = m as f64 / 64.0;
    let chi2: f64 = cells.iter().map(|c| (c - expect).powi(2) / expect).sum();
    println!("point: chi2 {chi2:.1} (63 dof), total {sum:.5} vs {:.5}", 8.0 * std::f64::consts::PI);
    assert!(chi2 < 110.0, "chi2 {chi2} with 63 degrees of freedom"); // p < 2e-4
    assert!((sum / (8.0 * std::f64::consts::PI) - 1.0).abs() < 1e-4);

    // Directional: uniform over a disc perpendicular to the direction, flux E × area.
    let dl = Light::Directional { direction: Vec3::new(1.0, -1.0, 0.0).normalize(), irradiance: Vec3::splat(4.0) };
    let em = Emitter::full(&dl, Vec3::new(1.0, 2.0, 3.0), 2.0);
    let mut rings = vec![0f64; 8];
    let mut sum = 0.0;
    for i in 0..n {
        let e = em.sample(sobol_2d(i, 11)).unwrap();
        assert!((e.dir - Vec3::new(1.0, -1.0, 0.0).normalize()).length() < 1e-6);
        let off = e.origin - Vec3::new(1.0, 2.0, 3.0);
        let radial = (off - e.dir * off.dot(e.dir)).length();
        assert!(off.dot(e.dir) < -2.0, "starts behind the scene");
        rings[((radial / 2.0).powi(2) * 8.0) as usize % 8] += 1.0;
        sum += e.flux_n.x as f64 / n as f64;
    }
    assert!(rings.iter().all(|&c| (c / (n as f64 / 8.0) - 1.0).abs() < 0.01), "{rings:?}");
    assert!((sum / (4.0 * std::f64::consts::PI * 4.0) - 1.0).abs() < 1e-5);
}

#[test]
fn bad_settings_are_clear_errors() {
    let s = Scene::default_scene();
    for (bad, field) in [
        (ReferenceSettings { photons_per_light: 0, ..Default::default() }, "--photons"),
        (ReferenceSettings { photons_per_light: (1 << 40) + 1, ..Default::default() }, "--photons"),
        (ReferenceSettings { caustic_map_size: 0, ..Default::default() }, "--caustic-map-size"),
        (ReferenceSettings { max_depth: 0, ..Default::default() }, "cpu.max_depth"),
        (ReferenceSettings { camera_spp: 0, ..Default::default() }, "cpu.spp"),
    ] {
        let e = reference::render(&s, &bad).unwrap_err();
        assert!(e.is_input());
        let msg = e.to_string();
        assert!(msg.contains(field) && msg.contains("<command line>"), "{msg}");
        assert!(reference::caustic_maps(&s, &bad).is_err());
    }
    let e = reference::caustic_deposits(&s, &settings(10), 5).unwrap_err();
    assert!(e.to_string().contains("no light 5"), "{e}");
}

/// glTF's spot curve (`SpotProfile::Gltf`): `spot_falloff` against `KHR_lights_punctual`'s
/// formula, written out from the extension's text, and the reference's emission against it: the
/// flux per angular bin and in all (`domain_flux`'s closed form).
#[test]
fn a_gltf_spot_emits_by_the_khr_curve() {
    use caustics::scene::{SpotProfile, spot_falloff};
    let khr = |cd: f64, inner: f64, outer: f64| {
        let scale = 1.0 / (inner.cos() - outer.cos()).max(0.001);
        let t = (cd * scale - outer.cos() * scale).clamp(0.0, 1.0);
        t * t
    };
    for (inner, outer) in [(10f64, 30f64), (0.0, 45.0), (25.0, 25.0), (89.0, 90.0)] {
        let (i, o) = (inner.to_radians(), outer.to_radians());
        for k in 0..=200 {
            let th = k as f64 / 200.0 * (o + 0.1);
            let got = spot_falloff(th.cos() as f32, o as f32, i as f32, SpotProfile::Gltf) as f64;
            // f32's rounding of the cosines (some 6e-8), times the ramp's slope 2 · scale.
            let tol = 2e-7 / (i.cos() - o.cos()).max(0.001) + 1e-6;
            assert!((got - khr(th.cos(), i, o)).abs() < tol, "({inner}°, {outer}°) at {th}: {got}");
        }
    }
    let (cone, start) = (30f32.to_radians(), 10f32.to_radians());
    let spot = Light::Spot {
        position: Vec3::ZERO,
        direction: Vec3::new(0.0, -1.0, 0.0),
        cone_angle: cone,
        falloff_start: start,
        intensity: Vec3::splat(3.0),
        profile: SpotProfile::Gltf,
    };
    let em = Emitter::full(&spot, Vec3::ZERO, 10.0);
    let (n, bins) = (1u64 << 18, 32usize);
    let mut hist = vec![0f64; bins];
    for i in 0..n {
        if let Some(e) = em.sample(sobol_2d(i, 5)) {
            let th = (-e.dir.y).clamp(-1.0, 1.0).acos();
            hist[((th / cone * bins as f32) as usize).min(bins - 1)] += e.flux_n.x as f64 / n as f64;
        }
    }
    let mut total = 0.0;
    for (b, h) in hist.iter().enumerate() {
        let (t0, t1) = (b as f64 / bins as f64 * cone as f64, (b + 1) as f64 / bins as f64 * cone as f64);
        let m = 200;
        let exp: f64 = (0..m)
            .map(|k| {
                let t = t0 + (k as f64 + 0.5) / m as f64 * (t1 - t0);
                let f = khr(t.cos(), start as f64, cone as f64);
                3.0 * f * std::f64::consts::TAU * t.sin() * (t1 - t0) / m as f64
            })
            .sum();
        total += exp;
        if exp > 1e-4 {
            assert!((h / exp - 1.0).abs() < 0.01, "bin {b}: {h} vs {exp}");
        }
    }
    let closed = em.domain_flux().x as f64;
    println!("glTF spot: flux {:.6} (closed form {closed:.6}, integral {total:.6})", hist.iter().sum::<f64>());
    assert!((closed / total - 1.0).abs() < 1e-4, "domain_flux {closed} vs ∫ I f dΩ {total}");
    assert!((hist.iter().sum::<f64>() / total - 1.0).abs() < 1e-3);
}
