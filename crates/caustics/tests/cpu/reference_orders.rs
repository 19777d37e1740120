//! The reference's split by diffuse bounce order (`ReferenceSettings::diffuse_orders`,
//! `DiffuseOrders`): disjoint ranges of orders add up to the default image path by path (camera
//! paths and photons, with a medium and with an environment light); an open scene has no light
//! of order 2 and up; inside a closed diffuse sphere lit from its centre every order is the one
//! before it times the albedo.

use caustics::Scene;
use caustics::image_io::Image;
use caustics_reference::reference::{self, DiffuseOrders, ReferenceOutput, ReferenceSettings};
use std::path::Path;

fn scenes() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes")
}

fn catalogue(name: &str, size: u32) -> Scene {
    let path = scenes().join(format!("{name}.json"));
    let text = std::fs::read_to_string(&path).unwrap();
    let mut s = Scene::from_json(&text, name, &scenes()).unwrap();
    s.camera.width = size;
    s.camera.height = size;
    s
}

fn scene(camera: &str, lights: &str, albedo: f32, objects: &str) -> Scene {
    let json = format!(
        r#"{{ "schema_version": 1, "name": "orders",
          "camera": {camera},
          "lights": [ {lights} ],
          "materials": {{ "wall": {{ "type": "diffuse", "albedo": {albedo} }} }},
          "objects": [ {objects} ] }}"#
    );
    Scene::from_json(&json, "orders.json", &scenes()).unwrap_or_else(|e| panic!("{e}"))
}

fn orders(s: &str) -> DiffuseOrders {
    DiffuseOrders::parse(s).unwrap_or_else(|| panic!("{s}"))
}

fn render(s: &Scene, rs: &ReferenceSettings, o: &str) -> ReferenceOutput {
    reference::render(s, &ReferenceSettings { diffuse_orders: orders(o), ..rs.clone() }).unwrap()
}

fn sum(img: &Image) -> f64 {
    img.pixels.iter().flatten().map(|&v| v as f64).sum()
}

#[test]
fn orders_parse_and_print() {
    assert_eq!(ReferenceSettings::default().diffuse_orders, DiffuseOrders::ALL);
    for (s, min, max) in [("all", 0, None), ("0", 0, Some(0)), ("1", 1, Some(1)), ("1-2", 1, Some(2)), ("2-", 2, None)]
    {
        let o = orders(s);
        assert_eq!((o.min, o.max), (min, max), "{s}");
        assert_eq!(o.to_string(), s);
    }
    for bad in ["", "-", "-2", "2-1", "x", "1-x", "1--", "+1", "1.5", "all-"] {
        assert_eq!(DiffuseOrders::parse(bad), None, "{bad}");
    }
    let rs = ReferenceSettings { diffuse_orders: DiffuseOrders { min: 3, max: Some(2) }, ..Default::default() };
    let e = rs.validate().unwrap_err().to_string();
    assert!(e.contains("cpu.diffuse_orders"), "{e}");
}

/// `a` = the sum of `parts`, pixel by pixel, to float rounding.
fn assert_sum(what: &str, a: &Image, parts: &[&Image]) {
    let peak = a.pixels.iter().flatten().fold(0.0f32, |m, &v| m.max(v.abs()));
    for (i, p) in a.pixels.iter().enumerate() {
        for (k, &v) in p.iter().enumerate() {
            let s: f32 = parts.iter().map(|q| q.pixels[i][k]).sum();
            assert!((v - s).abs() <= 1e-5 * v.abs() + 1e-6 * peak, "{what}, pixel {i}: {v} vs {s}");
        }
    }
}

/// Disjoint ranges covering every order add up to `all`: the glass ball over its floor (camera
/// paths and caustic photons, and the deposits seen through the ball), in fog (order 0: light
/// scattered in the medium, and the photon beams), in a heterogeneous smoke puff (whose
/// transmittances draw random numbers), under a sky (order 0: the sky seen directly and through
/// the ball). The caustic maps do not move.
#[test]
fn disjoint_orders_add_up_to_all() {
    for name in ["glass_sphere", "glass_sphere_fog", "glass_sphere_sky", "smoke_puff"] {
        let s = catalogue(name, 32);
        let rs = ReferenceSettings {
            photons_per_light: 1 << 17,
            camera_spp: 2,
            caustic_map_size: 32,
            seed: 5,
            medium_beam_photons: 1 << 14,
            specular_view_photons: 1 << 14,
            ..Default::default()
        };
        let all = render(&s, &rs, "all");
        let parts: Vec<ReferenceOutput> = ["0", "1", "2-"].iter().map(|o| render(&s, &rs, o)).collect();
        let mut line = format!("{name}: all: nocaustic {:.4}, caustic {:.4}", sum(&all.nocaustic), sum(&all.caustic));
        for (o, p) in ["0", "1", "2-"].iter().zip(&parts) {
            line += &format!("; {o}: {:.4}, {:.4}", sum(&p.nocaustic), sum(&p.caustic));
            assert!(p.caustic_maps == all.caustic_maps, "{name} {o}: the caustic maps moved");
        }
        eprintln!("{line}");
        let nc: Vec<&Image> = parts.iter().map(|p| &p.nocaustic).collect();
        let c: Vec<&Image> = parts.iter().map(|p| &p.caustic).collect();
        assert_sum(&format!("{name} nocaustic"), &all.nocaustic, &nc);
        assert_sum(&format!("{name} caustic"), &all.caustic, &c);
        // Each scene has light of order 1 and 2 and up (the caustic off the floor through the
        // ball and back); order 0 exactly where the scene has a medium or a sky.
        let total = sum(&all.image);
        let share = |p: &ReferenceOutput| sum(&p.image) / total;
        assert!(share(&parts[1]) > 0.3, "{name}: order 1 {}", share(&parts[1]));
        assert!(share(&parts[2]) > 1e-4, "{name}: orders 2- {}", share(&parts[2]));
        if name == "glass_sphere" {
            assert_eq!(sum(&parts[0].image), 0.0, "{name}: order 0");
        } else {
            assert!(share(&parts[0]) > 0.01, "{name}: order 0 {}", share(&parts[0]));
        }
    }
}

/// Nothing bounces off one diffuse surface onto another in an open scene: a floor alone under a
/// point light, a diffuse ball alone. Orders 2 and up are black and order 1 is the whole image,
/// bit for bit.
#[test]
fn an_open_scene_has_no_light_of_order_two() {
    let light = r#"{ "type": "point", "position": [0.3, 2, 0.2], "intensity": [10, 10, 10] }"#;
    let rs =
        ReferenceSettings { photons_per_light: 1, camera_spp: 8, caustic_map_size: 8, seed: 2, ..Default::default() };
    let floor = scene(
        r#"{ "position": [0, 1.5, 3], "look_at": [0, 0, 0], "fov_y_deg": 50, "width": 32, "height": 32 }"#,
        light,
        0.8,
        r#"{ "type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [6, 6], "material": "wall" }"#,
    );
    let ball = scene(
        r#"{ "position": [0, 0.5, 3], "look_at": [0, 0, 0], "fov_y_deg": 40, "width": 32, "height": 32 }"#,
        light,
        0.8,
        r#"{ "type": "sphere", "center": [0, 0, 0], "radius": 0.7, "material": "wall" }"#,
    );
    for (name, s) in [("floor", floor), ("ball", ball)] {
        let all = render(&s, &rs, "all");
        let first = render(&s, &rs, "1");
        let rest = render(&s, &rs, "2-");
        eprintln!(
            "{name}: all {:.5}, order 1 {:.5}, orders 2- {:.3e}",
            sum(&all.image),
            sum(&first.image),
            sum(&rest.image)
        );
        assert!(sum(&all.image) > 0.0);
        assert!(rest.image.pixels.iter().flatten().all(|&v| v == 0.0), "{name}: orders 2- not black");
        assert!(first.image.pixels == all.image.pixels, "{name}: order 1 is not the whole image");
    }
}

/// Inside a closed diffuse sphere of albedo a with a point light of intensity I at its centre,
/// every point of the wall gets the irradiance E1 = I/R² straight from the light, and every
/// order is uniform: the form factor between two patches inside a sphere is dA/(4πR²) whatever
/// their places, so the wall lit uniformly with radiosity a·E_k gives every point the
/// irradiance E_{k+1} = a·E_k. Every pixel sees the radiance a·E_k/π of order k: order k+1 is a
/// times order k, pixel by pixel in expectation, and orders 2 and up are a/(1 − a) times order
/// 1 (to a^16, the path length limit). Order 1 is exact (no sample varies): a·I/(πR²).
///
/// The camera paths are the only estimator (no specular objects, no photons). With Russian
/// roulette by the albedo every continued path keeps the weight 1, so a path's orders 2- are
/// a·E1/π times the number N of further diffuse vertices, geometric: mean a/(1 − a), variance
/// a/(1 − a)². The tolerance is 4 standard deviations of the image sums, from the reference's
/// own per-pixel variance estimates (independent pixels; an over-estimate, the paths are
/// stratified): about 0.5 % for orders 2- and 0.2 % for order 2 alone at 64 × 64 × 16 paths.
#[test]
fn a_closed_white_sphere_gives_the_geometric_series() {
    let (a, i, r) = (0.5f64, 10.0f64, 1.0f64);
    let s = scene(
        r#"{ "position": [0.2, 0.1, 0.4], "look_at": [-0.5, -0.2, -1], "fov_y_deg": 70, "width": 64, "height": 64 }"#,
        r#"{ "type": "point", "position": [0, 0, 0], "intensity": [10, 10, 10] }"#,
        a as f32,
        r#"{ "type": "sphere", "center": [0, 0, 0], "radius": 1.0, "material": "wall" }"#,
    );
    let rs =
        ReferenceSettings { photons_per_light: 1, camera_spp: 16, caustic_map_size: 8, seed: 7, ..Default::default() };
    let npix = 64.0 * 64.0;
    let first = render(&s, &rs, "1");
    let expected1 = a * i / (std::f64::consts::PI * r * r);
    for p in first.image.pixels.iter().flatten() {
        assert!((*p as f64 / expected1 - 1.0).abs() < 1e-4, "order 1 pixel {p} vs {expected1}");
    }
    let s1 = sum(&first.image) / 3.0 / npix;
    // Mean pixel value (one channel: all three are the same) and the standard deviation of it.
    let mean_sigma = |o: &ReferenceOutput| {
        let m = sum(&o.image) / 3.0 / npix;
        let var: f64 = o.nocaustic_variance.pixels.iter().map(|v| v[0] as f64).sum();
        (m, var.sqrt() / npix)
    };
    let mut line = format!("closed sphere, albedo {a}: order 1 {s1:.6} (exact {expected1:.6})");
    let mut prev = s1;
    for k in 2..=4 {
        let (m, sigma) = mean_sigma(&render(&s, &rs, &k.to_string()));
        line += &format!("; order {k} / order {} = {:.4} ± {:.4}", k - 1, m / prev, sigma / prev);
        if k == 2 {
            assert!((m / s1 - a).abs() < 4.0 * sigma / s1, "order 2 / order 1 = {} (σ {})", m / s1, sigma / s1);
        }
        prev = m;
    }
    let (m, sigma) = mean_sigma(&render(&s, &rs, "2-"));
    let series = a / (1.0 - a);
    line += &format!("; orders 2- / order 1 = {:.4} ± {:.4} (a/(1 - a) = {series})", m / s1, sigma / s1);
    eprintln!("{line}");
    assert!(sigma / s1 < 0.01, "σ {}", sigma / s1);
    assert!(
        (m / s1 - series).abs() < 4.0 * sigma / s1,
        "orders 2- / order 1 = {} vs {series} (σ {})",
        m / s1,
        sigma / s1
    );
    // And all = 1 + 2- (the split is exact).
    let all = render(&s, &rs, "all");
    let ma = sum(&all.image) / 3.0 / npix;
    assert!((ma - (s1 + m)).abs() < 1e-5 * ma, "all {ma} vs {}", s1 + m);
}
