//! The photon records: tracing, photons, splatting, coverage, the adaptive hierarchy's levels,
//! the temporal filter, caustic triangles and blending, receiver shading and its tiles.

use bytemuck::{Pod, Zeroable};

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
/// Side (texels) of the tiles of `caustic_mask` and `shadow_tiles`, which `shade_receivers` reads.
pub const SHADE_TILE: u32 = 8;
