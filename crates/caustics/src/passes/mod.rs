//! The passes of a GPU frame, each named (the name is both the wgpu label and the timer name),
//! which [`crate::renderer::Renderer`] records:
//!
//! 1. `eye_receivers`, `eye_specular_front`, `eye_specular_back` and the camera's second layer:
//!    camera geometry buffers (`record_eye`);
//! 2. per light (`record_light`) and face: `light_shadow` (depth of everything),
//!    `light_receivers` (position and normal of diffuse surfaces), `light_caster_front`,
//!    `light_caster_back`, and where the scene has caster meshes and two casters or more the
//!    second caster layer `light_caster_front2`, `light_caster_back2` (`raster_peel`: per texel
//!    the nearest caster of another object behind the first); then `coverage_mip` and the
//!    technique's photon stage ([`crate::techniques`]), `caustic_resolve` (flux per texel to
//!    irradiance), the temporal filter, and the shading tiles (`caustic_mask`, `shadow_tiles`:
//!    per-tile summaries of the caustic and shadow maps that `shade_receivers` skips work by);
//! 3. `shade_receivers` per light (`record_shade`), then `composite` (image-space refraction
//!    and reflection), in scenes with a medium `medium_scatter` per light (attenuation and
//!    single scattering along the camera rays), and `display` (`record_composite`).
//!
//! This module holds the geometry buffers the passes draw (`GBuffer`; the frame's shared types
//! are in [`crate::frame`]); the passes live in `geometry` (uploads),
//! `raster` (pipelines and draw helpers), `eye` (camera and shading), `light`, `composite`
//! (composite, medium, display) and `dump`.

use crate::gpu::GpuContext;

const POS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

mod composite;
mod dump;
mod eye;
mod light;
mod raster;
mod validate;

pub(crate) use crate::geometry::{
    Geometry, density_view, material_records, object_transform, upload_density, upload_geometry,
};
pub(crate) use composite::{Composite, Composited, Display, EyeSegments};
pub use dump::{DumpImage, DumpKind};
pub(crate) use dump::{bytes_to_image, dump_images};
pub(crate) use eye::{Camera, Shading, shadow_sampler};
pub(crate) use light::{flux_stats, light_record, record_light};
pub(crate) use raster::{Raster, raster_pipelines};

pub(crate) use crate::frame::{DrawCtx, EyeFrame, FrameConsts, LightFrame};

fn texture(
    ctx: &GpuContext,
    label: &str,
    size: u32,
    size_y: u32,
    layers: u32,
    format: wgpu::TextureFormat,
) -> wgpu::Texture {
    let usage =
        wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_SRC;
    ctx.texture(label, wgpu::Extent3d { width: size, height: size_y, depth_or_array_layers: layers }, format, usage)
}

pub(crate) fn layer_view(ctx: &GpuContext, t: &wgpu::Texture, layer: u32) -> wgpu::TextureView {
    ctx.view(t, Some(wgpu::TextureViewDimension::D2), layer, Some(1))
}

pub(crate) fn array_view(ctx: &GpuContext, t: &wgpu::Texture) -> wgpu::TextureView {
    ctx.view(t, Some(wgpu::TextureViewDimension::D2Array), 0, None)
}

/// A geometry buffer: position + object id, normal, depth; `layers` faces.
pub(crate) struct GBuffer {
    pub pos: wgpu::Texture,
    pub nrm: wgpu::Texture,
    pub depth: wgpu::Texture,
}

impl GBuffer {
    fn new(ctx: &GpuContext, label: &str, w: u32, h: u32, layers: u32) -> GBuffer {
        GBuffer {
            pos: texture(ctx, &format!("{label}_position"), w, h, layers, POS_FORMAT),
            nrm: texture(ctx, &format!("{label}_normal"), w, h, layers, POS_FORMAT),
            depth: texture(ctx, &format!("{label}_depth"), w, h, layers, DEPTH_FORMAT),
        }
    }
}
