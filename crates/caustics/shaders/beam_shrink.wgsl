// Stage: beam_shrink. The parts of the last level's triangles whose corners' edges take
// different paths (Liktor & Dachsbacher 2011 split such triangles without end; we stop at the
// last level and keep every path's light): one thread per part beam_refine queued (`parts`, an
// indirect dispatch over their count), which traces the triangle's three corners again on the
// part's branch (the same edges beam_refine traced), finds the part by bisection along the
// triangle's sides (`boundary`), and emits its beam in the triangle's place of the hierarchy, so
// the beams' order does not depend on the order of the threads (beam_order).
//
// Its own pass, not beam_refine's: a part traces some twenty to forty edges (bisection steps, the
// midpoint rule of its Fresnel weight), and one triangle has up to three parts on each of five
// branches and two layers. In one invocation that was more loop iterations than lavapipe lets a
// shader run (some 65536 in all; past them its loops end early) where the casters are meshes
// with deep BVHs: a quarter of the glass dragon's last-level triangles lost their light
// (docs/benchmarks.md). One part per thread also spreads the work that only silhouette
// triangles have over the GPU instead of leaving the other threads of beam_refine's waves idle.

#import raytrace
#import beams
#import medium
#import beam_medium
#import beam_trace

@group(0) @binding(0) var<uniform> light: LightGpu;
@group(0) @binding(1) var<uniform> bp: BeamParams;
@group(0) @binding(2) var<storage, read> materials: array<MaterialGpu>;
@group(0) @binding(3) var<storage, read> bvh_nodes: array<BvhNode>;
@group(0) @binding(4) var<storage, read> bvh_tris: array<BvhTri>;
@group(0) @binding(5) var<storage, read> bvh_instances: array<BvhInstance>;
// beam_refine's parts, and its indirect arguments (the parts' count at entry PARTS_ARGS).
@group(0) @binding(6) var<storage, read> parts: array<BeamPart>;
@group(0) @binding(7) var<storage, read> args: array<u32>;
// Per slot, branch and layer (BEAM_KINDS per slot): beam index + 1 (0: none).
@group(0) @binding(8) var<storage, read_write> slots: array<u32>;
@group(0) @binding(9) var<storage, read_write> beams: array<BeamGpu>;
// Word 0: beams appended; BS_WORDS statistics words follow at 1.
@group(0) @binding(10) var<storage, read_write> stats: array<atomic<u32>>;
// The medium's density grid (shared/beam_medium.wgsl: the light's optical depth up to a base).
@group(0) @binding(11) var density_grid: texture_3d<f32>;

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

// Sub-triangles per side of `part_mean`'s midpoint subdivision.
const PART_SPLIT: u32 = 4u;

// The mean weight of r's path over the triangle p0 p1 p2 (light NDC, a part of a last-level
// triangle at a silhouette), by the midpoint rule over its midpoint subdivision into
// PART_SPLIT^2 triangles of equal area (their centroids' edges traced; those on another path
// left out), and the subdivision's count of samples on the path (w; 0: none, use the corners).
// The Fresnel factors change steeply toward grazing incidence, and a silhouette part reaches
// into it: the rule exact for quadratics (`part_weight`) was measured to put 4.5 % too much
// light into the reflected light landing near a ball (that and the lost minority parts had
// cancelled, docs/benchmarks.md).
fn part_mean(f: u32, p0: vec2f, p1: vec2f, p2: vec2f, br: u32, layer: u32, r: Edge) -> vec4f {
    var acc = vec4f(0.0);
    let n = f32(PART_SPLIT);
    for (var i = 0u; i < PART_SPLIT; i++) {
        for (var j = 0u; i + j < PART_SPLIT; j++) {
            for (var up = 0u; up < 2u; up++) {
                // (upward sub-triangles at (i + 1/3, j + 1/3) / n, downward at (i + 2/3, j + 2/3) / n)
                if (up == 1u && i + j + 2u > PART_SPLIT) { continue; }
                let o = select(1.0 / 3.0, 2.0 / 3.0, up == 1u);
                let a = (f32(i) + o) / n;
                let b = (f32(j) + o) / n;
                let e = at_layer(trace_edge(f, p0 + a * (p1 - p0) + b * (p2 - p0), br), layer);
                if (same_path(e, r)) { acc += vec4f(e.weight, 1.0); }
            }
        }
    }
    return acc;
}

// Twice the area of the triangle p0 p1 p2 (light NDC).
fn ndc_area(p0: vec2f, p1: vec2f, p2: vec2f) -> f32 {
    let u = p1 - p0;
    let v = p2 - p0;
    return abs(u.x * v.y - u.y * v.x);
}

// One part of a last-level triangle whose edges on branch `br` and layer `layer` disagree (a
// silhouette, an edge landing elsewhere, light that meets a second caster or misses it): the
// part of the triangle on one of the caustic paths its corners take, found by bisection along
// its sides, emitted as part `part` (0, 1, 2) of the triangle's place (`emit`). Case c (as
// beam_refine's `part_applies`): c = 0, 1, 2, two corners (those other than c) that agree give
// the quad between them and the far side's boundary points (the beam is the triangle over its
// two good corners and the middle of its far side, carrying the quad's flux); c = 3, 4, 5,
// corner c - 3 on a path of its own gives the triangle between it and its boundary points
// toward the other two.
fn shrink_part(p: BeamPart, es: array<Edge, 3>, br: u32, layer: u32, c: u32, part: u32) {
    let ps = array<vec2f, 3>(p.a, p.b, p.c);
    let face = light.faces[p.face];
    let quad = c < 3u;
    let k = c % 3u;
    let i = (k + 1u) % 3u;
    let j = (k + 2u) % 3u;
    // The path's corner, and the boundary points: a quad's from i and from j toward k, a
    // lone corner's from k toward i and toward j.
    var r = es[k];
    if (quad) { r = es[i]; }
    var q: array<Boundary, 2>;
    for (var sd = 0u; sd < 2u; sd++) {
        let good = select(ps[k], select(ps[j], ps[i], sd == 0u), quad);
        let bad = select(select(ps[j], ps[i], sd == 0u), ps[k], quad);
        q[sd] = boundary(p.face, good, bad, br, layer, r);
    }
    let qi = q[0];
    let qj = q[1];
    var omega: f32;
    var x0 = es[k];
    var x1 = qi.e;
    var x2 = qj.e;
    var wm: vec3f;
    var centre: vec2f;
    if (quad) {
        let mp = 0.5 * (qi.ndc + qj.ndc);
        var em = at_layer(trace_edge(p.face, mp, br), layer);
        if (!same_path(em, es[i])) { em = qi.e; }
        let li = light_dir(face, ps[i]);
        let lj = light_dir(face, ps[j]);
        let lqi = light_dir(face, qi.ndc);
        let lqj = light_dir(face, qj.ndc);
        omega = solid_angle(li, lj, lqj) + solid_angle(li, lqj, lqi);
        x0 = es[i];
        x1 = es[j];
        x2 = em;
        wm = (es[i].weight + es[j].weight + qi.e.weight + qj.e.weight) / 4.0;
        centre = 0.25 * (ps[i] + ps[j] + qi.ndc + qj.ndc);
    } else {
        omega = solid_angle(light_dir(face, ps[k]), light_dir(face, qi.ndc), light_dir(face, qj.ndc));
        wm = (es[k].weight + qi.e.weight + qj.e.weight) / 3.0;
        centre = (ps[k] + qi.ndc + qj.ndc) / 3.0;
    }
    var b = make_beam(x0, x1, x2, omega, p.level);
    var wq = wm;
    if (br == 0u) {
        wq = part_weight(p.face, centre, br, layer, r, wm, quad);
    } else {
        // The midpoint rule over the part: a lone corner's triangle, or the quad as two
        // triangles, each weighted by its area.
        var m: array<vec4f, 2>;
        for (var t = 0u; t < select(1u, 2u, quad); t++) {
            let p0 = select(ps[k], ps[i], quad);
            let p1 = select(qi.ndc, select(qj.ndc, ps[j], t == 0u), quad);
            let p2 = select(qj.ndc, select(qi.ndc, qj.ndc, t == 0u), quad);
            m[t] = part_mean(p.face, p0, p1, p2, br, layer, r);
        }
        if (quad) {
            let ma = m[0];
            let mb = m[1];
            let aa = ndc_area(ps[i], ps[j], qj.ndc);
            let ab = ndc_area(ps[i], qj.ndc, qi.ndc);
            if (ma.w > 0.0 && mb.w > 0.0 && aa + ab > 0.0) {
                wq = (aa * ma.xyz / ma.w + ab * mb.xyz / mb.w) / (aa + ab);
            } else if (ma.w + mb.w > 0.0) {
                wq = (ma.xyz + mb.xyz) / (ma.w + mb.w);
            }
        } else {
            wq = select(wm, m[0].xyz / max(m[0].w, 1.0), m[0].w > 0.0);
        }
    }
    b.flux = vec4f(omega * wq, b.flux.w);
    emit(b, p.slot, br, layer, part);
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    let n = min(args[4u * PARTS_ARGS + 3u], min(bp.capacity, 65535u * 64u));
    if (gid.x >= n) { return; }
    let p = parts[gid.x];
    let br = p.kind & 15u;
    let layer = (p.kind >> 4u) & 15u;
    let c = (p.kind >> 8u) & 15u;
    let part = p.kind >> 12u;
    // The corners' edges on the part's branch and layer, as beam_refine traced them.
    var es: array<Edge, 3>;
    for (var k = 0u; k < 3u; k++) {
        let q = select(select(p.c, p.b, k == 1u), p.a, k == 0u);
        es[k] = at_layer(trace_edge(p.face, q, br), layer);
    }
    shrink_part(p, es, br, layer, c, part);
}
