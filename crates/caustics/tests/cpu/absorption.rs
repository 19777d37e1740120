//! Beer–Lambert absorption inside dielectrics: the CPU reference against the analytic slab, the
//! clear material's bits unchanged, and the scene fields' parsing and errors.

use caustics::Scene;
use caustics::scene::Material;
use caustics_reference::reference::{self, Deposit, ReferenceSettings};
use glam::Vec3;
use std::path::{Path, PathBuf};

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("caustics-absorb-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Axis-aligned box as an OBJ, faces counter-clockwise seen from outside.
fn write_box(path: &Path, lo: Vec3, hi: Vec3) {
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
    let mut s = String::new();
    for p in &v {
        s += &format!("v {} {} {}\n", p.x, p.y, p.z);
    }
    for q in quads {
        s += &format!("f {} {} {}\nf {} {} {}\n", q[0] + 1, q[1] + 1, q[2] + 1, q[0] + 1, q[2] + 1, q[3] + 1);
    }
    std::fs::write(path, s).unwrap();
}

/// A 2 m × 2 m slab of thickness `THICK` 1 m above a floor under a directional light straight
/// down, its glass given by `glass` (the fields after `"type": "dielectric"`), seen by a camera
/// straight above; and (`wall`) a lit wall seen through a vertical slab.
const THICK: f32 = 0.1;

fn slab_scene(dir: &Path, glass: &str) -> Scene {
    write_box(&dir.join("slab.obj"), Vec3::new(-1.0, 1.0 - THICK / 2.0, -1.0), Vec3::new(1.0, 1.0 + THICK / 2.0, 1.0));
    let json = format!(
        r#"{{ "schema_version": 1, "name": "slab",
        "camera": {{ "position": [0, 5, 5], "look_at": [0, 0, 0], "fov_y_deg": 40, "width": 16, "height": 16 }},
        "lights": [ {{ "type": "directional", "direction": [0, -1, 0], "irradiance": 1.0 }} ],
        "materials": {{ "floor": {{ "type": "diffuse", "albedo": 0.5 }}, "glass": {{ "type": "dielectric", "ior": 1.5{glass} }} }},
        "objects": [
          {{ "type": "mesh", "path": "slab.obj", "smooth_normals": false, "material": "glass" }},
          {{ "type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [20, 20], "material": "floor" }} ] }}"#
    );
    Scene::from_json(&json, "<test>", dir).unwrap()
}

fn settings(photons: u64) -> ReferenceSettings {
    ReferenceSettings { photons_per_light: photons, camera_spp: 4, max_depth: 64, seed: 3, ..Default::default() }
}

/// Deposited flux per channel, of the deposits `f` keeps.
fn total(d: &[Deposit], f: impl Fn(&Deposit) -> bool) -> [f64; 3] {
    let mut t = [0.0; 3];
    for x in d.iter().filter(|x| f(x)) {
        for (c, v) in t.iter_mut().enumerate() {
            *v += x.flux[c] as f64;
        }
    }
    t
}

/// The light under the slab: per channel, the first pass (straight through, two interfaces) is
/// the clear slab's times exp(−σ d) (the same photons, the same choices); all orders, with the
/// inter-reflections between the faces, (1 − R)² e / (1 − R² e²), e = exp(−σ d), R = 0.04.
#[test]
fn slab_transmits_beer_lambert() {
    let dir = tmpdir("slab");
    let sigma = [0.0f64, 2.0, 8.0];
    let clear = slab_scene(&dir, "");
    let tinted = slab_scene(&dir, r#", "absorption": [0, 2, 8]"#);
    let s = settings(1 << 18);
    let dc = reference::caustic_deposits(&clear, &s, 0).unwrap();
    let dt = reference::caustic_deposits(&tinted, &s, 0).unwrap();
    assert_eq!(dc.len(), dt.len(), "the same photons reach the floor");
    let first = |x: &Deposit| x.specular_bounces == 2;
    let (fc, ft) = (total(&dc, first), total(&dt, first));
    let at = total(&dt, |_| true);
    let area = 4.0; // slab top, irradiance 1
    let r = 0.04f64;
    for c in 0..3 {
        let e = (-sigma[c] * THICK as f64).exp();
        let ratio = ft[c] / fc[c];
        let all = at[c] / area;
        let expect_all = (1.0 - r).powi(2) * e / (1.0 - r * r * e * e);
        println!("channel {c}: first-pass ratio {ratio:.6} (exp(-σd) {e:.6}), all orders {all:.5} ({expect_all:.5})");
        assert!((ratio / e - 1.0).abs() < 1e-4, "channel {c}: first-pass ratio {ratio}, exp(-σd) = {e}");
        assert!((all / expect_all - 1.0).abs() < 0.005, "channel {c}: transmission {all}, expected {expect_all}");
    }
}

/// Camera paths: a lit wall seen through a vertical tinted slab at normal incidence is the clear
/// slab's view times exp(−σ d) per channel (the same camera paths, the same choices).
#[test]
fn camera_sees_through_tinted_slab() {
    let dir = tmpdir("wall");
    write_box(&dir.join("pane.obj"), Vec3::new(-1.0, -1.0, 3.0 - THICK / 2.0), Vec3::new(1.0, 1.0, 3.0 + THICK / 2.0));
    let scene = |glass: &str| {
        let json = format!(
            r#"{{ "schema_version": 1, "name": "wall",
            "camera": {{ "position": [0, 0, 6], "look_at": [0, 0, 0], "fov_y_deg": 6, "width": 8, "height": 8 }},
            "lights": [ {{ "type": "directional", "direction": [0, -1, -1], "irradiance": 1.0 }} ],
            "materials": {{ "wall": {{ "type": "diffuse", "albedo": 0.5 }}, "glass": {{ "type": "dielectric", "ior": 1.5{glass} }} }},
            "objects": [
              {{ "type": "mesh", "path": "pane.obj", "smooth_normals": false, "material": "glass" }},
              {{ "type": "rectangle", "center": [0, 0, 0], "normal": [0, 0, 1], "size": [20, 20], "material": "wall" }} ] }}"#
        );
        Scene::from_json(&json, "<test>", &dir).unwrap()
    };
    let s = ReferenceSettings { photons_per_light: 1 << 12, ..settings(0) };
    let clear = reference::render(&scene(""), &s).unwrap().nocaustic;
    let tinted = reference::render(&scene(r#", "absorption": [0.5, 3, 12]"#), &s).unwrap().nocaustic;
    let sigma = [0.5f32, 3.0, 12.0];
    let mut lit = 0;
    let (mut sum_a, mut sum_b) = ([0.0f64; 3], [0.0f64; 3]);
    for (a, b) in clear.pixels.iter().zip(&tinted.pixels) {
        if a[0] <= 0.0 {
            continue;
        }
        lit += 1;
        for c in 0..3 {
            // Never more than exp(−σ d): every path inside is at least d long.
            let e = (-sigma[c] * THICK).exp();
            assert!(b[c] <= a[c] * e * 1.00001, "channel {c}: {} vs {e}", b[c] / a[c]);
            sum_a[c] += a[c] as f64;
            sum_b[c] += b[c] as f64;
        }
    }
    // Over the image: exp(−σ d) but for the slightly longer oblique paths (≤ 4.3° off the axis:
    // ≤ 1.0013 d) and the few samples reflected inside (3 d or more), within 1 %.
    for c in 0..3 {
        let e = (-sigma[c] as f64 * THICK as f64).exp();
        let ratio = sum_b[c] / sum_a[c];
        println!("channel {c}: image ratio {ratio:.5}, exp(-σd) {e:.5}");
        assert!((ratio / e - 1.0).abs() < 0.01, "channel {c}: {ratio} vs {e}");
    }
    assert!(lit >= 32, "the wall is seen lit through the pane in {lit} pixels");
}

/// `absorption: 0` is the clear material exactly: the same material, the same deposits.
#[test]
fn zero_absorption_is_clear_bit_for_bit() {
    let dir = tmpdir("zero");
    let clear = slab_scene(&dir, "");
    let zero = slab_scene(&dir, r#", "absorption": 0"#);
    assert_eq!(clear.materials, zero.materials);
    let s = settings(1 << 12);
    let a = reference::caustic_deposits(&clear, &s, 0).unwrap();
    let b = reference::caustic_deposits(&zero, &s, 0).unwrap();
    assert_eq!(a.len(), b.len());
    assert!(a.iter().zip(&b).all(|(x, y)| x.flux.to_array().map(f32::to_bits) == y.flux.to_array().map(f32::to_bits)));
}

const GOOD: &str = r#"{
  "schema_version": 1, "name": "t",
  "camera": { "position": [0, 2, 4], "look_at": [0, 0, 0], "fov_y_deg": 40, "width": 64, "height": 64 },
  "lights": [ { "type": "spot", "position": [0, 4, 0], "direction": [0, -1, 0], "cone_angle_deg": 30, "intensity": 10 } ],
  "materials": { "floor": { "type": "diffuse", "albedo": 0.5 }, "glass": { "type": "dielectric", "ior": 1.5 GLASS } },
  "objects": [ { "type": "sphere", "center": [0, 1, 0], "radius": 0.5, "material": "glass" },
               { "type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [4, 4], "material": "floor" } ]
}"#;

fn load(glass: &str) -> caustics::Result<Scene> {
    Scene::from_json(&GOOD.replace("GLASS", glass), "bad.json", Path::new("."))
}

fn absorption_of(glass: &str) -> Vec3 {
    let s = load(glass).unwrap();
    let i = s.material_names.iter().position(|n| n == "glass").unwrap();
    s.materials[i].absorption()
}

#[test]
fn both_forms_parse() {
    assert_eq!(absorption_of(""), Vec3::ZERO);
    assert_eq!(absorption_of(r#", "absorption": [0.5, 1, 2]"#), Vec3::new(0.5, 1.0, 2.0));
    assert_eq!(absorption_of(r#", "absorption": 3"#), Vec3::splat(3.0));
    // σa = −ln(c) / d: c = e^−1 after 2 m is 0.5 per metre; c = 1 is clear.
    let s = absorption_of(r#", "attenuation_color": [0.36787944, 1, 0.25], "attenuation_distance": 2"#);
    assert!((s.x - 0.5).abs() < 1e-6 && s.y == 0.0 && (s.z - 4f32.ln() / 2.0).abs() < 1e-6, "{s}");
    let s = load(r#", "absorption": [0.5, 1, 2]"#).unwrap();
    assert!(s.materials.contains(&Material::Dielectric {
        ior: 1.5,
        ext_ior: 1.0,
        absorption: Vec3::new(0.5, 1.0, 2.0)
    }));
}

#[test]
fn bad_absorption_is_an_error_naming_the_field() {
    let cases = [
        (r#", "absorption": [0, -1, 0]"#, "materials.glass.absorption", "negative"),
        (r#", "absorption": [1, 1]"#, "materials.glass.absorption", ""),
        (
            r#", "absorption": 1, "attenuation_color": 0.5, "attenuation_distance": 1"#,
            "materials.glass.absorption",
            "not both",
        ),
        (r#", "absorption": 1, "attenuation_color": 0.5"#, "materials.glass.absorption", "not both"),
        (r#", "attenuation_color": 0.5"#, "materials.glass.attenuation_distance", "required"),
        (r#", "attenuation_distance": 1"#, "materials.glass.attenuation_color", "required"),
        (
            r#", "attenuation_color": [0.5, 0, 0.5], "attenuation_distance": 1"#,
            "materials.glass.attenuation_color",
            "(0, 1]",
        ),
        (r#", "attenuation_color": 1.5, "attenuation_distance": 1"#, "materials.glass.attenuation_color", "(0, 1]"),
        (
            r#", "attenuation_color": 0.5, "attenuation_distance": 0"#,
            "materials.glass.attenuation_distance",
            "positive",
        ),
        (
            r#", "attenuation_color": 0.5, "attenuation_distance": -2"#,
            "materials.glass.attenuation_distance",
            "positive",
        ),
    ];
    for (glass, field, words) in cases {
        let e = load(glass).expect_err(glass);
        assert!(e.is_input(), "{e}");
        let s = e.to_string();
        assert!(s.starts_with("bad.json: ") && s.contains(field) && s.contains(words), "{glass}: {s}");
    }
}

/// An open rectangle or cylinder has no inside to absorb in: an absorbing material on one is
/// refused, naming the object.
#[test]
fn absorbing_sheets_are_refused() {
    let json = GOOD.replace("GLASS", r#", "absorption": 1"#).replace(
        r#""type": "sphere", "center": [0, 1, 0], "radius": 0.5"#,
        r#""type": "rectangle", "center": [0, 1, 0], "normal": [0, 1, 0], "size": [1, 1]"#,
    );
    let e = Scene::from_json(&json, "bad.json", Path::new(".")).expect_err("a rectangle cannot absorb");
    let s = e.to_string();
    assert!(s.contains("objects[0].material") && s.contains("no inside"), "{s}");
    // Clear, it is a thin sheet as before.
    let clear = GOOD.replace("GLASS", "").replace(
        r#""type": "sphere", "center": [0, 1, 0], "radius": 0.5"#,
        r#""type": "rectangle", "center": [0, 1, 0], "normal": [0, 1, 0], "size": [1, 1]"#,
    );
    Scene::from_json(&clear, "ok.json", Path::new(".")).unwrap();
}
