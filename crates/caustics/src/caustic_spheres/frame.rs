//! Caustic spheres in a frame: the records of the frame's directional lights (the environment's
//! regions spread over their sub-directions), weighted on the GPU by the environment's
//! visibility from each object where there is one ([`super::visibility`], `sphere_weights`),
//! then `sphere_compile` (the compiled variant) and `sphere_gather`; `sphere_volume` later, after
//! the composite ([`SphereFrame::record_volume`]).

use super::Blend;
use super::gpu::{GpuSpheres, Records, record_compile, record_gather, record_volume};
use super::visibility::{self, VisibilityState, VisibilityUpdate};
use crate::gpu::PassTimer;
use crate::gpu::pass::Pass;
use crate::gpu::types::SphereRecord;
use crate::passes::{DrawCtx, EyeFrame};
use crate::scene::Light;
use glam::Affine3A;

/// What the frame's caustic spheres depend on besides the tables.
pub(crate) struct SphereInputs<'a> {
    /// The directional lights whose caustics the spheres draw: the scene's `own` lights, then
    /// the environment's regions or their sub-directions ([`super::gpu::spread_lights`]).
    pub lights: &'a [Light],
    pub own: usize,
    pub transforms: &'a [Affine3A],
    pub blend: Blend,
}

/// Records written by `sphere_weights`.
struct Weighted {
    /// Every record, the dropped ones black (the order and count of the CPU's list).
    weighted: wgpu::Buffer,
    /// The kept records.
    compact: wgpu::Buffer,
    /// Kept count and the full-filter threshold (`Records::Gpu`).
    counts: wgpu::Buffer,
    len: u32,
}

impl Weighted {
    fn compact(&self) -> Records<'_> {
        Records::Gpu { buffer: &self.compact, len: self.len, counts: &self.counts }
    }
}

/// The direct records a frame's `sphere_volume` reads.
enum Direct {
    Cpu(Vec<SphereRecord>),
    Gpu(Weighted),
}

/// A frame's caustic spheres, recorded up to the gather.
pub(crate) struct SphereFrame {
    /// `sphere_gather`'s statistics (8 bytes).
    pub stats: wgpu::Buffer,
    table: wgpu::Buffer,
    direct: Direct,
}

/// Records the frame's caustic spheres up to `sphere_gather` (the visibility first where
/// `update` says so, kept in `state`).
pub(crate) fn record(
    dc: &DrawCtx,
    eye: &EyeFrame,
    sp: &GpuSpheres,
    (state, update): (&mut Option<VisibilityState>, VisibilityUpdate),
    inputs: SphereInputs,
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) -> SphereFrame {
    match update {
        VisibilityUpdate::None => *state = None,
        VisibilityUpdate::Keep => {}
        VisibilityUpdate::New(rays) => *state = Some(visibility::record(dc, rays, enc, timer)),
    }
    let vis = state.as_ref();
    let index = |li: usize, oi: usize| vis.and_then(|v| v.index(oi, li.checked_sub(inputs.own)?));
    let mut records = sp.records_indexed(inputs.lights, inputs.transforms, inputs.blend, index);
    // Without any visibility to apply, the records are final on the CPU.
    let vis = vis.filter(|_| records.iter().any(|r| r.base[3] != u32::MAX));
    if vis.is_none() {
        records.iter_mut().for_each(|r| r.base[3] = 0);
    }
    let weigh = |list: &[SphereRecord], enc: &mut wgpu::CommandEncoder, timer: &mut PassTimer| {
        vis.map(|v| record_weights(dc, v, list, enc, timer))
    };
    let direct = weigh(&records, enc, timer);
    let stats = if sp.compiled {
        // Section 6: each object's records summed into its compiled table first (the
        // records grouped by object, in the order of the tables).
        let mut grouped = Vec::with_capacity(records.len());
        for (oi, _, _) in &sp.objects {
            grouped.extend(records.iter().filter(|r| r.base[1] == *oi as u32).copied());
        }
        let objects = sp.compiled_records(inputs.transforms);
        let weighted = weigh(&grouped, enc, timer);
        let compiled = record_compile(dc, sp, (&grouped, weighted.as_ref().map(|w| &w.weighted)), &objects, enc, timer);
        record_gather(dc, eye, (sp, &compiled), Records::Cpu(&objects), enc, timer)
    } else {
        let list = direct.as_ref().map_or(Records::Cpu(&records), Weighted::compact);
        record_gather(dc, eye, (sp, &sp.table), list, enc, timer)
    };
    let direct = match direct {
        Some(w) => Direct::Gpu(w),
        None => Direct::Cpu(records),
    };
    SphereFrame { stats, table: sp.table.clone(), direct }
}

/// Records `sphere_weights` over `records` (non-empty when any is indexed).
fn record_weights(
    dc: &DrawCtx,
    vis: &VisibilityState,
    records: &[SphereRecord],
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) -> Weighted {
    let ctx = dc.ctx;
    let storage = wgpu::BufferUsages::STORAGE;
    let bytes = std::mem::size_of_val(records).max(std::mem::size_of::<SphereRecord>()) as u64;
    let candidates = ctx.buffer_init("sphere_weight_candidates", bytemuck::cast_slice(records), storage);
    let weighted = ctx.buffer("sphere_weighted", bytes, storage);
    let compact = ctx.buffer("sphere_weighted_compact", bytes, storage);
    let counts = ctx.buffer("sphere_weight_counts", 8, storage | wgpu::BufferUsages::COPY_SRC);
    Pass::new(ctx, "sphere_weights")
        .bind("candidates", &candidates)
        .bind("visibility", &vis.buffer)
        .bind("weighted", &weighted)
        .bind("compact", &compact)
        .bind("weight_counts", &counts)
        .dispatch(enc, timer, [1, 1, 1]);
    Weighted { weighted, compact, counts, len: records.len() as u32 }
}

impl SphereFrame {
    /// Records `sphere_volume` over the frame's direct records (nothing without a homogeneous
    /// medium or records).
    pub(crate) fn record_volume(
        &self,
        dc: &DrawCtx,
        eye: &EyeFrame,
        steps: u32,
        images: (&wgpu::Buffer, &wgpu::Buffer),
        enc: &mut wgpu::CommandEncoder,
        timer: &mut PassTimer,
    ) {
        let records = match &self.direct {
            Direct::Cpu(r) => Records::Cpu(r),
            Direct::Gpu(w) => w.compact(),
        };
        record_volume(dc, eye, (&self.table, records), steps, images, enc, timer);
    }
}
