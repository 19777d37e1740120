//! The reference's switch between caustic path classes (`ReferenceSettings::caustic_paths`,
//! `CausticPaths`): the restricted camera image holds exactly the photons' first diffuse hits
//! seen by the camera (L S+ D E, the GPU's class), the rest holds the other connections, and
//! the two add up to the default image; the maps and the non-caustic image do not move.

use caustics::Scene;
use caustics_reference::reference::trace::CamProj;
use caustics_reference::reference::{self, CausticPaths, ReferenceSettings};
use glam::Vec3;
use std::f32::consts::PI;

fn scene() -> Scene {
    let mut s = Scene::from_json(
        include_str!("../../../scenes/glass_sphere.json"),
        "<test>",
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes").as_path(),
    )
    .unwrap();
    s.camera.width = 48;
    s.camera.height = 48;
    s
}

fn settings(paths: CausticPaths) -> ReferenceSettings {
    ReferenceSettings {
        photons_per_light: 200_000,
        camera_spp: 1,
        caustic_map_size: 64,
        seed: 3,
        caustic_paths: paths,
        ..Default::default()
    }
}

fn sum(img: &caustics::image_io::Image) -> f64 {
    img.pixels.iter().flatten().map(|&v| v as f64).sum()
}

#[test]
fn first_diffuse_and_rest_split_the_caustic_image_exactly() {
    let sc = scene();
    let all = reference::render(&sc, &settings(CausticPaths::All)).unwrap();
    let first = reference::render(&sc, &settings(CausticPaths::FirstDiffuse)).unwrap();
    let rest = reference::render(&sc, &settings(CausticPaths::Rest)).unwrap();
    // The default is All, and the switch does not touch the maps or the camera paths.
    assert_eq!(ReferenceSettings::default().caustic_paths, CausticPaths::All);
    for o in [&first, &rest] {
        assert!(o.caustic_maps[0][0].pixels == all.caustic_maps[0][0].pixels);
        assert!(o.nocaustic.pixels == all.nocaustic.pixels);
    }
    // Photon by photon the same paths: all = first + rest, pixel by pixel (float rounding of
    // the sums aside).
    let peak = all.caustic.pixels.iter().flatten().fold(0.0f32, |m, &v| m.max(v));
    for ((a, f), r) in all.caustic.pixels.iter().zip(&first.caustic.pixels).zip(&rest.caustic.pixels) {
        for k in 0..3 {
            assert!((a[k] - (f[k] + r[k])).abs() <= 1e-5 * a[k] + 1e-7 * peak, "{a:?} vs {f:?} + {r:?}");
        }
    }
    // The rest (caustic light off the floor, through or off the ball and back onto the floor)
    // is there, and small.
    let (sa, sr) = (sum(&all.caustic), sum(&rest.caustic));
    eprintln!(
        "caustic image: all {sa:.4}, first diffuse {:.4}, rest {sr:.4} ({:.2} %)",
        sum(&first.caustic),
        100.0 * sr / sa
    );
    assert!(sr > 0.0 && sr < 0.2 * sa, "rest {sr} of {sa}");
}

/// The restricted image, rebuilt independently from the first diffuse hits
/// (`reference::caustic_deposits`, the same photons): each hit the camera sees (visibility
/// against the ball in closed form) splats `Φ a/π cos θx / (d² A_pix cos³ θc)` into its pixel.
#[test]
fn first_diffuse_is_the_splat_of_the_first_diffuse_hits() {
    let sc = scene();
    let rs = settings(CausticPaths::FirstDiffuse);
    let first = reference::render(&sc, &rs).unwrap();
    let deposits = reference::caustic_deposits(&sc, &rs, 0).unwrap();
    let cam = CamProj::new(&sc.camera);
    let c = &sc.camera;
    let tan_y = (c.fov_y_deg.to_radians() * 0.5).tan();
    let tan_x = tan_y * c.aspect();
    let pix_area = (2.0 * tan_x / c.width as f32) * (2.0 * tan_y / c.height as f32);
    let (centre, radius, albedo) = (Vec3::new(0.0, 0.9, 0.0), 0.5f32, 0.8f32);
    let mut img = vec![[0.0f64; 3]; (c.width * c.height) as usize];
    for d in &deposits {
        let to = cam.pos - d.position;
        let dist2 = to.length_squared();
        let dir = to / dist2.sqrt();
        if dir.dot(d.normal) <= 0.0 {
            continue;
        }
        // The segment to the camera against the ball.
        let w = d.position - centre;
        let b = w.dot(dir);
        let disc = b * b - (w.length_squared() - radius * radius);
        if disc > 0.0 && -b - disc.sqrt() > 0.0 {
            continue;
        }
        let Some((pix, cos_c)) = cam.project(-dir) else { continue };
        let v = d.flux * albedo * (dir.dot(d.normal) / (dist2 * pix_area * cos_c.powi(3)) / PI);
        for k in 0..3 {
            img[pix as usize][k] += v[k] as f64;
        }
    }
    let (mut diff, mut total) = (0.0f64, 0.0f64);
    for (a, b) in first.caustic.pixels.iter().zip(&img) {
        for k in 0..3 {
            diff += (a[k] as f64 - b[k]).abs();
            total += b[k];
        }
    }
    eprintln!(
        "{} first diffuse hits; restricted image {:.5}, rebuilt {total:.5}, L1 difference {diff:.2e}",
        deposits.len(),
        sum(&first.caustic)
    );
    assert!(total > 0.0);
    assert!(diff <= 1e-5 * total, "L1 difference {diff} of {total}");
}
