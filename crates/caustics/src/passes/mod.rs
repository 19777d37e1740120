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
//! This module holds what the passes share (the uploaded `Geometry`, `GBuffer`, `DrawCtx`,
//! `FrameConsts`, `EyeFrame`, `LightFrame`); the passes live in `geometry` (uploads),
//! `raster` (pipelines and draw helpers), `eye` (camera and shading), `light`, `composite`
//! (composite, medium, display) and `dump`.

use crate::gpu::GpuContext;
use crate::scene::{Material, Scene};
use crate::settings::{MAX_GBUFFER, RenderSettings, Technique};
use glam::Mat4;

const POS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

mod composite;
mod dump;
mod eye;
mod light;
mod raster;
mod validate;

pub(crate) use crate::geometry::{Geometry, material_records, object_transform, upload_geometry};
pub(crate) use composite::{Composited, EyeSegments, record_composite, record_display};
pub use dump::{DumpImage, DumpKind};
pub(crate) use dump::{bytes_to_image, dump_images};
pub(crate) use eye::{record_eye, record_shade, shadow_sampler};
pub(crate) use light::{flux_stats, light_record, record_light};
pub(crate) use raster::raster_pipelines;

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

pub(crate) struct DrawCtx<'a> {
    pub ctx: &'a GpuContext,
    pub geo: &'a Geometry,
    pub scene: &'a Scene,
}

/// What the passes of a frame share, derived from the scene and the settings.
pub(crate) struct FrameConsts {
    /// Photon grid N, caster buffer size G, caustic map size M.
    pub n: u32,
    pub g: u32,
    pub m: u32,
    /// The light's second caster layer is drawn.
    pub layer2: bool,
    /// 0: no search for a second caster; 1: analytic casters only; 2: mesh casters too.
    pub multi_bounce: f32,
    pub caster_radius: f32,
    /// The reflected branch at glass is traced.
    pub reflect_branch: bool,
    /// Trace the branch reflected once inside a dielectric (exact tracer).
    pub internal_branch: bool,
    /// Trace the residual pass (exact tracer).
    pub residual_branch: bool,
    /// The caustics of directional lights come from caustic spheres: their photon stages are
    /// skipped (set by the renderer for `Technique::CausticSpheres`).
    pub caustic_spheres: bool,
}

impl FrameConsts {
    pub fn new(scene: &Scene, s: &RenderSettings) -> FrameConsts {
        // The light's second caster layer: only for scenes with caster meshes (analytic casters
        // met after the first are intersected exactly, and scenes without meshes keep their
        // maps) and at least two casters (the peel keeps other objects only: one caster leaves
        // it empty).
        let casters: Vec<_> =
            scene.objects.iter().filter(|o| o.caustic_caster && scene.material_of(o).is_specular()).collect();
        let meshes = casters.iter().any(|o| matches!(o.shape, crate::scene::Shape::Mesh(_)));
        let layer2 = s.testing.light_second_layer && casters.len() >= 2 && meshes;
        // Whether a photon leaving a caster can meet a caster again: not for a lone convex
        // caster (a sphere), where the search would only cost time.
        let multi_bounce = if casters.len() == 1 && matches!(casters[0].shape, crate::scene::Shape::Sphere { .. }) {
            0.0
        } else if meshes {
            2.0
        } else {
            1.0
        };
        FrameConsts {
            n: s.photons.count,
            g: s.photons.count.min(MAX_GBUFFER),
            m: s.photons.caustic_map_size,
            layer2,
            multi_bounce,
            caster_radius: scene.caster_bounds().map_or(1.0, |(a, b)| (b - a).length() * 0.5),
            reflect_branch: s.photons.reflection
                && scene
                    .objects
                    .iter()
                    .any(|o| o.caustic_caster && matches!(scene.material_of(o), Material::Dielectric { .. })),
            internal_branch: s.photons.internal_reflection
                && s.photons.tracer == crate::settings::Tracer::Exact
                && scene.objects.iter().any(|o| matches!(scene.material_of(o), Material::Dielectric { .. })),
            residual_branch: s.photons.residual
                && s.photons.tracer == crate::settings::Tracer::Exact
                && scene.objects.iter().any(|o| matches!(scene.material_of(o), Material::Dielectric { .. })),
            caustic_spheres: s.photons.technique == Technique::CausticSpheres,
        }
    }
}

/// The camera's geometry buffers and the frame's radiance accumulators.
pub(crate) struct EyeFrame {
    pub recv: GBuffer,
    pub front: GBuffer,
    pub back: GBuffer,
    pub front2: GBuffer,
    pub back2: GBuffer,
    pub cam_clip: Mat4,
    /// Radiance of the diffuse surfaces, all light and caustic light only (vec4 per pixel).
    pub radiance: wgpu::Buffer,
    pub caustic: wgpu::Buffer,
}

/// What a light's passes made: kept (in the light's resource scope) for the frames that do not
/// redo them.
pub(crate) struct LightFrame {
    pub light_buf: wgpu::Buffer,
    pub faces: u32,
    /// The faces photons (and beams) start from: all but a spot's spill face, the last.
    pub emit_faces: u32,
    pub scale: f64,
    pub shadow: wgpu::Texture,
    pub recv: GBuffer,
    pub casters: (GBuffer, GBuffer),
    pub casters2: Option<(GBuffer, GBuffer)>,
    /// Fixed-point flux per texel (r, g, b as 64-bit words), irradiance (vec4 per texel), and
    /// the flux bookkeeping (six 64-bit sums).
    pub accum: wgpu::Buffer,
    pub irradiance: wgpu::Buffer,
    pub stats: wgpu::Buffer,
    /// The irradiance as an M × M × faces Rgba32Float texture (the renderer's output).
    pub irradiance_tex: wgpu::Texture,
    /// Per tile of the caustic map, whether it holds light (`caustic_mask`), and per tile of
    /// the shadow map its depth range (`shadow_tiles`), for `shade_receivers`.
    pub caustic_mask: wgpu::Buffer,
    pub shadow_tiles: wgpu::Buffer,
}
