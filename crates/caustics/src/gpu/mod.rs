//! The GPU side: device creation, shader loading, timing and readback. Techniques live in
//! [`crate::render()`].

pub(crate) mod pass;
pub mod pool;
#[doc(hidden)]
pub mod types;

mod context;
mod layout;
mod resources;
mod stages;
mod timer;

pub use context::{GpuContext, list_adapters};
pub(crate) use layout::SCENE_GROUP;
pub use layout::{render_stage_bindings, stage_bindings};
pub use pool::ResourceCounts;
use stages::parse_stage;
pub use stages::{COMMON_WGSL, SHARED, STAGES, stage_source, validate_stage};
pub use timer::PassTimer;

/// A storage buffer (zeroed; at least 16 bytes) of the open scope.
pub(crate) fn storage(ctx: &GpuContext, label: &str, size: u64, extra: wgpu::BufferUsages) -> wgpu::Buffer {
    ctx.buffer(label, size.max(16), wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | extra)
}

pub(crate) fn uniform(ctx: &GpuContext, label: &str, bytes: &[u8]) -> wgpu::Buffer {
    ctx.uniform(label, bytes)
}
