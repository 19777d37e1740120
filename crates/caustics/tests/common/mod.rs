//! Shared by the GPU test files.

use caustics::gpu::GpuContext;
use std::sync::OnceLock;

/// The GPU, or `None` with a printed reason when there is no adapter; in CI (`CI=true`) a
/// missing adapter fails the test instead. One device per test binary: its clones share the
/// pipelines, so a binary compiles each shader once.
pub fn gpu() -> Option<GpuContext> {
    static CTX: OnceLock<Result<GpuContext, String>> = OnceLock::new();
    match CTX.get_or_init(|| GpuContext::new(None).map_err(|e| e.to_string())) {
        Ok(c) => Some(c.clone()),
        Err(e) => {
            if std::env::var("CI").is_ok_and(|v| v == "true") {
                panic!("CI requires a GPU adapter (install mesa-vulkan-drivers): {e}");
            }
            eprintln!("skipping GPU test: {e}");
            None
        }
    }
}

/// The CPU reference's settings for the medium tests: single scattering only, `photons` light
/// paths per light, `spp` camera samples per pixel, `seed`; paths up to 8 specular interactions;
/// the caustic maps (not compared by these tests) at 8².
#[allow(dead_code)]
pub fn single_scattering_reference(
    photons: u64,
    spp: u32,
    seed: u64,
) -> caustics_reference::reference::ReferenceSettings {
    caustics_reference::reference::ReferenceSettings {
        photons_per_light: photons,
        camera_spp: spp,
        max_depth: 8,
        seed,
        caustic_map_size: 8,
        medium_single_scattering_only: true,
        ..Default::default()
    }
}

/// What a renderer creates in one frame (its pool's new resources): encode, submit.
#[allow(dead_code)]
pub fn created_by_a_frame(r: &mut caustics::renderer::Renderer) -> u64 {
    let ctx = r.context().clone();
    let before = r.created();
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    r.encode(&mut enc, caustics::renderer::FrameRequest { stats: false }).unwrap();
    let created = (r.created() - before).total();
    ctx.queue.submit([enc.finish()]);
    created
}
