//! The CPU reference against the ground-truth images in `references/` (rendered by Mitsuba 3
//! from `scenes/a_glass_sphere.json` and `scenes/b_mirror_ring.json`).
//!
//! On the pixels outside the specular mask (where the references lack caustics seen through
//! glass or in a mirror):
//! - energy (sum over pixels and channels) of the full, caustic and non-caustic images within
//!   3% of the reference;
//! - mean HDR-FLIP of the full image below 0.05;
//! - a per-pixel z-test on luminance, z = (cpu - ref) / sqrt(var_cpu + var_ref + (0.01 ref)²),
//!   with var_cpu the renderer's own per-pixel variance estimate and var_ref from the
//!   reference's stated relative noise: at most 0.5% of pixels beyond |z| > 4 and mean z² below 2
//!   (1 for pure noise; the 1% term allows for the scene reconstruction's residuals).

use caustics::Scene;
use caustics::image_io::Image;
use caustics_reference::ImageIo as _;
use caustics_reference::metrics::{self, Mask};
use caustics_reference::reference::{self, ReferenceSettings};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn noise(json: &serde_json::Value, key: &str) -> f64 {
    json["noise_estimate"][key].as_f64().unwrap()
}

fn check(name: &str) {
    let scene_path = root().join(format!("scenes/{name}.json"));
    if !scene_path.exists() {
        eprintln!("SKIPPED: {} does not exist", scene_path.display());
        return;
    }
    let scene = Scene::load(&scene_path).unwrap();
    let refs = root().join("references");
    let info: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(refs.join(format!("{name}.json"))).unwrap()).unwrap();
    let settings = ReferenceSettings {
        photons_per_light: 4_000_000,
        camera_spp: 16,
        max_depth: 64,
        seed: 7,
        caustic_map_size: 64,
        medium_single_scattering_only: false,
        ..Default::default()
    };
    let out = reference::render(&scene, &settings).unwrap();
    println!("{name}: {}", out.stats);
    let mask = Mask::read(&refs.join(format!("{name}_specmask.png")), true).unwrap();
    let full = Image::read(&refs.join(format!("{name}.exr"))).unwrap();
    let caustic = Image::read(&refs.join(format!("{name}_caustic.exr"))).unwrap();
    let nocaustic = Image::read(&refs.join(format!("{name}_nocaustic.exr"))).unwrap();
    let rel_c = noise(&info, "caustic_rel_rms_in_caustic_pixels");
    let rel_f = noise(&info, "full_rel_rms_non_specular_pixels");
    let ref_var = |img: &Image, rel: f64| Image {
        width: img.width,
        height: img.height,
        pixels: img.pixels.iter().map(|p| p.map(|c| ((c as f64 * rel).powi(2)) as f32)).collect(),
    };
    let mut full_var = out.caustic_variance.clone();
    for (v, w) in full_var.pixels.iter_mut().zip(&out.nocaustic_variance.pixels) {
        for k in 0..3 {
            v[k] += w[k];
        }
    }
    // Differences below 0.1% of the mean non-specular luminance are not tested.
    let abs_tol = 1e-3 * metrics::energy(&full, Some(&mask)) / 3.0 / mask.count() as f64;
    let mut failures = Vec::new();
    for (what, mine, var, theirs, rel) in [
        ("full", &out.image, &full_var, &full, rel_f),
        ("caustic", &out.caustic, &out.caustic_variance, &caustic, rel_c),
        ("nocaustic", &out.nocaustic, &out.nocaustic_variance, &nocaustic, rel_f),
    ] {
        let e = metrics::energy_ratio(mine, theirs, Some(&mask)).unwrap();
        let var = metrics::spread_variance(var, 3);
        let z =
            metrics::z_test(mine, Some(&var), theirs, Some(&ref_var(theirs, rel)), Some(&mask), 0.01, abs_tol).unwrap();
        let flip = metrics::hdr_flip(mine, theirs, Some(&mask)).unwrap().mean;
        println!(
            "{name} {what:>9}: energy ratio {e:.5}, FLIP {flip:.4}, z-test: mean z² {:.3}, |z|>3 {:.3}%, |z|>4 {:.3}%, |z|>5 {:.3}% of {} px",
            z.mean_z2,
            100.0 * z.frac_over_3,
            100.0 * z.frac_over_4,
            100.0 * z.frac_over_5,
            z.pixels
        );
        if (e - 1.0).abs() > 0.03 {
            failures.push(format!("{what}: energy ratio {e}"));
        }
        if z.frac_over_4 > 0.005 || z.mean_z2 > 2.0 {
            failures.push(format!("{what}: z-test {z:?}"));
        }
        if what == "full" && flip > 0.05 {
            failures.push(format!("{what}: mean FLIP {flip}"));
        }
    }
    assert!(failures.is_empty(), "{name}: {failures:#?}");
}

#[test]
fn a_glass_sphere_matches_reference() {
    check("a_glass_sphere");
}

#[test]
fn b_mirror_ring_matches_reference() {
    check("b_mirror_ring");
}
