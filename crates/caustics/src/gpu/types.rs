//! Every struct the GPU sees, `#[repr(C)]` + bytemuck, mirrored from `shaders/shared/common.wgsl`
//! and the stage files. `tests/gpu_layout.rs` checks sizes and field offsets against the WGSL
//! declarations with naga, so the two cannot drift apart silently.

use bytemuck::{Pod, Zeroable};

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct FaceGpu {
    pub world_to_clip: [[f32; 4]; 4],
    pub clip_to_world: [[f32; 4]; 4],
    pub origin: [f32; 4],
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct LightGpu {
    pub faces: [FaceGpu; 6],
    /// face count, kind (0 spot, 1 point, 2 directional), photon grid N, caustic map M
    pub info: [u32; 4],
    /// rgb intensity or irradiance; a = cos(cone)
    pub power: [f32; 4],
    /// axis / direction, w = cone angle (radians)
    pub axis: [f32; 4],
    /// falloff start (radians), fixed-point scale (units per watt), splat sigma (texels), G
    pub params: [f32; 4],
    /// bounding radius of the casters (m), of the scene (m), unused, unused
    pub extra: [f32; 4],
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct MaterialGpu {
    pub kind: [u32; 4],
    pub a: [f32; 4],
    pub b: [f32; 4],
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct Vertex {
    pub position: [f32; 3],
    pub normal: [f32; 3],
    pub object: u32,
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct RasterView {
    pub world_to_clip: [[f32; 4]; 4],
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct TraceParams {
    pub face: u32,
    pub batch_offset: u32,
    pub batch_count: u32,
    pub _pad: u32,
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct Photon {
    pub pos: [f32; 2],
    pub face: u32,
    pub _pad: u32,
    pub flux: [f32; 4],
}

/// Used by photon_splat (`SplatParams`) and caustic_resolve (`ResolveParams`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct CountParams {
    pub count: u32,
    pub _pad: [u32; 3],
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct ShadeParams {
    pub width: u32,
    pub height: u32,
    pub shadow_size: u32,
    pub _pad: u32,
    pub camera: [f32; 4],
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct CompositeParams {
    pub world_to_clip: [[f32; 4]; 4],
    pub camera: [f32; 4],
    pub width: u32,
    pub height: u32,
    pub _pad: [u32; 2],
}

/// (Rust type name, WGSL struct name, size) for the layout test.
pub const LAYOUTS: &[(&str, &str, usize)] = &[
    ("FaceGpu", "Face", std::mem::size_of::<FaceGpu>()),
    ("LightGpu", "LightGpu", std::mem::size_of::<LightGpu>()),
    ("MaterialGpu", "MaterialGpu", std::mem::size_of::<MaterialGpu>()),
    ("RasterView", "RasterView", std::mem::size_of::<RasterView>()),
    ("TraceParams", "TraceParams", std::mem::size_of::<TraceParams>()),
    ("Photon", "Photon", std::mem::size_of::<Photon>()),
    ("CountParams", "SplatParams", std::mem::size_of::<CountParams>()),
    ("CountParams", "ResolveParams", std::mem::size_of::<CountParams>()),
    ("ShadeParams", "ShadeParams", std::mem::size_of::<ShadeParams>()),
    ("CompositeParams", "CompositeParams", std::mem::size_of::<CompositeParams>()),
];
