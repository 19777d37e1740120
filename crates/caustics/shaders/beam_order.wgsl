// Stage: beam_order. The beams' list in hierarchy order: the slots (level, triangle id,
// branch, layer, part) hold each kept beam's index, and the list takes them in slot order, so
// that the image sums the beams in the same order whatever order beam_refine's atomics appended
// them in (the image is the same bits from run to run). beam_order_runs counted the beams of
// each run of BEAM_ORDER_RUN slot entries (`runs`); this one workgroup turns the counts into
// each run's place in the list (an exclusive prefix sum: each of the 256 threads sums its
// share of the runs, a prefix sum over the threads places the shares), and beam_order_runs
// then writes each run's beams there. Then the indirect dispatch sizes of beam_gather's and
// beam_surface's chunks of the list: the image's workgroups for a chunk that holds beams, none
// for one past the count (the host records a dispatch per chunk of the most beams the
// hierarchy can keep, far more than an adaptive hierarchy keeps: on lavapipe each empty
// dispatch cost some milliseconds); and the sizes of beam_hull's dispatch and beam_raster's
// draw (a thread and BEAM_HULL_PARTS instances per listed beam).

#import beams

@group(0) @binding(0) var<uniform> bp: BeamParams;
// Per run of slot entries its beams (beam_order_runs), replaced by its place in the list.
@group(0) @binding(1) var<storage, read_write> runs: array<u32>;
@group(0) @binding(2) var<storage, read_write> stats: array<u32>;
// The chunks (beams.rs `Chunks`, in a BeamLevel record): level = beams per gather chunk, offset
// = gather chunks, next_offset = beams per surface chunk, base_count = surface chunks.
@group(0) @binding(3) var<uniform> ch: BeamLevel;
// Per chunk (gather chunks, then surface chunks): workgroups x, y, z; then beam_hull's
// workgroups (x, y, z) and beam_raster's draw (vertices, instances, first vertex, first
// instance).
@group(0) @binding(4) var<storage, read_write> dispatch: array<u32>;

var<workgroup> counts: array<u32, 256>;
var<workgroup> listed: u32;

@compute @workgroup_size(256)
fn main(@builtin(local_invocation_index) t: u32) {
    let n_runs = (BEAM_KINDS * bp.slots + BEAM_ORDER_RUN - 1u) / BEAM_ORDER_RUN;
    let share = (n_runs + 255u) / 256u;
    let r0 = min(t * share, n_runs);
    let r1 = min(r0 + share, n_runs);
    var n = 0u;
    for (var r = r0; r < r1; r++) { n += runs[r]; }
    counts[t] = n;
    workgroupBarrier();
    if (t == 0u) {
        var acc = 0u;
        for (var k = 0u; k < 256u; k++) {
            let c = counts[k];
            counts[k] = acc;
            acc += c;
        }
        stats[1u + BS_ORDERED] = acc;
        listed = acc;
        let n = min(acc, bp.capacity);
        let at = 3u * (ch.offset + ch.base_count);
        dispatch[at] = (n + 63u) / 64u;
        dispatch[at + 1u] = 1u;
        dispatch[at + 2u] = 1u;
        dispatch[at + 3u] = BEAM_HULL_VERTICES;
        dispatch[at + 4u] = n * BEAM_HULL_PARTS;
        dispatch[at + 5u] = 0u;
        dispatch[at + 6u] = 0u;
    }
    workgroupBarrier();
    let count = min(listed, bp.capacity);
    let gx = (bp.width + 7u) / 8u;
    let gy = (bp.height + 7u) / 8u;
    for (var c = t; c < ch.offset + ch.base_count; c += 256u) {
        var first = (c - ch.offset) * ch.next_offset;
        if (c < ch.offset) { first = c * ch.level; }
        let used = first < count;
        dispatch[3u * c] = select(0u, gx, used);
        dispatch[3u * c + 1u] = select(0u, gy, used);
        dispatch[3u * c + 2u] = 1u;
    }
    var at = counts[t];
    for (var r = r0; r < r1; r++) {
        let c = runs[r];
        runs[r] = at;
        at += c;
    }
}
