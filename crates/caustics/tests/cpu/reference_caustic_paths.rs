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
        include_str!("../../../../scenes/glass_sphere.json"),
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

#[test]
fn deposits_gathered_through_glass_agree_with_light_tracing() {
    // The floor caustic the camera sees through the ball (light -> glass -> floor -> glass ->
    // camera) comes from the deposits of `reference::view_photons`, gathered at the camera
    // path's first diffuse vertex after a specular chain; light tracing cannot connect through
    // glass. The estimate is checked where both apply: the caustic seen directly, once by the
    // photons' camera connections and once by the camera rays gathering the deposits
    // (`gather_direct`). The built-in glass ball over its floor, 48 x 48.
    let s = ReferenceSettings {
        photons_per_light: 1 << 21,
        camera_spp: 16,
        specular_view_photons: 1 << 20,
        ..settings(CausticPaths::All)
    };
    let tracing = reference::render(&scene(), &s).unwrap();
    let gathered = reference::render(&scene(), &ReferenceSettings { gather_direct: true, ..s.clone() }).unwrap();
    let none =
        reference::render(&scene(), &ReferenceSettings { gather_direct: true, specular_view_photons: 0, ..s.clone() })
            .unwrap();
    let (a, b) = (sum(&tracing.caustic), sum(&gathered.caustic));
    println!("floor caustic: light tracing {a:.5}, deposits {b:.5}, ratio {:.4}", b / a);
    // Measured: 1.005; the blocks within 1 %.
    assert!(a > 0.0 && (b / a - 1.0).abs() < 0.02, "{b} vs {a}");
    // Without the deposits that setting leaves the floor caustic out.
    assert!(sum(&none.caustic) < 0.05 * a, "{}", sum(&none.caustic));
    // By 8-pixel blocks holding a tenth of the image's caustic or more.
    let w = 48usize;
    let block = |img: &caustics::image_io::Image, bx: usize, by: usize| -> f64 {
        (0..8)
            .flat_map(|y| (0..8).map(move |x| (x, y)))
            .map(|(x, y)| img.pixels[(by * 8 + y) * w + bx * 8 + x][1] as f64)
            .sum()
    };
    for by in 0..6 {
        for bx in 0..6 {
            let (p, q) = (block(&tracing.caustic, bx, by), block(&gathered.caustic, bx, by));
            if p > 0.1 * a / 3.0 {
                println!("block ({bx}, {by}): light tracing {p:.5}, deposits {q:.5}");
                assert!((q / p - 1.0).abs() < 0.05, "block ({bx}, {by}): {q} vs {p}");
            }
        }
    }
    // The default rendering now shows the floor caustic through the ball, which light tracing
    // alone left black: what the deposits add lies inside the ball's disk on the image, and
    // nowhere clearly outside it.
    let plain = reference::render(&scene(), &ReferenceSettings { specular_view_photons: 0, ..s }).unwrap();
    let sc = scene();
    let cam = CamProj::new(&sc.camera);
    let (center, radius) = match sc.objects[0].shape {
        caustics::scene::Shape::Sphere { center, radius } => (center, radius),
        _ => panic!("the built-in scene's first object is its ball"),
    };
    let (mut inside, mut outside) = (0.0f64, 0.0f64);
    for y in 0..48u32 {
        for x in 0..48u32 {
            let d = sc.camera.ray_dir(x as f32 + 0.5, y as f32 + 0.5);
            // The pixel's ray meets the ball where its distance to the centre is under R.
            let oc = center - cam.pos;
            let miss = (oc - d * oc.dot(d)).length();
            let i = (y * 48 + x) as usize;
            let added = (tracing.caustic.pixels[i][1] - plain.caustic.pixels[i][1]) as f64;
            // (pixels on the disk's rim, partly the ball's, are left out)
            if miss < radius {
                inside += added
            } else if miss > 1.1 * radius {
                outside += added.abs()
            }
        }
    }
    println!(
        "the caustic through the ball: {inside:.4} ({:.2} % of the image's), elsewhere {outside:.2e}",
        inside / a * 100.0
    );
    assert!(inside > 0.01 * a && outside < 1e-6 * a, "{inside} {outside}");
}
