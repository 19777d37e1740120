//! Every struct the GPU sees, `#[repr(C)]` + bytemuck, mirrored from `shaders/shared/common.wgsl`
//! and the stage files. [`LAYOUTS`] lists each with its fields; `tests/shaders.rs` checks it
//! against naga's layout of the WGSL declaration in every stage (the struct's size, and each
//! member's name, offset and size), so the two cannot drift apart silently. [`Vertex`] has no
//! WGSL struct: it is the vertex buffer that the raster stages' `vs_main` reads by location.

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
    /// no caster buffers; else 0), unused × 2
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
    pub a: [f32; 4],
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
pub struct TraceParams {
    pub face: u32,
    pub batch_offset: u32,
    pub batch_count: u32,
    /// 0: the batch is `batch_count` consecutive cells of the row-major grid from `batch_offset`;
    /// T > 0: a T × T tile whose top-left cell has row-major index `batch_offset`.
    pub tile: u32,
}

#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct Photon {
    pub pos: [f32; 2],
    pub face: u32,
    pub _pad: u32,
    pub flux: [f32; 4],
}

/// Used by caustic_resolve (`ResolveParams`).
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
    /// 1: skip lookups by the light's tiles (`caustic_mask`, `shadow_tiles`); 0: never.
    pub tiles: u32,
    pub camera: [f32; 4],
    /// The medium's box (w = 1 with a medium, else all 0) and its extinction sigma_t (1/m).
    pub medium_lo: [f32; 4],
    pub medium_hi: [f32; 4],
    pub sigma_t: [f32; 4],
    /// x = 1 with a density grid (heterogeneous medium), y = ray-march steps toward the light.
    pub medium_grid: [u32; 4],
}

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

/// Parameters of the beam stages (`shaders/shared/beams.wgsl`, `BeamParams`; `crate::beams`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct BeamParams {
    pub clip_to_world: [[f32; 4]; 4],
    pub camera: [f32; 4],
    pub lo: [f32; 4],
    pub hi: [f32; 4],
    /// rgb = sigma_s, w = Henyey-Greenstein g.
    pub sigma_s: [f32; 4],
    pub sigma_t: [f32; 4],
    pub grid: u32,
    pub levels: u32,
    pub faces: u32,
    pub max_depth: u32,
    pub normal_cos: f32,
    pub depth_rel: f32,
    pub energy: f32,
    pub camera_size: f32,
    /// Points per pixel side on the surface's tangent plane in `beam_surface`.
    pub surface_samples: u32,
    pub capacity: u32,
    pub slots: u32,
    pub samples: u32,
    pub width: u32,
    pub height: u32,
    /// Bit 0: trace the branch reflected at the first dielectric surface too.
    pub flags: u32,
    /// Camera rays per pixel side in `beam_gather`.
    pub pixel_samples: u32,
    /// Split where the centroid's light is farther than this fraction of the beam's width off
    /// the beam's line (`beam_refine`'s `nonlinearity`); 0: off.
    pub linearity: f32,
    /// The residual branch's least probability of reflecting at a dielectric interface (it
    /// reflects with max(F, residual): `BeamSettings::residual`; 0: no residual branch).
    pub residual: f32,
    /// The energy cutoff (`BeamSettings::cutoff`) as σs (its largest channel, times the density
    /// grid's largest value) · the phase function's largest value / the cutoff, in m/W
    /// (`beams::cut_factor`); 0: off.
    pub cut: f32,
    pub _pad: u32,
    /// Inverse of `clip_to_world`: where `beam_surface` finds a beam's end in the image.
    pub world_to_clip: [[f32; 4]; 4],
}

/// One level of `beam_refine` (WGSL `BeamLevel`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct BeamLevel {
    pub level: u32,
    pub offset: u32,
    pub next_offset: u32,
    pub base_count: u32,
}

/// A triangle of the beams' projected grid (WGSL `BeamTri`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct BeamTri {
    pub a: [f32; 2],
    pub b: [f32; 2],
    pub c: [f32; 2],
    pub id: u32,
    pub face: u32,
}

/// A part of a last-level triangle whose corners take different paths (WGSL `BeamPart`):
/// `beam_refine` queues it, `beam_shrink` makes its beam. `kind` = branch | layer << 4 |
/// case << 8 | part << 12.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct BeamPart {
    pub a: [f32; 2],
    pub b: [f32; 2],
    pub c: [f32; 2],
    pub face: u32,
    pub slot: u32,
    pub level: u32,
    pub kind: u32,
}

/// A beam (WGSL `BeamGpu`): base vertices (w: in-medium light path before them), unit edge
/// directions (w: length to the edge's end), flux (W; w: level), bounding sphere, `info.x`
/// the object its edges land on (`u32::MAX`: they leave the scene), `info.y` branch | layer << 4
/// | part << 8, `info.z`, `info.w` the clip heights of edges 1 and 2 (f32 bits; `Beam::clip`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct BeamGpu {
    pub v: [[f32; 4]; 3],
    pub d: [[f32; 4]; 3],
    pub flux: [f32; 4],
    pub bound: [f32; 4],
    pub info: [u32; 4],
}

/// A beam's hull on the image (WGSL `BeamHull`, beam_hull.wgsl), [`BEAM_HULL_PARTS`] per beam:
/// `info[0]` its vertices, `info[1]` the beam's index, `info[2..4]` the part's heights over the
/// base (f32 bits); the vertices in pixels, two per row.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct BeamHull {
    pub info: [u32; 4],
    pub p: [[f32; 4]; 6],
}

/// Most vertices of a beam's hull polygon (`BeamHull`).
pub const BEAM_HULL_MAX: u32 = 12;
/// Hull polygons per beam (`BeamHull`): the beam split at up to two foci between its ends.
pub const BEAM_HULL_PARTS: u32 = 3;

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
    pub _pad: u32,
    /// The medium's box (scenes with one; `composite_medium`): w of `medium_hi` 1 for a density
    /// grid, else 0.
    pub medium_lo: [f32; 4],
    pub medium_hi: [f32; 4],
    /// rgb = sigma_t (1/m); w = the midpoint rule's steps along a segment in a density grid.
    pub medium_sigma_t: [f32; 4],
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

/// Read by photon_splat from a storage buffer: the first three words are also the indirect
/// dispatch arguments of the splat (the adaptive techniques write them on the GPU).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct SplatParams {
    pub groups: [u32; 3],
    pub count: u32,
}

/// Coverage mip chain build (coverage_mip): level 0 from the caster front buffer, or a level
/// from the one below (sum of 2 × 2 counts).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct CoverParams {
    /// Face (layer of the caster buffers).
    pub face: u32,
    /// Destination level (0 = from the texture).
    pub level: u32,
    /// Size of the destination level (texels per side).
    pub size: u32,
    /// Word offset of the source level (level > 0).
    pub src: u32,
    /// Word offset of the destination level.
    pub dst: u32,
    /// Level 0 source: 0 the caster front buffer (coverage), 1 a dense photon tile (validity).
    pub source: u32,
    pub _pad: [u32; 2],
}

/// One step of the GPU-driven photon hierarchy (adaptive and hierarchical techniques): the
/// parameters of one level, fixed when the frame is recorded; what changes on the GPU (counts,
/// offsets, batch index) lives in the control buffer.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct LevelParams {
    pub face: u32,
    /// Level index k of the clusters this step reads (grid `grid`), or of the cells written.
    pub level: u32,
    /// Grid size of the clusters read (cells per side).
    pub grid: u32,
    /// Finest grid N (adaptive) or tile size (hierarchical).
    pub finest: u32,
    /// Caster geometry buffer size G (size of coverage level 0).
    pub gbuffer: u32,
    /// Bit 0: children are the finest level (emit photons); bit 1: check convergence (maximal
    /// caustic map error); bit 2: setup step after init (begin batch); bit 3: setup at batch end.
    pub flags: u32,
    /// Capacity of each of the two cell regions (cells).
    pub cell_capacity: u32,
    /// Capacity of the photon buffer (photons).
    pub photon_capacity: u32,
    /// Convergence tolerance in caustic-map texels (0: all children in one texel).
    pub tolerance: f32,
    /// Batch grid size (cells per side) and batch capacity in leaf photons (plan).
    pub batch_grid: u32,
    pub batch_leaves: u32,
    /// Batches the host recorded (the plan flags an overflow beyond).
    pub max_batches: u32,
    /// Hierarchical: column and row of the tile's top-left cell in the N × N grid, N.
    pub tile_x: u32,
    pub tile_y: u32,
    pub grid_n: u32,
    /// Maximal caustic map error with caustic triangles: the linearity stopping rule's
    /// tolerance in caustic-map texels (0: off; `RenderSettings::quad_linearity`).
    pub linearity: f32,
}

/// Temporal filter of one light's caustic maps (`temporal_filter`, [`crate::temporal`]).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct TemporalParams {
    /// Caustic map size M.
    pub size: u32,
    pub faces: u32,
    /// 0: no history yet (the output is the new map).
    pub has_history: u32,
    /// 0: blend, 1: local flux correction.
    pub stage: u32,
    /// Weight of the new frame.
    pub alpha: f32,
    /// Relative change of the 3 × 3 flux sums that rejects the history.
    pub threshold: f32,
    /// Bit 0: dilate the rejection over the 3 × 3 neighbourhood; bits 1..: the flux radius.
    pub flags: u32,
    pub _pad: u32,
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
/// `BeamParams::flags`: trace the branches reflected at the first dielectric surface and inside it.
pub const BEAM_FLAG_REFLECTION: u32 = 1;
/// `BeamParams::flags`: the medium has a density grid (shared/beam_medium.wgsl).
pub const BEAM_FLAG_GRID: u32 = 2;
/// `BeamParams::flags`: light can cross the medium from one specular object to another (more
/// than one, or one that is neither a sphere nor a rectangle): with reflection, trace the branches
/// reflected at the second dielectric too (beams.rs `chains`).
pub const BEAM_FLAG_CHAINS: u32 = 4;
/// `BeamParams::flags`: count the hull draws' fragments (`BeamStats::hull_fragments`,
/// `hull_lit_fragments`): one-shot renders only, whose statistics are read (a global atomic
/// per fragment is not for the frame loop).
pub const BEAM_FLAG_FRAGMENTS: u32 = 8;
/// `BeamParams::flags`: the beams' ends light surfaces (`SurfaceCaustics::Beams`): the energy
/// cutoff leaves the beams that land on an object whole.
pub const BEAM_FLAG_SURFACE: u32 = 16;
/// Beam branches (beam_trace.wgsl `trace_edge`): transmitted; reflected at the first, second,
/// third or fourth interaction (the first dielectric's surface and inside it, the second's); the
/// residual branch ([`BEAM_RESIDUAL`]).
pub const BEAM_BRANCHES: u32 = 6;
/// The residual branch: light reflected partially where no other branch reflects (at the fifth
/// interaction or later, or at two or more), its Fresnel choices drawn at random per triangle.
pub const BEAM_RESIDUAL: u32 = 5;
/// Beam layers per branch: the path's last segment, and the one before it from one specular
/// object to the next.
pub const BEAM_LAYERS: u32 = 2;
/// Beams per branch and layer of a slot: a last-level triangle whose corners take different
/// paths gives one beam per path, and one more for the light on paths none of its corners
/// takes (its orphans: beam_shrink.wgsl).
pub const BEAM_PARTS: u32 = 4;
/// Beams per slot of the beam hierarchy (`BEAM_BRANCHES` x `BEAM_LAYERS` x `BEAM_PARTS`).
pub const BEAM_KINDS: u32 = BEAM_BRANCHES * BEAM_LAYERS * BEAM_PARTS;
/// Slot entries per thread of `beam_order_runs` (the beams' list in slot order: lavapipe's loop
/// limit bounds a thread's run).
pub const BEAM_ORDER_RUN: u32 = 4096;
/// Side (texels) of the tiles of `caustic_mask` and `shadow_tiles`, which `shade_receivers` reads.
pub const SHADE_TILE: u32 = 8;

/// (name, value) of the constants the WGSL declares under the same name: `tests/shaders.rs`
/// checks that at least one stage declares each, and that every stage that does has this value.
pub const CONSTANTS: &[(&str, u32)] = &[
    ("KIND_DIFFUSE", KIND_DIFFUSE),
    ("KIND_DIELECTRIC", KIND_DIELECTRIC),
    ("KIND_MIRROR", KIND_MIRROR),
    ("KIND_CONDUCTOR", KIND_CONDUCTOR),
    ("SHAPE_MESH", SHAPE_MESH),
    ("SHAPE_SPHERE", SHAPE_SPHERE),
    ("SHAPE_CYLINDER", SHAPE_CYLINDER),
    ("SHAPE_RECTANGLE", SHAPE_RECTANGLE),
    ("LIGHT_SPOT", LIGHT_SPOT),
    ("LIGHT_POINT", LIGHT_POINT),
    ("LIGHT_DIRECTIONAL", LIGHT_DIRECTIONAL),
    ("SHADE_TILE", SHADE_TILE),
    ("SPILL_FACE_PRESENT", SPILL_FACE_PRESENT),
    ("BEAM_FLAG_REFLECTION", BEAM_FLAG_REFLECTION),
    ("BEAM_FLAG_GRID", BEAM_FLAG_GRID),
    ("BEAM_FLAG_CHAINS", BEAM_FLAG_CHAINS),
    ("BEAM_FLAG_FRAGMENTS", BEAM_FLAG_FRAGMENTS),
    ("BEAM_FLAG_SURFACE", BEAM_FLAG_SURFACE),
    ("BEAM_BRANCHES", BEAM_BRANCHES),
    ("BEAM_RESIDUAL", BEAM_RESIDUAL),
    ("BEAM_LAYERS", BEAM_LAYERS),
    ("BEAM_PARTS", BEAM_PARTS),
    ("BEAM_KINDS", BEAM_KINDS),
    ("BEAM_ORDER_RUN", BEAM_ORDER_RUN),
    ("BEAM_HULL_MAX", BEAM_HULL_MAX),
    ("BEAM_HULL_PARTS", BEAM_HULL_PARTS),
];

/// Parameters of `caustic_triangles` (mirrors the WGSL `TriParams`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct TriParams {
    pub n: u32,
    pub r0: u32,
    pub rows: u32,
    pub quad_rows: u32,
    pub cur_off: u32,
    pub has_prev: u32,
    pub max_edge: f32,
    pub _pad: u32,
}

/// Parameters of `splat_multires_blend` (mirrors the WGSL `BlendParams`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct BlendParams {
    pub count: u32,
    pub pass_index: u32,
    pub _pad: [u32; 2],
}

/// Parameters of `caustic_mask` and `shadow_tiles` (mirror the WGSL `MaskParams` and
/// `TileParams`): map size per face, tiles per side, faces.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct TileParams {
    pub size: u32,
    pub tiles: u32,
    pub faces: u32,
    pub _pad: u32,
}

/// One field of a Rust GPU struct as the layout test (`tests/shaders.rs`) compares it with the
/// WGSL member or members it mirrors.
#[derive(Debug, Clone, Copy)]
pub struct FieldLayout {
    /// The Rust field's name.
    pub name: &'static str,
    /// The WGSL members it mirrors, in order: one (of the same name, or renamed where the two
    /// differ), or one per element of a Rust array that WGSL spells as separate members
    /// (`_pad0`, `_pad1`, ...: a uniform buffer's arrays need a 16-byte stride, so WGSL writes
    /// such arrays of scalars out member by member).
    pub wgsl: &'static [&'static str],
    /// `offset_of!` the field, in bytes.
    pub offset: usize,
    /// `size_of` the field's type.
    pub size: usize,
    /// Bytes from one element to the next: an array's element, else the whole type.
    pub element: usize,
    /// The scalar under the field's arrays (`f32`, `u32`, `i32`), or the nested GPU struct's Rust
    /// name ([`GpuMember::LEAF`]).
    pub leaf: &'static str,
}

/// A Rust GPU struct and the WGSL struct it mirrors, field by field ([`LAYOUTS`]).
#[derive(Debug, Clone, Copy)]
pub struct StructLayout {
    /// The Rust struct's name.
    pub rust: &'static str,
    /// The WGSL struct's name (one Rust struct may mirror several: [`TileParams`]).
    pub wgsl: &'static str,
    /// `size_of` the Rust struct: the WGSL struct's span.
    pub size: usize,
    /// Every field, in declaration order.
    pub fields: &'static [FieldLayout],
}

/// A type a GPU struct's field may have, as the layout test sees it: the scalar under its
/// arrays and the size of one element. Implemented for the scalars, arrays of them, and the GPU
/// structs nested in others.
pub trait GpuMember {
    /// `f32`, `u32`, `i32`, or a nested struct's Rust name.
    const LEAF: &'static str;
    /// An array's element size; the type's own size otherwise.
    const ELEMENT: usize;
}

macro_rules! gpu_member {
    ($($t:ty),*) => {$(
        impl GpuMember for $t {
            const LEAF: &'static str = stringify!($t);
            const ELEMENT: usize = size_of::<$t>();
        }
    )*};
}
gpu_member!(f32, u32, i32, FaceGpu, EnvTap);

impl<T: GpuMember, const N: usize> GpuMember for [T; N] {
    const LEAF: &'static str = T::LEAF;
    const ELEMENT: usize = size_of::<T>();
}

/// The [`FieldLayout`] of a field of `T`, its type read off `get` (a closure `|s| &s.field`,
/// never called).
const fn field<T, M: GpuMember>(
    name: &'static str,
    wgsl: &'static [&'static str],
    offset: usize,
    _get: fn(&T) -> &M,
) -> FieldLayout {
    FieldLayout { name, wgsl, offset, size: size_of::<M>(), element: M::ELEMENT, leaf: M::LEAF }
}

/// `layouts! { Rust as Wgsl { field, field => wgsl_name, field => [wgsl0, wgsl1] } ... }`: the
/// [`LAYOUTS`] entry of each struct, one line each (`as Wgsl` where the names differ). Every
/// field must be listed, in order: a field left out fails to compile, one out of order fails
/// the layout test.
macro_rules! layouts {
    (@wgsl $rust:ident) => { stringify!($rust) };
    (@wgsl $rust:ident $wgsl:ident) => { stringify!($wgsl) };
    (@members $f:ident) => { &[stringify!($f)] };
    (@members $f:ident $to:ident) => { &[stringify!($to)] };
    (@members $f:ident [$($to:ident),+]) => { &[$(stringify!($to)),+] };
    ($($rust:ident $(as $wgsl:ident)? { $($f:ident $(=> $to:tt)?),* $(,)? })*) => {
        /// Every Rust struct the shaders read or write and the WGSL struct it mirrors, field by
        /// field. `tests/shaders.rs` checks each against naga's layout of the WGSL in every
        /// stage that declares it: the span, and every member's name, offset and size.
        pub const LAYOUTS: &[StructLayout] = &[$(StructLayout {
            rust: stringify!($rust),
            wgsl: layouts!(@wgsl $rust $($wgsl)?),
            size: size_of::<$rust>(),
            fields: &[$(field(
                stringify!($f),
                layouts!(@members $f $($to)?),
                std::mem::offset_of!($rust, $f),
                |s: &$rust| &s.$f,
            )),*],
        }),*];
        // `Pod` structs have no padding: the listed fields cover the struct only if none is
        // missing.
        $(const _: () = assert!(
            0 $(+ field(stringify!($f), &[], 0, |s: &$rust| &s.$f).size)* == size_of::<$rust>(),
            concat!("layouts!: a field of ", stringify!($rust), " is missing from its line"),
        );)*
    };
}

// Where a Rust field's name is not its WGSL member's: `=> name` renames it (the padding words'
// numbering), `=> [a, b, ...]` maps a Rust array to as many WGSL members, one per element (arrays
// of scalars in a uniform buffer need a 16-byte stride, so WGSL spells those out; the
// indirect-dispatch words `groups_x`..; rows of matrices the shaders index by name).
layouts! {
    FaceGpu as Face { world_to_clip, clip_to_world, origin }
    LightGpu { faces, info, power, axis, params, extra, splat, crop, medium_lo, medium_hi, medium_sigma_t }
    MaterialGpu { kind, a, b, shape => [s0, s1, s2, s3] }
    RasterView { world_to_clip }
    TraceParams { face, batch_offset, batch_count, tile }
    Photon { pos, face, _pad, flux }
    SplatParams { groups => [groups_x, groups_y, groups_z], count }
    CoverParams { face, level, size, src, dst, source, _pad => [_pad0, _pad1] }
    LevelParams { face, level, grid, finest, gbuffer, flags, cell_capacity, photon_capacity, tolerance, batch_grid, batch_leaves, max_batches, tile_x, tile_y, grid_n, linearity }
    CountParams as ResolveParams { count, _pad => [_pad0, _pad1, _pad2] }
    TemporalParams { size, faces, has_history, stage, alpha, threshold, flags, _pad }
    ShadeParams { width, height, shadow_size, tiles, camera, medium_lo, medium_hi, sigma_t, medium_grid }
    TileParams as MaskParams { size, tiles, faces, _pad }
    TileParams { size, tiles, faces, _pad }
    EnvTap { rows => [r0, r1, r2], weight }
    EnvTapsGpu as EnvTaps { centre, info, taps }
    SphereGatherParams { width, height, records, samples, camera, medium_lo, medium_hi, sigma_t }
    SphereRecord { to_obj, axes, rot, center, shape, irradiance, base }
    SphereCompileParams { first, count, cells, out_base }
    SphereVolumeParams { clip_to_world, camera, lo, hi, sigma_s, sigma_t, width, height, steps, records }
    CompositeParams { world_to_clip, clip_to_world, camera, env_rotation, width, height, layer2, _pad, medium_lo, medium_hi, medium_sigma_t }
    EyeSegmentGpu as EyeSegment { o, w, dir }
    EmitParams { lo, hi, sigma_s, sigma_t, grid, faces, bins, slices, scale, heterogeneous, vpl_offset, vpl_count, caustic, _pad => [_pad0, _pad1, _pad2] }
    MediumParams { clip_to_world, camera, lo, hi, sigma_s, sigma_t, width, height, steps, flags, shadow_size, grid, light_steps, _pad => _pad0 }
    BounceLightParams { lo, hi, sigma_t, grid, shadow_size, heterogeneous, light_steps, offset, _pad => [_pad0, _pad1, _pad2], sigma_s }
    VplGpu as Vpl { pos, nrm, full, caustic }
    BounceParams { clip_to_world, camera, lo, hi, sigma_s, sigma_t, width, height, steps, count, heterogeneous, _pad => [_pad0, _pad1, _pad2] }
    SurfaceBounceParams { lo, hi, sigma_t, camera, width, height, count, heterogeneous, layers, _pad => [_pad0, _pad1, _pad2] }
    BeamParams { clip_to_world, camera, lo, hi, sigma_s, sigma_t, grid, levels, faces, max_depth, normal_cos, depth_rel, energy, camera_size, surface_samples, capacity, slots, samples, width, height, flags, pixel_samples, linearity, residual, cut, _pad => _pad2, world_to_clip }
    BeamLevel { level, offset, next_offset, base_count }
    BeamTri { a, b, c, id, face }
    BeamPart { a, b, c, face, slot, level, kind }
    BeamGpu { v => [v0, v1, v2], d => [d0, d1, d2], flux, bound, info }
    BeamHull { info, p }
    TriParams { n, r0, rows, quad_rows, cur_off, has_prev, max_edge, _pad }
    BlendParams { count, pass_index, _pad => [_pad0, _pad1] }
    ObjectTransform { model, normal }
    DisplayParams { width, height, exposure, _pad }
    BvhNode { lo, a, hi, count }
    RayQuery { o, d }
    RayResult { t, object, triangle, overflows, ng }
    QueryParams { count, any_hit, _pad => [_pad0, _pad1] }
    BvhTri { p0, p1, p2, n0, n1, n2 }
    BvhInstance { to_object, to_world, lo, hi, root, first_tri, object, _pad }
}
