//! Participating medium records: scattering, bounce lights (VPLs), surface and volume bounce,
//! eye segments and the point emitters.

use bytemuck::{Pod, Zeroable};

/// `medium_scatter` (shaders/medium_scatter.wgsl).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct MediumParams {
    pub clip_to_world: [[f32; 4]; 4],
    pub camera: [f32; 4],
    pub lo: [f32; 4],
    pub hi: [f32; 4],
    /// rgb = sigma_s, w = Henyey-Greenstein g (0: isotropic).
    pub sigma_s: [f32; 4],
    /// rgb = sigma_t.
    pub sigma_t: [f32; 4],
    pub width: u32,
    pub height: u32,
    pub steps: u32,
    /// Bit 0: attenuate the image first; bit 1: add this light's in-scattering.
    pub flags: u32,
    pub shadow_size: u32,
    /// 1: heterogeneous medium (read the density grid), 0: homogeneous.
    pub grid: u32,
    /// Heterogeneous: ray-march steps of each transmittance toward the light.
    pub light_steps: u32,
    pub _pad: u32,
}

/// `medium_bounce_lights` and `medium_bounce_shafts` (shaders/medium_bounce_lights.wgsl,
/// shaders/medium_bounce_shafts.wgsl; `crate::medium_bounce`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct BounceLightParams {
    /// The medium's box (w = 1) and sigma_t.
    pub lo: [f32; 4],
    pub hi: [f32; 4],
    pub sigma_t: [f32; 4],
    /// VPL blocks per side of a light face.
    pub grid: u32,
    pub shadow_size: u32,
    /// 1: heterogeneous medium (read the density grid), 0: homogeneous.
    pub heterogeneous: u32,
    /// Heterogeneous: ray-march steps of the transmittance toward the light.
    pub light_steps: u32,
    /// This light's first VPL.
    pub offset: u32,
    pub _pad: [u32; 3],
    /// rgb = sigma_s (`medium_bounce_shafts`).
    pub sigma_s: [f32; 4],
}

/// A virtual point light of `medium_bounce` (the light a block of a light's receiver map
/// reflects; shaders/medium_bounce_lights.wgsl, `Vpl`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct VplGpu {
    /// xyz = position, w = squared radius (m²).
    pub pos: [f32; 4],
    /// xyz = unit normal of the emitting side.
    pub nrm: [f32; 4],
    /// rgb = reflected flux (W).
    pub full: [f32; 4],
    /// rgb = the part of it that arrived as caustic light (W).
    pub caustic: [f32; 4],
}

/// `medium_bounce_surfaces` (shaders/medium_bounce_surfaces.wgsl).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct SurfaceBounceParams {
    pub lo: [f32; 4],
    pub hi: [f32; 4],
    /// rgb = sigma_t, w = Henyey-Greenstein g.
    pub sigma_t: [f32; 4],
    pub camera: [f32; 4],
    pub width: u32,
    pub height: u32,
    /// Shaft VPLs to read.
    pub count: u32,
    /// 1: heterogeneous medium, 0: homogeneous.
    pub heterogeneous: u32,
    /// 1: the emitters stand for fog filling the space (shafts, glow): their near field gets
    /// the layer gain (`layer_gain` in the shader); 0: the beams' emitters (caustic light).
    pub layers: u32,
    pub _pad: [u32; 3],
}

/// `medium_bounce` (shaders/medium_bounce.wgsl).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct BounceParams {
    pub clip_to_world: [[f32; 4]; 4],
    pub camera: [f32; 4],
    pub lo: [f32; 4],
    pub hi: [f32; 4],
    /// rgb = sigma_s, w = Henyey-Greenstein g (0: isotropic).
    pub sigma_s: [f32; 4],
    /// rgb = sigma_t.
    pub sigma_t: [f32; 4],
    pub width: u32,
    pub height: u32,
    pub steps: u32,
    /// VPLs to read.
    pub count: u32,
    /// 1: heterogeneous medium, 0: homogeneous.
    pub heterogeneous: u32,
    pub _pad: [u32; 3],
}

/// A camera path's segment in the medium beyond the first specular surface (`composite` keeps
/// [`EYE_SEGMENTS`] per specular pixel for the medium's stages; `shaders/shared/medium.wgsl`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct EyeSegmentGpu {
    /// xyz: start (on a specular surface); w: length (1e30: out of the scene; 0: empty slot).
    pub o: [f32; 4],
    /// The path's weight from the camera to the start.
    pub w: [f32; 3],
    /// The direction, octahedral, 2 x snorm16.
    pub dir: u32,
}

/// The point emitters' parameters of `medium_bounce_beams` and `medium_bounce_glow`
/// (`shaders/shared/medium_emit.wgsl`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct EmitParams {
    /// The medium's box, sigma_s (w = Henyey-Greenstein g) and sigma_t.
    pub lo: [f32; 4],
    pub hi: [f32; 4],
    pub sigma_s: [f32; 4],
    pub sigma_t: [f32; 4],
    /// Blocks per side of a light face, the light's faces, the bins (faces × grid² × slices),
    /// slices per block.
    pub grid: u32,
    pub faces: u32,
    pub bins: u32,
    pub slices: u32,
    /// The fixed-point scale (units per W: the light's).
    pub scale: f32,
    /// 1: a density grid.
    pub heterogeneous: u32,
    /// `medium_bounce_glow`: the light's first surface VPL and its VPLs.
    pub vpl_offset: u32,
    pub vpl_count: u32,
    /// 1: the emitters' light is caustic light (their `caustic` = their flux): the beams'
    /// landing emitters.
    pub caustic: u32,
    pub _pad: [u32; 3],
}

/// Segments kept per specular pixel (`EYE_SEGMENTS` in `shaders/shared/medium.wgsl`).
pub const EYE_SEGMENTS: u64 = 2;

/// The multiple-scattering grid's stages (`medium_ms_trace`, `medium_ms_resolve`,
/// `medium_ms_view`: shaders/shared/medium_multiple.wgsl).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct MsParams {
    pub clip_to_world: [[f32; 4]; 4],
    pub camera: [f32; 4],
    pub lo: [f32; 4],
    pub hi: [f32; 4],
    /// rgb = sigma_s, w = Henyey-Greenstein g.
    pub sigma_s: [f32; 4],
    /// rgb = sigma_t, w = the free flights' majorant (1/m).
    pub sigma_t: [f32; 4],
    /// A directional light's emission disk: centre, radius (m).
    pub disk: [f32; 4],
    /// xyz = cells per axis, w = 1 with a density grid.
    pub dims: [u32; 4],
    pub photons: u32,
    pub seed: u32,
    pub _pad: [u32; 2],
    pub width: u32,
    pub height: u32,
    pub steps: u32,
    pub max_events: u32,
}

/// Cells per side of a block of the multiple-scattering grid that becomes one emitter
/// (`medium_ms_resolve`'s `ms_emitters`; per-cell emitters measured the same on the sun in fog,
/// at 8 times the gather's cost).
pub const MS_BLOCK: u32 = 2;
