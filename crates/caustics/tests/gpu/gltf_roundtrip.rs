//! A scene and its `caustics convert` glTF twin render the same bits on the GPU: meshes (a glass of water),
//! a heterogeneous fog (smoke_puff) and an environment-lit one, at 32².

use crate::common;
use caustics::Scene;
use caustics::render::{RenderSettings, render};
use common::gpu;
use std::path::Path;

fn settings() -> RenderSettings {
    RenderSettings {
        photons: caustics::settings::PhotonSettings { count: 64, caustic_map_size: 64, ..Default::default() },
        shading: caustics::settings::ShadingSettings { shadow_map_size: 128, ..Default::default() },
        medium: caustics::settings::MediumSettings { multiple_photons: 0, bounce_grid: 0, ..Default::default() },
        ..Default::default()
    }
}

#[test]
fn converted_scenes_render_the_same_bits() {
    let Some(ctx) = gpu() else { return };
    let dir = std::env::temp_dir().join(format!("caustics_gltf_roundtrip_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for name in ["glass_of_water", "smoke_puff", "glass_sphere_sky"] {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../../scenes/{name}.json"));
        let mut a = Scene::load(&path).unwrap();
        let out = dir.join(format!("{name}.glb"));
        caustics::scene::write_gltf(&a, &out).unwrap();
        let mut b = Scene::load(&out).unwrap();
        for s in [&mut a, &mut b] {
            s.camera.width = 32;
            s.camera.height = 32;
        }
        let t = std::time::Instant::now();
        let (ra, rb) = (render(&ctx, &a, &settings()).unwrap(), render(&ctx, &b, &settings()).unwrap());
        eprintln!("{name}: two renders in {:.1} s", t.elapsed().as_secs_f64());
        assert!(ra.image.pixels.iter().flatten().any(|x| *x > 0.0), "{name}: a black image proves nothing");
        let bits = |r: &caustics::GpuRender| -> Vec<[u32; 3]> {
            r.image.pixels.iter().map(|p| [p[0].to_bits(), p[1].to_bits(), p[2].to_bits()]).collect()
        };
        assert!(bits(&ra) == bits(&rb), "{name}: the converted scene renders other bits");
        assert!(ra.caustic_flux_bits == rb.caustic_flux_bits, "{name}: other caustic flux");
    }
    std::fs::remove_dir_all(&dir).ok();
}
