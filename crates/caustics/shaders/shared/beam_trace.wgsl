// Shared WGSL (`#import beam_trace`, after `#import raytrace`, `#import beams`, `#import medium`
// and `#import beam_medium`): the beam edges of the adaptive grid traced exactly from the light
// (`trace_edge`), the beam over three of them (`make_beam`; `thin_beam` along one), the parts of
// a triangle whose corners take different paths (`part_applies`), and a beam's entry in the beam
// buffer and the hierarchy (`emit`), for beam_refine (the grid's triangles, level by level) and
// beam_shrink (the parts of the triangles whose corners take different paths). A stage importing it
// declares `light` (LightGpu), `bp` (BeamParams), `slots`, `beams` and `stats` (shared/beams.wgsl),
// and imports the scene group (shared/scene.wgsl: materials, BVH, density grid).

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
    // The last segment: from the last specular interaction o along unit d, t_end to its end;
    // n the surface's geometric normal at o on d's side.
    o: vec3f,
    d: vec3f,
    n: vec3f,
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
    n1: vec3f,
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
    r.n = e.n1;
    r.t_end = e.t1;
    r.pre = e.pre1;
    r.weight = e.w1;
    return r;
}

// The triangle of the grid whose edges are traced (its slot of the hierarchy: beam_refine and
// beam_shrink set it before tracing): the key of the residual branch's random choices, so that
// all the triangle's edges make the same ones, in every run.
var<private> beam_key: u32 = 0u;

// The branches with fixed reflections traced (0, 1 and 2; 3 and 4 too where light crosses
// the medium from one specular object to another: BEAM_FLAG_CHAINS), the transmitted alone
// without BEAM_FLAG_REFLECTION.
fn fixed_branches() -> u32 {
    let chains = (bp.flags & BEAM_FLAG_CHAINS) != 0u;
    return select(1u, select(3u, 5u, chains), (bp.flags & BEAM_FLAG_REFLECTION) != 0u);
}
// Branches traced: the fixed ones, and the residual branch where it is on (the host sets
// BeamParams.residual to 0 without BEAM_FLAG_REFLECTION).
fn traced_branches() -> u32 {
    return fixed_branches() + u32(bp.residual > 0.0);
}
// The j-th traced branch (j < traced_branches()): the fixed ones in order, then the residual.
fn traced_branch(j: u32) -> u32 {
    return select(j, BEAM_RESIDUAL, j >= fixed_branches());
}

// A uniform number in [0, 1) from the triangle's key and the interaction's depth (common.wgsl
// `hash_uniform`, as the photon tracer's residual pass: shared/trace.wgsl).
fn beam_random(key: u32, depth: u32) -> f32 {
    return hash_uniform(key, depth);
}

// Whether the residual branch's light, having reflected partially `count` times (bit k of
// `chosen`: at interaction k), is its own: no fixed branch follows that path (the transmitted
// branch none, branch k + 1 the one at interaction k).
fn residual_owns(chosen: u32, count: u32) -> bool {
    return count >= 2u || (count == 1u && (chosen == 0u || firstTrailingBit(chosen) + 1u >= fixed_branches()));
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
// The residual branch (BEAM_RESIDUAL, where BeamParams.residual > 0) draws its choice at
// each dielectric interface that does not reflect totally (`beam_random` of the triangle's
// `beam_key` and the depth, so the triangle's edges all choose alike): reflect with probability
// p = max(F, BeamParams.residual) and weight F / p, else transmit with weight (1 - F) / (1 - p),
// the expected weight of every path its Fresnel factors' product. (p = F would make every weight
// 1; the floor keeps the rare reflections at normal incidence from being too rare. A fixed p
// gave weights up to (F / p)² near a silhouette, where F runs to 1.) Its path is whole only where no fixed branch follows it
// (`residual_owns`): the light of two or more partial reflections, or of one at an interaction
// no reflected branch reflects at, on a mesh whose light crosses it several times.
fn trace_edge(f: u32, ndc: vec2f, br: u32) -> Edge {
    let residual = br == BEAM_RESIDUAL;
    let branch = select(0u, 1u << (br - 1u), br > 0u && !residual);
    // (the residual branch: where it reflected partially, bit k at interaction k, and how often)
    var chosen = 0u;
    var count = 0u;
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
    var seg_n = dir;
    loop {
        let h = scene_hit(o, dir, 1e30);
        if (h.object == INVALID) {
            if (depth == 0u) { return e; }
            // Leaves the scene: the beam runs to the far side of the medium's box. Where no
            // medium lies along it (none in the scene, or the box behind), its light meets
            // nothing: not a caustic path (no beam to draw; before, such beams were made with
            // no length and dropped as grazing).
            let c = box_clip(seg_o, dir, 1e30, bp.lo.xyz, bp.hi.xyz);
            if (c.y <= max(c.x, 0.0)) { return e; }
            e.ok = !inside && (depth >= 32u || (branch >> depth) == 0u) && (!residual || residual_owns(chosen, count));
            e.land = INVALID;
            e.o = seg_o;
            e.d = dir;
            e.n = seg_n;
            e.t_end = c.y;
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
            // A receiver inside a dielectric (a pool's floor under water) takes the beam's light
            // where the scene has no medium; with one, such beams are dropped (their segment lies
            // inside the dielectric, where the medium's gather would wrongly scatter it).
            let landing_ok = !inside || max(max(bp.sigma_t.x, bp.sigma_t.y), bp.sigma_t.z) <= 0.0;
            e.ok = landing_ok && (depth >= 32u || (branch >> depth) == 0u) && (!residual || residual_owns(chosen, count));
            e.land = h.object;
            e.o = seg_o;
            e.d = dir;
            e.n = seg_n;
            e.t_end = length(h.p - seg_o);
            break;
        }
        if (depth >= bp.max_depth) { return e; }
        if (depth > 0u && !inside) {
            // A segment after a specular interaction, outside dielectrics, ends on another
            // specular surface: the latest such is layer 1. Only where the branch reflected
            // before it (or is branch 0): otherwise the segment's light is the transmitted
            // branch's, whose layer 1 it is (for the residual branch: until its choices so far
            // are its own).
            e.has1 = select(br == 0u || br - 1u < depth, residual_owns(chosen, count), residual);
            e.o1 = seg_o;
            e.d1 = dir;
            e.n1 = seg_n;
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
            if (residual && fr < 1.0) {
                let p = max(fr, bp.residual);
                reflect_it = beam_random(beam_key, depth) < p;
                if (reflect_it) {
                    chosen |= select(0u, 1u << depth, depth < 32u);
                    count++;
                }
                w *= select((1.0 - fr) / (1.0 - p), fr / p, reflect_it);
            } else {
                w *= select(1.0 - fr, select(fr, 1.0, fr >= 1.0), reflect_it);
            }
        }
        let bz = rt_bounce(dir, n, ng, eta, reflect_it);
        let reflected = bz.reflected;
        let new_dir = bz.dir;
        if (!reflected && mat.kind.x == KIND_DIELECTRIC) { inside = front; }
        e.sig = (e.sig * 31u + h.object * 8u + u32(reflected) * 2u + u32(front) + 1u) & 0xffffffu;
        dir = new_dir;
        seg_o = h.p;
        seg_n = select(-h.ng, h.ng, dot(new_dir, h.ng) > 0.0);
        o = rt_spawn(h.p, h.ng, dir);
        depth++;
    }
    e.pre = pre;
    e.weight = w;
    return e;
}

// Beams whose edges meet their base at a cosine below this are rebased (make_beam), back
// behind the surface (with clip heights) where every edge meets it at a cosine above
// CLIP_MIN_COS.
const REBASE_COS: f32 = 0.95;
const CLIP_MIN_COS: f32 = 0.05;

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
    var clip = vec3f(0.0);
    let cos_base = vec3f(dot(nrm, e0.d), dot(nrm, e1.d), dot(nrm, e2.d));
    if (min(min(cos_base.x, cos_base.y), cos_base.z) < REBASE_COS) {
        // A base oblique to the edges (light leaving a curved surface at an angle, near a
        // silhouette above all): the beam's sections parallel to it would spread its flux
        // unevenly over its directions (uniform per area of a plane the edges cross obliquely,
        // the far side of a section gets less light per solid angle than the near side: on a
        // floor lit at a grazing angle, bands across every beam's footprint). Its edges are
        // rebased to the plane across their mean direction. Where every edge leaves the
        // surface's plane forward, the plane goes through the least advanced start: the edges
        // are extended back behind the surface (inside the object the light leaves, where no
        // medium is), and the beam keeps the clip heights of the surface points (`clip`:
        // beams.wgsl's `beam_clip`: only the points beyond their plane are lit), so no light
        // of the wedge between the surface and the plane is lost. Otherwise the plane goes
        // through the most advanced start and that wedge is dropped (its light has not
        // travelled yet).
        let m = normalize(e0.d + e1.d + e2.d);
        let dm = vec3f(dot(e0.d, m), dot(e1.d, m), dot(e2.d, m));
        if (min(min(dm.x, dm.y), dm.z) < 1e-3) { b.flux.w = -1.0; return b; }
        let om = vec3f(dot(e0.o, m), dot(e1.o, m), dot(e2.o, m));
        let back = min(min(cos_base.x, cos_base.y), cos_base.z) > CLIP_MIN_COS;
        let c = select(max(max(om.x, om.y), om.z), min(min(om.x, om.y), om.z), back);
        let t = (vec3f(c) - om) / dm;
        if (any(t > vec3f(e0.t_end, e1.t_end, e2.t_end))) { b.flux.w = -1.0; return b; }
        let o0 = e0.o;
        let o1 = e1.o;
        let o2 = e2.o;
        let p0 = e0.o + e0.d * t.x;
        let p1 = e1.o + e1.d * t.y;
        let p2 = e2.o + e2.d * t.z;
        // (the in-medium length of the light's path up to the new start: longer forward,
        // shorter back, by the same measure beam_scatter uses from the base)
        e0.pre += select(beam_depth(e0.o, p0), -beam_depth(p0, e0.o), back);
        e1.pre += select(beam_depth(e1.o, p1), -beam_depth(p1, e1.o), back);
        e2.pre += select(beam_depth(e2.o, p2), -beam_depth(p2, e2.o), back);
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
        if (back) {
            clip = max(vec3f(dot(o0 - p0, nrm), dot(o1 - p0, nrm), dot(o2 - p0, nrm)), vec3f(0.0));
        }
    }
    // The edge whose surface point is the base's first (clip height 0: the record keeps the
    // other two).
    if (clip.y < clip.x && clip.y <= clip.z) {
        let e = e0;
        e0 = e1;
        e1 = e2;
        e2 = e;
        clip = clip.yzx;
    } else if (clip.z < clip.x && clip.z < clip.y) {
        let e = e2;
        e2 = e1;
        e1 = e0;
        e0 = e;
        clip = clip.zxy;
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
    b.bound = beam_bound(array<vec3f, 3>(e0.o, e1.o, e2.o), array<vec3f, 3>(e0.d, e1.d, e2.d), nrm, ym);
    // (consistent edges: all three land on the same object)
    b.info = vec4u(e0.land, 0u, bitcast<u32>(clip.y), bitcast<u32>(clip.z));
    return b;
}

// A bounding sphere (centre, radius) of the beam with base vertices v, unit edges d and base
// normal nrm up to height ym: the six corners' (the beam between its base and that height lies
// in their convex hull).
fn beam_bound(v: array<vec3f, 3>, d: array<vec3f, 3>, nrm: vec3f, ym: f32) -> vec4f {
    var p: array<vec3f, 6>;
    for (var k = 0u; k < 3u; k++) {
        p[k] = v[k];
        p[k + 3u] = v[k] + d[k] * (ym / dot(nrm, d[k]));
    }
    var lo = p[0];
    var hi = p[0];
    for (var k = 1; k < 6; k++) { lo = min(lo, p[k]); hi = max(hi, p[k]); }
    let c = 0.5 * (lo + hi);
    var r = 0.0;
    for (var k = 0; k < 6; k++) { r = max(r, length(p[k] - c)); }
    return vec4f(c, r * 1.0001 + 1e-6);
}

// The energy cutoff (BeamSettings::cutoff; the paper's section 4.3: a divergent beam is extruded
// only as far as its contribution is not negligible). A camera ray collects at most
// σs p flux ∫ dl / A along a beam (p the phase function's largest value; transmittance left
// out, which only lowers it); dl = dy / cos, cos at least the edges' least cosine with the
// base's normal; and beyond the section's last focus yf (its larger root; the vertex of the
// quadratic where it has none) twice the area is at least |q.z| (y - yf)², so the light of the
// part beyond height yc is at most σs p flux · 2 / (cos |q.z| (yc - yf)). The beam is cut at
// the height yc where that is the cutoff radiance (bp.cut = σs p / the cutoff: yc = yf +
// 2 flux bp.cut / (cos |q.z|)), when all three edges end beyond it (then the new end is the
// section at yc and only light beyond it goes); where yc is at or below its base the whole
// beam is below the cutoff: the returned beam has flux.w = -2 (dropped).
// Sections that grow at most linearly (a prism, the thin beams) are never cut: their light does
// not fall off along them. The bound is per beam: a pixel that sees the tails of many beams
// loses up to the cutoff for each (docs/benchmarks.md, "Beams: the energy cutoff").
fn cut_tail(b_in: BeamGpu) -> BeamGpu {
    var b = b_in;
    // (make_beam keeps no beam with a degenerate base or an edge within 1e-3 of it)
    let bs = beam_space(b);
    let cs = vec3f(dot(bs.nrm, bs.dir[0]), dot(bs.nrm, bs.dir[1]), dot(bs.nrm, bs.dir[2]));
    let cmin = min(min(cs.x, cs.y), cs.z);
    let q = bs.kq;
    let kz = abs(q.z);
    if (kz <= 0.0) { return b; }
    let yv = -q.y / (2.0 * q.z);
    let yf = yv + sqrt(max(q.y * q.y - 4.0 * q.z * q.x, 0.0)) / (2.0 * kz);
    let flux = max(max(b.flux.x, b.flux.y), b.flux.z);
    let yc = yf + 2.0 * flux * bp.cut / (cmin * kz);
    if (yc >= min(min(bs.yend.x, bs.yend.y), bs.yend.z)) { return b; }
    if (yc <= 0.0) {
        b.flux.w = -2.0;
        return b;
    }
    b.d0.w = yc / cs.x;
    b.d1.w = yc / cs.y;
    b.d2.w = yc / cs.z;
    b.bound = beam_bound(bs.v, bs.dir, bs.nrm, yc);
    return b;
}

// A thin beam along edge e, for the light of a part whose own beam is degenerate (beam_shrink:
// bisection found no neighbour on its path, or its base is too oblique to rebase) and for a
// triangle's orphans (beam_shrink's `orphan_beam`): three edges
// from points `radius` from e's start on the surface's tangent plane there (outside a convex
// surface), parallel to e (a prism whose end section lights the surface e lands on:
// beam_surface), or with `converge` meeting at e's end (a layer-1 beam ends exactly on the next
// specular surface).
fn thin_beam(e: Edge, radius: f32, omega: f32, level: u32, converge: bool) -> BeamGpu {
    let a = select(vec3f(1.0, 0.0, 0.0), vec3f(0.0, 1.0, 0.0), abs(e.n.x) > 0.9);
    let u = normalize(a - e.n * dot(e.n, a));
    let v = cross(e.n, u);
    let end = e.o + e.d * e.t_end;
    let offs = array<vec3f, 3>(u, -0.5 * u + 0.8660254 * v, -0.5 * u - 0.8660254 * v);
    var es = array<Edge, 3>(e, e, e);
    for (var k = 0u; k < 3u; k++) {
        es[k].o = e.o + radius * offs[k];
        if (converge) {
            es[k].t_end = length(end - es[k].o);
            es[k].d = (end - es[k].o) / max(es[k].t_end, 1e-30);
        }
    }
    return make_beam(es[0], es[1], es[2], omega, level);
}

fn consistent(e0: Edge, e1: Edge, e2: Edge) -> bool {
    return e0.ok && e1.ok && e2.ok && e0.sig == e1.sig && e1.sig == e2.sig && e0.land == e1.land && e1.land == e2.land;
}

// Whether the three edges' paths differ (objects, reflected or refracted, side, where they
// land, whether they end on a caustic path of the branch): then a triangle none of whose
// corners is on a caustic path may still hold such light inside (beam_refine's orphans-only
// parts).
fn paths_differ(e0: Edge, e1: Edge, e2: Edge) -> bool {
    let same = e0.caster == e1.caster && e1.caster == e2.caster && e0.ok == e1.ok && e1.ok == e2.ok
        && e0.sig == e1.sig && e1.sig == e2.sig && e0.land == e1.land && e1.land == e2.land;
    return !same;
}

// Whether edge e took the path of `r` (and meets a caster first).
fn same_path(e: Edge, r: Edge) -> bool {
    return e.ok && e.caster && e.sig == r.sig && e.land == r.land;
}

// Whether case c of a triangle whose corners' edges es take different paths gives a part
// (beam_refine queues one for each, beam_shrink's `shrink_part` makes its beam): c = 0, 1, 2
// the quad over the two corners other than c that take one path (corner c another), c = 3, 4,
// 5 corner c - 3 on a path no other corner takes.
// At most one quad applies, and a lone corner is in no quad, so the cases are independent.
fn part_applies(es: array<Edge, 3>, c: u32) -> bool {
    let k = c % 3u;
    let i = (k + 1u) % 3u;
    let j = (k + 2u) % 3u;
    if (c < 3u) {
        return same_path(es[i], es[i]) && same_path(es[j], es[i]) && !same_path(es[k], es[i]);
    }
    return same_path(es[k], es[k]) && !same_path(es[i], es[k]) && !same_path(es[j], es[k]);
}

// Appends beam b of branch `br`, layer `layer` and part `part` (0; a shrunk triangle's other
// paths 1 and 2) in its place of hierarchy slot `slot` (BEAM_KINDS places per slot), branch and
// layer recorded in info.y and info.z. A layer-1 beam ends on a specular surface: it lands on
// nothing (info.x INVALID: beam_surface lights no point with it).
fn emit(b: BeamGpu, slot: u32, br: u32, layer: u32, part: u32) {
    if (b.flux.w < 0.0) { atomicAdd(&stats[1u + BS_GRAZING], 1u); return; }
    // (a part or orphans' beam whose samples' corrections left it no light: 3.7 % of the glass
    // dragon's beams, hull fill for nothing)
    if (all(b.flux.xyz <= vec3f(0.0))) { atomicAdd(&stats[1u + BS_DARK], 1u); return; }
    var out = b;
    // The energy cutoff (`cut_tail`), but for beams whose ends light the surface they land on.
    if (bp.cut > 0.0 && (layer > 0u || b.info.x == INVALID || (bp.flags & BEAM_FLAG_SURFACE) == 0u)) {
        out = cut_tail(b);
        if (out.d0.w != b.d0.w || out.flux.w < 0.0) { atomicAdd(&stats[1u + BS_CUT], 1u); }
        if (out.flux.w < 0.0) { return; }
    }
    let i = atomicAdd(&stats[0], 1u);
    if (i >= bp.capacity) { atomicAdd(&stats[1u + BS_OVERFLOW], 1u); return; }
    out.info.y = br | (layer << 4u) | (part << 8u);
    if (layer > 0u) {
        out.info.x = INVALID;
        atomicAdd(&stats[1u + BS_LAYER1], 1u);
    }
    beams[i] = out;
    if (br == BEAM_RESIDUAL) { atomicAdd(&stats[1u + BS_RESIDUAL], 1u); }
    slots[BEAM_KINDS * slot + BEAM_PARTS * (BEAM_LAYERS * br + layer) + part] = i + 1u;
    atomicAdd(&stats[1u + BS_KEPT + min(u32(b.flux.w), 7u)], 1u);
}
