//! What a one-shot render returns: the images, maps and bookkeeping of a frame.

use crate::image_io::Image;
use crate::techniques::TechniqueStats;
use glam::Vec3;

/// Flux bookkeeping of one light (watts, summed over r, g and b).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FluxStats {
    /// Flux of the photons that hit a caster.
    pub emitted: f64,
    /// Flux that landed in the caustic map.
    pub landed: f64,
    /// Flux lost for want of a back surface in the caster buffers.
    pub lost_no_exit: f64,
    /// Flux lost to total internal reflection (the basic technique follows one refraction path).
    pub lost_tir: f64,
    /// Flux whose receiver the iterative search did not find.
    pub lost_no_receiver: f64,
    /// Flux that landed outside the caustic map.
    pub lost_outside: f64,
    /// Exact tracer: flux of the Fresnel branches after the first surface that no photon
    /// follows (light reflected inside a dielectric that leaves it later; the image-space tracer
    /// drops the same light without booking it). emitted = landed + lost + untraced, for the
    /// transmitted pass.
    pub untraced_branches: f64,
    /// Photon rays of the exact tracer that would have overflowed the BVH traversal stack
    /// (they may have missed a surface; reported as an overflow).
    pub stack_overflows: u64,
}

/// Bytes of a light's flux bookkeeping buffer: six fixed-point (lo, hi) pairs, the stack
/// overflow count, a spare word, the untraced branches' (lo, hi) pair.
pub const FLUX_STATS_BYTES: u64 = 64;

/// What a GPU render produces.
#[derive(Debug, Clone)]
pub struct GpuRender {
    /// Full image, linear radiance W/(m² sr).
    pub image: Image,
    /// Caustic light only, on the diffuse surfaces the camera sees directly.
    pub caustic: Image,
    /// Per light, per face: caustic irradiance maps (W/m²), M × M.
    pub caustic_maps: Vec<Vec<Image>>,
    /// Per light, per face: the raw fixed-point flux per texel (r, g, b), for determinism checks.
    pub caustic_flux_bits: Vec<Vec<u64>>,
    /// Per light: flux bookkeeping of the light's photon stage.
    pub flux: Vec<FluxStats>,
    /// GPU milliseconds per named pass (empty without timestamp queries).
    pub timings: Vec<(String, f64)>,
    /// Host wall-clock milliseconds from the frame's submission to the GPU's completion of it:
    /// all of the frame's GPU work, without recording, pipeline builds or read-back. Where pass
    /// timestamps are not to be trusted (on lavapipe the basic technique's `photon_splat`
    /// escapes its own: `docs/benchmarks.md`) this is the measure to compare.
    pub frame_wall_ms: f64,
    /// Photons traced (all lights, faces and batches).
    pub photons_traced: u64,
    /// Batches the photon grid was split into (all lights and faces).
    pub batches: u32,
    /// What the photon emission technique did (photons traced, splatted, relevant, coverage,
    /// per level, memory, batches).
    pub technique: TechniqueStats,
    /// The adapter it ran on: name, backend and driver.
    pub adapter: String,
    /// Per light with beams (volume caustics, the `beams` module): the statistics and the beams
    /// rendered, in rendering order.
    pub beams: Vec<(BeamStats, Vec<Beam>)>,
}

/// A beam: a triangle of light leaving a specular surface of its path (the last, or on layer 1
/// the one before: `layer`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Beam {
    /// Base vertices (on the specular surface the light leaves).
    pub vertices: [Vec3; 3],
    /// In-medium length of the light's path before each base vertex (m).
    pub pre: [f32; 3],
    /// Unit edge directions.
    pub dirs: [Vec3; 3],
    /// Length of each edge from its base vertex to its end on a surface (m).
    pub ends: [f32; 3],
    /// Flux (W, rgb).
    pub flux: Vec3,
    /// Refinement level it was kept at.
    pub level: u32,
    /// The object its edges land on (`u32::MAX`: they leave the scene); surface caustics from
    /// beams light only that object's points.
    pub land: u32,
    /// The traced branch (`beam_refine`): 0 transmitted at every dielectric interface, 1
    /// reflected at the first surface, 2 reflected once inside the first dielectric, 3 and 4 the
    /// same at a second dielectric the light crosses the medium into, 5 the residual branch
    /// (partial reflections elsewhere, drawn at random per triangle:
    /// [`crate::settings::BeamSettings::residual`]).
    pub branch: u32,
    /// The segment of its path it lights: 0 the last (it ends on a diffuse surface or leaves
    /// the scene), 1 the one before, from one specular object to the next (it ends on that
    /// object's surface, and `land` is `u32::MAX`).
    pub layer: u32,
    /// 0, or for the parts of a last-level triangle whose corners took different paths, 1 or 2
    /// (its other paths' beams: `beam_shrink`).
    pub part: u32,
    /// Heights over the base plane where the edges leave the specular surface, for a beam whose
    /// oblique base `beam_refine` rebased behind that surface (all 0 otherwise): only the
    /// points beyond the plane through those three points are in the beam (the edges run
    /// inside the object before it).
    pub clip: [f32; 3],
}

impl Beam {
    /// The base triangle's unit normal, oriented along the edges.
    pub fn normal(&self) -> Vec3 {
        let [a, b, c] = self.vertices;
        let n = (b - a).cross(c - a).normalize();
        if n.dot(self.dirs[0] + self.dirs[1] + self.dirs[2]) < 0.0 { -n } else { n }
    }

    /// Edge directions scaled to unit height over the base plane (beam space).
    fn scaled(&self) -> [Vec3; 3] {
        let n = self.normal();
        self.dirs.map(|d| d / n.dot(d))
    }

    /// The cross-section at height y over the base plane.
    pub fn section(&self, y: f32) -> [Vec3; 3] {
        let s = self.scaled();
        [0, 1, 2].map(|i| self.vertices[i] + s[i] * y)
    }

    /// Area of the cross-section parallel to the base at height y (a quadratic in y: the
    /// paper's A(y)); unsigned.
    pub fn area(&self, y: f32) -> f32 {
        let [a, b, c] = self.section(y);
        0.5 * (b - a).cross(c - a).dot(self.normal()).abs()
    }

    /// The four beams of the midpoint subdivision (flux split by base area: uniform), which
    /// tile this one exactly.
    pub fn split(&self) -> [Beam; 4] {
        let s = self.scaled();
        let n = self.normal();
        let mid = |i: usize, j: usize| {
            let d = (s[i] + s[j]) * 0.5;
            (
                (self.vertices[i] + self.vertices[j]) * 0.5,
                (self.pre[i] + self.pre[j]) * 0.5,
                d.normalize(),
                // The end height interpolated along the edge.
                0.5 * (self.ends[i] * n.dot(self.dirs[i]) + self.ends[j] * n.dot(self.dirs[j])) / n.dot(d.normalize()),
                // (the clip plane's height there: it is a plane)
                0.5 * (self.clip[i] + self.clip[j]),
            )
        };
        let corner = |i: usize| (self.vertices[i], self.pre[i], self.dirs[i], self.ends[i], self.clip[i]);
        let make = |p: [(Vec3, f32, Vec3, f32, f32); 3]| Beam {
            vertices: p.map(|q| q.0),
            pre: p.map(|q| q.1),
            dirs: p.map(|q| q.2),
            ends: p.map(|q| q.3),
            flux: self.flux * 0.25,
            level: self.level + 1,
            land: self.land,
            branch: self.branch,
            layer: self.layer,
            part: self.part,
            clip: p.map(|q| q.4),
        };
        let (ab, bc, ca) = (mid(0, 1), mid(1, 2), mid(2, 0));
        [make([corner(0), ab, ca]), make([ab, corner(1), bc]), make([ca, bc, corner(2)]), make([bc, ca, ab])]
    }

    /// The GPU record (with its bounding sphere). The record keeps two clip heights: its
    /// vertices are rotated to put the lowest first, and a beam whose clip heights are all above
    /// its base (a piece of a split clipped beam) starts at the lowest (no point below it is in
    /// the beam; the in-medium length before the base grows by the edges' lengths up to it).
    pub fn to_gpu(&self) -> crate::gpu::types::BeamGpu {
        let k = (0..3).fold(0, |k, i| if self.clip[i] < self.clip[k] { i } else { k });
        let r = |i: usize| (i + k) % 3;
        let lift = self.clip[k].max(0.0);
        // (edge i reaches height `lift` after lift |s_i| along it)
        let s = self.scaled();
        let b = Beam {
            vertices: [0, 1, 2].map(|i| self.vertices[r(i)] + s[r(i)] * lift),
            pre: [0, 1, 2].map(|i| self.pre[r(i)] + s[r(i)].length() * lift),
            dirs: [0, 1, 2].map(|i| self.dirs[r(i)]),
            ends: [0, 1, 2].map(|i| self.ends[r(i)] - s[r(i)].length() * lift),
            clip: [0, 1, 2].map(|i| (self.clip[r(i)] - lift).max(0.0)),
            ..*self
        };
        b.record()
    }

    fn record(&self) -> crate::gpu::types::BeamGpu {
        let n = self.normal();
        let ym = (0..3).map(|i| self.ends[i] * n.dot(self.dirs[i])).fold(0.0f32, f32::max);
        let s = self.scaled();
        let pts: Vec<Vec3> = (0..3).flat_map(|i| [self.vertices[i], self.vertices[i] + s[i] * ym]).collect();
        let lo = pts.iter().fold(Vec3::splat(f32::MAX), |a, p| a.min(*p));
        let hi = pts.iter().fold(Vec3::splat(f32::MIN), |a, p| a.max(*p));
        let c = (lo + hi) * 0.5;
        let r = pts.iter().map(|p| (*p - c).length()).fold(0.0f32, f32::max);
        crate::gpu::types::BeamGpu {
            v: [0, 1, 2].map(|i| self.vertices[i].extend(self.pre[i]).to_array()),
            d: [0, 1, 2].map(|i| self.dirs[i].extend(self.ends[i]).to_array()),
            flux: self.flux.extend(self.level as f32).to_array(),
            bound: c.extend(r * 1.0001 + 1e-6).to_array(),
            info: [
                self.land,
                self.branch | (self.layer << 4) | (self.part << 8),
                self.clip[1].to_bits(),
                self.clip[2].to_bits(),
            ],
        }
    }

    pub(crate) fn from_gpu(b: &crate::gpu::types::BeamGpu) -> Beam {
        let v3 = |a: [f32; 4]| Vec3::new(a[0], a[1], a[2]);
        Beam {
            vertices: b.v.map(v3),
            pre: b.v.map(|a| a[3]),
            dirs: b.d.map(v3),
            ends: b.d.map(|a| a[3]),
            flux: v3(b.flux),
            level: b.flux[3] as u32,
            land: b.info[0],
            branch: b.info[1] & 0xf,
            layer: (b.info[1] >> 4) & 0xf,
            part: b.info[1] >> 8,
            clip: [0.0, f32::from_bits(b.info[2]), f32::from_bits(b.info[3])],
        }
    }
}

/// What the beam stages of one light did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BeamStats {
    /// Beams kept per level (0 ..= levels).
    pub kept_per_level: Vec<u32>,
    /// Triangles traced per level.
    pub visited_per_level: Vec<u32>,
    /// Beams rendered (in the ordered list).
    pub beams: u32,
    /// Beams that did not fit the beam buffer (`BeamSettings::capacity`): an overflow.
    pub overflow: u32,
    /// Triangles at the last level whose edges still took different paths and none of whose
    /// corners takes a caustic path on the transmitted branch (their light goes only to an
    /// orphans' beam, where their samples find it; the others are split into parts).
    pub inconsistent: u32,
    /// Beams dropped for a degenerate or grazing base.
    pub grazing: u32,
    /// Beams kept on layer 1 (light crossing the medium from one specular object to another),
    /// included in `kept_per_level`.
    pub between_casters: u32,
    /// Fragments the beams' hulls shaded (`BeamVolume::Hulls`: one per pixel a hull covers; 0
    /// with the gather). Counted in one-shot renders (`Renderer::render_once`,
    /// [`crate::render()`]) only: the frame loop does not count them.
    pub hull_fragments: u32,
    /// Of `hull_fragments`, those that added light (a beam's light reached the pixel): the rest
    /// is the hulls' fill beyond the beams.
    pub hull_lit_fragments: u32,
    /// Beams kept on the residual branch ([`crate::settings::BeamSettings::residual`]),
    /// included in `kept_per_level`.
    pub residual: u32,
    /// Beams the energy cutoff ([`crate::settings::BeamSettings::cutoff`]) shortened or, whose
    /// light was below it all along, dropped (those are not in `kept_per_level`).
    pub cut: u32,
    /// Beams dropped because they carry no light (a part or orphans' beam of a last-level
    /// triangle whose samples leave it none; not in `kept_per_level`).
    pub dark: u32,
}
