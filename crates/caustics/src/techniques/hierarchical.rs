//! Hierarchical caustic maps (Wyman 2008), the baseline of adaptive caustic maps: the dense
//! N × N photon grid is traced (`photon_trace`) into a dense photon buffer, tile by tile (a tile
//! is T × T photons, the largest that fits the photon memory), a mip hierarchy of valid-photon
//! counts is built over the tile (`hcm_mip`), and traversed top-down (`hcm_traverse`, GPU-driven
//! like the adaptive technique: indirect dispatches, atomic appends) to copy only the valid
//! photons into a compact buffer that is splatted (indirect). Irrelevant regions are skipped by
//! the traversal and the splat, but every photon of the dense grid is still created.
//! With caustic triangles, `hcm_traverse` also gives each compacted photon its dual quad from
//! its neighbours in the dense tile (`splat_quads`, `docs/splatting.md`).

use super::{
    Emit, FLAG_BEGIN, FLAG_END, FLAG_LAST, FLAG_NO_PLAN, FLAG_QUADS, Pending, Traversal, build_mip, ctrl, level_params,
    mip_words, storage, uniform,
};
use crate::error::{Error, Result};
use crate::gpu::PassTimer;
use crate::gpu::pass::Pass;
use crate::gpu::types::{LevelParams, Photon, TraceParams};
use crate::settings::RenderSettings;

/// Tile layout of the dense grid (host side).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HierarchicalPlan {
    pub n: u32,
    /// Tile size T (photons per side) and the traversal's start grid over a tile.
    pub tile: u32,
    pub start: u32,
    /// Bytes of photon storage: dense tile, compact buffer, cell regions, mip chain (and the
    /// compacted photons' quad corners with caustic triangles).
    pub bytes: u64,
    /// Caustic triangles: the compacted photons carry dual quads (`hcm_traverse`).
    pub quads: bool,
}

impl HierarchicalPlan {
    pub fn bytes_for(t: u32, start: u32, quads: bool) -> u64 {
        let t2 = (t as u64).pow(2);
        let corners = if quads { t2 * QUAD_BYTES } else { 0 };
        t2 * 64 + corners + (t as u64 / 2).pow(2).max(1) * 8 + mip_words(t, start) * 4
    }

    pub fn new(s: &RenderSettings, max_bind: u64) -> Result<HierarchicalPlan> {
        let n = s.photons.count;
        let cl = |f: &str, m: String| Err(Error::input("<settings>", f, m));
        if !n.is_power_of_two() || n < 32 {
            return cl(
                "photons.count",
                format!("hierarchical caustic maps need a power of two from 32 to 8192 (got {n})"),
            );
        }
        let quads = s.photons.splat.cell_quads(s.photons.emission);
        let mut t = n.min(2048);
        loop {
            let start = s.adaptive.base_grid.min(t / 2).max(1);
            let bytes = HierarchicalPlan::bytes_for(t, start, quads);
            if bytes <= s.photons.memory && (t as u64).pow(2) * 32 <= max_bind {
                return Ok(HierarchicalPlan { n, tile: t, start, bytes, quads });
            }
            if t <= 8 {
                return cl(
                    "photon_memory",
                    format!(
                        "{} KiB is too small for one 8x8 tile of hierarchical caustic maps",
                        s.photons.memory >> 10
                    ),
                );
            }
            t /= 2;
        }
    }
}

pub(crate) struct Hierarchical {
    plan: HierarchicalPlan,
    tile: wgpu::Buffer,
    compact: wgpu::Buffer,
    cells: wgpu::Buffer,
    mip: wgpu::Buffer,
    args: wgpu::Buffer,
    dummy: wgpu::Buffer,
    /// Caustic triangles: two vec4f per compacted photon (its dual quad's corners); otherwise a
    /// 16-byte placeholder for hcm_traverse's binding.
    corners: wgpu::Buffer,
    tiles: u32,
}

/// Bytes per compacted photon of its dual quad's corners (caustic triangles).
const QUAD_BYTES: u64 = 32;

impl Hierarchical {
    pub fn new(e: &Emit) -> Result<Hierarchical> {
        let plan = HierarchicalPlan::new(e.settings, e.ctx.device.limits().max_storage_buffer_binding_size)?;
        let none = wgpu::BufferUsages::empty();
        let t2 = (plan.tile as u64).pow(2);
        let stride = std::mem::size_of::<Photon>() as u64;
        Ok(Hierarchical {
            tile: storage(e.ctx, "dense_photons", t2 * stride, none),
            compact: storage(e.ctx, "photons", t2 * stride, none),
            cells: storage(e.ctx, "cells", (plan.tile as u64 / 2).pow(2).max(1) * 8, none),
            mip: storage(e.ctx, "hcm_mip", mip_words(plan.tile, plan.start) * 4, none),
            args: storage(e.ctx, "indirect_args", ctrl::SPLAT_ARGS + 16, wgpu::BufferUsages::INDIRECT),
            dummy: storage(e.ctx, "unused", 64, none),
            corners: storage(e.ctx, "corners", if plan.quads { t2 * QUAD_BYTES } else { 16 }, none),
            plan,
            tiles: 0,
        })
    }

    fn record_face_inner(
        &mut self,
        e: &Emit,
        enc: &mut wgpu::CommandEncoder,
        timer: &mut PassTimer,
        f: u32,
        branch: super::Branch,
    ) -> wgpu::Buffer {
        let p = self.plan;
        let t = p.tile;
        let ctrl_buf = storage(e.ctx, "hierarchy_control", ctrl::WORDS * 4, wgpu::BufferUsages::empty());
        let cap = (t as u64 / 2).pow(2).max(1) as u32;
        let lp = LevelParams {
            finest: t,
            gbuffer: t,
            cell_capacity: cap,
            photon_capacity: t * t,
            batch_grid: p.start,
            flags: FLAG_NO_PLAN,
            grid_n: p.n,
            ..level_params(f)
        };
        let setup = |label, lp| super::setup(e.ctx, &ctrl_buf, &self.args, label, lp);
        let u_init = uniform(e.ctx, "hcm_init", bytemuck::bytes_of(&lp));
        // (the tile's mip in place of the coverage, and no batch plan)
        let init = Pass::new(e.ctx, "adaptive_init")
            .bind("lp", &u_init)
            .bind("cover", &self.mip)
            .bind("plan", &self.dummy)
            .bind("cells", &self.cells)
            .bind("ctrl", &ctrl_buf)
            .group();
        let begin = setup("adaptive_setup", LevelParams { flags: FLAG_BEGIN, ..lp });
        let end_begin = setup("adaptive_setup", LevelParams { flags: FLAG_BEGIN | FLAG_END, ..lp });
        let end = setup("hcm_end", LevelParams { flags: FLAG_END, ..lp });
        let after_init = setup("adaptive_setup", LevelParams { level: 0, flags: 0, ..lp });
        let mut steps = Vec::new();
        let (mut grid, mut level) = (p.start, 0);
        while grid < t {
            let mut flags = if grid * 2 == t { FLAG_LAST } else { 0 };
            if p.quads {
                flags |= FLAG_QUADS;
            }
            let hl = LevelParams { level, grid, flags, ..lp };
            let u = uniform(e.ctx, "hcm_traverse", bytemuck::bytes_of(&hl));
            let traverse = Pass::new(e.ctx, "hcm_traverse")
                .bind("lp", &u)
                .bind("cover", &self.mip)
                .bind("cells", &self.cells)
                .bind("tile", &self.tile)
                .bind("photons", &self.compact)
                .bind("ctrl", &ctrl_buf)
                .bind("corners", &self.corners)
                .bind("light", e.light_buf)
                .group();
            steps.push((traverse, setup("adaptive_setup", LevelParams { level: level + 1, flags: 0, ..lp })));
            grid *= 2;
            level += 1;
        }
        let splat_params =
            wgpu::BufferBinding { buffer: &self.args, offset: ctrl::SPLAT_ARGS, size: std::num::NonZeroU64::new(16) };
        let splat = e.splat_targets.splat(e, splat_params, &self.compact, Some(&self.corners));
        let traversal = Traversal {
            init: &init,
            init_groups: p.start.div_ceil(8),
            after_init: &after_init,
            steps: &steps,
            args: &self.args,
            splat: &splat,
        };
        let per_side = p.n / t;
        let mut first = true;
        for ty in 0..per_side {
            for tx in 0..per_side {
                let tp = uniform(
                    e.ctx,
                    "trace_params",
                    bytemuck::bytes_of(&TraceParams {
                        // The high bits select the branch (photon_trace).
                        face: f | branch.face_bits(),
                        batch_offset: ty * t * p.n + tx * t,
                        batch_count: t * t,
                        tile: t,
                    }),
                );
                let trace = e.tracing("photon_trace").bind("tp", &tp).bind("photons", &self.tile);
                trace.dispatch(enc, timer, [(t * t).div_ceil(64), 1, 1]);
                let chain = super::MipChain {
                    name: "hcm_mip",
                    cover: &self.mip,
                    tile: &self.tile,
                    g: t,
                    down_to: p.start,
                    source: 1,
                };
                build_mip(e, enc, timer, f, chain);
                traversal.record(enc, timer, "hcm_traverse", if first { &begin } else { &end_begin });
                first = false;
                self.tiles += 1;
            }
        }
        end.dispatch(enc, &mut PassTimer::disabled(), [1, 1, 1]);
        ctrl_buf
    }

    fn fill_inner(&self, pending: &mut Pending) {
        let p = self.plan;
        pending.level0_grid = p.start * (p.n / p.tile);
        let s = &mut pending.stats;
        s.photon_bytes = p.bytes;
        s.batches = self.tiles;
        s.photons_traced = (p.n as u64).pow(2) * pending.ctrl.len() as u64;
    }
}

impl super::EmissionStrategy for Hierarchical {
    fn record_face(
        &mut self,
        e: &Emit,
        enc: &mut wgpu::CommandEncoder,
        timer: &mut PassTimer,
        _cover: &wgpu::Buffer,
        face: u32,
        pending: &mut Pending,
    ) {
        for b in e.branches() {
            pending.ctrl.push(self.record_face_inner(e, enc, timer, face, b));
        }
    }

    fn fill(&self, pending: &mut Pending) {
        self.fill_inner(pending);
    }
}
