//! The volume caustic beams' records (`crate::beams`): parameters, levels, triangles, parts,
//! beams and hulls, and the beam constants (flags, branches, layers, parts, kinds).

use bytemuck::{Pod, Zeroable};

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
/// `BeamParams::flags`: the beams' ends light surfaces (`LocalSource::Beams`): the energy
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
