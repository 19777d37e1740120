//! Adaptive caustic maps (Wyman & Nichols 2009), GPU-driven with compute shaders as Piao 2015
//! proposes: a photon hierarchy over the light-space geometry buffers, traversed breadth-first
//! from a coarse grid (64² by default) down to the finest grid N, with photons created only
//! where needed by point-sampling the geometry buffers (deferred), never as a dense buffer.
//!
//! Per face and batch, recorded once per frame with no CPU readback between levels:
//! `adaptive_setup` (begin), `adaptive_init` (the batch's cells of the start grid), then per
//! level `adaptive_refine` (indirect dispatch: discard, emit or refine each cluster, appending
//! children and photons with atomic counters into one cell list with read and write regions and
//! one photon buffer) and `adaptive_setup` (next level's indirect arguments, the splat's
//! indirect arguments and photon count), then `photon_splat` (indirect), or the splat mode's
//! stage: with caustic triangles, `adaptive_refine` also traces each emitted cell's corners and
//! `splat_quads` spreads the cell's flux over their quad (`docs/splatting.md`).
//!
//! Batching: `adaptive_plan` splits each face's hierarchy into batches of at most the photon
//! capacity the memory budget allows, from the exact relevant-photon counts of the coverage mip
//! (an upper bound of what either metric emits), so memory stays bounded whatever N. The host
//! records as many batches as an upper bound from the casters' bounding box allows; batches the
//! plan leaves empty cost empty indirect dispatches. Any overflow is flagged on the GPU and
//! reported after the frame.

use super::{
    Emission, Emit, FLAG_BEGIN, FLAG_CHECK, FLAG_END, FLAG_LAST, FLAG_QUADS, FLAG_SKIP, Pending, Traversal, ctrl,
    level_params, storage, uniform,
};
use crate::error::{Error, Result};
use crate::gpu::PassTimer;
use crate::gpu::pass::Pass;
use crate::gpu::types::{LevelParams, Photon};
use crate::settings::RenderSettings;

/// Bytes per leaf photon of batch capacity: the photon (32) and its slots in the two cell
/// regions (2 × 4).
pub const BYTES_PER_PHOTON: u64 = 40;
/// Further bytes per photon with caustic triangles (`--splat triangles`): the landing points of
/// its cell's four corners (`splat_quads`).
pub const BYTES_PER_QUAD: u64 = 32;

/// Bytes per leaf photon of batch capacity for `settings`.
pub fn bytes_per_photon(s: &RenderSettings) -> u64 {
    BYTES_PER_PHOTON + if s.photons.splat.cell_quads(s.photons.emission) { BYTES_PER_QUAD } else { 0 }
}
/// The largest batch grid (the plan is S² words, and one workgroup walks it).
const MAX_BATCH_GRID: u32 = 4096;

/// How one frame's hierarchy is laid out and batched (host side).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AdaptivePlan {
    /// Finest grid N and start grid (base, a power of two, at most N / 2).
    pub n: u32,
    pub base: u32,
    /// Grid whose cells are assigned to batches (≥ base).
    pub batch_grid: u32,
    /// Photons (and cells per region) one batch can hold.
    pub capacity: u64,
    /// Leaf photons per batch the plan fills up to (capacity less the largest cell).
    pub batch_leaves: u64,
    /// Bytes of photon storage: photon buffer, two cell regions, plan (and the corner buffer).
    pub bytes: u64,
    /// Bytes per photon of capacity ([`bytes_per_photon`]).
    pub photon_bytes: u64,
}

impl AdaptivePlan {
    /// The plan for `settings`, or an input error naming the option at fault.
    pub fn new(s: &RenderSettings, max_bind: u64) -> Result<AdaptivePlan> {
        let n = s.photons.count;
        let cl = |f: &str, m: String| Err(Error::input("<settings>", f, m));
        if !n.is_power_of_two() || !(32..=65536).contains(&n) {
            return cl(
                "photons.count",
                format!("adaptive caustic maps need a power of two from 32 to 65536 (got {n})"),
            );
        }
        if !s.adaptive.base_grid.is_power_of_two() || !(4..=4096).contains(&s.adaptive.base_grid) {
            return cl(
                "adaptive.base_grid",
                format!("must be a power of two from 4 to 4096 (got {})", s.adaptive.base_grid),
            );
        }
        let base = s.adaptive.base_grid.min(n / 2);
        let per_photon = bytes_per_photon(s);
        let mut sb = base;
        loop {
            let plan_bytes = (sb as u64).pow(2) * 4;
            let capacity = (s.photons.memory.saturating_sub(plan_bytes) / per_photon).min(max_bind / 32);
            let cell = ((n / sb) as u64).pow(2);
            if cell * 2 <= capacity && capacity >= 64 {
                return Ok(AdaptivePlan {
                    n,
                    base,
                    batch_grid: sb,
                    capacity,
                    batch_leaves: capacity - cell,
                    bytes: capacity * per_photon + plan_bytes,
                    photon_bytes: per_photon,
                });
            }
            if sb >= n / 2 || sb >= MAX_BATCH_GRID {
                return cl(
                    "photon_memory",
                    format!(
                        "{} KiB of photon memory is too small for even one batch of the {n}x{n} photon hierarchy \
                         (a batch must hold at least two {1}x{1} cells of {per_photon} bytes per photon, \
                         plus a {2}x{2} plan)",
                        s.photons.memory >> 10,
                        n / sb,
                        sb
                    ),
                );
            }
            sb *= 2;
        }
    }

    /// Level index (of the control buffer's per-level counters) of grid `s`.
    fn level(&self, s: u32) -> u32 {
        (s / self.base).trailing_zeros()
    }
}

pub(crate) struct Adaptive {
    plan: AdaptivePlan,
    cells: wgpu::Buffer,
    photons: wgpu::Buffer,
    plan_buf: wgpu::Buffer,
    args: wgpu::Buffer,
    /// Caustic triangles: two vec4f per photon, its cell's corner landing points (otherwise a
    /// 16-byte placeholder for adaptive_refine's binding).
    corners: wgpu::Buffer,
    quads: bool,
}

impl Adaptive {
    pub fn new(e: &Emit) -> Result<Adaptive> {
        let mut plan = AdaptivePlan::new(e.settings, e.ctx.device.limits().max_storage_buffer_binding_size)?;
        // Allocate no more than the whole N × N face can need (one batch then suffices). Sized
        // by the settings alone, not by where the casters are: a persistent renderer keeps the
        // buffers while lights and objects move.
        let cell = ((plan.n / plan.batch_grid) as u64).pow(2);
        let need = ((plan.n as u64).pow(2) + cell).max(2 * cell).max(64);
        if need < plan.capacity {
            plan.bytes -= (plan.capacity - need) * plan.photon_bytes;
            plan.capacity = need;
            plan.batch_leaves = need - cell;
        }
        let none = wgpu::BufferUsages::empty();
        let quads = e.settings.photons.splat.cell_quads(e.settings.photons.emission);
        Ok(Adaptive {
            corners: storage(e.ctx, "corners", if quads { plan.capacity * BYTES_PER_QUAD } else { 16 }, none),
            quads,
            cells: storage(e.ctx, "cells", plan.capacity * 8, none),
            photons: storage(e.ctx, "photons", plan.capacity * std::mem::size_of::<Photon>() as u64, none),
            plan_buf: storage(e.ctx, "batch_plan", (plan.batch_grid as u64).pow(2) * 4, none),
            args: storage(e.ctx, "indirect_args", ctrl::SPLAT_ARGS + 16, wgpu::BufferUsages::INDIRECT),
            plan,
        })
    }

    fn record_face_inner(
        &mut self,
        e: &Emit,
        enc: &mut wgpu::CommandEncoder,
        timer: &mut PassTimer,
        cover: &wgpu::Buffer,
        f: u32,
        branch: super::Branch,
    ) -> wgpu::Buffer {
        let p = self.plan;
        let s = e.settings;
        let ctrl_buf = storage(e.ctx, "hierarchy_control", ctrl::WORDS * 4, wgpu::BufferUsages::empty());
        let max_batches = e.bound[f as usize].div_ceil(p.batch_leaves).clamp(1, (p.batch_grid as u64).pow(2)) as u32;
        let lp = LevelParams {
            finest: p.n,
            gbuffer: e.g,
            cell_capacity: p.capacity as u32,
            photon_capacity: p.capacity as u32,
            tolerance: s.adaptive.error_tolerance,
            linearity: s.adaptive.quad_linearity,
            batch_grid: p.batch_grid,
            batch_leaves: p.batch_leaves as u32,
            max_batches,
            grid_n: p.n,
            ..level_params(f)
        };
        let setup = |label, lp| super::setup(e.ctx, &ctrl_buf, &self.args, label, lp);
        let u_plan = uniform(e.ctx, "adaptive_plan", bytemuck::bytes_of(&lp));
        let plan = Pass::new(e.ctx, "adaptive_plan")
            .bind("lp", &u_plan)
            .bind("cover", cover)
            .bind("plan", &self.plan_buf)
            .bind("ctrl", &ctrl_buf)
            .group();
        let init = Pass::new(e.ctx, "adaptive_init")
            .bind("lp", &u_plan)
            .bind("cover", cover)
            .bind("plan", &self.plan_buf)
            .bind("cells", &self.cells)
            .bind("ctrl", &ctrl_buf)
            .group();
        let begin = setup("adaptive_setup", LevelParams { flags: FLAG_BEGIN, ..lp });
        let end_begin = setup("adaptive_setup", LevelParams { flags: FLAG_BEGIN | FLAG_END, ..lp });
        let end = setup("adaptive_end", LevelParams { flags: FLAG_END, ..lp });
        let after_init = setup("adaptive_setup", LevelParams { level: p.level(p.batch_grid), ..lp });
        // One step per cluster grid from the batch grid to N / 2.
        let mut steps = Vec::new();
        let mut grid = p.batch_grid;
        while grid < p.n {
            let mut flags = 0;
            if grid * 2 == p.n {
                flags |= FLAG_LAST;
            }
            if s.photons.emission == Emission::AdaptiveError && grid * 2 >= s.adaptive.check_grid {
                flags |= FLAG_CHECK;
                if s.testing.error_skip_hopeless {
                    flags |= FLAG_SKIP;
                }
            }
            if self.quads {
                flags |= FLAG_QUADS;
            }
            flags |= branch.flags();
            let rl = LevelParams { level: p.level(grid), grid, flags, ..lp };
            let u = uniform(e.ctx, "adaptive_refine", bytemuck::bytes_of(&rl));
            let refine = e
                .tracing("adaptive_refine")
                .bind("lp", &u)
                .bind("cover", cover)
                .bind("cells", &self.cells)
                .bind("photons", &self.photons)
                .bind("ctrl", &ctrl_buf)
                .bind("corners", &self.corners)
                .group();
            steps.push((refine, setup("adaptive_setup", LevelParams { level: p.level(grid * 2), ..lp })));
            grid *= 2;
        }
        let splat_params =
            wgpu::BufferBinding { buffer: &self.args, offset: ctrl::SPLAT_ARGS, size: std::num::NonZeroU64::new(16) };
        let splat = e.splat_targets.splat(e, splat_params, &self.photons, Some(&self.corners));
        plan.dispatch(enc, timer, [1, 1, 1]);
        let traversal = Traversal {
            init: &init,
            init_groups: p.batch_grid.div_ceil(8),
            after_init: &after_init,
            steps: &steps,
            args: &self.args,
            splat: &splat,
        };
        for b in 0..max_batches {
            traversal.record(enc, timer, "adaptive_traverse", if b == 0 { &begin } else { &end_begin });
        }
        end.dispatch(enc, &mut PassTimer::disabled(), [1, 1, 1]);
        ctrl_buf
    }

    fn fill_inner(&self, pending: &mut Pending) {
        pending.level0_grid = self.plan.base;
        pending.stats.photon_bytes = self.plan.bytes;
        pending.record_bytes = self.plan.photon_bytes - 8;
    }
}

impl super::EmissionStrategy for Adaptive {
    fn record_face(
        &mut self,
        e: &Emit,
        enc: &mut wgpu::CommandEncoder,
        timer: &mut PassTimer,
        cover: &wgpu::Buffer,
        face: u32,
        pending: &mut Pending,
    ) {
        for b in e.branches() {
            pending.ctrl.push(self.record_face_inner(e, enc, timer, cover, face, b));
        }
    }

    fn fill(&self, pending: &mut Pending) {
        self.fill_inner(pending);
    }
}
