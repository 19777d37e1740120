//! Shared by the GPU test files.

use caustics::gpu::GpuContext;

/// The GPU, or `None` with a printed reason when there is no adapter; in CI (`CI=true`) a
/// missing adapter fails the test instead.
pub fn gpu() -> Option<GpuContext> {
    match GpuContext::new(None) {
        Ok(c) => Some(c),
        Err(e) => {
            if std::env::var("CI").is_ok_and(|v| v == "true") {
                panic!("CI requires a GPU adapter (install mesa-vulkan-drivers): {e}");
            }
            eprintln!("skipping GPU test: {e}");
            None
        }
    }
}
