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
// emitted cell or the convergence test needs it; never booked in the flux statistics) and, if
// they are valid, on the photon's face and path, with no quad edge over the discontinuity
// limit, the photon is marked (_pad bit 0) and its corners' landing points are stored in
// `corners` for splat_quads.
// Every photon of a thread is traced by one call of trace_photon (trace_points): the thread
// decides in rounds what it needs traced next (its children, then the corner lattice for the
// test, then the corners of the cells it emits). Shader compilers inline every call site and
// unroll loops of constant count, so tracing from several places multiplied the tracer's code:
// building this pipeline took 11 s on lavapipe (36 s with ray differentials) before.

#import hierarchy
#import coverage
#import shapes
#import raytrace
#import medium
#import trace
#import scene

@group(0) @binding(0) var<uniform> light: LightGpu;
@group(0) @binding(1) var<uniform> lp: LevelParams;
@group(0) @binding(2) var front_pos: texture_2d_array<f32>;
@group(0) @binding(3) var front_nrm: texture_2d_array<f32>;
@group(0) @binding(4) var back_pos: texture_2d_array<f32>;
@group(0) @binding(5) var back_nrm: texture_2d_array<f32>;
@group(0) @binding(6) var recv_pos: texture_2d_array<f32>;
@group(0) @binding(7) var recv_nrm: texture_2d_array<f32>;
@group(0) @binding(8) var<storage, read> cover: array<u32>;
@group(0) @binding(9) var<storage, read_write> cells: array<u32>;
@group(0) @binding(10) var<storage, read_write> photons: array<Photon>;
@group(0) @binding(11) var<storage, read_write> ctrl: array<atomic<u32>>;
@group(0) @binding(12) var<storage, read_write> stats: array<atomic<u32>>;
@group(0) @binding(13) var<storage, read_write> corners: array<vec4f>;
// The light's second caster layer (front, back), or the first where the scene needs none.
@group(0) @binding(14) var front_pos2: texture_2d_array<f32>;
@group(0) @binding(15) var front_nrm2: texture_2d_array<f32>;
@group(0) @binding(16) var back_pos2: texture_2d_array<f32>;
@group(0) @binding(17) var back_nrm2: texture_2d_array<f32>;

// The points of the current cluster traced so far: the corner lattice of its children (point
// (a, b), a, b in 0..2, at a + 3 b) and the children's centres (child q at KIDS + q, child q
// being (2 parent.x + (q & 1), 2 parent.y + (q >> 1))); bit k of pts_done says whether point k
// was traced. (Private memory, zero-initialised: an untraced point reads as a zero Photon.)
const KIDS: u32 = 9u;
var<private> pts: array<Photon, 13>;
var<private> pts_done: u32 = 0u;
var<private> corner_traces: u32 = 0u;

// Trace the points of `mask` not traced yet (cluster `parent`, children grid s): the stage's only
// call of trace_photon, in a loop whose count the compiler cannot know. The points are integer
// multiples of half a cell, so each is exactly the point photon_trace traces for the same cell
// or corner: -1 + (i + 0.5) (2 / s) there, -1 + (2 i + 1) (1 / s) here, the same real number
// rounded once. Corners only shape the quad: their flux is not booked (nor collected for later).
fn trace_points(parent: vec2u, s: u32, mask: u32) {
    var m = mask & ~pts_done;
    pts_done |= m;
    let cell = 2.0 / f32(s);
    let h = 0.5 * cell;
    loop {
        if (m == 0u) { break; }
        let k = firstTrailingBit(m);
        m &= m - 1u;
        let corner = k < KIDS;
        var x2 = 2u * (2u * parent.x + k % 3u);
        var y2 = 2u * (2u * parent.y + k / 3u);
        if (!corner) {
            x2 = 2u * (2u * parent.x + ((k - KIDS) & 1u)) + 1u;
            y2 = 2u * (2u * parent.y + ((k - KIDS) >> 1u)) + 1u;
        }
        let defer = trace_defer;
        let pending = trace_pending;
        if (corner) {
            trace_defer = true;
            corner_traces += 1u;
        }
        pts[k] = trace_photon(lp.face, vec2f(-1.0 + f32(x2) * h, 1.0 - f32(y2) * h), vec2f(cell));
        if (corner) {
            trace_defer = defer;
            trace_pending = pending;
        }
    }
}

// The lattice points at the corners of the cell (a, b), (a + d, b), (a, b + d), (a + d, b + d).
fn cell_corners(a: u32, b: u32, d: u32) -> u32 {
    return (1u << (a + 3u * b)) | (1u << (a + d + 3u * b)) | (1u << (a + 3u * (b + d))) | (1u << (a + d + 3u * (b + d)));
}

// Longest quad edge (caustic-map texels) not taken for a discontinuity, for a cell of the
// cells x cells grid: eight unrefracted cell widths and at least 32 texels (as the dense grid's
// caustic triangles, splat::triangle_max_edge).
fn max_edge(cells: u32) -> f32 {
    return max(32.0, 8.0 * f32(light.info.w) / f32(cells));
}

// With FLAG_QUADS, _pad is 1 for a photon that carries its quad, else `fallback`: 0 for the
// fixed splat's Gaussian, or the f32 bits (lowest bit cleared) of a wider Gaussian's sigma.
fn emit_record(p: Photon, level: u32, quad: bool, top: vec4f, bottom: vec4f, fallback: u32) {
    let k = atomicAdd(&ctrl[C_PHOTONS], 1u);
    atomicAdd(&ctrl[C_EMITTED + level], 1u);
    if (k >= lp.photon_capacity) { atomicOr(&ctrl[C_OVERFLOW], 2u); return; }
    var r = p;
    if ((lp.flags & FLAG_QUADS) != 0u) {
        r._pad = select(fallback, 1u, quad);
        if (quad) {
            corners[2u * k] = top;
            corners[2u * k + 1u] = bottom;
        }
    }
    photons[k] = r;
}

fn emit(p: Photon, level: u32) {
    emit_record(p, level, false, vec4f(0.0), vec4f(0.0), 0u);
}

// Emit photon p standing for the cell whose corners are lattice points cell_corners(a, b, d)
// (traced beforehand); the cell is one of a cells x cells grid. With FLAG_QUADS, with its quad
// if the corners agree with p (valid, on p's face or, for a point light's cube, on a face across
// a seam, same path signature flux.w, no edge over max_edge). Otherwise p is a Gaussian as wide as its cell's image where the corners on p's path
// (at (+-1/2, +-1/2) cells) tell its size (light spreading thin, quads dropped at silhouettes;
// fallback_sigma_bits), as the dense grid's triangles size theirs from ray differentials; else
// of the fixed sigma.
fn emit_cell(p: Photon, level: u32, a: u32, b: u32, d: u32, cells: u32) {
    if ((lp.flags & FLAG_QUADS) == 0u || p.face == INVALID) {
        emit(p, level);
        return;
    }
    var c: array<Photon, 4>;
    c[0] = pts[a + 3u * b];
    c[1] = pts[a + d + 3u * b];
    c[2] = pts[a + 3u * (b + d)];
    c[3] = pts[a + d + 3u * (b + d)];
    var ok = true;
    var sum_a = vec4f(0.0);
    var sum_m = vec3f(0.0);
    for (var q = 0u; q < 4u; q++) {
        var same = c[q].face == p.face && c[q].flux.w == p.flux.w;
        if (!same && light.info.x == 6u && c[q].face != INVALID && c[q].flux.w == p.flux.w) {
            // A corner across a seam of a point light's cube: in p's face's coordinates (past
            // its map); splat_quads spreads the quad over the faces it covers.
            let t = texel_in_face(light.faces[c[q].face], light.faces[p.face], c[q].pos, f32(light.info.w));
            same = t.z != 0.0;
            c[q].pos = t.xy;
        }
        ok = ok && same;
        if (same) {
            let dq = vec2f(f32(q & 1u) - 0.5, f32(q >> 1u) - 0.5);
            let r = c[q].pos - p.pos;
            sum_a += vec4f(r.x * dq.x, r.x * dq.y, r.y * dq.x, r.y * dq.y);
            sum_m += vec3f(dq.x * dq.x, dq.x * dq.y, dq.y * dq.y);
        }
    }
    if (ok) {
        let e = max(max(distance(c[0].pos, c[1].pos), distance(c[0].pos, c[2].pos)),
                    max(max(distance(c[1].pos, c[3].pos), distance(c[2].pos, c[3].pos)), distance(c[0].pos, c[3].pos)));
        ok = e <= max_edge(cells);
    }
    var fallback = 0u;
    if (!ok) { fallback = fallback_sigma_bits(sum_a, sum_m, light.params.z); }
    emit_record(p, level, ok, vec4f(c[0].pos, c[1].pos), vec4f(c[2].pos, c[3].pos), fallback);
}

fn flush_corner_count() {
    if (corner_traces == 0u) { return; }
    let old = atomicAdd(&ctrl[C_CORNERS], corner_traces);
    if (old > 0xffffffffu - corner_traces) { atomicAdd(&ctrl[C_CORNERS + 1u], 1u); }
}

// Cells in the list are parents, on grids of at most 32768 (N <= 65536), so each coordinate
// leaves its top bit free: together they hold the number of levels (0..3) over which the
// cluster's descendants skip the convergence check (see `hopeless_levels`).
fn append_cell(c: vec2u, skip: u32) {
    let k = atomicAdd(&ctrl[C_WRITE_COUNT], 1u);
    if (k >= lp.cell_capacity) { atomicOr(&ctrl[C_OVERFLOW], 1u); return; }
    cells[atomicLoad(&ctrl[C_WRITE_OFF]) + k] = pack_cell(c.x, c.y) | ((skip & 1u) << 15u) | ((skip >> 1u) << 31u);
}

fn cell_skip(raw: u32) -> u32 {
    return ((raw >> 15u) & 1u) | ((raw >> 30u) & 2u);
}

// Maximal caustic map error: how many of the next levels cannot converge, predicted from the
// spread of the children (texels): below a child the photons lie half as far apart, so its
// children spread about spread / 2 where the map is smooth, and less slowly where it is not
// (across folds and changes of path they do not shrink at all). A level whose predicted spread
// is still four times the tolerance (one texel for the paper's rule) is skipped: its clusters
// are refined without tracing their children, which the check would only trace to refine them.
// Off with the linearity rule (it merges clusters of any spread that map affinely).
fn hopeless_levels(spread: f32) -> u32 {
    if (lp.linearity > 0.0 || (lp.flags & FLAG_SKIP) == 0u) { return 0u; }
    let r = spread / (4.0 * max(1.0, lp.tolerance));
    if (r < 2.0) { return 0u; }
    return min(u32(floor(log2(r))), 3u);
}

fn flush_pending() {
    trace_defer = false;
    // Pairs 0..5 and 7 (words 14, 15: untraced branches); word 12 is a plain counter.
    for (var s = 0u; s < 8u; s++) {
        if (s != 6u && trace_pending[s] > 0.0) { add_fixed(2u * s, trace_pending[s]); }
    }
}

// What a cluster does once its points are traced.
const ACT_REFINE: u32 = 0u;
const ACT_MERGE: u32 = 1u;
const ACT_EMIT_KIDS: u32 = 2u;
var<private> action: u32 = ACT_REFINE;
var<private> merged: Photon;
var<private> merged_same_path: bool = false;
// The children's spread (texels) when the covered ones all land on one face (else 0).
var<private> kids_spread: f32 = 0.0;

// The lattice points needed to emit the covered children `cov` (bit q: child q) as cells.
fn kids_corners(cov: u32) -> u32 {
    var need = 0u;
    if ((lp.flags & FLAG_QUADS) == 0u) { return need; }
    for (var q = 0u; q < 4u; q++) {
        if ((cov & (1u << q)) != 0u && pts[KIDS + q].face != INVALID) { need |= cell_corners(q & 1u, q >> 1u, 1u); }
    }
    return need;
}

// Decide the cluster's action from the points traced so far (its covered children `cov` are);
// returns the points still needed for the decision or the emission (0: decided, in `action`).
fn decide(cov: u32, nfull: u32, check: bool) -> u32 {
    let last = (lp.flags & FLAG_LAST) != 0u;
    let quads = (lp.flags & FLAG_QUADS) != 0u;
    if (!check) {
        action = ACT_EMIT_KIDS;
        return kids_corners(cov) & ~pts_done;
    }
    // Maximal caustic map error.
    let p0 = pts[KIDS];
    var converged = nfull == 4u;
    var one_face = true;
    var same_path = true;
    var lo = vec2f(1e30);
    var hi = vec2f(-1e30);
    var sum = vec3f(0.0);
    var wpos = vec2f(0.0);
    for (var q = 0u; q < 4u; q++) {
        if ((cov & (1u << q)) == 0u) { continue; }
        let p = pts[KIDS + q];
        if (p.face == INVALID || p.face != p0.face) {
            converged = false;
            one_face = false;
        }
        same_path = same_path && p.flux.w == p0.flux.w;
        lo = min(lo, p.pos);
        hi = max(hi, p.pos);
        let w = p.flux.r + p.flux.g + p.flux.b;
        sum += p.flux.rgb;
        wpos += w * p.pos;
    }
    kids_spread = select(0.0, max(hi.x - lo.x, hi.y - lo.y), one_face);
    // Caustic triangles: the merged cluster is the parent cell's quad, so the test covers the
    // corner lattice too (the parent's corners and its children's): if every lattice point is on
    // the children's face and path, it must lie in the texel (within the tolerance) as well, and
    // the merged quad deposits its flux where the children's quads would. (A lattice point off
    // the path leaves the one-texel test to the children: the merged photon is then a Gaussian.)
    var linear = false;
    if (converged && quads && same_path) {
        if ((pts_done & 0x1ffu) != 0x1ffu) { return 0x1ffu & ~pts_done; }
        var agree = true;
        var clo = lo;
        var chi = hi;
        for (var k = 0u; k < 9u; k++) {
            let c = pts[k];
            agree = agree && c.face == p0.face && c.flux.w == p0.flux.w;
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
                let c00 = pts[0].pos;
                let c10 = pts[2].pos;
                let c01 = pts[6].pos;
                let c11 = pts[8].pos;
                let mid = 0.25 * (c00 + c10 + c01 + c11);
                let du = 0.5 * (c10 - c00 + c11 - c01);
                let dv = 0.5 * (c01 - c00 + c11 - c10);
                var dev = 0.0;
                for (var k = 0u; k < 9u; k++) {
                    let u = 0.5 * f32(k % 3u) - 0.5;
                    let v = 0.5 * f32(k / 3u) - 0.5;
                    dev = max(dev, distance(pts[k].pos, mid + u * du + v * dv));
                }
                for (var q = 0u; q < 4u; q++) {
                    let u = 0.5 * f32(q & 1u) - 0.25;
                    let v = 0.5 * f32(q >> 1u) - 0.25;
                    dev = max(dev, distance(pts[KIDS + q].pos, mid + u * du + v * dv));
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
        action = ACT_MERGE;
        merged.pos = wpos / wsum;
        merged.face = p0.face;
        merged.flux = vec4f(sum, 0.0);
        merged._pad = 0u;
        if (light.splat.x > 0.5 && !quads) {
            // Lens and differential splats: the merged photon's beam is its cluster's, whose
            // area is the sum of the children's (and at least the cluster's spread).
            var area = 0.0;
            for (var q = 0u; q < 4u; q++) { let dq = bitcast<f32>(pts[KIDS + q]._pad); area += dq * dq; }
            merged._pad = bitcast<u32>(max(sqrt(area), max(hi.x - lo.x, hi.y - lo.y)));
        }
        // The merged cluster is the parent cell: with one path, its quad is the parent's four
        // corners (traced for the test above when there are quads).
        merged_same_path = same_path;
        if (same_path) { merged.flux.w = p0.flux.w; }
        return 0u;
    }
    if (last) {
        action = ACT_EMIT_KIDS;
        return kids_corners(cov) & ~pts_done;
    }
    action = ACT_REFINE;
    return 0u;
}

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) nwg: vec3u, @builtin(local_invocation_index) lid: u32) {
    let t = thread_index(wg, nwg, lid);
    if (t >= atomicLoad(&ctrl[C_READ_COUNT])) { return; }
    trace_reflect = (lp.flags & FLAG_REFLECT) != 0u;
    trace_internal_branch = (lp.flags & FLAG_INTERNAL) != 0u;
    trace_residual = (lp.flags & FLAG_RESIDUAL) != 0u;
    let raw = cells[atomicLoad(&ctrl[C_READ_OFF]) + t];
    let parent = vec2u(raw & 0x7fffu, (raw >> 16u) & 0x7fffu);
    let skip = cell_skip(raw);
    let s = 2u * lp.grid;
    let child_level = lp.level + 1u;
    let last = (lp.flags & FLAG_LAST) != 0u;
    // A level the cluster's parent predicted hopeless is not checked (its photons are then
    // booked as they are traced, as without the check).
    let check = (lp.flags & FLAG_CHECK) != 0u && skip == 0u;
    var kids: array<vec2u, 4>;
    var cov = 0u;
    var ncov = 0u;
    var nfull = 0u;
    // Level-0 coverage texels under a child: all covered = every finest photon below it hits.
    let per_child = select((lp.gbuffer / s) * (lp.gbuffer / s), 1u, s >= lp.gbuffer);
    for (var q = 0u; q < 4u; q++) {
        kids[q] = 2u * parent + vec2u(q & 1u, q >> 1u);
        let c = covered_count(kids[q].x, kids[q].y, s);
        if (c > 0u) {
            cov |= 1u << q;
            ncov += 1u;
        }
        if (c == per_child) { nfull += 1u; }
    }
    if (!check && !last) {
        for (var q = 0u; q < 4u; q++) {
            if ((cov & (1u << q)) != 0u) { append_cell(kids[q], max(skip, 1u) - 1u); }
        }
        return;
    }
    // Trace the covered children; with maximal error, book their flux only if they are emitted.
    trace_defer = check;
    for (var k = 0u; k < 8u; k++) { trace_pending[k] = 0.0; }
    var need = cov << KIDS;
    loop {
        trace_points(parent, s, need);
        need = decide(cov, nfull, check);
        if (need == 0u) { break; }
    }
    atomicAdd(&ctrl[C_TRACED + child_level], ncov);
    if (action == ACT_MERGE) {
        flush_pending();
        if (merged_same_path) {
            emit_cell(merged, lp.level, 0u, 0u, 2u, lp.grid);
        } else {
            emit(merged, lp.level);
        }
    } else if (action == ACT_EMIT_KIDS) {
        flush_pending();
        for (var q = 0u; q < 4u; q++) {
            if ((cov & (1u << q)) != 0u) { emit_cell(pts[KIDS + q], child_level, q & 1u, q >> 1u, 1u, s); }
        }
    } else {
        trace_defer = false;
        let next_skip = hopeless_levels(kids_spread);
        for (var q = 0u; q < 4u; q++) {
            if ((cov & (1u << q)) != 0u) { append_cell(kids[q], next_skip); }
        }
    }
    flush_corner_count();
}
