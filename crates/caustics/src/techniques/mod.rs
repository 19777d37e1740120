//! Photon emission techniques: how the photons of one light-view face are created, traced and
//! splatted into the caustic map. The rest of the frame (light-space buffers, resolve, shading,
//! composite) is shared, in [`crate::render()`].
//!
//! - [`Emission::Basic`]: a dense N × N photon grid ([`basic`]);
//! - [`Emission::Hierarchical`]: the dense grid traced tile by tile, a mip hierarchy of valid
//!   photons built over it and traversed top-down to splat only the valid ones ([`hierarchical`],
//!   Wyman 2008);
//! - [`Emission::AdaptiveLevel`] and [`Emission::AdaptiveError`]: adaptive caustic maps
//!   (Wyman & Nichols 2009) with the maximal traversal level and the maximal caustic map error
//!   stopping metrics, GPU-driven as Piao 2015 proposes ([`adaptive`]).
//!
//! Every technique builds the coverage mip chain of the caster front buffer (`coverage_mip`),
//! from which the relevant photons (those of the dense N × N grid that hit a caster) and the
//! coverage (fraction of the light's view covered by casters) are reported.

pub mod adaptive;
pub mod basic;
pub mod hierarchical;
pub mod splat;

use crate::error::{Error, Result};
use crate::gpu::pass::{Bound, Pass};
use crate::gpu::types::{CoverParams, LevelParams};
use crate::gpu::{GpuContext, PassTimer};
use crate::settings::RenderSettings;

pub use crate::settings::Emission;

/// Counts of one level of the photon hierarchy (summed over lights, faces and batches).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LevelStats {
    /// Grid size of the level (cells per side of a face).
    pub grid: u32,
    /// Cells (clusters) kept at this level: relevant, refined further or emitted.
    pub cells: u64,
    /// Photons traced on this level's grid.
    pub traced: u64,
    /// Photons emitted (handed to the splat) from this level: cells of this grid (maximal
    /// traversal, finest level) or merged clusters of four cells of the next finer grid.
    pub emitted: u64,
}

/// What a technique did in one frame (all lights and faces).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TechniqueStats {
    /// The emission technique that did it.
    pub technique: Emission,
    /// Equivalent photon grid N (per face).
    pub grid: u32,
    /// Photons traced (calls of the photon tracer).
    pub photons_traced: u64,
    /// Photons handed to the splat pass.
    pub photons_splatted: u64,
    /// Caustic triangles over the adaptive hierarchy: photons traced through the corners of
    /// emitted cells (not in `photons_traced` nor in the per-level counts, and not booked in the
    /// flux statistics; each corner is traced at most once per cluster of four cells).
    pub corners_traced: u64,
    /// Photons of the dense N × N grid that hit a caster (a specular caustic caster).
    pub relevant: u64,
    /// Caster front-buffer texels covered by a caster.
    pub covered_texels: u64,
    /// All caster front-buffer texels (faces × G²).
    pub face_texels: u64,
    /// Cells kept over all levels of the hierarchy plus the photons traced below the last
    /// level of cells: what the traversal evaluated (adaptive and hierarchical techniques).
    pub evaluated: u64,
    /// Per level of the hierarchy, coarse to fine.
    pub levels: Vec<LevelStats>,
    /// Bytes allocated for photon storage (photon buffers, cell lists, dense tiles).
    pub photon_bytes: u64,
    /// Peak bytes of photon storage in use (measured on the GPU where the technique appends).
    pub peak_photon_bytes: u64,
    /// Batches processed (all lights and faces).
    pub batches: u32,
    /// With `Inspect::coverage`: per light and face, the G × G coverage mask of the
    /// caster front buffer (1 where a caster is), row-major.
    pub coverage_masks: Vec<Vec<u32>>,
    /// With `Inspect::photons` (basic technique, photon-buffer splats): every
    /// traced photon in trace order (per light: faces in order, per face the transmitted
    /// branch's grid in row-major order, then the reflected branch's).
    pub photons: Vec<crate::gpu::types::Photon>,
}

impl TechniqueStats {
    /// Fraction of the light's view covered by casters.
    pub fn coverage(&self) -> f64 {
        if self.face_texels == 0 { 0.0 } else { self.covered_texels as f64 / self.face_texels as f64 }
    }

    pub(crate) fn level_mut(&mut self, grid: u32) -> &mut LevelStats {
        let i = match self.levels.iter().position(|l| l.grid == grid) {
            Some(i) => i,
            None => {
                self.levels.push(LevelStats { grid, ..Default::default() });
                self.levels.sort_by_key(|l| l.grid);
                self.levels.iter().position(|l| l.grid == grid).unwrap()
            }
        };
        &mut self.levels[i]
    }
}

/// The constants the frame compiles the photon stages for.
pub(crate) struct Stages {
    /// The tracing stages' (photon_trace, adaptive_refine): built for the splat mode
    /// (shared/trace.wgsl, trace_splat_mode), which compiles out the lens and ray-differential
    /// code the mode does not use; for whether the light's second caster layer is used
    /// (trace_light_layer2); for the tracer (trace_exact, trace_max_depth) and the branches.
    pub trace: [(&'static str, f64); 7],
    /// coverage_mip's.
    pub coverage: [(&'static str, f64); 1],
    pub splat: crate::splat::SplatStages,
}

impl Stages {
    /// `branches`: the frame's reflected, internal and residual passes (`FrameConsts`).
    pub fn new(s: &RenderSettings, layer2: bool, branches: [bool; 3]) -> Stages {
        let (t, splat) = (s.photons.emission, s.photons.splat);
        let exact = s.photons.tracer == crate::settings::Tracer::Exact;
        Stages {
            trace: [
                ("trace_splat_mode", f64::from(splat.lens_flag(t))),
                ("trace_light_layer2", f64::from(u8::from(layer2 && !exact))),
                ("trace_exact", f64::from(u8::from(exact))),
                ("trace_max_depth", f64::from(s.photons.max_depth)),
                ("trace_first_hit_buffer", f64::from(u8::from(s.testing.first_hit_from_buffer))),
                ("trace_residual_pass", f64::from(u8::from(branches[2]))),
                ("trace_covered", f64::from(1 | u8::from(branches[0]) << 1 | u8::from(branches[1]) << 2)),
            ],
            coverage: [("cover_dilate", f64::from(u8::from(exact)))],
            splat: crate::splat::SplatStages::new(splat, t),
        }
    }
}

/// What the photon stage of one light needs from the frame.
pub(crate) struct Emit<'a> {
    pub ctx: &'a GpuContext,
    pub settings: &'a RenderSettings,
    /// What the frame copies out for inspection.
    pub inspect: crate::settings::Inspect,
    pub stages: &'a Stages,
    pub light_buf: &'a wgpu::Buffer,
    /// Caster front/back, receiver position/normal array views (2D arrays, all faces).
    pub front_pos: &'a wgpu::TextureView,
    pub front_nrm: &'a wgpu::TextureView,
    pub back_pos: &'a wgpu::TextureView,
    pub back_nrm: &'a wgpu::TextureView,
    /// The second caster layer (front position, front normal, back position, back normal): the
    /// casters behind the nearest one (`light_caster_front2`, `light_caster_back2`), or the
    /// first layer's views where the frame has no second layer (the tracing stages then compile
    /// its code out).
    pub layer2: [&'a wgpu::TextureView; 4],
    pub recv_pos: &'a wgpu::TextureView,
    pub recv_nrm: &'a wgpu::TextureView,
    /// The scene (its group: the materials, the BVH for the exact tracer (`crate::accel`), and
    /// the density grid photons march for their path's transmittance, shared/trace.wgsl).
    pub geo: &'a crate::geometry::Geometry,
    pub stats: &'a wgpu::Buffer,
    pub accum: &'a wgpu::Buffer,
    /// The splat mode's extra buffers (multi-resolution maps).
    pub splat_targets: &'a crate::splat::SplatTargets,
    /// Photon grid N and caster buffer size G.
    pub n: u32,
    pub g: u32,
    /// Per face: an upper bound of the relevant photons of the N × N grid (from the casters'
    /// bounding box seen from the light), for the number of batches to record.
    pub bound: Vec<u64>,
    /// Also trace the reflected branch at the first dielectric surface (basic technique).
    pub reflect_branch: bool,
    /// Also trace the branch reflected once inside a dielectric (exact tracer).
    pub internal_branch: bool,
    /// Also trace the residual pass (exact tracer).
    pub residual_branch: bool,
    /// Trace no photons (a directional light whose caustics come from the caustic spheres):
    /// the map stays zero and the statistics count nothing.
    pub skip_photons: bool,
}

impl Emit<'_> {
    /// The branches each face's grid is traced for, in order.
    pub fn branches(&self) -> Vec<Branch> {
        let mut b = vec![Branch::Transmitted];
        if self.reflect_branch {
            b.push(Branch::Reflected);
        }
        if self.internal_branch {
            b.push(Branch::Internal);
        }
        if self.residual_branch {
            b.push(Branch::Residual);
        }
        b
    }
}

impl<'a> Emit<'a> {
    /// A pass of tracing stage `stage` (`photon_trace`, `adaptive_refine`) with what every
    /// tracing stage reads bound: the light, the light-space geometry buffers, the scene group
    /// (materials, BVH, density grid), and the flux bookkeeping.
    pub fn tracing(&self, stage: &'a str) -> Pass<'a> {
        Pass::new(self.ctx, stage)
            .constants(&self.stages.trace)
            .bind("light", self.light_buf)
            .bind("front_pos", self.front_pos)
            .bind("front_nrm", self.front_nrm)
            .bind("back_pos", self.back_pos)
            .bind("back_nrm", self.back_nrm)
            .bind("recv_pos", self.recv_pos)
            .bind("recv_nrm", self.recv_nrm)
            .bind("stats", self.stats)
            .bind("front_pos2", self.layer2[0])
            .bind("front_nrm2", self.layer2[1])
            .bind("back_pos2", self.layer2[2])
            .bind("back_nrm2", self.layer2[3])
            .shared(&self.geo.scene)
    }
}

/// Buffers read back after the frame to fill in the statistics.
pub(crate) struct Pending {
    /// One word per face: covered caster-buffer texels.
    pub coverage: wgpu::Buffer,
    pub faces: u32,
    /// Control buffers (adaptive, hierarchical), one per face.
    pub ctrl: Vec<wgpu::Buffer>,
    pub stats: TechniqueStats,
    /// Grid size of level index 0 of the control buffers' per-level counters.
    pub level0_grid: u32,
    /// Copies of level 0 of the coverage mip per face (`Inspect::coverage`).
    pub masks: Vec<wgpu::Buffer>,
    /// Copies of the traced photon batches (`Inspect::photons`), with their photon counts.
    pub kept: Vec<(wgpu::Buffer, u64)>,
    /// Bytes of one emitted photon's record (adaptive: the photon, and its quad's corners with
    /// caustic triangles), for the peak memory in use.
    pub record_bytes: u64,
}

/// Word indices of the control buffer (mirrors `shaders/shared/hierarchy.wgsl`).
pub(crate) mod ctrl {
    pub const OVERFLOW: usize = 9;
    pub const BATCHES: usize = 11;
    pub const PEAK_CELLS: usize = 13;
    pub const PEAK_PHOTONS: usize = 14;
    pub const SPLATTED: usize = 16;
    pub const CORNERS: usize = 18;
    pub const CELLS: usize = 32;
    pub const TRACED: usize = 64;
    pub const EMITTED: usize = 96;
    pub const WORDS: u64 = 256;
    /// Byte offset of the splat's SplatParams in the indirect-arguments buffer.
    pub const SPLAT_ARGS: u64 = 256;
}

/// The GPU-driven traversal both hierarchies share (adaptive levels, hierarchical tiles): a
/// setup pass that begins it, the start grid's cells (`init`), then per level the stage that
/// refines or traverses (indirect dispatch) and the setup pass that turns its output into the
/// next level's input and dispatch arguments; then the splat, indirect too. No CPU readback.
pub(crate) struct Traversal<'a> {
    pub init: &'a Bound,
    pub init_groups: u32,
    /// The setup after `init`.
    pub after_init: &'a Bound,
    /// Per level: the step and the following setup.
    pub steps: &'a [(Bound, Bound)],
    /// Indirect arguments: the step's at offset 0, the splat's at `ctrl::SPLAT_ARGS`.
    pub args: &'a wgpu::Buffer,
    pub splat: &'a Bound,
}

impl Traversal<'_> {
    /// Record one traversal (pass `label`) beginning with setup `begin`, and its splat.
    pub fn record(&self, enc: &mut wgpu::CommandEncoder, timer: &mut PassTimer, label: &str, begin: &Bound) {
        {
            let mut cp = crate::gpu::pass::begin(enc, timer, label);
            begin.dispatch_in(&mut cp, [1, 1, 1]);
            self.init.dispatch_in(&mut cp, [self.init_groups, self.init_groups, 1]);
            self.after_init.dispatch_in(&mut cp, [1, 1, 1]);
            for (step, setup) in self.steps {
                step.dispatch_indirect_in(&mut cp, self.args, 0);
                setup.dispatch_in(&mut cp, [1, 1, 1]);
            }
        }
        self.splat.dispatch_indirect(enc, timer, self.args, ctrl::SPLAT_ARGS);
    }
}

/// `adaptive_setup` (labelled `label`) with level parameters `lp` over a traversal's control
/// buffer and indirect arguments.
pub(crate) fn setup(ctx: &GpuContext, ctrl: &wgpu::Buffer, args: &wgpu::Buffer, label: &str, lp: LevelParams) -> Bound {
    let u = uniform(ctx, "adaptive_setup", bytemuck::bytes_of(&lp));
    Pass::new(ctx, "adaptive_setup").label(label).bind("lp", &u).bind("ctrl", ctrl).bind("args", args).group()
}

pub(crate) const FLAG_LAST: u32 = 1;
pub(crate) const FLAG_CHECK: u32 = 2;
pub(crate) const FLAG_BEGIN: u32 = 4;
pub(crate) const FLAG_END: u32 = 8;
pub(crate) const FLAG_NO_PLAN: u32 = 16;
pub(crate) const FLAG_QUADS: u32 = 32;
pub(crate) const FLAG_REFLECT: u32 = 64;
pub(crate) const FLAG_SKIP: u32 = 128;
pub(crate) const FLAG_INTERNAL: u32 = 256;
pub(crate) const FLAG_RESIDUAL: u32 = 512;

/// Which branch of the Fresnel tree of paths a pass over the photon grid traces (every
/// technique traces each branch the frame needs as its own pass; shared/trace.wgsl).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Branch {
    /// Transmitted at every dielectric interface (total internal reflection reflects).
    Transmitted,
    /// Reflected at the first dielectric surface.
    Reflected,
    /// Exact tracer: transmitted into the first dielectric, reflected once inside it at the
    /// first exit, transmitted after.
    Internal,
    /// Exact tracer: every Fresnel choice at random with its probability, keeping the paths no
    /// other pass follows (the rest of the tree, unbiased; noisy where it carries much).
    Residual,
}

impl Branch {
    /// The bits of `TraceParams.face` that select it (photon_trace).
    pub fn face_bits(self) -> u32 {
        match self {
            Branch::Transmitted => 0,
            Branch::Reflected => 1 << 31,
            Branch::Internal => 1 << 30,
            Branch::Residual => 1 << 29,
        }
    }

    /// The `LevelParams.flags` that select it (adaptive_refine).
    pub fn flags(self) -> u32 {
        match self {
            Branch::Transmitted => 0,
            Branch::Reflected => FLAG_REFLECT,
            Branch::Internal => FLAG_INTERNAL,
            Branch::Residual => FLAG_RESIDUAL,
        }
    }
}

pub(crate) use crate::gpu::{storage, uniform};

/// Word offset of level `l` of a mip chain whose level 0 is g × g.
pub(crate) fn mip_offset(l: u32, g: u32) -> u64 {
    (0..l).map(|m| ((g >> m) as u64).pow(2)).sum()
}

/// Words of a mip chain of g × g down to `down_to` × `down_to`.
pub(crate) fn mip_words(g: u32, down_to: u32) -> u64 {
    mip_offset(g.trailing_zeros() - down_to.trailing_zeros() + 1, g)
}

/// A coverage mip chain: its passes' name, the buffer it is built in, level 0 `g` × `g` down to
/// `down_to`², from `source` (0: the caster front buffer, 1: the dense photon tile `tile`, which
/// is bound either way).
pub(crate) struct MipChain<'a> {
    pub name: &'a str,
    pub cover: &'a wgpu::Buffer,
    pub tile: &'a wgpu::Buffer,
    pub g: u32,
    pub down_to: u32,
    pub source: u32,
}

/// Record the passes that build coverage mip chain `chain` of face `face`.
pub(crate) fn build_mip(e: &Emit, enc: &mut wgpu::CommandEncoder, timer: &mut PassTimer, face: u32, chain: MipChain) {
    let MipChain { name, cover, tile, g, down_to, source } = chain;
    let levels = g.trailing_zeros() - down_to.trailing_zeros() + 1;
    let groups: Vec<(Bound, u32)> = (0..levels)
        .map(|l| {
            let size = g >> l;
            let p = CoverParams {
                face,
                level: l,
                size,
                src: if l == 0 { 0 } else { mip_offset(l - 1, g) as u32 },
                dst: mip_offset(l, g) as u32,
                source,
                _pad: [0; 2],
            };
            let u = uniform(e.ctx, name, bytemuck::bytes_of(&p));
            let pass = Pass::new(e.ctx, "coverage_mip")
                .constants(&e.stages.coverage)
                .label(name)
                .bind("cp", &u)
                .bind("front_pos", e.front_pos)
                .bind("tile", tile)
                .bind("cover", cover);
            (pass.group(), size)
        })
        .collect();
    let mut cp = crate::gpu::pass::begin(enc, timer, name);
    for (pass, size) in &groups {
        pass.dispatch_in(&mut cp, [size.div_ceil(8), size.div_ceil(8), 1]);
    }
}

/// The level parameters every step of one face shares.
pub(crate) fn level_params(face: u32) -> LevelParams {
    LevelParams {
        face,
        level: 0,
        grid: 0,
        finest: 0,
        gbuffer: 0,
        flags: 0,
        cell_capacity: 0,
        photon_capacity: 0,
        tolerance: 0.0,
        batch_grid: 0,
        batch_leaves: 0,
        max_batches: 0,
        tile_x: 0,
        tile_y: 0,
        grid_n: 0,
        linearity: 0.0,
    }
}

/// A photon emission technique: what the light-space buffers of one light become in its
/// caustic map. A new technique is a module implementing this trait, a [`Emission`] variant
/// and its arm in [`emission`]; the frame around it (light-space passes, resolve, shading,
/// statistics) is shared.
pub(crate) trait EmissionStrategy {
    /// Record face `face`'s photon stage (every branch of `Emit::branches`, each its own pass
    /// or traversal), given the face's coverage mip `cover`; buffers whose contents the
    /// statistics need go into `pending`.
    fn record_face(
        &mut self,
        e: &Emit,
        enc: &mut wgpu::CommandEncoder,
        timer: &mut PassTimer,
        cover: &wgpu::Buffer,
        face: u32,
        pending: &mut Pending,
    );
    /// Fill in what the host knows of the statistics after the last face.
    fn fill(&self, pending: &mut Pending);
}

/// The registry: the emission of technique `t` for the light `e` describes.
fn emission(t: Emission, e: &Emit) -> Result<Box<dyn EmissionStrategy>> {
    Ok(match t {
        Emission::Basic => Box::new(basic::Basic::new(e)),
        Emission::Hierarchical => Box::new(hierarchical::Hierarchical::new(e)?),
        Emission::AdaptiveLevel | Emission::AdaptiveError => Box::new(adaptive::Adaptive::new(e)?),
        // Caustic spheres: directional lights never get here (`Emit::skip_photons`; their
        // caustics are `sphere_gather`'s, recorded by the renderer after the shading passes),
        // spot and point lights get basic caustic maps (`Emission::emission`).
    })
}

/// Record the photon stage of one light: per face, the coverage mip, then the technique.
pub(crate) fn emit(e: &Emit, enc: &mut wgpu::CommandEncoder, timer: &mut PassTimer, faces: u32) -> Result<Pending> {
    let t = e.settings.photons.emission;
    let g = e.g;
    let cover = storage(e.ctx, "coverage", mip_words(g, 1) * 4, wgpu::BufferUsages::empty());
    let dummy = storage(e.ctx, "unused", 64, wgpu::BufferUsages::empty());
    let covres = storage(e.ctx, "covered_texels", faces as u64 * 4, wgpu::BufferUsages::empty());
    let mut pending = Pending {
        coverage: covres,
        faces,
        ctrl: Vec::new(),
        stats: TechniqueStats { technique: t, grid: e.n, ..Default::default() },
        level0_grid: 1,
        masks: Vec::new(),
        kept: Vec::new(),
        record_bytes: 32,
    };
    if e.skip_photons {
        return Ok(pending);
    }
    let mut emission = emission(t, e)?;
    for f in 0..faces {
        let chain = MipChain { name: "coverage_mip", cover: &cover, tile: &dummy, g, down_to: 1, source: 0 };
        build_mip(e, enc, timer, f, chain);
        enc.copy_buffer_to_buffer(&cover, mip_offset(g.trailing_zeros(), g) * 4, &pending.coverage, f as u64 * 4, 4);
        if e.inspect.coverage {
            let m = storage(e.ctx, "coverage_mask", (g as u64).pow(2) * 4, wgpu::BufferUsages::empty());
            enc.copy_buffer_to_buffer(&cover, 0, &m, 0, (g as u64).pow(2) * 4);
            pending.masks.push(m);
        }
        emission.record_face(e, enc, timer, &cover, f, &mut pending);
    }
    emission.fill(&mut pending);
    Ok(pending)
}

impl Pending {
    /// The buffers (and byte counts) [`Pending::finish`] reads, in the order it reads them.
    pub fn sources(&self) -> Vec<(wgpu::Buffer, u64)> {
        let mut out = vec![(self.coverage.clone(), self.faces as u64 * 4)];
        out.extend(self.masks.iter().map(|m| (m.clone(), m.size())));
        let photon = std::mem::size_of::<crate::gpu::types::Photon>() as u64;
        out.extend(self.kept.iter().map(|(b, count)| (b.clone(), count * photon)));
        out.extend(self.ctrl.iter().map(|b| (b.clone(), ctrl::WORDS * 4)));
        out
    }

    /// The statistics, from the contents of [`Pending::sources`] (read after the frame ran).
    pub fn finish(mut self, data: &[Vec<u8>]) -> Result<TechniqueStats> {
        let mut data = data.iter();
        let mut next = || data.next().cloned().ok_or_else(|| Error::Device("technique statistics incomplete".into()));
        let cov = next()?;
        let words: &[u32] = bytemuck::cast_slice(&cov);
        let s = &mut self.stats;
        let covered: u64 = words.iter().map(|&w| w as u64).sum();
        s.covered_texels += covered;
        let g = s.face_texels_g();
        s.face_texels += self.faces as u64 * (g as u64).pow(2);
        let r = (s.grid as u64 / g as u64).pow(2);
        s.relevant += covered * r;
        for _ in &self.masks {
            s.coverage_masks.push(bytemuck::cast_slice(&next()?).to_vec());
        }
        for _ in &self.kept {
            s.photons.extend_from_slice(bytemuck::cast_slice(&next()?));
        }
        let mut peak_cells = 0u64;
        let mut peak_photons = 0u64;
        for _ in &self.ctrl {
            let data = next()?;
            let c: &[u32] = bytemuck::cast_slice(&data);
            let overflow = c[ctrl::OVERFLOW];
            if overflow != 0 {
                let mut what = Vec::new();
                if overflow & 1 != 0 {
                    what.push("the cell list");
                }
                if overflow & 2 != 0 {
                    what.push("the photon buffer");
                }
                if overflow & 4 != 0 {
                    what.push("the batch plan's 32-bit photon count (too many relevant photons per face)");
                }
                if overflow & 8 != 0 {
                    what.push("the number of batches recorded");
                }
                return Err(Error::Device(format!(
                    "{} overflowed: {} (detected on the GPU; the caustic map is incomplete)",
                    s.technique,
                    what.join(", ")
                )));
            }
            if s.technique.is_adaptive() {
                s.batches += c[ctrl::BATCHES];
            }
            s.photons_splatted += c[ctrl::SPLATTED] as u64 | (c[ctrl::SPLATTED + 1] as u64) << 32;
            s.corners_traced += c[ctrl::CORNERS] as u64 | (c[ctrl::CORNERS + 1] as u64) << 32;
            peak_cells = peak_cells.max(c[ctrl::PEAK_CELLS] as u64);
            peak_photons = peak_photons.max(c[ctrl::PEAK_PHOTONS] as u64);
            for k in 0..32 {
                let (cells, traced, emitted) =
                    (c[ctrl::CELLS + k] as u64, c[ctrl::TRACED + k] as u64, c[ctrl::EMITTED + k] as u64);
                if cells + traced + emitted == 0 {
                    continue;
                }
                let l = s.level_mut(self.level0_grid << k);
                l.cells += cells;
                l.traced += traced;
                l.emitted += emitted;
            }
        }
        if s.technique.is_adaptive() {
            s.peak_photon_bytes = peak_cells * 4 + peak_photons * self.record_bytes;
        } else {
            s.peak_photon_bytes = s.photon_bytes;
        }
        if !self.ctrl.is_empty() {
            let traced: u64 = s.levels.iter().map(|l| l.traced).sum();
            let cells: u64 = s.levels.iter().map(|l| l.cells).sum();
            if s.technique.is_adaptive() {
                s.photons_traced = traced;
                s.evaluated = cells + traced;
            } else {
                s.evaluated = cells + s.photons_splatted;
            }
        }
        Ok(self.stats)
    }
}

impl TechniqueStats {
    /// Add another light's statistics.
    pub fn merge(&mut self, o: &TechniqueStats) {
        self.technique = o.technique;
        self.grid = o.grid;
        self.photons_traced += o.photons_traced;
        self.photons_splatted += o.photons_splatted;
        self.corners_traced += o.corners_traced;
        self.relevant += o.relevant;
        self.covered_texels += o.covered_texels;
        self.face_texels += o.face_texels;
        self.evaluated += o.evaluated;
        for l in &o.levels {
            let m = self.level_mut(l.grid);
            m.cells += l.cells;
            m.traced += l.traced;
            m.emitted += l.emitted;
        }
        self.photon_bytes = self.photon_bytes.max(o.photon_bytes);
        self.peak_photon_bytes = self.peak_photon_bytes.max(o.peak_photon_bytes);
        self.batches += o.batches;
        self.coverage_masks.extend(o.coverage_masks.iter().cloned());
        self.photons.extend_from_slice(&o.photons);
    }

    fn face_texels_g(&self) -> u32 {
        self.grid.min(crate::settings::MAX_GBUFFER)
    }
}
