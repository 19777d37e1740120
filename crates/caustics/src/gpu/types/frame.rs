//! The scene and frame records: faces, lights, materials, vertices, the composite and display
//! parameters, the ray-cast BVH and queries, and the material, shape and light constants.

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
    /// bounding radius of the casters (m), of the scene (m), tan of half the field of view, multi-bounce flag
    pub extra: [f32; 4],
    /// beam diameters from the lens equations (0 off, 1 thin lens, 2 thick lens),
    /// [`SPILL_FACE_PRESENT`] (as f32) if the last face is a spill face (receives photons, has
    /// no caster buffers; else 0), a spot light's profile (0 linear in the angle, 1 glTF's
    /// curve), unused
    pub splat: [f32; 4],
    /// The NDC rectangle (lo.x, lo.y, hi.x, hi.y) that `photon_trace` spreads its N × N grid
    /// over: the casters' box for a directional light traced by the basic technique, else the
    /// whole face (-1, -1, 1, 1).
    pub crop: [f32; 4],
    /// The medium's box (`medium_lo.w`: 0 none, 1 homogeneous, 2 a density grid; with one the
    /// photons carry their path's transmittance into the caustic map) and sigma_t (rgb, 1/m;
    /// w: the grid's march steps per path segment).
    pub medium_lo: [f32; 4],
    pub medium_hi: [f32; 4],
    pub medium_sigma_t: [f32; 4],
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct MaterialGpu {
    /// material kind, caster, analytic shape (0 mesh, 1 sphere, 2 cylinder, 3 rectangle), -
    pub kind: [u32; 4],
    /// diffuse: albedo; dielectric: ior, ext_ior; mirror: reflectance; conductor: eta
    pub a: [f32; 4],
    /// conductor: k; dielectric: absorption coefficient of the inside (1/m)
    pub b: [f32; 4],
    /// The analytic shape's parameters (see `common.wgsl`).
    pub shape: [[f32; 4]; 4],
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
pub struct CompositeParams {
    pub world_to_clip: [[f32; 4]; 4],
    /// Inverse of `world_to_clip`: the camera ray of a pixel that sees the environment.
    pub clip_to_world: [[f32; 4]; 4],
    pub camera: [f32; 4],
    /// (cos, sin) of the environment's `rotate_y`, 1 if the scene has an environment, 0.
    pub env_rotation: [f32; 4],
    pub width: u32,
    pub height: u32,
    /// 1 when the scene has specular meshes (the camera's second layer can hold something), 0:
    /// `composite` then skips the march through the (empty) second-layer buffers.
    pub layer2: u32,
    /// The closed dielectric object the camera is in, plus 1 (a camera under water); 0: none.
    pub camera_inside: u32,
    /// The medium's box (scenes with one; `composite_medium`): w of `medium_hi` 1 for a density
    /// grid, else 0.
    pub medium_lo: [f32; 4],
    pub medium_hi: [f32; 4],
    /// rgb = sigma_t (1/m); w = the midpoint rule's steps along a segment in a density grid.
    pub medium_sigma_t: [f32; 4],
}
/// An object's placement relative to the pose in the scene file (`shared/raster_common.wgsl`):
/// positions by `model`, normals by `normal` (the rotation alone; the transform is a
/// similarity). Identity for objects that never moved, which leaves every vertex bit for bit.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct ObjectTransform {
    pub model: [[f32; 4]; 4],
    pub normal: [[f32; 4]; 4],
}

/// A node of a bottom-level BVH (`shared/raytrace.wgsl`): `count == 0`: inner node whose
/// children are nodes `a` and `a + 1`; otherwise a leaf of `count` triangles from `a`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
pub struct BvhNode {
    pub lo: [f32; 3],
    pub a: u32,
    pub hi: [f32; 3],
    pub count: u32,
}

/// A triangle of a bottom-level BVH: positions (`p0.w`: the mesh's triangle index, as f32
/// bits) and the shading normals of its vertices, in the scene file's pose.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
pub struct BvhTri {
    pub p0: [f32; 4],
    pub p1: [f32; 4],
    pub p2: [f32; 4],
    pub n0: [f32; 4],
    pub n1: [f32; 4],
    pub n2: [f32; 4],
}

/// A mesh object in the top level: the maps from world to its BVH's space and back (rows of
/// 3 × 4 matrices: similarity transforms), its world bounds, its root node, first triangle and
/// object index.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
pub struct BvhInstance {
    pub to_object: [[f32; 4]; 3],
    pub to_world: [[f32; 4]; 3],
    pub lo: [f32; 4],
    pub hi: [f32; 4],
    pub root: u32,
    pub first_tri: u32,
    pub object: u32,
    pub _pad: u32,
}

/// A ray of `ray_query`: origin (w: t_max), unit direction.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct RayQuery {
    pub o: [f32; 4],
    pub d: [f32; 4],
}

/// What `ray_query` found: t (< 0: nothing), object, the mesh's triangle index, stack
/// overflows, the geometric normal.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct RayResult {
    pub t: f32,
    pub object: u32,
    pub triangle: u32,
    pub overflows: u32,
    pub ng: [f32; 4],
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct QueryParams {
    pub count: u32,
    pub any_hit: u32,
    pub _pad: [u32; 2],
}

/// Tone mapping of the radiance image for display (`display`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct DisplayParams {
    pub width: u32,
    pub height: u32,
    pub exposure: f32,
    pub _pad: u32,
}

/// `MaterialGpu.kind.x`: the material (WGSL `KIND_*`).
pub const KIND_DIFFUSE: u32 = 0;
pub const KIND_DIELECTRIC: u32 = 1;
pub const KIND_MIRROR: u32 = 2;
pub const KIND_CONDUCTOR: u32 = 3;
/// `MaterialGpu.kind.z`: the analytic shape (WGSL `SHAPE_*`).
pub const SHAPE_MESH: u32 = 0;
pub const SHAPE_SPHERE: u32 = 1;
pub const SHAPE_CYLINDER: u32 = 2;
pub const SHAPE_RECTANGLE: u32 = 3;
/// `LightGpu.info.y`: the light's kind (WGSL `LIGHT_*`).
pub const LIGHT_SPOT: u32 = 0;
pub const LIGHT_POINT: u32 = 1;
pub const LIGHT_DIRECTIONAL: u32 = 2;
/// `LightGpu.splat.y`: the light's last face is a spill face (WGSL `caster_faces()`).
pub const SPILL_FACE_PRESENT: u32 = 1;
