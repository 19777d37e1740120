//! The beam hierarchy of one light: `beam_refine` at every level (and `beam_shrink`), then
//! `beam_order`, which lists the kept beams in hierarchy order.

use crate::gpu::pass::Pass;
use crate::gpu::types::{BEAM_KINDS, BEAM_ORDER_RUN, BeamGpu, BeamLevel, BeamParams, BeamPart, BeamTri};
use crate::gpu::{GpuContext, PassTimer};
use crate::passes::DrawCtx;

use super::params::{Chunks, KINDS, kinds};
use super::{BeamFrame, STATS_WORDS};

/// The entry of `beam_refine`'s indirect arguments (16 bytes each, one per level before it) that
/// holds `beam_shrink`'s dispatch size and the parts queued (`PARTS_ARGS` in
/// shaders/shared/beams.wgsl).
const PARTS_ARGS: u64 = 7;

/// The most parts `beam_shrink` takes (one dispatch of 65535 workgroups of 64).
const PARTS_MAX: u64 = 65535 * 64;

/// `beam_refine` (every level) and `beam_order` for one light.
pub(super) fn record_light_beams(
    ctx: &GpuContext,
    dc: &DrawCtx,
    light_buf: &wgpu::Buffer,
    bp: &BeamParams,
    (footprint, scale): ([f32; 4], u32),
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) -> BeamFrame {
    let storage = wgpu::BufferUsages::empty();
    let levels = bp.levels;
    let per_level = |l: u32| (2 * u64::from(bp.grid).pow(2) * u64::from(bp.faces)) << (2 * l);
    let offset = |l: u32| (0..l).map(per_level).sum::<u64>();
    let slots = u64::from(bp.slots);
    let params = ctx.constants("beam_params", bytemuck::bytes_of(bp));
    let work = crate::gpu::storage(ctx, "beam_work", slots * std::mem::size_of::<BeamTri>() as u64, storage);
    let args = crate::gpu::storage(ctx, "beam_args", 16 * 8, storage);
    // The next level's dispatch size, copied out of `args` (a buffer a dispatch writes cannot be
    // its own indirect argument).
    let indirect = crate::gpu::storage(ctx, "beam_indirect", 16 * 8, wgpu::BufferUsages::INDIRECT);
    let slot_buf = crate::gpu::storage(ctx, "beam_slots", KINDS * slots * 4, storage);
    let cap = u64::from(bp.capacity);
    let beams = crate::gpu::storage(ctx, "beams", cap * std::mem::size_of::<BeamGpu>() as u64, storage);
    let order = crate::gpu::storage(ctx, "beam_order", cap * 4, storage);
    let stats = crate::gpu::storage(ctx, "beam_stats", STATS_WORDS * 4, storage);
    // The parts of the silhouette triangles (`beam_shrink`): at most one beam each, so no more
    // than the beam buffer holds (more are counted as an overflow).
    let parts =
        crate::gpu::storage(ctx, "beam_parts", cap.min(PARTS_MAX) * std::mem::size_of::<BeamPart>() as u64, storage);
    let geo = dc.geo;
    for l in 0..=levels {
        let lv = BeamLevel {
            level: l,
            offset: offset(l) as u32,
            next_offset: offset(l + 1) as u32,
            base_count: per_level(0) as u32,
        };
        let lvb = ctx.uniform("beam_level", bytemuck::bytes_of(&lv));
        let refine = Pass::new(ctx, "beam_refine")
            .bind("light", light_buf)
            .bind("bp", &params)
            .bind("lv", &lvb)
            .shared(&geo.scene)
            .bind("work", &work)
            .bind("args", &args)
            .bind("slots", &slot_buf)
            .bind("beams", &beams)
            .bind("stats", &stats)
            .bind("parts", &parts);
        if l == 0 {
            let groups = (per_level(0) as u32).div_ceil(64);
            refine.dispatch(enc, timer, [groups.min(65535), groups.div_ceil(65535), 1]);
        } else {
            refine.dispatch_indirect(enc, timer, &indirect, 16 * u64::from(l));
        }
        if l < levels {
            let at = 16 * u64::from(l + 1);
            enc.copy_buffer_to_buffer(&args, at, &indirect, at, 16);
        }
    }
    // `beam_shrink`: the beams of the silhouette triangles' parts `beam_refine` queued, one
    // thread each (indirect dispatch over their count, in `args`' entry [`PARTS_ARGS`]).
    let at = 16 * PARTS_ARGS;
    enc.copy_buffer_to_buffer(&args, at, &indirect, at, 16);
    Pass::new(ctx, "beam_shrink")
        .bind("light", light_buf)
        .bind("bp", &params)
        .shared(&geo.scene)
        .bind("parts", &parts)
        .bind("args", &args)
        .bind("slots", &slot_buf)
        .bind("beams", &beams)
        .bind("stats", &stats)
        .dispatch_indirect(enc, timer, &indirect, at);
    let chunks = Chunks::new(bp, &footprint, (kinds(bp), scale));
    let dispatch = chunks.dispatch_buffer(ctx);
    record_order(ctx, (&params, bp.slots), (&slot_buf, &order, &stats), (&chunks, &dispatch), enc, timer);
    let size = (bp.width, bp.height);
    BeamFrame {
        light: 0,
        params,
        stats,
        beams,
        order,
        capacity: bp.capacity,
        levels,
        footprint,
        chunks,
        dispatch,
        size,
        hulls: None,
    }
}

/// `beam_order_runs` (count), `beam_order` (the runs' places, the dispatch sizes) and
/// `beam_order_runs` (write): the kept beams listed in hierarchy order.
pub(super) fn record_order(
    ctx: &GpuContext,
    (params, slots_n): (&wgpu::Buffer, u32),
    (slots, order, stats): (&wgpu::Buffer, &wgpu::Buffer, &wgpu::Buffer),
    (chunks, dispatch): (&Chunks, &wgpu::Buffer),
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) {
    let n_runs = (u64::from(BEAM_KINDS) * u64::from(slots_n)).div_ceil(u64::from(BEAM_ORDER_RUN)).max(1);
    let runs = crate::gpu::storage(ctx, "beam_order_runs", 4 * n_runs, wgpu::BufferUsages::empty());
    let groups = n_runs.div_ceil(64) as u32;
    // Each dispatch labelled and timed as `beam_order` (the list's three dispatches are one pass
    // to `bench`).
    let groups = [groups.min(65535), groups.div_ceil(65535), 1];
    let runs_pass = |write: bool| {
        Pass::new(ctx, "beam_order_runs")
            .constants(&[("order_write", f64::from(u8::from(write)))])
            .label("beam_order")
            .bind("bp", params)
            .bind("slots", slots)
            .bind("runs", &runs)
            .bind("order", order)
    };
    runs_pass(false).dispatch(enc, timer, groups);
    let cu = ctx.uniform("beam_order_chunks", bytemuck::bytes_of(&chunks.gpu()));
    Pass::new(ctx, "beam_order")
        .bind("bp", params)
        .bind("runs", &runs)
        .bind("stats", stats)
        .bind("ch", &cu)
        .bind("dispatch", dispatch)
        .dispatch(enc, timer, [1, 1, 1]);
    runs_pass(true).dispatch(enc, timer, groups);
}
