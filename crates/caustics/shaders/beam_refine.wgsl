// Stage: beam_refine. One level of the adaptive projected grid of beams (Liktor & Dachsbacher
// 2011, section 4.2), one thread per triangle: level 0 from the thread index (the B x B grid
// over each light face, two triangles per cell), later levels from the work list the level
// before appended (indirect dispatch). The triangle's three edge rays are traced exactly
// (shared/raytrace.wgsl: refraction with Fresnel, total internal reflection, mirrors) from
// the light to the first diffuse surface; then the triangle is
//   - discarded: no edge meets a specular caster first (no caustic light);
//   - split 1 -> 4 (edge midpoints; appended to the next level's list, its indirect dispatch
//     size raised by atomicMax) while levels remain, when: the edges meet a caster's silhouette
//     (some meet the caster, some not), a different object, or their first-surface normals
//     differ by more than the normal threshold or their distances from the light by more than
//     the depth threshold (discontinuities); the edges took different paths or land on
//     different objects (on any traced branch); the beam's flux relative to the face's flux, times its convergence
//     (base area over its smallest cross-section before the receiver), exceeds the energy
//     threshold; the beam's width over its distance from the camera exceeds the camera
//     threshold; or (ours) a beam it would keep departs from the light of the triangle's
//     centroid by more than the linearity threshold of its width, weighted by the share of the
//     triangle's light it carries (`nonlinearity`);
//   - kept: one beam per traced branch whose three edges took the same path (the transmitted
//     branch; with flags bit 0 also the branch reflected at the first dielectric surface and
//     the branch reflected once inside it),
//     appended to the beam buffer (overflow counted, never written out of bounds) and entered
//     in its slot of the hierarchy (beam_order lists the slots in order, so the image does not
//     depend on the order of the atomics). At the last level, a triangle whose edges still
//     disagree (a silhouette) is split into the parts on its corners' paths (`shrink`:
//     bisection along its sides), one beam each, on every branch and layer; those none of whose
//     corners takes a caustic path are counted (their light is lost). The reflected branches'
//     flux is a quadrature over the triangle exact for quadratics (`part_weight`), over a
//     silhouette part the midpoint rule of its subdivision (`part_mean`).
//     Each branch's path gives a beam on each of its layers (`at_layer`): its last segment, and
//     where its light crossed the medium from one specular object to another (a lens focusing
//     onto a second lens, a mirror onto glass), that segment too (the second caster layer),
//     ending on the next object's surface.

#import raytrace
#import beams
#import medium
#import beam_medium

@group(0) @binding(0) var<uniform> light: LightGpu;
@group(0) @binding(1) var<uniform> bp: BeamParams;
@group(0) @binding(2) var<uniform> lv: BeamLevel;
@group(0) @binding(3) var<storage, read> materials: array<MaterialGpu>;
@group(0) @binding(4) var<storage, read> bvh_nodes: array<BvhNode>;
@group(0) @binding(5) var<storage, read> bvh_tris: array<BvhTri>;
@group(0) @binding(6) var<storage, read> bvh_instances: array<BvhInstance>;
@group(0) @binding(7) var<storage, read_write> work: array<BeamTri>;
// Per level l: (workgroups x, 1, 1, triangles appended) at words 4l..4l+3.
@group(0) @binding(8) var<storage, read_write> args: array<atomic<u32>>;
// Per slot, branch and layer (BEAM_KINDS per slot): beam index + 1 (0: none).
@group(0) @binding(9) var<storage, read_write> slots: array<u32>;
@group(0) @binding(10) var<storage, read_write> beams: array<BeamGpu>;
// Word 0: beams appended; BS_WORDS statistics words follow at 1.
@group(0) @binding(11) var<storage, read_write> stats: array<atomic<u32>>;
// The medium's density grid (shared/beam_medium.wgsl: the light's optical depth up to a base).
@group(0) @binding(12) var density_grid: texture_3d<f32>;

// One traced edge.
struct Edge {
    // The first surface the light ray meets is a specular caster.
    caster: bool,
    // The path reached a diffuse surface or left the scene outside any dielectric, within the
    // interactions allowed (a beam can be built on it).
    ok: bool,
    first_obj: u32,
    first_n: vec3f,
    first_t: f32,
    // The path (objects, reflected or refracted, side) and the object it lands on.
    sig: u32,
    land: u32,
    // The last segment: from the last specular interaction o along unit d, t_end to its end.
    o: vec3f,
    d: vec3f,
    t_end: f32,
    // In-medium length of the path before o (outside dielectrics, inside the box).
    pre: f32,
    // Radiant intensity toward the edge (W/sr) times the Fresnel and mirror factors.
    weight: vec3f,
    // The segment before the last, where the path has one (layer 1: light between two
    // specular objects, e.g. from one glass ball to the next): outside dielectrics, from the
    // specular interaction o1 along unit d1 to the specular surface it meets at t1; pre1 and w1
    // as pre and weight at its start.
    has1: bool,
    o1: vec3f,
    d1: vec3f,
    t1: f32,
    pre1: f32,
    w1: vec3f,
}

// Beam layers (BEAM_LAYERS in shared/beams.wgsl): layer 0 the path's last segment (it ends on
// a diffuse surface or leaves the scene), layer 1 the segment before it when that runs
// outside dielectrics from one specular interaction to the next. The edge with its fields
// o, d, t_end, pre and weight those of `layer` (ok: the path is whole and has that layer).
fn at_layer(e: Edge, layer: u32) -> Edge {
    if (layer == 0u) { return e; }
    var r = e;
    r.ok = e.ok && e.has1;
    r.o = e.o1;
    r.d = e.d1;
    r.t_end = e.t1;
    r.pre = e.pre1;
    r.weight = e.w1;
    return r;
}

fn light_dir(face: Face, ndc: vec2f) -> vec3f {
    let a4 = face.clip_to_world * vec4f(ndc, 0.0, 1.0);
    let b4 = face.clip_to_world * vec4f(ndc, 1.0, 1.0);
    return normalize(b4.xyz / b4.w - a4.xyz / a4.w);
}

// The edge ray of light-NDC point ndc of face f, on branch `br` (BEAM_BRANCHES): 0 transmitted
// at every dielectric interface (total internal reflection reflecting), br >= 1 reflected at
// the br-th interaction and transmitted elsewhere (1: at the first surface; 2: inside the first
// dielectric; 3 and 4: at the second dielectric's surface and inside it, where light crosses
// the medium from one glass object into another). The branch's mask (`branch`, bit k: reflect
// at interaction k, as the photon tracer's branch masks) needs a dielectric interface there
// that does not reflect totally (there the light is branch 0's), and a path that reaches it.
fn trace_edge(f: u32, ndc: vec2f, br: u32) -> Edge {
    let branch = select(0u, 1u << (br - 1u), br > 0u);
    var e: Edge;
    e.caster = false;
    e.ok = false;
    e.first_obj = INVALID;
    e.land = INVALID;
    e.sig = 0u;
    e.has1 = false;
    let face = light.faces[f];
    let lp = face.origin.xyz;
    var o = lp;
    var dir = light_dir(face, ndc);
    var w = intensity_toward(light, dir);
    var inside = false;
    var pre = 0.0;
    var depth = 0u;
    var seg_o = lp;
    loop {
        let h = scene_hit(o, dir, 1e30);
        if (h.object == INVALID) {
            if (depth == 0u) { return e; }
            // Leaves the scene: the beam runs to the far side of the medium's box.
            e.ok = !inside && (depth >= 32u || (branch >> depth) == 0u);
            e.land = INVALID;
            e.o = seg_o;
            e.d = dir;
            let c = box_clip(seg_o, dir, 1e30, bp.lo.xyz, bp.hi.xyz);
            e.t_end = max(c.y, 0.0);
            break;
        }
        let mat = materials[h.object];
        if (depth == 0u) {
            e.first_obj = h.object;
            e.first_n = h.ns;
            e.first_t = h.t;
            if (mat.kind.x == KIND_DIFFUSE || mat.kind.y == 0u) { return e; }
            e.caster = true;
        }
        let reflect_here = depth < 32u && ((branch >> depth) & 1u) == 1u;
        if (reflect_here && mat.kind.x != KIND_DIELECTRIC) { return e; }
        if (mat.kind.x == KIND_DIFFUSE) {
            e.ok = !inside && (depth >= 32u || (branch >> depth) == 0u);
            e.land = h.object;
            e.o = seg_o;
            e.d = dir;
            e.t_end = length(h.p - seg_o);
            break;
        }
        if (depth >= bp.max_depth) { return e; }
        if (depth > 0u && !inside) {
            // A segment after a specular interaction, outside dielectrics, ends on another
            // specular surface: the latest such is layer 1. Only where the branch reflected
            // before it (or is branch 0): otherwise the segment's light is the transmitted
            // branch's, whose layer 1 it is.
            e.has1 = br == 0u || br - 1u < depth;
            e.o1 = seg_o;
            e.d1 = dir;
            e.t1 = length(h.p - seg_o);
            e.pre1 = pre;
            e.w1 = w;
        }
        if (!inside) { pre += beam_depth(seg_o, h.p); }
        let front = dot(dir, h.ng) < 0.0;
        let ng = select(-h.ng, h.ng, front);
        let ns = select(-h.ns, h.ns, front);
        // The interface step (shared/raytrace.wgsl, as the photon tracer's: shared/trace.wgsl).
        var n = ns;
        var reflect_it = true;
        var eta = 1.0;
        if (mat.kind.x == KIND_MIRROR || mat.kind.x == KIND_CONDUCTOR) {
            w *= rt_metal_weight(mat, dir, ns);
        } else {
            let fz = rt_dielectric_fresnel(mat, dir, ns, ng, front);
            n = fz.n;
            eta = fz.eta;
            let fr = fz.f;
            if (reflect_here && fr >= 1.0) { return e; }
            reflect_it = reflect_here || fr >= 1.0;
            w *= select(1.0 - fr, select(fr, 1.0, fr >= 1.0), reflect_it);
        }
        let bz = rt_bounce(dir, n, ng, eta, reflect_it);
        let reflected = bz.reflected;
        let new_dir = bz.dir;
        if (!reflected && mat.kind.x == KIND_DIELECTRIC) { inside = front; }
        e.sig = (e.sig * 31u + h.object * 8u + u32(reflected) * 2u + u32(front) + 1u) & 0xffffffu;
        dir = new_dir;
        seg_o = h.p;
        o = rt_spawn(h.p, h.ng, dir);
        depth++;
    }
    e.pre = pre;
    e.weight = w;
    return e;
}

// Beams whose edges meet their base at a cosine below this are rebased (make_beam).
const REBASE_COS: f32 = 0.25;

// Solid angle of the spherical triangle of unit directions a, b, c (Van Oosterom & Strackee).
fn solid_angle(a: vec3f, b: vec3f, c: vec3f) -> f32 {
    let num = abs(dot(a, cross(b, c)));
    let den = 1.0 + dot(a, b) + dot(b, c) + dot(c, a);
    return 2.0 * atan2(num, den);
}

// The beam over edges e0..e2 of a triangle of light directions l0..l2. Returns flux.w < 0 when
// the base is degenerate or its edges diverge too far to rebase.
fn make_beam(e0_in: Edge, e1_in: Edge, e2_in: Edge, omega: f32, level: u32) -> BeamGpu {
    var e0 = e0_in;
    var e1 = e1_in;
    var e2 = e2_in;
    var b: BeamGpu;
    b.flux = vec4f(omega * (e0.weight + e1.weight + e2.weight) / 3.0, f32(level));
    var nrm = cross(e1.o - e0.o, e2.o - e0.o);
    var len = length(nrm);
    if (len <= 0.0) { b.flux.w = -1.0; return b; }
    nrm /= len;
    if (dot(nrm, e0.d + e1.d + e2.d) < 0.0) { nrm = -nrm; }
    if (min(min(dot(nrm, e0.d), dot(nrm, e1.d)), dot(nrm, e2.d)) < REBASE_COS) {
        // An oblique base (light reflected or refracted near a silhouette, where Fresnel
        // reflection is strongest): each edge's start moved along it to the plane across the
        // mean direction through the most advanced start, so the beam's sections are not
        // degenerate. The sliver between the surface and that plane is dropped (its light
        // has not travelled yet: a short wedge at the surface).
        let m = normalize(e0.d + e1.d + e2.d);
        let c = max(max(dot(e0.o, m), dot(e1.o, m)), dot(e2.o, m));
        let dm = vec3f(dot(e0.d, m), dot(e1.d, m), dot(e2.d, m));
        if (min(min(dm.x, dm.y), dm.z) < 1e-3) { b.flux.w = -1.0; return b; }
        let t = vec3f(c - dot(e0.o, m), c - dot(e1.o, m), c - dot(e2.o, m)) / dm;
        if (any(t > vec3f(e0.t_end, e1.t_end, e2.t_end))) { b.flux.w = -1.0; return b; }
        let p0 = e0.o + e0.d * t.x;
        let p1 = e1.o + e1.d * t.y;
        let p2 = e2.o + e2.d * t.z;
        e0.pre += beam_depth(e0.o, p0);
        e1.pre += beam_depth(e1.o, p1);
        e2.pre += beam_depth(e2.o, p2);
        e0.o = p0;
        e1.o = p1;
        e2.o = p2;
        e0.t_end -= t.x;
        e1.t_end -= t.y;
        e2.t_end -= t.z;
        nrm = cross(e1.o - e0.o, e2.o - e0.o);
        len = length(nrm);
        if (len <= 0.0) { b.flux.w = -1.0; return b; }
        nrm /= len;
        if (dot(nrm, m) < 0.0) { nrm = -nrm; }
    }
    b.v0 = vec4f(e0.o, e0.pre);
    b.v1 = vec4f(e1.o, e1.pre);
    b.v2 = vec4f(e2.o, e2.pre);
    b.d0 = vec4f(e0.d, e0.t_end);
    b.d1 = vec4f(e1.d, e1.t_end);
    b.d2 = vec4f(e2.d, e2.t_end);
    if (min(min(dot(nrm, e0.d), dot(nrm, e1.d)), dot(nrm, e2.d)) < 1e-3) { b.flux.w = -1.0; return b; }
    // Bounding sphere of the six corners (the beam between its base and its farthest end
    // height lies in their convex hull).
    let y0 = e0.t_end * dot(nrm, e0.d);
    let y1 = e1.t_end * dot(nrm, e1.d);
    let y2 = e2.t_end * dot(nrm, e2.d);
    let ym = max(max(y0, y1), y2);
    let p = array<vec3f, 6>(e0.o, e1.o, e2.o,
        e0.o + e0.d * (ym / dot(nrm, e0.d)), e1.o + e1.d * (ym / dot(nrm, e1.d)), e2.o + e2.d * (ym / dot(nrm, e2.d)));
    var lo = p[0];
    var hi = p[0];
    for (var k = 1; k < 6; k++) { lo = min(lo, p[k]); hi = max(hi, p[k]); }
    let c = 0.5 * (lo + hi);
    var r = 0.0;
    for (var k = 0; k < 6; k++) { r = max(r, length(p[k] - c)); }
    b.bound = vec4f(c, r * 1.0001 + 1e-6);
    // (consistent edges: all three land on the same object)
    b.info = vec4u(e0.land, 0u, 0u, 0u);
    return b;
}

// Signed twice-area of the beam's cross-section at height y over its base plane (normal nrm):
// a quadratic in y (Ernst et al. 2005), returned as its value; its smallest |value| over
// [0, ym] is what the energy criterion's convergence uses.
fn min_area(e0: Edge, e1: Edge, e2: Edge, ym: f32) -> vec2f {
    var nrm = normalize(cross(e1.o - e0.o, e2.o - e0.o));
    if (dot(nrm, e0.d + e1.d + e2.d) < 0.0) { nrm = -nrm; }
    let s0 = e0.d / max(dot(nrm, e0.d), 1e-3);
    let s1 = e1.d / max(dot(nrm, e1.d), 1e-3);
    let s2 = e2.d / max(dot(nrm, e2.d), 1e-3);
    // 2A(y) = nrm . ((a + y b) x (c + y d)), a = v1 - v0, b = s1 - s0, c = v2 - v0, d = s2 - s0.
    let a = e1.o - e0.o;
    let bb = s1 - s0;
    let c = e2.o - e0.o;
    let dd = s2 - s0;
    let k0 = dot(nrm, cross(a, c));
    let k1 = dot(nrm, cross(a, dd) + cross(bb, c));
    let k2 = dot(nrm, cross(bb, dd));
    var m = min(abs(k0), abs(k0 + k1 * ym + k2 * ym * ym));
    if (abs(k2) > 0.0) {
        let yv = -k1 / (2.0 * k2);
        if (yv > 0.0 && yv < ym) { m = min(m, abs(k0 + k1 * yv + k2 * yv * yv)); }
    }
    return vec2f(abs(k0), m);
}

// How far the beam over edges e0..e2 departs from the light it stands for (the linearity
// criterion, ours: the paper's criteria look at the corners only). A beam interpolates its
// edges linearly; the light of the triangle's centroid really runs along `ec` (traced). Both
// are cut by the planes across the edges' mean direction at the beam's start and at its
// farthest end; the larger distance between the centroid's true point and the beam's point
// of barycentrics (1/3, 1/3, 1/3), over the beam's widest section there (the sections'
// corners move linearly, so the width and that distance are largest at one of the two
// planes). A fraction of the beam's size, so it does not depend on the scene's scale: near
// a ball's rim, where refraction bends fast, coarse beams put their light up to a section's
// width off its true place. Returns 2 where the centroid takes another path, 0 where the
// planes cannot be built (edges nearly across the mean direction: left to the other criteria).
fn nonlinearity(e0: Edge, e1: Edge, e2: Edge, ec: Edge) -> f32 {
    if (!same_path(ec, e0)) { return 2.0; }
    let m = normalize(e0.d + e1.d + e2.d);
    let dm = vec4f(dot(e0.d, m), dot(e1.d, m), dot(e2.d, m), dot(ec.d, m));
    if (min(min(dm.x, dm.y), min(dm.z, dm.w)) < 1e-3) { return 0.0; }
    let z0 = max(max(dot(e0.o, m), dot(e1.o, m)), dot(e2.o, m));
    let z1 = max(max(dot(e0.o + e0.d * e0.t_end, m), dot(e1.o + e1.d * e1.t_end, m)), dot(e2.o + e2.d * e2.t_end, m));
    var dev = 0.0;
    var width = 0.0;
    for (var k = 0; k < 2; k++) {
        let z = select(z0, max(z1, z0), k == 1);
        let p0 = e0.o + e0.d * ((z - dot(e0.o, m)) / dm.x);
        let p1 = e1.o + e1.d * ((z - dot(e1.o, m)) / dm.y);
        let p2 = e2.o + e2.d * ((z - dot(e2.o, m)) / dm.z);
        let pc = ec.o + ec.d * ((z - dot(ec.o, m)) / dm.w);
        dev = max(dev, length(pc - (p0 + p1 + p2) / 3.0));
        width = max(width, max(max(length(p1 - p0), length(p2 - p1)), length(p0 - p2)));
    }
    return dev / max(width, 1e-30);
}

fn consistent(e0: Edge, e1: Edge, e2: Edge) -> bool {
    return e0.ok && e1.ok && e2.ok && e0.sig == e1.sig && e1.sig == e2.sig && e0.land == e1.land && e1.land == e2.land;
}

// Whether edge e took the path of `r` (and meets a caster first).
fn same_path(e: Edge, r: Edge) -> bool {
    return e.ok && e.caster && e.sig == r.sig && e.land == r.land;
}

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

// The mean weight over a triangle (light NDC) from its corners' mean `wc` and its centre's
// weight, by the rule exact for quadratics: corners 1/12 each and centroid 3/4, i.e.
// (wc + 3 centre) / 4; over a parallelogram, corners 1/12 each and centre 2/3, i.e.
// (wc + 2 centre) / 3 (`quad`). The Fresnel factors change steeply near a silhouette
// (the corners' mean alone overestimates them there: F is convex toward grazing). The centre's
// edge is traced once more; where it takes another path, the corners' mean.
fn part_weight(f: u32, centre: vec2f, br: u32, layer: u32, r: Edge, wc: vec3f, quad: bool) -> vec3f {
    let e = at_layer(trace_edge(f, centre, br), layer);
    if (!same_path(e, r)) { return wc; }
    return select((wc + 3.0 * e.weight) / 4.0, (wc + 2.0 * e.weight) / 3.0, quad);
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

// A last-level triangle whose edges on branch `br` and layer `layer` disagree (a silhouette, an
// edge landing elsewhere, light that meets a second caster or misses it): one beam per caustic
// path its corners take, each over the part of the triangle on that path, found by bisection
// along its sides, emitted as parts 0, 1, 2 of the triangle's place (`emit`). Two corners that
// agree give the quad between them and the far side's boundary points (the beam is the
// triangle over its two good corners and the middle of its far side, carrying the quad's
// flux), part 0; a corner on a path of its own the triangle between it and its boundary points
// toward the other two. Returns whether a part was emitted (none: no corner on a caustic path).
//
// The six cases (three quads, then three lone corners) share one loop body, so that each
// tracing helper is called from one place: a GPU's shader compiler inlines every call of
// `trace_edge` with the whole BVH traversal in it, and with a call per case the stage held
// some thirty such copies, which NVIDIA's compiler did not finish compiling in a minute
// (docs/benchmarks.md, the first NVIDIA figures; tests/shaders.rs bounds the copies).
fn shrink(tri: BeamTri, es: array<Edge, 3>, br: u32, layer: u32, level: u32, slot: u32) -> bool {
    let ps = array<vec2f, 3>(tri.a, tri.b, tri.c);
    let face = light.faces[tri.face];
    var done = array<bool, 3>(false, false, false);
    var part = 0u;
    var quad_done = false;
    for (var c = 0u; c < 6u; c++) {
        let quad = c < 3u;
        let k = c % 3u;
        let i = (k + 1u) % 3u;
        let j = (k + 2u) % 3u;
        var applies: bool;
        if (quad) {
            // Corners i and j agree, k differs (the first such quad only).
            applies = !quad_done && same_path(es[i], es[i]) && same_path(es[j], es[i]) && !same_path(es[k], es[i]);
        } else {
            // Corner k on a path of its own (no other corner takes it).
            applies = !done[k] && same_path(es[k], es[k]) && !same_path(es[i], es[k]) && !same_path(es[j], es[k]);
        }
        if (!applies) { continue; }
        // The path's corner, and the boundary points: a quad's from i and from j toward k, a
        // lone corner's from k toward i and toward j.
        var r = es[k];
        if (quad) { r = es[i]; }
        var q: array<Boundary, 2>;
        for (var sd = 0u; sd < 2u; sd++) {
            let good = select(ps[k], select(ps[j], ps[i], sd == 0u), quad);
            let bad = select(select(ps[j], ps[i], sd == 0u), ps[k], quad);
            q[sd] = boundary(tri.face, good, bad, br, layer, r);
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
            var em = at_layer(trace_edge(tri.face, mp, br), layer);
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
        var b = make_beam(x0, x1, x2, omega, level);
        var wq = wm;
        if (br == 0u) {
            wq = part_weight(tri.face, centre, br, layer, r, wm, quad);
        } else {
            // The midpoint rule over the part: a lone corner's triangle, or the quad as two
            // triangles, each weighted by its area.
            var m: array<vec4f, 2>;
            for (var t = 0u; t < select(1u, 2u, quad); t++) {
                let p0 = select(ps[k], ps[i], quad);
                let p1 = select(qi.ndc, select(qj.ndc, ps[j], t == 0u), quad);
                let p2 = select(qj.ndc, select(qi.ndc, qj.ndc, t == 0u), quad);
                m[t] = part_mean(tri.face, p0, p1, p2, br, layer, r);
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
        emit(b, slot, br, layer, part);
        part++;
        if (quad) {
            done[i] = true;
            done[j] = true;
            quad_done = true;
        }
    }
    return part > 0u;
}

// Appends beam b of branch `br`, layer `layer` and part `part` (0; a shrunk triangle's other
// paths 1 and 2) in its place of hierarchy slot `slot` (BEAM_KINDS places per slot), branch and
// layer recorded in info.y and info.z. A layer-1 beam ends on a specular surface: it lands on
// nothing (info.x INVALID: beam_surface lights no point with it).
fn emit(b: BeamGpu, slot: u32, br: u32, layer: u32, part: u32) {
    if (b.flux.w < 0.0) { atomicAdd(&stats[1u + BS_GRAZING], 1u); return; }
    let i = atomicAdd(&stats[0], 1u);
    if (i >= bp.capacity) { atomicAdd(&stats[1u + BS_OVERFLOW], 1u); return; }
    var out = b;
    out.info.y = br;
    out.info.z = layer;
    out.info.w = part;
    if (layer > 0u) {
        out.info.x = INVALID;
        atomicAdd(&stats[1u + BS_LAYER1], 1u);
    }
    beams[i] = out;
    slots[BEAM_KINDS * slot + BEAM_PARTS * (BEAM_LAYERS * br + layer) + part] = i + 1u;
    atomicAdd(&stats[1u + BS_KEPT + min(u32(b.flux.w), 7u)], 1u);
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    let i = gid.x + gid.y * 65535u * 64u;
    let level = lv.level;
    var tri: BeamTri;
    if (level == 0u) {
        if (i >= lv.base_count) { return; }
        if (i == 0u) {
            for (var l = 0u; l < 8u; l++) {
                atomicStore(&args[4u * l + 1u], 1u);
                atomicStore(&args[4u * l + 2u], 1u);
            }
        }
        let per_face = 2u * bp.grid * bp.grid;
        let f = i / per_face;
        let r = i % per_face;
        let cell = r / 2u;
        let s = 2.0 / f32(bp.grid);
        let x0 = -1.0 + s * f32(cell % bp.grid);
        let y0 = -1.0 + s * f32(cell / bp.grid);
        tri.face = f;
        tri.id = i;
        tri.a = vec2f(x0, y0);
        if ((r & 1u) == 0u) {
            tri.b = vec2f(x0 + s, y0);
            tri.c = vec2f(x0 + s, y0 + s);
        } else {
            tri.b = vec2f(x0 + s, y0 + s);
            tri.c = vec2f(x0, y0 + s);
        }
    } else {
        if (i >= atomicLoad(&args[4u * level + 3u])) { return; }
        tri = work[lv.offset + i];
    }
    atomicAdd(&stats[1u + BS_VISITED + min(level, 7u)], 1u);
    // (branches 3 and 4, at a second dielectric, where light can meet one: BEAM_FLAG_CHAINS)
    let branches = select(1u, select(3u, BEAM_BRANCHES, (bp.flags & BEAM_FLAG_CHAINS) != 0u), (bp.flags & BEAM_FLAG_REFLECTION) != 0u);
    // The corners' edges on every branch (es[3 br + corner]), traced at one call site (see
    // `shrink`); the reflected branches only where a corner's light meets a caster.
    var es: array<Edge, 15>;
    for (var k = 0u; k < 3u * branches; k++) {
        let p = select(select(tri.c, tri.b, k % 3u == 1u), tri.a, k % 3u == 0u);
        es[k] = trace_edge(tri.face, p, k / 3u);
        if (k == 2u && u32(es[0].caster) + u32(es[1].caster) + u32(es[2].caster) == 0u) { return; }
    }
    let e0 = es[0];
    let e1 = es[1];
    let e2 = es[2];
    let casters = u32(e0.caster) + u32(e1.caster) + u32(e2.caster);
    let face = light.faces[tri.face];
    let omega = solid_angle(light_dir(face, tri.a), light_dir(face, tri.b), light_dir(face, tri.c));
    var split = casters < 3u || !consistent(e0, e1, e2);
    if (!split) {
        // Discontinuities of the specular surface.
        let same_obj = e0.first_obj == e1.first_obj && e1.first_obj == e2.first_obj;
        let ncos = min(min(dot(e0.first_n, e1.first_n), dot(e1.first_n, e2.first_n)), dot(e2.first_n, e0.first_n));
        let tm = (e0.first_t + e1.first_t + e2.first_t) / 3.0;
        let dt = max(max(e0.first_t, e1.first_t), e2.first_t) - min(min(e0.first_t, e1.first_t), e2.first_t);
        split = !same_obj || ncos < bp.normal_cos || dt > bp.depth_rel * tm;
    }
    if (!split) {
        // Energy and convergence.
        let w = (e0.weight + e1.weight + e2.weight) / 3.0;
        let phi = omega * (w.r + w.g + w.b) / 3.0;
        // (the longest edge: at least the end height over the base)
        let ym = max(max(e0.t_end, e1.t_end), e2.t_end);
        let ar = min_area(e0, e1, e2, ym);
        // (capped at 100: a ball lens's beams all but vanish at their focus)
        var conv = ar.x / max(ar.y, 1e-2 * ar.x);
        // Light between two casters (layer 1) converges too (a lens focusing onto the next):
        // the larger convergence of the two layers.
        let l0 = at_layer(e0, 1u);
        let l1 = at_layer(e1, 1u);
        let l2 = at_layer(e2, 1u);
        if (consistent(l0, l1, l2) && length(cross(l1.o - l0.o, l2.o - l0.o)) > 0.0) {
            let a1 = min_area(l0, l1, l2, max(max(l0.t_end, l1.t_end), l2.t_end));
            conv = max(conv, a1.x / max(a1.y, 1e-2 * a1.x));
        }
        let face_omega = solid_angle(light_dir(face, vec2f(-1.0, -1.0)), light_dir(face, vec2f(1.0, -1.0)), light_dir(face, vec2f(1.0, 1.0)))
            + solid_angle(light_dir(face, vec2f(-1.0, -1.0)), light_dir(face, vec2f(1.0, 1.0)), light_dir(face, vec2f(-1.0, 1.0)));
        let peak = max(max(light.power.r, light.power.g), light.power.b);
        split = phi / max(face_omega * peak, 1e-30) * max(conv, 1.0) > bp.energy;
        // Distance to the camera: the closest point of the central ray to the camera.
        let co = (e0.o + e1.o + e2.o) / 3.0;
        let cd = normalize(e0.d + e1.d + e2.d);
        let tc = clamp(dot(bp.camera.xyz - co, cd), 0.0, ym);
        let dist = max(length(co + cd * tc - bp.camera.xyz), 1e-6);
        split = split || sqrt(0.5 * ar.x) / dist > bp.camera_size;
    }
    // The reflected branches (flags bit 0) split where their edges disagree too (their light
    // would be lost otherwise: reflected edges that land on different objects, or leave the
    // scene, near the silhouette).
    for (var br = 1u; br < branches; br++) {
        let r0 = es[3u * br];
        let r1 = es[3u * br + 1u];
        let r2 = es[3u * br + 2u];
        split = split || ((r0.ok || r1.ok || r2.ok) && !consistent(r0, r1, r2));
    }
    if (!split && level < bp.levels && bp.linearity > 0.0) {
        // Linearity: the centroid's edge on every branch and layer a beam would be kept on,
        // its departure weighted by the share of the light toward the triangle the beam
        // carries (its corners' weights over the light's intensity toward them: about 0.9 on
        // the transmitted branch, the Fresnel factor on a reflected one), so a beam is split
        // for the fraction of the triangle's light it misplaces.
        let centre = (tri.a + tri.b + tri.c) / 3.0;
        let inc = intensity_toward(light, light_dir(face, tri.a)) + intensity_toward(light, light_dir(face, tri.b))
            + intensity_toward(light, light_dir(face, tri.c));
        for (var br = 0u; br < branches && !split; br++) {
            let c0 = es[3u * br];
            let c1 = es[3u * br + 1u];
            let c2 = es[3u * br + 2u];
            if (!consistent(c0, c1, c2)) { continue; }
            let ec = trace_edge(tri.face, centre, br);
            for (var layer = 0u; layer < BEAM_LAYERS; layer++) {
                let a0 = at_layer(c0, layer);
                let a1 = at_layer(c1, layer);
                let a2 = at_layer(c2, layer);
                if (consistent(a0, a1, a2)) {
                    let share = dot(a0.weight + a1.weight + a2.weight, vec3f(1.0)) / max(dot(inc, vec3f(1.0)), 1e-30);
                    split = split || nonlinearity(a0, a1, a2, at_layer(ec, layer)) * share > bp.linearity;
                }
            }
        }
    }
    if (split && level < bp.levels) {
        let k = atomicAdd(&args[4u * (level + 1u) + 3u], 4u);
        atomicMax(&args[4u * (level + 1u)], (k + 4u + 63u) / 64u);
        let ab = 0.5 * (tri.a + tri.b);
        let bc = 0.5 * (tri.b + tri.c);
        let ca = 0.5 * (tri.c + tri.a);
        let base = lv.next_offset + k;
        work[base] = BeamTri(tri.a, ab, ca, tri.id * 4u, tri.face);
        work[base + 1u] = BeamTri(ab, tri.b, bc, tri.id * 4u + 1u, tri.face);
        work[base + 2u] = BeamTri(ca, bc, tri.c, tri.id * 4u + 2u, tri.face);
        work[base + 3u] = BeamTri(bc, ca, ab, tri.id * 4u + 3u, tri.face);
        return;
    }
    let slot = lv.offset + tri.id;
    // Branch 1: reflected at the first surface; branch 2: refracted in, reflected once inside,
    // then refracted out (the light a sphere sends back toward the light's side); 3 and 4 the
    // same at a second dielectric (trace_edge). Their Fresnel
    // factors change fast across a triangle near the silhouette (where F is largest): the
    // beam's flux is the quadrature exact for quadratics (corners 1/12 each, centroid 3/4; one
    // more edge traced), not the corners' mean. At the last level, triangles whose edges
    // disagree are split into their corners' paths' parts as the transmitted branch's. Each branch
    // gives a beam on each layer its path has (at_layer: its last segment, and the one between
    // its last two specular objects).
    let centroid = (tri.a + tri.b + tri.c) / 3.0;
    for (var layer = 0u; layer < BEAM_LAYERS; layer++) {
        for (var br = 0u; br < branches; br++) {
            let r0 = at_layer(es[3u * br], layer);
            let r1 = at_layer(es[3u * br + 1u], layer);
            let r2 = at_layer(es[3u * br + 2u], layer);
            if (consistent(r0, r1, r2)) {
                var b = make_beam(r0, r1, r2, omega, level);
                if (br > 0u) {
                    let wc = (r0.weight + r1.weight + r2.weight) / 3.0;
                    b.flux = vec4f(omega * part_weight(tri.face, centroid, br, layer, r0, wc, false), b.flux.w);
                }
                emit(b, slot, br, layer, 0u);
            } else if ((br == 0u && layer == 0u) || r0.ok || r1.ok || r2.ok) {
                // The last level: the parts of the triangle on its corners' paths (shrink), else lost.
                if (!shrink(tri, array<Edge, 3>(r0, r1, r2), br, layer, level, slot)) {
                    atomicAdd(&stats[1u + BS_INCONSISTENT], 1u);
                }
            }
        }
    }
}
