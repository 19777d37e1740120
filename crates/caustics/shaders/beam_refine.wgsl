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
//     threshold; or the beam's width over its distance from the camera exceeds the camera
//     threshold;
//   - kept: one beam per traced branch whose three edges took the same path (the transmitted
//     branch; with flags bit 0 also the branch reflected at the first dielectric surface and
//     the branch reflected once inside it),
//     appended to the beam buffer (overflow counted, never written out of bounds) and entered
//     in its slot of the hierarchy (beam_order lists the slots in order, so the image does not
//     depend on the order of the atomics). At the last level, a triangle whose transmitted
//     edges still disagree (a silhouette) is shrunk to the part on its majority's path
//     (`shrink`: bisection along its sides) and kept as one beam carrying that part's flux,
//     on every branch; those with no majority are counted (their light is lost). The reflected
//     branches' flux is a quadrature over the triangle exact for quadratics (`part_weight`).

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
// Per slot and branch (BEAM_BRANCHES per slot): beam index + 1 (0: none).
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
}

fn light_dir(face: Face, ndc: vec2f) -> vec3f {
    let a4 = face.clip_to_world * vec4f(ndc, 0.0, 1.0);
    let b4 = face.clip_to_world * vec4f(ndc, 1.0, 1.0);
    return normalize(b4.xyz / b4.w - a4.xyz / a4.w);
}

// The edge ray of light-NDC point ndc of face f, on branch `branch`: a mask, bit k set: reflected
// at the k-th interface (0: transmitted at every dielectric interface, total internal reflection
// reflecting; 1: reflected at the first surface, then transmitted; 2: reflected at the second,
// inside the first dielectric), as the photon tracer's branch masks.
fn trace_edge(f: u32, ndc: vec2f, branch: u32) -> Edge {
    var e: Edge;
    e.caster = false;
    e.ok = false;
    e.first_obj = INVALID;
    e.land = INVALID;
    e.sig = 0u;
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
            e.ok = !inside;
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
            if ((branch & 1u) == 1u && mat.kind.x != KIND_DIELECTRIC) { return e; }
        }
        if (mat.kind.x == KIND_DIFFUSE) {
            e.ok = !inside;
            e.land = h.object;
            e.o = seg_o;
            e.d = dir;
            e.t_end = length(h.p - seg_o);
            break;
        }
        if (depth >= bp.max_depth) { return e; }
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
            reflect_it = (depth < 32u && ((branch >> depth) & 1u) == 1u) || fr >= 1.0;
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

const SHRINK_STEPS: u32 = 6u;

fn boundary(f: u32, good: vec2f, bad: vec2f, br: u32, r: Edge) -> Boundary {
    var out = Boundary(good, r);
    var lo = 0.0;
    var hi = 1.0;
    for (var k = 0u; k < SHRINK_STEPS; k++) {
        let mid = 0.5 * (lo + hi);
        let p = mix(good, bad, mid);
        let e = trace_edge(f, p, br);
        if (same_path(e, r)) {
            lo = mid;
            out = Boundary(p, e);
        } else {
            hi = mid;
        }
    }
    return out;
}

// The mean weight over a part of a triangle (light NDC) from its corners' mean `wc` and its
// centre's weight, by the rule exact for quadratics: over a triangle, corners 1/12 each and
// centroid 3/4, i.e. (wc + 3 centre) / 4; over a parallelogram, corners 1/12 each and centre
// 2/3, i.e. (wc + 2 centre) / 3 (`quad`). The Fresnel factors change steeply near a silhouette
// (the corners' mean alone overestimates them there: F is convex toward grazing). The centre's
// edge is traced once more; where it takes another path, the corners' mean.
fn part_weight(f: u32, centre: vec2f, br: u32, r: Edge, wc: vec3f, quad: bool) -> vec3f {
    let e = trace_edge(f, centre, br);
    if (!same_path(e, r)) { return wc; }
    return select((wc + 3.0 * e.weight) / 4.0, (wc + 2.0 * e.weight) / 3.0, quad);
}

// A last-level triangle whose edges on branch `br` disagree (a silhouette, an edge landing
// elsewhere): one beam over the part of it whose edges take the path of its majority (two
// edges that agree, or the one edge that meets a caster), found by bisection along its sides;
// its flux is that part's (a quad: the beam is the triangle over its two good corners and the
// middle of its far side, carrying the quad's flux). flux.w < 0: none (no majority).
fn shrink(tri: BeamTri, es: array<Edge, 3>, br: u32, level: u32) -> BeamGpu {
    var none: BeamGpu;
    none.flux.w = -1.0;
    let ps = array<vec2f, 3>(tri.a, tri.b, tri.c);
    let face = light.faces[tri.face];
    for (var k = 0u; k < 3u; k++) {
        let i = (k + 1u) % 3u;
        let j = (k + 2u) % 3u;
        // Corners i and j agree, k differs.
        if (same_path(es[i], es[i]) && same_path(es[j], es[i]) && !same_path(es[k], es[i])) {
            let qi = boundary(tri.face, ps[i], ps[k], br, es[i]);
            let qj = boundary(tri.face, ps[j], ps[k], br, es[i]);
            let mp = 0.5 * (qi.ndc + qj.ndc);
            var em = trace_edge(tri.face, mp, br);
            if (!same_path(em, es[i])) { em = qi.e; }
            let li = light_dir(face, ps[i]);
            let lj = light_dir(face, ps[j]);
            let lqi = light_dir(face, qi.ndc);
            let lqj = light_dir(face, qj.ndc);
            let omega = solid_angle(li, lj, lqj) + solid_angle(li, lqj, lqi);
            var b = make_beam(es[i], es[j], em, omega, level);
            let w4 = (es[i].weight + es[j].weight + qi.e.weight + qj.e.weight) / 4.0;
            b.flux = vec4f(omega * part_weight(tri.face, 0.25 * (ps[i] + ps[j] + qi.ndc + qj.ndc), br, es[i], w4, true), b.flux.w);
            return b;
        }
    }
    for (var k = 0u; k < 3u; k++) {
        let i = (k + 1u) % 3u;
        let j = (k + 2u) % 3u;
        // Only corner k meets a caster on a path of its own.
        if (same_path(es[k], es[k]) && !same_path(es[i], es[k]) && !same_path(es[j], es[k])) {
            let qi = boundary(tri.face, ps[k], ps[i], br, es[k]);
            let qj = boundary(tri.face, ps[k], ps[j], br, es[k]);
            let omega = solid_angle(light_dir(face, ps[k]), light_dir(face, qi.ndc), light_dir(face, qj.ndc));
            var b = make_beam(es[k], qi.e, qj.e, omega, level);
            let w3 = (es[k].weight + qi.e.weight + qj.e.weight) / 3.0;
            b.flux = vec4f(omega * part_weight(tri.face, (ps[k] + qi.ndc + qj.ndc) / 3.0, br, es[k], w3, false), b.flux.w);
            return b;
        }
    }
    return none;
}

// Appends beam b in `slot` (BEAM_BRANCHES per hierarchy slot: its branch is slot's remainder,
// recorded in info.y).
fn emit(b: BeamGpu, slot: u32) {
    if (b.flux.w < 0.0) { atomicAdd(&stats[1u + BS_GRAZING], 1u); return; }
    let i = atomicAdd(&stats[0], 1u);
    if (i >= bp.capacity) { atomicAdd(&stats[1u + BS_OVERFLOW], 1u); return; }
    var out = b;
    out.info.y = slot % BEAM_BRANCHES;
    beams[i] = out;
    slots[slot] = i + 1u;
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
    let e0 = trace_edge(tri.face, tri.a, 0u);
    let e1 = trace_edge(tri.face, tri.b, 0u);
    let e2 = trace_edge(tri.face, tri.c, 0u);
    let casters = u32(e0.caster) + u32(e1.caster) + u32(e2.caster);
    if (casters == 0u) { return; }
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
        let conv = ar.x / max(ar.y, 1e-2 * ar.x);
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
    var rb: array<Edge, 6>;
    let branches = select(1u, BEAM_BRANCHES, (bp.flags & BEAM_FLAG_REFLECTION) != 0u);
    for (var br = 1u; br < branches; br++) {
        rb[3u * (br - 1u)] = trace_edge(tri.face, tri.a, br);
        rb[3u * (br - 1u) + 1u] = trace_edge(tri.face, tri.b, br);
        rb[3u * (br - 1u) + 2u] = trace_edge(tri.face, tri.c, br);
        let r0 = rb[3u * (br - 1u)];
        let r1 = rb[3u * (br - 1u) + 1u];
        let r2 = rb[3u * (br - 1u) + 2u];
        split = split || ((r0.ok || r1.ok || r2.ok) && !consistent(r0, r1, r2));
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
    if (consistent(e0, e1, e2)) {
        emit(make_beam(e0, e1, e2, omega, level), BEAM_BRANCHES * slot);
    } else {
        // The last level: the part of the triangle on its majority's path (shrink), else lost.
        let sb = shrink(tri, array<Edge, 3>(e0, e1, e2), 0u, level);
        if (sb.flux.w >= 0.0) {
            emit(sb, BEAM_BRANCHES * slot);
        } else {
            atomicAdd(&stats[1u + BS_INCONSISTENT], 1u);
        }
    }
    // Branch 1: reflected at the first surface; branch 2: refracted in, reflected once inside,
    // then refracted out (the light a sphere sends back toward the light's side). Their Fresnel
    // factors change fast across a triangle near the silhouette (where F is largest): the
    // beam's flux is the quadrature exact for quadratics (corners 1/12 each, centroid 3/4; one
    // more edge traced), not the corners' mean. At the last level, triangles whose edges
    // disagree are shrunk to their majority's part as the transmitted branch's.
    let centroid = (tri.a + tri.b + tri.c) / 3.0;
    for (var br = 1u; br < branches; br++) {
        let r0 = rb[3u * (br - 1u)];
        let r1 = rb[3u * (br - 1u) + 1u];
        let r2 = rb[3u * (br - 1u) + 2u];
        if (consistent(r0, r1, r2)) {
            var b = make_beam(r0, r1, r2, omega, level);
            let wc = (r0.weight + r1.weight + r2.weight) / 3.0;
            b.flux = vec4f(omega * part_weight(tri.face, centroid, br, r0, wc, false), b.flux.w);
            emit(b, BEAM_BRANCHES * slot + br);
        } else if (r0.ok || r1.ok || r2.ok) {
            let sb = shrink(tri, array<Edge, 3>(r0, r1, r2), br, level);
            if (sb.flux.w >= 0.0) {
                emit(sb, BEAM_BRANCHES * slot + br);
            } else {
                atomicAdd(&stats[1u + BS_INCONSISTENT], 1u);
            }
        }
    }
}
