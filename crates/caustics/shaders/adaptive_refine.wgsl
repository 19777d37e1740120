// Stage: adaptive_refine. One level of adaptive caustic maps (Wyman & Nichols 2009, section 3;
// compute-shader form after Piao 2015): each thread takes one surviving cluster (cell (i, j) of
// the grid lp.grid) from the read region of the cell list and looks at its four children on the
// grid 2 * lp.grid. Children that the coverage mip says miss every caster are discarded
// (conservative and exact: a child is kept iff one of its finest photons hits a caster).
// - FLAG_LAST (the children are the finest grid N): the covered children are traced (deferred:
//   by point-sampling the light-space geometry buffers) and appended to the photon buffer;
// - FLAG_CHECK (maximal caustic map error): the covered children are traced; if all four are
//   covered, land, and fall in one caustic-map texel (or within lp.tolerance texels), one photon
//   is emitted at their flux-weighted mean position carrying the sum of their fluxes (the
//   cluster's flux, exactly); otherwise the covered children are refined (or emitted one by
//   one at the finest level);
// - otherwise the covered children are appended to the write region of the cell list.
// Appends use atomic counters; overflow of a capacity is flagged in ctrl, never silent.

#import hierarchy
#import coverage
#import shapes
#import trace

@group(0) @binding(0) var<uniform> light: LightGpu;
@group(0) @binding(1) var<uniform> lp: LevelParams;
@group(0) @binding(2) var front_pos: texture_2d_array<f32>;
@group(0) @binding(3) var front_nrm: texture_2d_array<f32>;
@group(0) @binding(4) var back_pos: texture_2d_array<f32>;
@group(0) @binding(5) var back_nrm: texture_2d_array<f32>;
@group(0) @binding(6) var recv_pos: texture_2d_array<f32>;
@group(0) @binding(7) var recv_nrm: texture_2d_array<f32>;
@group(0) @binding(8) var<storage, read> materials: array<MaterialGpu>;
@group(0) @binding(9) var<storage, read> cover: array<u32>;
@group(0) @binding(10) var<storage, read_write> cells: array<u32>;
@group(0) @binding(11) var<storage, read_write> photons: array<Photon>;
@group(0) @binding(12) var<storage, read_write> ctrl: array<atomic<u32>>;
@group(0) @binding(13) var<storage, read_write> stats: array<atomic<u32>>;

fn emit(p: Photon, level: u32) {
    let k = atomicAdd(&ctrl[C_PHOTONS], 1u);
    atomicAdd(&ctrl[C_EMITTED + level], 1u);
    if (k >= lp.photon_capacity) { atomicOr(&ctrl[C_OVERFLOW], 2u); return; }
    photons[k] = p;
}

fn append_cell(c: vec2u) {
    let k = atomicAdd(&ctrl[C_WRITE_COUNT], 1u);
    if (k >= lp.cell_capacity) { atomicOr(&ctrl[C_OVERFLOW], 1u); return; }
    cells[atomicLoad(&ctrl[C_WRITE_OFF]) + k] = pack_cell(c.x, c.y);
}

// The photon of cell c of the s x s grid (same cell geometry as photon_trace).
fn trace_cell(c: vec2u, s: u32) -> Photon {
    let cell = 2.0 / f32(s);
    let ndc = vec2f(-1.0 + (f32(c.x) + 0.5) * cell, 1.0 - (f32(c.y) + 0.5) * cell);
    return trace_photon(lp.face, ndc, vec2f(cell));
}

fn flush_pending() {
    trace_defer = false;
    for (var s = 0u; s < 6u; s++) {
        if (trace_pending[s] > 0.0) { add_fixed(2u * s, trace_pending[s]); }
    }
}

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) nwg: vec3u, @builtin(local_invocation_index) lid: u32) {
    let t = thread_index(wg, nwg, lid);
    if (t >= atomicLoad(&ctrl[C_READ_COUNT])) { return; }
    let parent = unpack_cell(cells[atomicLoad(&ctrl[C_READ_OFF]) + t]);
    let s = 2u * lp.grid;
    let child_level = lp.level + 1u;
    let last = (lp.flags & FLAG_LAST) != 0u;
    let check = (lp.flags & FLAG_CHECK) != 0u;
    var kids: array<vec2u, 4>;
    var cov: array<bool, 4>;
    var ncov = 0u;
    for (var q = 0u; q < 4u; q++) {
        kids[q] = 2u * parent + vec2u(q & 1u, q >> 1u);
        cov[q] = covered_count(kids[q].x, kids[q].y, s) > 0u;
        if (cov[q]) { ncov += 1u; }
    }
    if (!check) {
        for (var q = 0u; q < 4u; q++) {
            if (!cov[q]) { continue; }
            if (last) {
                atomicAdd(&ctrl[C_TRACED + child_level], 1u);
                emit(trace_cell(kids[q], s), child_level);
            } else {
                append_cell(kids[q]);
            }
        }
        return;
    }
    // Maximal caustic map error: trace the covered children, book their flux only if emitted.
    trace_defer = true;
    for (var k = 0u; k < 6u; k++) { trace_pending[k] = 0.0; }
    var ph: array<Photon, 4>;
    var converged = ncov == 4u;
    var lo = vec2f(1e30);
    var hi = vec2f(-1e30);
    var sum = vec3f(0.0);
    var wpos = vec2f(0.0);
    for (var q = 0u; q < 4u; q++) {
        if (!cov[q]) { continue; }
        ph[q] = trace_cell(kids[q], s);
        if (ph[q].face == INVALID || ph[q].face != ph[0].face) { converged = false; }
        lo = min(lo, ph[q].pos);
        hi = max(hi, ph[q].pos);
        let w = ph[q].flux.r + ph[q].flux.g + ph[q].flux.b;
        sum += ph[q].flux.rgb;
        wpos += w * ph[q].pos;
    }
    atomicAdd(&ctrl[C_TRACED + child_level], ncov);
    if (converged) {
        if (lp.tolerance > 0.0) {
            converged = all(hi - lo <= vec2f(lp.tolerance));
        } else {
            converged = all(floor(lo) == floor(hi));
        }
    }
    let wsum = sum.r + sum.g + sum.b;
    if (converged && wsum > 0.0) {
        var m: Photon;
        m.pos = wpos / wsum;
        m.face = ph[0].face;
        m.flux = vec4f(sum, 0.0);
        flush_pending();
        emit(m, lp.level);
        return;
    }
    if (last) {
        flush_pending();
        for (var q = 0u; q < 4u; q++) {
            if (cov[q]) { emit(ph[q], child_level); }
        }
        return;
    }
    trace_defer = false;
    for (var q = 0u; q < 4u; q++) {
        if (cov[q]) { append_cell(kids[q]); }
    }
}
