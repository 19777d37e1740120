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

mod composite;
mod dump;
mod eye;
mod light;
mod photon_maps;
mod raster;
mod validate;

pub(crate) use crate::geometry::{Geometry, material_records, object_transform, upload_geometry};
pub(crate) use composite::{Composite, Display};
pub use dump::{DumpImage, DumpKind};
pub(crate) use dump::{bytes_to_image, dump_images};
pub(crate) use eye::{Camera, Shading, shadow_sampler};
pub(crate) use light::{LightJob, flux_stats, light_record, record_light};
pub(crate) use photon_maps::PhotonMaps;
pub(crate) use raster::raster_pipelines;

pub(crate) use crate::frame::{Composited, DrawCtx, EyeFrame, EyeSegments, FrameConsts, GBuffer, LightFrame};
use crate::frame::{DEPTH_FORMAT, POS_FORMAT, texture};

pub(crate) fn layer_view(ctx: &GpuContext, t: &wgpu::Texture, layer: u32) -> wgpu::TextureView {
    ctx.view(t, Some(wgpu::TextureViewDimension::D2), layer, Some(1))
}

pub(crate) fn array_view(ctx: &GpuContext, t: &wgpu::Texture) -> wgpu::TextureView {
    ctx.view(t, Some(wgpu::TextureViewDimension::D2Array), 0, None)
}
