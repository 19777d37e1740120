// Stage: adaptive_plan. Splits the photon hierarchy of one face into batches that fit the photon
// memory budget, on the GPU (no readback): the cells of the batch grid (S x S, S >= the base
// grid), in Morton order, each with its number of relevant leaf photons from the coverage mip
// (an upper bound of what any stopping metric emits below it), are assigned greedily to batches
// of at most `batch_leaves` leaves plus one cell. One workgroup; a prefix sum over its threads.

#import hierarchy
#import coverage

@group(0) @binding(0) var<uniform> lp: LevelParams;
@group(0) @binding(1) var<storage, read> cover: array<u32>;
@group(0) @binding(2) var<storage, read_write> plan: array<u32>;
@group(0) @binding(3) var<storage, read_write> ctrl: array<atomic<u32>>;

var<workgroup> sums: array<u32, 256>;
var<workgroup> over: atomic<u32>;

fn compact1(x: u32) -> u32 {
    var v = x & 0x55555555u;
    v = (v | (v >> 1u)) & 0x33333333u;
    v = (v | (v >> 2u)) & 0x0f0f0f0fu;
    v = (v | (v >> 4u)) & 0x00ff00ffu;
    v = (v | (v >> 8u)) & 0x0000ffffu;
    return v;
}

// Relevant leaf photons (finest grid N) under cell (i, j) of the S x S batch grid.
fn leaves(i: u32, j: u32, s: u32) -> u32 {
    let c = covered_count(i, j, s);
    if (c == 0u) { return 0u; }
    let g = lp.gbuffer;
    let n = lp.finest;
    if (s >= g) { return (n / s) * (n / s); }
    return c * (n / g) * (n / g);
}

@compute @workgroup_size(256)
fn main(@builtin(local_invocation_index) t: u32) {
    let s = lp.batch_grid;
    let total = s * s;
    let chunk = (total + 255u) / 256u;
    let start = min(t * chunk, total);
    let end = min(start + chunk, total);
    var sum = 0u;
    for (var m = start; m < end; m++) {
        let x = leaves(compact1(m), compact1(m >> 1u), s);
        if (sum > 0xffffffffu - x) { atomicOr(&over, 4u); }
        sum += x;
    }
    sums[t] = sum;
    workgroupBarrier();
    if (t == 0u) {
        var acc = 0u;
        for (var k = 0u; k < 256u; k++) {
            let x = sums[k];
            sums[k] = acc;
            if (acc > 0xffffffffu - x) { atomicOr(&over, 4u); }
            acc += x;
        }
        let cap = lp.batch_leaves;
        var batches = acc / cap;
        if (acc % cap != 0u) { batches += 1u; }
        atomicStore(&ctrl[C_BATCHES], batches);
        atomicStore(&ctrl[C_LEAVES], acc);
        if (batches > lp.max_batches) { atomicOr(&over, 8u); }
    }
    workgroupBarrier();
    var prefix = sums[t];
    for (var m = start; m < end; m++) {
        let i = compact1(m);
        let j = compact1(m >> 1u);
        let x = leaves(i, j, s);
        plan[j * s + i] = select(INVALID, prefix / lp.batch_leaves, x > 0u);
        prefix += x;
    }
    workgroupBarrier();
    if (t == 0u) {
        let o = atomicLoad(&over);
        if (o != 0u) { atomicOr(&ctrl[C_OVERFLOW], o); }
    }
}
