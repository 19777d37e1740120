//! Basic caustic maps (Wyman & Nichols 2009, section 2; Shah et al. 2007): one photon per cell of
//! a dense N × N grid over each light-view face, traced (`photon_trace`) and splatted
//! (`photon_splat`) in batches that fit the photon memory.

use super::{Emit, Pending, storage, uniform};
use crate::gpu::PassTimer;
use crate::gpu::types::{Photon, SplatParams, TraceParams};

pub(crate) struct Basic {
    photons: wgpu::Buffer,
    /// Caustic triangles: one photon row carried from batch to batch, rows per batch.
    carry: Option<(wgpu::Buffer, u32)>,
    batch: u64,
    traced: u64,
    batches: u32,
}

impl Basic {
    /// Photons per batch: what fits the photon memory, the storage-binding limit and one
    /// dispatch.
    pub fn batch_size(e: &Emit) -> u64 {
        let stride = std::mem::size_of::<Photon>() as u64;
        let max_bind = e.ctx.device.limits().max_storage_buffer_binding_size;
        let cap = (e.settings.photons.memory.min(max_bind) / stride).min(65535 * 64);
        (e.n as u64 * e.n as u64).min(cap).max(1)
    }

    pub fn new(e: &Emit) -> Basic {
        let batch = Basic::batch_size(e);
        if e.stages.splat.grid_triangles {
            let rows = crate::splat::triangle_rows(e.n, batch);
            let (_, bytes) = crate::splat::triangle_buffer_layout(e.n, rows);
            let photons = storage(e.ctx, "photons", bytes, wgpu::BufferUsages::empty());
            let row = e.n as u64 * std::mem::size_of::<Photon>() as u64;
            let carry = storage(e.ctx, "photon_row", row, wgpu::BufferUsages::empty());
            return Basic { photons, carry: Some((carry, rows)), batch, traced: 0, batches: 0 };
        }
        let photons =
            storage(e.ctx, "photons", batch * std::mem::size_of::<Photon>() as u64, wgpu::BufferUsages::empty());
        Basic { photons, carry: None, batch, traced: 0, batches: 0 }
    }

    /// Trace and splat the grid of face `f`: the transmitted branch, then, when the scene has
    /// dielectric casters, the reflected branch (the face index's high bit tells the tracer).
    /// `kept` receives copies of the traced photons when `Inspect::photons` is set.
    fn record_face_inner(
        &mut self,
        e: &Emit,
        enc: &mut wgpu::CommandEncoder,
        timer: &mut PassTimer,
        f: u32,
        kept: &mut Vec<(wgpu::Buffer, u64)>,
    ) {
        for b in e.branches() {
            self.record_branch(e, enc, timer, f | b.face_bits(), kept);
        }
    }

    fn record_branch(
        &mut self,
        e: &Emit,
        enc: &mut wgpu::CommandEncoder,
        timer: &mut PassTimer,
        f: u32,
        kept: &mut Vec<(wgpu::Buffer, u64)>,
    ) {
        let per_face = e.n as u64 * e.n as u64;
        if let Some((carry, rows)) = &self.carry {
            let g = crate::splat::GridTriangles { photons: &self.photons, carry, rows: *rows };
            let (traced, batches) = crate::splat::record_grid_triangles(e, &g, enc, timer, f);
            self.traced += traced;
            self.batches += batches;
            return;
        }
        let mut off = 0u64;
        while off < per_face {
            let count = self.batch.min(per_face - off);
            let groups = (count as u32).div_ceil(64);
            let tp = uniform(
                e.ctx,
                "trace_params",
                bytemuck::bytes_of(&TraceParams {
                    face: f,
                    batch_offset: off as u32,
                    batch_count: count as u32,
                    tile: 0,
                }),
            );
            let sp = storage_init(e, &SplatParams { groups: [groups, 1, 1], count: count as u32 });
            let trace = e.tracing("photon_trace").bind("tp", &tp).bind("photons", &self.photons).group();
            let splat = e.splat_targets.splat(e, &sp, &self.photons, None);
            trace.dispatch(enc, timer, [groups, 1, 1]);
            if e.inspect.photons {
                let bytes = count * std::mem::size_of::<Photon>() as u64;
                let copy = storage(e.ctx, "kept_photons", bytes, wgpu::BufferUsages::empty());
                enc.copy_buffer_to_buffer(&self.photons, 0, &copy, 0, bytes);
                kept.push((copy, count));
            }
            splat.dispatch(enc, timer, [groups, 1, 1]);
            self.traced += count;
            self.batches += 1;
            off += count;
        }
    }

    fn fill_inner(&self, p: &mut Pending) {
        let s = &mut p.stats;
        s.photons_traced = self.traced;
        s.photons_splatted = self.traced;
        s.batches = self.batches;
        s.photon_bytes = self.photons.size();
        s.peak_photon_bytes = self.photons.size();
        s.evaluated = self.traced;
        s.level_mut(s.grid).traced = self.traced;
        s.level_mut(s.grid).emitted = self.traced;
    }
}

/// A small read-only storage buffer holding `v`.
pub(crate) fn storage_init<T: bytemuck::Pod>(e: &Emit, v: &T) -> wgpu::Buffer {
    e.ctx.buffer_init("splat_params", bytemuck::bytes_of(v), wgpu::BufferUsages::STORAGE)
}

impl super::EmissionStrategy for Basic {
    fn record_face(
        &mut self,
        e: &Emit,
        enc: &mut wgpu::CommandEncoder,
        timer: &mut PassTimer,
        _cover: &wgpu::Buffer,
        face: u32,
        pending: &mut Pending,
    ) {
        self.record_face_inner(e, enc, timer, face, &mut pending.kept);
    }

    fn fill(&self, pending: &mut Pending) {
        self.fill_inner(pending);
    }
}
