// Stage: beam_order_runs. The hierarchy's slots (BEAM_KINDS entries each: a kept beam's index
// + 1, or 0) in runs of BEAM_ORDER_RUN entries, one thread per run, for the beams' list in slot order
// (beam_order.wgsl). Run twice: first (`order_write` false) each thread counts the beams of its
// run into `runs`; beam_order turns the counts into each run's place in the list (an exclusive
// prefix sum); then (`order_write` true) each thread writes its run's beam indices from there.
// Spread over many threads, not beam_order's one workgroup: lavapipe ends an invocation's loops
// after some 65536 iterations in all, and a hierarchy of 16² + 4 levels (8.4 M entries, 32 736
// a thread in one workgroup of 256, walked twice) lost part of its list and repeated stale
// entries in its place (docs/benchmarks.md, "Beams: the list of a deep hierarchy").

#import beams

@group(0) @binding(0) var<uniform> bp: BeamParams;
@group(0) @binding(1) var<storage, read> slots: array<u32>;
@group(0) @binding(2) var<storage, read_write> runs: array<u32>;
@group(0) @binding(3) var<storage, read_write> order: array<u32>;

override order_write: bool = false;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u, @builtin(num_workgroups) nw: vec3u) {
    let r = gid.x + gid.y * nw.x * 64u;
    let total = BEAM_KINDS * bp.slots;
    let s0 = r * BEAM_ORDER_RUN;
    if (s0 >= total) { return; }
    let s1 = min(s0 + BEAM_ORDER_RUN, total);
    if (!order_write) {
        var n = 0u;
        for (var s = s0; s < s1; s++) { n += u32(slots[s] != 0u); }
        runs[r] = n;
        return;
    }
    var at = runs[r];
    for (var s = s0; s < s1; s++) {
        let b = slots[s];
        if (b != 0u && at < bp.capacity) {
            order[at] = b - 1u;
            at++;
        }
    }
}
