//! Caustic spheres' and environment records: the environment's sub-direction taps and the
//! sphere gather, volume and compile parameters and records.

use bytemuck::{Pod, Zeroable};

/// Most sub-directions ([`EnvTapsGpu`]) one environment region's caustic is spread over.
pub const MAX_ENV_TAPS: usize = 32;

/// One sub-direction of an environment region (`shade_receivers`, `crate::env_taps`): the
/// rows of Rᵀ, R the rotation taking the region's light direction to the sub-direction's; the
/// weight (rgb) is the sub-region's share of the light's irradiance.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct EnvTap {
    pub rows: [[f32; 4]; 3],
    pub weight: [f32; 4],
}

/// `shade_receivers`: the sub-directions the caustic of one light is spread over (count 0:
/// the light's own caustic map, unchanged; every light but a broad environment region).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct EnvTapsGpu {
    /// Centre of rotation (the casters' bounding-box centre), w unused.
    pub centre: [f32; 4],
    /// x = tap count (0 to `MAX_ENV_TAPS`), rest unused.
    pub info: [u32; 4],
    pub taps: [EnvTap; MAX_ENV_TAPS],
}

/// `sphere_gather` (shaders/sphere_gather.wgsl).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct SphereGatherParams {
    pub width: u32,
    pub height: u32,
    pub records: u32,
    /// Points per pixel side of the lookup's box filter (`caustic_spheres::gpu::PIXEL_SAMPLES`).
    pub samples: u32,
    pub camera: [f32; 4],
    /// A homogeneous medium's box (w = 1; 0: none, or a density grid: not attenuated).
    pub medium_lo: [f32; 4],
    pub medium_hi: [f32; 4],
    /// rgb = σt (1/m); w = the irradiance luminance from which a record gets every point of
    /// the box filter.
    pub sigma_t: [f32; 4],
}

/// `sphere_volume` (shaders/sphere_volume.wgsl): volumetric caustics from the spheres.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct SphereVolumeParams {
    pub clip_to_world: [[f32; 4]; 4],
    pub camera: [f32; 4],
    /// The medium's box.
    pub lo: [f32; 4],
    pub hi: [f32; 4],
    /// rgb = σs (1/m), w = Henyey–Greenstein g (0: isotropic).
    pub sigma_s: [f32; 4],
    /// rgb = σt (1/m); w = the irradiance luminance from which a record gets every point of
    /// the box filter.
    pub sigma_t: [f32; 4],
    pub width: u32,
    pub height: u32,
    /// Midpoint-rule steps along the camera ray.
    pub steps: u32,
    pub records: u32,
}

/// `sphere_compile` (shaders/sphere_compile.wgsl): one caustic object's dispatch.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct SphereCompileParams {
    /// The object's records: `records[first .. first + count]`.
    pub first: u32,
    pub count: u32,
    /// Cells of the compiled table and the index of its first vec4.
    pub cells: u32,
    pub out_base: u32,
}

/// One (directional light, caustic object, blended stored direction) of `sphere_gather`, or
/// one caustic object's compiled table (`base.z` = 2).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct SphereRecord {
    /// World → the object's frame (the scene file's pose): rows of a 3×4 matrix.
    pub to_obj: [[f32; 4]; 3],
    /// The stored pattern's frame rotated onto the light: R a, R b, R ω.
    pub axes: [[f32; 4]; 3],
    /// Rows of R (stored mean directions d appear as R d).
    pub rot: [[f32; 4]; 3],
    /// Sphere centre (xyz), r_min (w).
    pub center: [f32; 4],
    /// r_max, sphere count, longitudes, latitudes.
    pub shape: [f32; 4],
    /// Blend weight × the light's irradiance (W/m², rgb).
    pub irradiance: [f32; 4],
    /// x: table index (in vec4s) of the stored direction's first cell; y: the object's index;
    /// z: 1 for a half-float table (one vec4 per cell), 0 for f32 (two), 2 for a compiled
    /// table (three vec4 of f32: V_r, V_g, V_b).
    pub base: [u32; 4],
}
