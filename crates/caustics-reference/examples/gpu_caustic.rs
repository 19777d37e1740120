//! The GPU's camera caustic image (`RenderOutput::caustic`) of a scene with the exact tracer,
//! camera clamped to 320 px as `tracers` does, with or without the residual pass, for diagnosis
//! against a saved reference caustic (`caustics compare`).
//!
//! `cargo run --release -p caustics-reference --example gpu_caustic -- SCENE GRID MAP
//!  residual|no-residual OUT.exr [SPLAT]`
use caustics::render::{RenderSettings, Technique, Tracer};
use caustics_reference::ImageIo as _;

fn main() {
    let a: Vec<String> = std::env::args().skip(1).collect();
    assert!(a.len() == 5 || a.len() == 6, "usage: gpu_caustic SCENE GRID MAP residual|no-residual OUT.exr [SPLAT]");
    let mut scene = caustics::Scene::load(std::path::Path::new(&a[0])).expect("scene");
    scene.camera.width = scene.camera.width.min(320);
    scene.camera.height = scene.camera.height.min(320);
    let ctx = caustics::gpu::GpuContext::new(None).expect("a GPU adapter");
    let s = RenderSettings {
        photons: caustics::settings::PhotonSettings {
            count: a[1].parse().unwrap(),
            caustic_map_size: a[2].parse().unwrap(),
            technique: Technique::Basic,
            tracer: Tracer::Exact,
            residual: a[3] == "residual",
            ..Default::default()
        },
        shading: caustics::settings::ShadingSettings { shadow_map_size: 1024, ..Default::default() },
        ..Default::default()
    };
    let s = match a.get(5) {
        Some(m) => RenderSettings {
            photons: caustics::settings::PhotonSettings {
                splat: caustics::splat::SplatMode::parse(m).expect("a splat mode"),
                ..s.photons
            },
            ..s
        },
        None => s,
    };
    let out = caustics::render::render(&ctx, &scene, &s).expect("gpu render");
    let f = &out.flux[0];
    eprintln!(
        "{:?}: landed {:.4}, untraced {:.4} of emitted",
        a[3],
        f.landed / f.emitted,
        f.untraced_branches / f.emitted
    );
    out.caustic.write(std::path::Path::new(&a[4]), 1.0).unwrap();
}
