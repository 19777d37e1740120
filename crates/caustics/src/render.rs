//! One-shot rendering: a [`crate::renderer::Renderer`] made for one frame, with everything read
//! back (the command line, the tests and the benchmarks). Engines drive the renderer itself.

use crate::error::Result;
use crate::gpu::GpuContext;
use crate::scene::Scene;

pub use crate::output::{FluxStats, GpuRender};
pub use crate::passes::{DumpImage, DumpKind};
pub use crate::settings::{
    BeamVolume, DistantSource, Emission, Inspect, LocalSource, RenderSettings, SourceSettings, SpillFaces, SplatMode,
    Technique, Tracer, VolumeSource,
};
pub use crate::techniques::{LevelStats, TechniqueStats};

/// Render `scene` once on the GPU: a [`crate::renderer::Renderer`] made for one frame, with
/// everything read back.
pub fn render(ctx: &GpuContext, scene: &Scene, s: &RenderSettings) -> Result<GpuRender> {
    crate::renderer::Renderer::with_context(ctx.clone(), scene.clone(), s.clone())?.render_once()
}

/// [`render`], also copying out what `inspect` asks for (in [`GpuRender::technique`]).
pub fn render_inspect(ctx: &GpuContext, scene: &Scene, s: &RenderSettings, inspect: Inspect) -> Result<GpuRender> {
    let mut r = crate::renderer::Renderer::with_context(ctx.clone(), scene.clone(), s.clone())?;
    r.set_inspect(inspect);
    r.render_once()
}

/// [`render`], and the frame's light-space buffers as images ([`DumpImage`]).
pub fn render_dump(ctx: &GpuContext, scene: &Scene, s: &RenderSettings) -> Result<(GpuRender, Vec<DumpImage>)> {
    let mut r = crate::renderer::Renderer::with_context(ctx.clone(), scene.clone(), s.clone())?;
    let out = r.render_once()?;
    let dump = r.dump_images(&out.caustic_maps)?;
    Ok((out, dump))
}
