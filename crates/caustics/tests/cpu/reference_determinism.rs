//! Determinism, convergence and the variance estimate of the CPU reference.

use caustics::Scene;
use caustics_reference::metrics;
use caustics_reference::reference::{self, ReferenceOutput, ReferenceSettings};
use std::path::Path;

fn small_scene(name: &str, size: u32) -> Scene {
    let mut s = Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../../scenes/{name}.json"))).unwrap();
    s.camera.width = size;
    s.camera.height = size;
    s
}

fn render_with_threads(scene: &Scene, settings: &ReferenceSettings, threads: usize) -> ReferenceOutput {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(|| reference::render(scene, settings).unwrap())
}

#[test]
fn same_seed_same_image_whatever_the_thread_count() {
    let scene = small_scene("glass_bunny", 48);
    let s = ReferenceSettings {
        photons_per_light: 100_000,
        camera_spp: 2,
        max_depth: 16,
        seed: 3,
        caustic_map_size: 32,
        medium_single_scattering_only: false,
        ..Default::default()
    };
    let a = render_with_threads(&scene, &s, 1);
    let b = render_with_threads(&scene, &s, 3);
    assert_eq!(a.stats.threads, 1);
    assert_eq!(b.stats.threads, 3);
    assert_eq!(a.image, b.image);
    assert_eq!(a.caustic, b.caustic);
    assert_eq!(a.caustic_variance, b.caustic_variance);
    assert_eq!(a.caustic_maps, b.caustic_maps);
    assert_eq!(a.stats.rays, b.stats.rays);
    assert!(a.caustic.sum() > 0.0);
    // A different seed gives a different (but statistically equal) image.
    let c = render_with_threads(&scene, &ReferenceSettings { seed: 4, ..s.clone() }, 2);
    assert_ne!(a.caustic, c.caustic);
    // The maps alone are the same as the maps of a full render.
    let maps = reference::caustic_maps(&scene, &s).unwrap();
    assert_eq!(maps, a.caustic_maps);
}

#[test]
fn more_photons_less_noise_and_the_variance_estimate_is_calibrated() {
    let scene = small_scene("glass_sphere", 64);
    let base = ReferenceSettings {
        photons_per_light: 200_000,
        camera_spp: 1,
        max_depth: 16,
        seed: 0,
        caustic_map_size: 32,
        medium_single_scattering_only: false,
        // The light tracing's variance is the one checked: the caustic seen through the ball,
        // gathered from a separate set of deposits, has no batch variance (its noise is the
        // deposits', which `caustic_variance` does not estimate).
        specular_view_photons: 0,
        ..Default::default()
    };
    let truth =
        reference::render(&scene, &ReferenceSettings { photons_per_light: 12_800_000, ..base.clone() }).unwrap();
    let mut errs = Vec::new();
    for (i, n) in [200_000u64, 800_000, 3_200_000].into_iter().enumerate() {
        let o =
            reference::render(&scene, &ReferenceSettings { photons_per_light: n, seed: 10 + i as u64, ..base.clone() })
                .unwrap();
        let e = metrics::rmse(&o.caustic, &truth.caustic, None).unwrap();
        // Against an (almost) noise-free image, z² should average about 1 where light is.
        let mask = metrics::Mask {
            width: 64,
            height: 64,
            include: truth.caustic.pixels.iter().map(|p| p[1] > 0.05).collect(),
        };
        let z = metrics::z_test(
            &o.caustic,
            Some(&o.caustic_variance),
            &truth.caustic,
            Some(&truth.caustic_variance),
            Some(&mask),
            0.0,
            1e-9,
        )
        .unwrap();
        println!("{n} photons: RMSE {e:.5}, z-test {z:?}");
        assert!(z.pixels > 100);
        assert!(z.mean_z2 > 0.3 && z.mean_z2 < 3.0, "variance estimate off: {z:?}");
        errs.push(e);
    }
    // Four times the photons: about half the error.
    assert!(errs[1] < 0.7 * errs[0] && errs[2] < 0.7 * errs[1], "{errs:?}");
}
