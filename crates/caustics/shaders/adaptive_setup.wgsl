// Stage: adaptive_setup. One thread between the steps of the photon hierarchy, so that the CPU
// never reads anything back between levels (Piao 2015's statistics shader):
// - FLAG_END: after a batch's splat: count its photons, go on to the next batch;
// - FLAG_BEGIN: start a batch (empty cell list and photon buffer), after FLAG_END's work;
// - otherwise, after a step that appended cells (of level lp.level) to the write region: they
//   become the read region, the regions swap, and the next step's indirect dispatch arguments
//   and the splat's indirect arguments (in `args`) and photon count are written. Counts over a capacity
//   are clamped and flagged (ctrl[C_OVERFLOW]), never silent.

#import hierarchy

@group(0) @binding(0) var<uniform> lp: LevelParams;
@group(0) @binding(1) var<storage, read_write> ctrl: array<atomic<u32>>;
@group(0) @binding(2) var<storage, read_write> args: array<u32>;

@compute @workgroup_size(1)
fn main() {
    if ((lp.flags & FLAG_END) != 0u) {
        var p = atomicLoad(&ctrl[C_PHOTONS]);
        p = min(p, lp.photon_capacity);
        atomicMax(&ctrl[C_PEAK_PHOTONS], p);
        let lo = atomicAdd(&ctrl[C_SPLATTED], p);
        if (lo > 0xffffffffu - p) { atomicAdd(&ctrl[C_SPLATTED + 1u], 1u); }
        atomicStore(&ctrl[C_PHOTONS], 0u);
        atomicAdd(&ctrl[C_BATCH], 1u);
    }
    if ((lp.flags & FLAG_BEGIN) != 0u) {
        atomicStore(&ctrl[C_READ_OFF], 0u);
        atomicStore(&ctrl[C_READ_COUNT], 0u);
        atomicStore(&ctrl[C_WRITE_OFF], 0u);
        atomicStore(&ctrl[C_WRITE_COUNT], 0u);
        atomicStore(&ctrl[C_PHOTONS], 0u);
    }
    if ((lp.flags & (FLAG_BEGIN | FLAG_END)) != 0u) { return; }
    var n = atomicLoad(&ctrl[C_WRITE_COUNT]);
    if (n > lp.cell_capacity) {
        atomicOr(&ctrl[C_OVERFLOW], 1u);
        n = lp.cell_capacity;
    }
    atomicAdd(&ctrl[C_CELLS + lp.level], n);
    atomicMax(&ctrl[C_PEAK_CELLS], n + atomicLoad(&ctrl[C_READ_COUNT]));
    let w = atomicLoad(&ctrl[C_WRITE_OFF]);
    atomicStore(&ctrl[C_READ_OFF], w);
    atomicStore(&ctrl[C_READ_COUNT], n);
    atomicStore(&ctrl[C_WRITE_OFF], select(0u, lp.cell_capacity, w == 0u));
    atomicStore(&ctrl[C_WRITE_COUNT], 0u);
    let g = groups_for(n);
    args[A_REFINE] = g.x;
    args[A_REFINE + 1u] = g.y;
    args[A_REFINE + 2u] = g.z;
    var p = atomicLoad(&ctrl[C_PHOTONS]);
    if (p > lp.photon_capacity) {
        atomicOr(&ctrl[C_OVERFLOW], 2u);
        p = lp.photon_capacity;
    }
    let gs = groups_for(p);
    args[A_SPLAT] = gs.x;
    args[A_SPLAT + 1u] = gs.y;
    args[A_SPLAT + 2u] = gs.z;
    args[A_SPLAT + 3u] = p;
}
