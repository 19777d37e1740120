//! Small golden images: the catalogue's analytic scenes rendered at 96 px wide, compared with the
//! stored EXR by HDR-FLIP and energy. On failure the actual image and a difference heat map are
//! written beside the golden file (`*.actual.png`, `*.difference.png`). To accept new output:
//! `CAUSTICS_ACCEPT_GOLDEN=1 cargo test --release --test gpu -- golden::`.

use crate::common;
use caustics::Scene;
use caustics::image_io::Image;
use caustics::render::{RenderSettings, render};
use caustics_reference::ImageIo as _;
use common::gpu;
use std::path::Path;

fn golden(name: &str) {
    let Some(ctx) = gpu() else { return };
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut s = Scene::load(&dir.join("../../scenes").join(format!("{name}.json"))).unwrap();
    s.camera.height = s.camera.height * 96 / s.camera.width;
    s.camera.width = 96;
    let settings = RenderSettings {
        photons: caustics::settings::PhotonSettings { count: 256, caustic_map_size: 256, ..Default::default() },
        shading: caustics::settings::ShadingSettings { shadow_map_size: 512, ..Default::default() },
        ..Default::default()
    };
    let out = render(&ctx, &s, &settings).unwrap();
    let path = dir.join("tests/golden").join(format!("{name}.exr"));
    if !path.exists() && std::env::var("CI").is_ok_and(|v| v == "true") {
        panic!("missing golden image {} (run with CAUSTICS_ACCEPT_GOLDEN=1 and commit it)", path.display());
    }
    if std::env::var("CAUSTICS_ACCEPT_GOLDEN").is_ok_and(|v| v == "1") || !path.exists() {
        out.image.write(&path, 1.0).unwrap();
        eprintln!("wrote golden image {}", path.display());
        return;
    }
    let want = Image::read(&path).unwrap();
    let flip = caustics_reference::metrics::hdr_flip(&out.image, &want, None).unwrap();
    let ratio = caustics_reference::metrics::energy_ratio(&out.image, &want, None).unwrap();
    if flip.mean > 0.02 || (ratio - 1.0).abs() > 0.01 {
        let actual = path.with_extension("actual.png");
        out.image.write(&actual, s.exposure).unwrap();
        caustics_reference::metrics::write_heatmap(
            &path.with_extension("difference.png"),
            &out.image,
            &want,
            None,
            &flip,
        )
        .unwrap();
        panic!(
            "{name}: FLIP {:.4}, energy ratio {ratio:.4} against {}; wrote {}",
            flip.mean,
            path.display(),
            actual.display()
        );
    }
}

#[test]
fn golden_glass_sphere() {
    golden("glass_sphere");
}

#[test]
fn golden_mirror_ring() {
    golden("mirror_ring");
}

#[test]
fn golden_two_spheres() {
    golden("two_spheres");
}
