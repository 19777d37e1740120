// Stage: beam_shrink. The parts of the last level's triangles whose corners' edges take
// different paths (Liktor & Dachsbacher 2011 split such triangles without end; we stop at the
// last level and keep every path's light): SAMPLES threads per part beam_refine queued (`parts`,
// an indirect dispatch over their count, GROUP_PARTS parts per workgroup). Together they trace
// the triangle's three corners again on the part's branch (the same edges beam_refine traced)
// and SAMPLES sample edges of the triangle, find the part by bisection along the triangle's
// sides (`boundary`, one side per thread), trace SAMPLES sample edges of each of the part's own
// region's triangles, each assigns its sample to a beam if no corner takes its path (an orphan:
// `nearest_part`), and one of them emits its beam with its flux (`part_flux`) in the triangle's
// place of the hierarchy, so the beams' order does not depend on the order of the threads
// (beam_order); part 0's also the triangle's orphans' beam (`orphan_beam`).
//
// Its own pass, not beam_refine's: a part traces some fifty edges, and one triangle has up to
// three parts on each of six branches and two layers. In one invocation that is more loop
// iterations than lavapipe lets a shader run (some 65536 in all; past them its loops end early)
// where the casters are meshes with deep BVHs: a quarter of the glass dragon's last-level
// triangles lost their light in beam_refine, and half of its silhouette light was lost with one
// thread per part here (docs/benchmarks.md, "Beams on a mesh caster"). Spread over the
// threads of a workgroup, no invocation traces more than 15 edges, and the work that only
// silhouette triangles have runs in parallel instead of leaving the other threads of
// beam_refine's waves idle.

#import raytrace
#import beams
#import medium
#import beam_medium
#import beam_trace
#import scene

@group(0) @binding(0) var<uniform> light: LightGpu;
@group(0) @binding(1) var<uniform> bp: BeamParams;
// beam_refine's parts, and its indirect arguments (the parts' count at entry PARTS_ARGS).
@group(0) @binding(2) var<storage, read> parts: array<BeamPart>;
@group(0) @binding(3) var<storage, read> args: array<u32>;
// Per slot, branch and layer (BEAM_KINDS per slot): beam index + 1 (0: none).
@group(0) @binding(4) var<storage, read_write> slots: array<u32>;
@group(0) @binding(5) var<storage, read_write> beams: array<BeamGpu>;
// Word 0: beams appended; BS_WORDS statistics words follow at 1.
@group(0) @binding(6) var<storage, read_write> stats: array<atomic<u32>>;

// The last point from `good` toward `bad` (light NDC) whose edge still takes `r`'s path
// (bisection, SHRINK_STEPS traces), and its edge.
struct Boundary {
    ndc: vec2f,
    e: Edge,
}

const SHRINK_STEPS: u32 = 10u;

fn boundary(f: u32, good: vec2f, bad: vec2f, br: u32, layer: u32, r: Edge) -> Boundary {
    var out = Boundary(good, r);
    var lo = 0.0;
    var hi = 1.0;
    for (var k = 0u; k < SHRINK_STEPS; k++) {
        let mid = 0.5 * (lo + hi);
        let p = mix(good, bad, mid);
        let e = at_layer(trace_edge(f, p, br), layer);
        if (same_path(e, r)) {
            lo = mid;
            out = Boundary(p, e);
        } else {
            hi = mid;
        }
    }
    return out;
}

// Sub-triangles per side of a triangle's midpoint subdivision (`sample_point`): its
// PART_SPLIT^2 sub-triangles' centroids are its samples, one thread each.
const PART_SPLIT: u32 = 4u;
const SAMPLES: u32 = PART_SPLIT * PART_SPLIT;
// Parts per workgroup (SAMPLES threads each).
const GROUP_PARTS: u32 = 64u / SAMPLES;

// Sample s of triangle p0 p1 p2 (light NDC): the centroid of the s-th sub-triangle of its
// midpoint subdivision into PART_SPLIT^2 triangles of equal area (row i, column j; upward
// sub-triangles at (i + 1/3, j + 1/3) / n, downward at (i + 2/3, j + 2/3) / n).
fn sample_point(p0: vec2f, p1: vec2f, p2: vec2f, s: u32) -> vec2f {
    var i = 0u;
    var left = s;
    // (row i has 2 (PART_SPLIT - i) - 1 sub-triangles)
    while (left >= 2u * (PART_SPLIT - i) - 1u) {
        left -= 2u * (PART_SPLIT - i) - 1u;
        i++;
    }
    let up = left & 1u;
    let j = left / 2u;
    let n = f32(PART_SPLIT);
    let o = select(1.0 / 3.0, 2.0 / 3.0, up == 1u);
    let a = (f32(i) + o) / n;
    let b = (f32(j) + o) / n;
    return p0 + a * (p1 - p0) + b * (p2 - p0);
}

// Twice the area of the triangle p0 p1 p2 (light NDC).
fn ndc_area(p0: vec2f, p1: vec2f, p2: vec2f) -> f32 {
    let u = p1 - p0;
    let v = p2 - p0;
    return abs(u.x * v.y - u.y * v.x);
}

// Whether point x lies in the convex polygon of n (3 or 4) vertices q (light NDC, either
// orientation; on its border counts; a polygon of no area, a part whose bisection found no
// neighbour on its path, holds nothing).
fn in_polygon(x: vec2f, q: array<vec2f, 4>, n: u32) -> bool {
    var pos = false;
    var neg = false;
    for (var k = 0u; k < n; k++) {
        let a = q[k];
        let b = q[(k + 1u) % n];
        let c = (b.x - a.x) * (x.y - a.y) - (b.y - a.y) * (x.x - a.x);
        pos = pos || c > 0.0;
        neg = neg || c < 0.0;
    }
    return (pos || neg) && !(pos && neg);
}

// A traced sample's path and weight, as the part's threads share it.
struct Sample {
    weight: vec3f,
    // The sample's edge is on a caustic path (ok, meets a caster first).
    ok: u32,
    // Its last segment's direction (where an orphan goes: `nearest_part`).
    dir: vec3f,
    sig: u32,
    land: u32,
}
// What beam_shrink's threads share for each of a workgroup's parts: the triangle's corners'
// edges, its samples, the two boundary points, and the samples of the part's own region (a
// quad as its two triangles: (weight sum, count) of those on the part's path).
var<workgroup> corners: array<array<Edge, 3>, GROUP_PARTS>;
var<workgroup> samples: array<array<Sample, SAMPLES>, GROUP_PARTS>;
var<workgroup> bounds: array<array<Boundary, 2>, GROUP_PARTS>;
var<workgroup> region: array<array<array<vec4f, SAMPLES>, 2>, GROUP_PARTS>;
// The orphans' axis: the index of the first orphan sample that lands where no corner's path
// does, else SAMPLES + the first orphan's (2 SAMPLES: none), and its edge (`orphan_beam`).
var<workgroup> orphan_s: array<atomic<u32>, GROUP_PARTS>;
var<workgroup> orphan: array<Edge, GROUP_PARTS>;
// Which beam carries each sample that is an orphan (`nearest_part`: a part's case, 6 the orphans'
// beam; 7 not an orphan).
var<workgroup> assign: array<array<u32, SAMPLES>, GROUP_PARTS>;

// Whether a sample took path r.
fn sample_on(x: Sample, r: Edge) -> bool {
    return x.ok != 0u && r.ok && r.caster && x.sig == r.sig && x.land == r.land;
}

// The part's case c (as `part_applies`): c = 0, 1, 2, two corners (those other than c) that
// agree give the quad between them and the far side's boundary points; c = 3, 4, 5, corner
// c - 3 on a path of its own the triangle between it and its boundary points toward the other
// two. Its corners k, i, j (k the case's corner) and the path's corner.
struct Case {
    quad: bool,
    k: u32,
    i: u32,
    j: u32,
    path: u32,
}

fn part_case(c: u32) -> Case {
    let k = c % 3u;
    let quad = c < 3u;
    return Case(quad, k, (k + 1u) % 3u, (k + 2u) % 3u, select(k, (k + 1u) % 3u, quad));
}

// The part's region (light NDC; a lone corner's triangle, or the quad) and its two triangles
// (the quad's i j qj and i qj qi; a lone corner's k qi qj and nothing).
struct Region {
    q: array<vec2f, 4>,
    n: u32,
    t: array<array<vec2f, 3>, 2>,
}

fn part_region(p: BeamPart, cs: Case, qi: vec2f, qj: vec2f) -> Region {
    let ps = array<vec2f, 3>(p.a, p.b, p.c);
    if (cs.quad) {
        return Region(array<vec2f, 4>(ps[cs.i], ps[cs.j], qj, qi), 4u,
            array<array<vec2f, 3>, 2>(array<vec2f, 3>(ps[cs.i], ps[cs.j], qj), array<vec2f, 3>(ps[cs.i], qj, qi)));
    }
    let lone = array<vec2f, 3>(ps[cs.k], qi, qj);
    return Region(array<vec2f, 4>(ps[cs.k], qi, qj, qj), 3u, array<array<vec2f, 3>, 2>(lone, lone));
}

// Whether a sample is an orphan: on a caustic path none of the triangle's corners takes.
fn is_orphan(x: Sample, es: array<Edge, 3>) -> bool {
    return x.ok != 0u && !sample_on(x, es[0]) && !sample_on(x, es[1]) && !sample_on(x, es[2]);
}

// Whether an orphan lands where none of the triangle's corners' caustic paths do (on another
// object, or out of the scene).
fn foreign(x: Sample, es: array<Edge, 3>) -> bool {
    var f = true;
    for (var k = 0u; k < 3u; k++) { f = f && !(es[k].ok && es[k].caster && es[k].land == x.land); }
    return f;
}

// The axis of a triangle's orphans' beam (`orphan_beam`), where it has one, its part (its
// place after the triangle's parts') and its shape (`orphan_shape`).
struct OrphanAxis {
    has: bool,
    d: vec3f,
    land: u32,
    part: u32,
    shape: BeamGpu,
}

// The orphans' axis of workgroup part g (once `orphan` is written): the triangle has an
// orphans' beam where it has orphans, a free part (its place after the parts') and the beam
// is not degenerate (`orphan_beam`; else its orphans go to the parts).
fn orphan_axis(g: u32, es: array<Edge, 3>, omega: f32, level: u32, layer: u32) -> OrphanAxis {
    var parts = 0u;
    for (var cc = 0u; cc < 6u; cc++) { parts += u32(part_applies(es, cc)); }
    var shape: BeamGpu;
    shape.flux.w = -1.0;
    if (atomicLoad(&orphan_s[g]) < 2u * SAMPLES && parts < BEAM_PARTS) { shape = orphan_shape(g, omega, level, layer); }
    return OrphanAxis(shape.flux.w >= 0.0, orphan[g].d, orphan[g].land, parts, shape);
}

// Which beam of the triangle whose corners' edges are `es` carries orphan sample x: of its
// parts (their cases, as `part_applies`) and its orphans' beam (6, where `ax.has`), one whose
// path lands where x does (the object, or out of the scene) if any does, and of those the one
// whose path's last segment leaves nearest to x's (the largest cosine; the first on a tie).
// Every orphan goes to exactly one beam, so that its light stays near where it goes: an equal
// share of them to the parts put the light that leaves the glass dragon sideways and upward on
// the floor.
fn nearest_part(es: array<Edge, 3>, x: Sample, ax: OrphanAxis) -> u32 {
    var best = 6u;
    var best_score = -8.0;
    if (ax.has) { best_score = dot(x.dir, ax.d) + select(0.0, 4.0, ax.land == x.land); }
    for (var cc = 0u; cc < 6u; cc++) {
        if (!part_applies(es, cc)) { continue; }
        let e = es[part_case(cc).path];
        let score = dot(x.dir, e.d) + select(0.0, 4.0, e.land == x.land);
        if (score > best_score) {
            best = cc;
            best_score = score;
        }
    }
    return best;
}

// The part's flux: the light of its own region (its solid angle times the mean weight of the
// region's samples on its path, the midpoint rule over each of its triangles: the Fresnel
// factors change steeply toward grazing incidence, which a silhouette part reaches into, and
// the rule exact for quadratics, beam_refine's `part_weight`, put 4.5 % too much light into the
// reflected light landing near a ball), corrected by the triangle's samples where the paths do
// not follow the bisected boundaries: plus the samples on its path outside its region, minus
// (at its mean weight) the samples inside its region on another path or none, plus the
// triangle's orphans assigned to it (`assign`, `nearest_part`). Where the boundaries are
// straight (a ball's silhouette) the corrections vanish. Where a mesh caster's light takes
// many paths within a triangle (the glass dragon: light leaving one body part into another, reflected totally inside a thin one a
// varying number of times) the regions cover a fraction of the triangle, and weighting each
// part by its own area lost 43 % of the dragon's transmitted light (docs/benchmarks.md, "Beams
// on a mesh caster: the deficit found"); with the corrections the parts carry all the
// triangle's caustic light in the samples' estimate, each within the triangle's extent of
// where it goes.
fn part_flux(p: BeamPart, g: u32, cs: Case, rg: Region, es: array<Edge, 3>, omega_tri: f32) -> vec3f {
    let r = es[cs.path];
    // (this part's case, as `part_applies`)
    let own = select(cs.k + 3u, cs.k, cs.quad);
    let face = light.faces[p.face];
    // The region's own light.
    var mean = vec3f(0.0);
    var area = 0.0;
    var omega = 0.0;
    for (var t = 0u; t < select(1u, 2u, cs.quad); t++) {
        var m = vec4f(0.0);
        for (var s = 0u; s < SAMPLES; s++) { m += region[g][t][s]; }
        let tr = rg.t[t];
        let a = ndc_area(tr[0], tr[1], tr[2]);
        if (m.w > 0.0) {
            mean += a * m.xyz / m.w;
            area += a;
        }
        omega += solid_angle(light_dir(face, tr[0]), light_dir(face, tr[1]), light_dir(face, tr[2]));
    }
    // (no region sample on the path: the mean of its corners)
    let corner_mean = select(r.weight, 0.5 * (es[cs.i].weight + es[cs.j].weight), cs.quad);
    mean = select(corner_mean, mean / area, area > 0.0);
    // The triangle's samples.
    var extra = vec3f(0.0);
    var intruders = 0.0;
    for (var s = 0u; s < SAMPLES; s++) {
        let x = samples[g][s];
        let inside = in_polygon(sample_point(p.a, p.b, p.c, s), rg.q, rg.n);
        let on = sample_on(x, r);
        if (on && !inside) { extra += x.weight; }
        if (!on && inside) { intruders += 1.0; }
        if (assign[g][s] == own) {
            extra += x.weight;
        }
    }
    return max(omega * mean + omega_tri / f32(SAMPLES) * (extra - intruders * mean), vec3f(0.0));
}

// One part of a last-level triangle whose edges on its branch and layer disagree (a silhouette,
// an edge landing elsewhere, light that meets a second caster or misses it): the part of the
// triangle on one of the caustic paths its corners take, found by bisection along its sides (the
// boundary points: a quad's from i and from j toward k, a lone corner's from k toward i and
// toward j), emitted as part `part` (0, 1, 2) of the triangle's place (`emit`). A quad's beam is
// the triangle over its two good corners and the middle of its far side; a part whose beam is
// degenerate (bisection found no neighbour on its path: a sliver) a thin beam along its
// corner's edge, as wide as the light's bundle through the triangle where it meets the caster
// (on layer 1 meeting at the edge's end on the next specular surface).
fn shrink_part(p: BeamPart, g: u32, es: array<Edge, 3>, br: u32, layer: u32, cs: Case, part: u32, ax: OrphanAxis) {
    let qi = bounds[g][0];
    let qj = bounds[g][1];
    var x0 = es[cs.k];
    var x1 = qi.e;
    var x2 = qj.e;
    if (cs.quad) {
        var em = at_layer(trace_edge(p.face, 0.5 * (qi.ndc + qj.ndc), br), layer);
        if (!same_path(em, es[cs.i])) { em = qi.e; }
        x0 = es[cs.i];
        x1 = es[cs.j];
        x2 = em;
    }
    let face = light.faces[p.face];
    let omega = solid_angle(light_dir(face, p.a), light_dir(face, p.b), light_dir(face, p.c));
    var b = make_beam(x0, x1, x2, omega, p.level);
    if (b.flux.w < 0.0) {
        let e = es[cs.path];
        b = thin_beam(e, 0.5 * sqrt(omega) * e.first_t, omega, p.level, layer > 0u);
    }
    b.flux = vec4f(part_flux(p, g, cs, part_region(p, cs, qi.ndc, qj.ndc), es, omega), b.flux.w);
    emit(b, p.slot, br, layer, part);
    // The orphans' beam, where the triangle has one (its place after the parts'): made by part 0.
    if (part == 0u && ax.has) {
        emit(orphan_beam(g, omega, ax), p.slot, br, layer, ax.part);
    }
}

// The orphans' beam of a triangle (light on caustic paths none of its corners takes; on the
// glass dragon much of it leaves sideways and upward from triangles whose corners all land on
// the floor): a thin beam along the orphans' axis (`orphan_s`: the first orphan sample that
// lands where no corner's path does, else the first), as wide as a part's thin beam, carrying
// the orphans assigned to it (`nearest_part`). Without it their light went to the corners'
// parts: 4.8 % too much of the dragon's transmitted light on the floor.
fn orphan_beam(g: u32, omega: f32, ax: OrphanAxis) -> BeamGpu {
    var sum = vec3f(0.0);
    for (var s = 0u; s < SAMPLES; s++) {
        if (assign[g][s] == 6u) { sum += samples[g][s].weight; }
    }
    var b = ax.shape;
    b.flux = vec4f(omega / f32(SAMPLES) * sum, b.flux.w);
    return b;
}

// The orphans' beam's shape (flux.w < 0: degenerate).
fn orphan_shape(g: u32, omega: f32, level: u32, layer: u32) -> BeamGpu {
    let e = orphan[g];
    return thin_beam(e, 0.5 * sqrt(omega) * e.first_t, omega, level, layer > 0u);
}

// SAMPLES threads per part (GROUP_PARTS parts per workgroup; the header says why): each traces
// a sample of the triangle (threads 0..2 their corner too), threads 0 and 1 bisect a side each,
// each traces a sample of each of the part's region's triangles and assigns its triangle sample
// if it is an orphan, and thread 0 makes the beam (in one thread, the assignment took
// `beam_shrink` from 37 s to 58 s on the dragon on lavapipe).
// (Threads past the parts' count take part in the barriers only.)
@compute @workgroup_size(64)
fn main(@builtin(local_invocation_index) li: u32, @builtin(workgroup_id) wid: vec3u) {
    let n = min(args[4u * PARTS_ARGS + 3u], min(bp.capacity, 65535u * 64u));
    let g = li / SAMPLES;
    let s = li % SAMPLES;
    let index = (wid.x + wid.y * 65535u) * GROUP_PARTS + g;
    let live = index < n;
    var p: BeamPart;
    if (live) { p = parts[index]; }
    // (the residual branch's choices: those beam_refine drew for the triangle)
    beam_key = p.slot;
    let br = p.kind & 15u;
    let layer = (p.kind >> 4u) & 15u;
    let c = (p.kind >> 8u) & 15u;
    let part = p.kind >> 12u;
    let cs = part_case(c);
    // (a triangle none of whose corners is on a caustic path of the branch: its orphans' beam
    // alone, no bisection, no region)
    let orphans_only = c == PART_ORPHANS;
    // The triangle's sample, and (threads 0..2) the corner's edge: the corners' edges on the
    // part's branch and layer as beam_refine traced them.
    var mine: Edge;
    if (s == 0u) { atomicStore(&orphan_s[g], 2u * SAMPLES); }
    if (live) {
        for (var t = 0u; t < select(1u, 2u, s < 3u); t++) {
            let q = select(sample_point(p.a, p.b, p.c, s), select(select(p.c, p.b, s == 1u), p.a, s == 0u), t == 1u);
            let e = at_layer(trace_edge(p.face, q, br), layer);
            if (t == 0u) {
                samples[g][s] = Sample(e.weight, u32(e.ok && e.caster), e.d, e.sig, e.land);
                mine = e;
            } else {
                corners[g][s] = e;
            }
        }
    }
    workgroupBarrier();
    let es = corners[g];
    // The orphans' axis: the first orphan sample that lands where no corner's path does, else
    // the first orphan (its edge is written after the next barrier).
    let xs = samples[g][s];
    if (live && is_orphan(xs, es)) { atomicMin(&orphan_s[g], s + select(SAMPLES, 0u, foreign(xs, es))); }
    if (live && s < 2u && !orphans_only) {
        let ps = array<vec2f, 3>(p.a, p.b, p.c);
        let good = select(ps[cs.k], select(ps[cs.j], ps[cs.i], s == 0u), cs.quad);
        let bad = select(select(ps[cs.j], ps[cs.i], s == 0u), ps[cs.k], cs.quad);
        bounds[g][s] = boundary(p.face, good, bad, br, layer, es[cs.path]);
    }
    workgroupBarrier();
    if (live && atomicLoad(&orphan_s[g]) % SAMPLES == s) { orphan[g] = mine; }
    // The samples of the part's own region.
    let rg = part_region(p, cs, bounds[g][0].ndc, bounds[g][1].ndc);
    for (var t = 0u; t < 2u; t++) {
        var m = vec4f(0.0);
        if (live && !orphans_only && (t == 0u || cs.quad)) {
            let tr = rg.t[t];
            let e = at_layer(trace_edge(p.face, sample_point(tr[0], tr[1], tr[2], s), br), layer);
            if (same_path(e, es[cs.path])) { m = vec4f(e.weight, 1.0); }
        }
        region[g][t][s] = m;
    }
    workgroupBarrier();
    // Each orphan sample's beam (`nearest_part`), one thread each.
    var to = 7u;
    let face = light.faces[p.face];
    let omega = solid_angle(light_dir(face, p.a), light_dir(face, p.b), light_dir(face, p.c));
    let ax = orphan_axis(g, es, omega, p.level, layer);
    if (live && is_orphan(xs, es)) { to = nearest_part(es, xs, ax); }
    assign[g][s] = to;
    workgroupBarrier();
    if (live && s == 0u && !orphans_only) {
        shrink_part(p, g, es, br, layer, cs, part, ax);
    }
    if (live && s == 0u && orphans_only && ax.has) {
        emit(orphan_beam(g, omega, ax), p.slot, br, layer, ax.part);
    }
}
