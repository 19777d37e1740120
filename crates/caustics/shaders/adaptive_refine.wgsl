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
//   with FLAG_QUADS the test also covers the cell corners (see below), and lp.linearity > 0
//   adds a second way to converge: a cell mapping close enough to affine;
//   Children above the finest level must be fully covered to merge (each stands for all the
//   finest photons below it, so a child cut by a silhouette would bring the flux of its photons
//   that miss the casters);
// - otherwise the covered children are appended to the write region of the cell list.
// Appends use atomic counters; overflow of a capacity is flagged in ctrl, never silent.
// FLAG_QUADS (caustic triangles): every emitted photon stands for a cell (a child, or the
// merged parent); the photons through the cell's four corners are traced too (the 3 x 3 corner
// lattice of the parent's children, each point traced at most once per thread, only where an
// emitted cell needs it; never booked in the flux statistics) and, if they are valid, on the
// photon's face and path, with no quad edge over the discontinuity limit, the photon is marked
// (_pad bit 0) and its corners' landing points are stored in `corners` for splat_quads.

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
@group(0) @binding(14) var<storage, read_write> corners: array<vec4f>;
// The light's second caster layer (front, back), or the first where the scene needs none.
@group(0) @binding(15) var front_pos2: texture_2d_array<f32>;
@group(0) @binding(16) var front_nrm2: texture_2d_array<f32>;
@group(0) @binding(17) var back_pos2: texture_2d_array<f32>;
@group(0) @binding(18) var back_nrm2: texture_2d_array<f32>;

// The corner lattice of the current cluster's children: point (a, b), a, b in 0..2, is stored
// at a + 3 b; bit k of lattice_done says whether point k was traced.
var<private> lattice: array<Photon, 9>;
var<private> lattice_done: u32 = 0u;
var<private> corner_traces: u32 = 0u;

// Corner (a, b) of the children of cluster `parent` (children grid s): the light ray through
// NDC (-1 + (2 parent.x + a) 2/s, 1 - (2 parent.y + b) 2/s), exact in f32 for power-of-two
// grids, so a corner shared by neighbouring cells (of any level) lands at the same point.
fn lattice_point(parent: vec2u, k: u32, s: u32) -> Photon {
    if ((lattice_done & (1u << k)) == 0u) {
        let cell = 2.0 / f32(s);
        let ndc = vec2f(-1.0 + f32(2u * parent.x + k % 3u) * cell, 1.0 - f32(2u * parent.y + k / 3u) * cell);
        // Corners only shape the quad: their flux is not booked (nor collected for later).
        let defer = trace_defer;
        let pending = trace_pending;
        trace_defer = true;
        lattice[k] = trace_photon(lp.face, ndc, vec2f(cell));
        trace_defer = defer;
        trace_pending = pending;
        lattice_done |= 1u << k;
        corner_traces += 1u;
    }
    return lattice[k];
}

// Longest quad edge (caustic-map texels) not taken for a discontinuity, for a cell of the
// cells x cells grid: eight unrefracted cell widths and at least 32 texels (as the dense grid's
// caustic triangles, splat::triangle_max_edge).
fn max_edge(cells: u32) -> f32 {
    return max(32.0, 8.0 * f32(light.info.w) / f32(cells));
}

fn emit_record(p: Photon, level: u32, quad: bool, top: vec4f, bottom: vec4f) {
    let k = atomicAdd(&ctrl[C_PHOTONS], 1u);
    atomicAdd(&ctrl[C_EMITTED + level], 1u);
    if (k >= lp.photon_capacity) { atomicOr(&ctrl[C_OVERFLOW], 2u); return; }
    var r = p;
    if ((lp.flags & FLAG_QUADS) != 0u) {
        r._pad = select(0u, 1u, quad);
        if (quad) {
            corners[2u * k] = top;
            corners[2u * k + 1u] = bottom;
        }
    }
    photons[k] = r;
}

fn emit(p: Photon, level: u32) {
    emit_record(p, level, false, vec4f(0.0), vec4f(0.0));
}

// Emit photon p standing for the cell whose corners are lattice points (a, b), (a + d, b),
// (a, b + d), (a + d, b + d) of cluster `parent` (children grid s); the cell is one of a
// cells x cells grid. With FLAG_QUADS, with its quad if the corners agree with p (valid, on
// p's face, same path signature flux.w, no edge over max_edge): otherwise p is a Gaussian.
fn emit_cell(p: Photon, level: u32, parent: vec2u, a: u32, b: u32, d: u32, s: u32, cells: u32) {
    if ((lp.flags & FLAG_QUADS) == 0u || p.face == INVALID) {
        emit(p, level);
        return;
    }
    var c: array<Photon, 4>;
    c[0] = lattice_point(parent, a + 3u * b, s);
    c[1] = lattice_point(parent, a + d + 3u * b, s);
    c[2] = lattice_point(parent, a + 3u * (b + d), s);
    c[3] = lattice_point(parent, a + d + 3u * (b + d), s);
    var ok = true;
    for (var q = 0u; q < 4u; q++) {
        ok = ok && c[q].face == p.face && c[q].flux.w == p.flux.w;
    }
    if (ok) {
        let e = max(max(distance(c[0].pos, c[1].pos), distance(c[0].pos, c[2].pos)),
                    max(max(distance(c[1].pos, c[3].pos), distance(c[2].pos, c[3].pos)), distance(c[0].pos, c[3].pos)));
        ok = e <= max_edge(cells);
    }
    emit_record(p, level, ok, vec4f(c[0].pos, c[1].pos), vec4f(c[2].pos, c[3].pos));
}

fn flush_corner_count() {
    if (corner_traces == 0u) { return; }
    let old = atomicAdd(&ctrl[C_CORNERS], corner_traces);
    if (old > 0xffffffffu - corner_traces) { atomicAdd(&ctrl[C_CORNERS + 1u], 1u); }
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
    trace_reflect = (lp.flags & FLAG_REFLECT) != 0u;
    let parent = unpack_cell(cells[atomicLoad(&ctrl[C_READ_OFF]) + t]);
    let s = 2u * lp.grid;
    let child_level = lp.level + 1u;
    let last = (lp.flags & FLAG_LAST) != 0u;
    let check = (lp.flags & FLAG_CHECK) != 0u;
    let quads = (lp.flags & FLAG_QUADS) != 0u;
    var kids: array<vec2u, 4>;
    var cov: array<bool, 4>;
    var ncov = 0u;
    var nfull = 0u;
    // Level-0 coverage texels under a child: all covered = every finest photon below it hits.
    let per_child = select((lp.gbuffer / s) * (lp.gbuffer / s), 1u, s >= lp.gbuffer);
    for (var q = 0u; q < 4u; q++) {
        kids[q] = 2u * parent + vec2u(q & 1u, q >> 1u);
        let c = covered_count(kids[q].x, kids[q].y, s);
        cov[q] = c > 0u;
        if (cov[q]) { ncov += 1u; }
        if (c == per_child) { nfull += 1u; }
    }
    if (!check) {
        for (var q = 0u; q < 4u; q++) {
            if (!cov[q]) { continue; }
            if (last) {
                atomicAdd(&ctrl[C_TRACED + child_level], 1u);
                emit_cell(trace_cell(kids[q], s), child_level, parent, q & 1u, q >> 1u, 1u, s, s);
            } else {
                append_cell(kids[q]);
            }
        }
        flush_corner_count();
        return;
    }
    // Maximal caustic map error: trace the covered children, book their flux only if emitted.
    trace_defer = true;
    for (var k = 0u; k < 6u; k++) { trace_pending[k] = 0.0; }
    var ph: array<Photon, 4>;
    var converged = nfull == 4u;
    var same_path = true;
    var lo = vec2f(1e30);
    var hi = vec2f(-1e30);
    var sum = vec3f(0.0);
    var wpos = vec2f(0.0);
    for (var q = 0u; q < 4u; q++) {
        if (!cov[q]) { continue; }
        ph[q] = trace_cell(kids[q], s);
        if (ph[q].face == INVALID || ph[q].face != ph[0].face) { converged = false; }
        same_path = same_path && ph[q].flux.w == ph[0].flux.w;
        lo = min(lo, ph[q].pos);
        hi = max(hi, ph[q].pos);
        let w = ph[q].flux.r + ph[q].flux.g + ph[q].flux.b;
        sum += ph[q].flux.rgb;
        wpos += w * ph[q].pos;
    }
    atomicAdd(&ctrl[C_TRACED + child_level], ncov);
    // Caustic triangles: the merged cluster is the parent cell's quad, so the test covers the
    // corner lattice too (the parent's corners and its children's): if every lattice point is on
    // the children's face and path, it must lie in the texel (within the tolerance) as well, and
    // the merged quad deposits its flux where the children's quads would. (A lattice point off
    // the path leaves the one-texel test to the children: the merged photon is then a Gaussian.)
    var linear = false;
    if (converged && quads && same_path) {
        var agree = true;
        var clo = lo;
        var chi = hi;
        var l: array<vec2f, 9>;
        for (var k = 0u; k < 9u; k++) {
            let c = lattice_point(parent, k, s);
            if (c.face != ph[0].face || c.flux.w != ph[0].flux.w) {
                agree = false;
                break;
            }
            l[k] = c.pos;
            clo = min(clo, c.pos);
            chi = max(chi, c.pos);
        }
        if (agree) {
            lo = clo;
            hi = chi;
            // Optional linearity rule (--quad-linearity): the mapping from the cell to the
            // map is close to affine (a uniform flux density over the quad is then right): the
            // lattice points and the children's photons lie within lp.linearity texels of the
            // affine map fitted to the parent's corners (the corners miss it by a quarter of
            // the quad's twist), and no edge is a discontinuity.
            if (lp.linearity > 0.0) {
                let c00 = l[0];
                let c10 = l[2];
                let c01 = l[6];
                let c11 = l[8];
                let mid = 0.25 * (c00 + c10 + c01 + c11);
                let du = 0.5 * (c10 - c00 + c11 - c01);
                let dv = 0.5 * (c01 - c00 + c11 - c10);
                var dev = 0.0;
                for (var k = 0u; k < 9u; k++) {
                    let u = 0.5 * f32(k % 3u) - 0.5;
                    let v = 0.5 * f32(k / 3u) - 0.5;
                    dev = max(dev, distance(l[k], mid + u * du + v * dv));
                }
                for (var q = 0u; q < 4u; q++) {
                    let u = 0.5 * f32(q & 1u) - 0.25;
                    let v = 0.5 * f32(q >> 1u) - 0.25;
                    dev = max(dev, distance(ph[q].pos, mid + u * du + v * dv));
                }
                let e = max(max(distance(c00, c10), distance(c00, c01)),
                            max(max(distance(c10, c11), distance(c01, c11)), distance(c00, c11)));
                linear = dev <= lp.linearity && e <= max_edge(lp.grid);
            }
        }
    }
    if (converged) {
        if (lp.tolerance > 0.0) {
            converged = all(hi - lo <= vec2f(lp.tolerance));
        } else {
            converged = all(floor(lo) == floor(hi));
        }
        converged = converged || linear;
    }
    let wsum = sum.r + sum.g + sum.b;
    if (converged && wsum > 0.0) {
        var m: Photon;
        m.pos = wpos / wsum;
        m.face = ph[0].face;
        m.flux = vec4f(sum, 0.0);
        if (light.splat.x > 0.5 && (lp.flags & FLAG_QUADS) == 0u) {
            // Lens and differential splats: the merged photon's beam is its cluster's, whose
            // area is the sum of the children's (and at least the cluster's spread).
            var area = 0.0;
            for (var q = 0u; q < 4u; q++) { let dq = bitcast<f32>(ph[q]._pad); area += dq * dq; }
            m._pad = bitcast<u32>(max(sqrt(area), max(hi.x - lo.x, hi.y - lo.y)));
        }
        flush_pending();
        if (same_path) {
            // The merged cluster is the parent cell: its quad is the parent's four corners.
            m.flux.w = ph[0].flux.w;
            emit_cell(m, lp.level, parent, 0u, 0u, 2u, s, lp.grid);
        } else {
            emit(m, lp.level);
        }
        flush_corner_count();
        return;
    }
    if (last) {
        flush_pending();
        for (var q = 0u; q < 4u; q++) {
            if (cov[q]) { emit_cell(ph[q], child_level, parent, q & 1u, q >> 1u, 1u, s, s); }
        }
        flush_corner_count();
        return;
    }
    trace_defer = false;
    flush_corner_count();
    for (var q = 0u; q < 4u; q++) {
        if (cov[q]) { append_cell(kids[q]); }
    }
}
