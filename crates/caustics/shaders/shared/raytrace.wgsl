// Shared WGSL: exact ray tracing of the whole scene (src/accel.rs builds what it reads).
// Analytic shapes (spheres, open cylinders, rectangles: `materials[i].s0..s3`) are intersected
// in closed form; mesh objects through a two-level BVH: a list of instances (per mesh object
// the maps world -> BVH space and back, world bounds) over bottom-level BVH2s (32-byte nodes,
// children adjacent, near child first, a short stack), triangles by the watertight test of Woop,
// Benthin and Wald (2013), the CPU reference's model. Rays are (o, d) with unit d; a bottom
// level is traversed with d mapped by the instance's linear part, unnormalised, so distances
// stay world distances (instances are similarity transforms).
// It reads the scene group's materials and BVH (shared/scene.wgsl, imported by the stage).

const BVH_STACK: u32 = 32u;
// Stack entries used per bottom level (at most BVH_STACK); tests lower it to check that an
// overflow is detected. A ray that would overflow counts itself in rt_overflow and drops the
// subtree it could not push (the hit may be missed: never silently, the caller reports it).
override bvh_stack_limit: u32 = 32u;
var<private> rt_overflow: u32 = 0u;

struct SceneHit {
    t: f32,
    p: vec3f,
    // Geometric normal (outward for analytic shapes; the triangle's winding for meshes).
    ng: vec3f,
    // Shading normal on the same side as ng (interpolated vertex normals for meshes).
    ns: vec3f,
    object: u32,
    // Global triangle index (into bvh_tris) for mesh hits, INVALID otherwise.
    tri: u32,
    // The instance of a mesh hit (INVALID otherwise) and the hit's barycentrics (b1, b2).
    inst: u32,
    bary: vec2f,
}

fn rt_none() -> SceneHit {
    var h: SceneHit;
    h.t = 1e30;
    h.object = INVALID;
    h.tri = INVALID;
    h.inst = INVALID;
    return h;
}

// Entry distance of the ray into the box, or 1e30 when it misses it before tmax. The far
// distance is enlarged by 2 gamma(3) (pbrt-v4) so that rounding never culls a box the ray
// touches.
fn rt_box(lo: vec3f, hi: vec3f, o: vec3f, inv_d: vec3f, tmax: f32) -> f32 {
    let t0 = (lo - o) * inv_d;
    let t1 = (hi - o) * inv_d;
    let tn = max(max(min(t0.x, t1.x), min(t0.y, t1.y)), max(min(t0.z, t1.z), 0.0));
    let tf = min(min(max(t0.x, t1.x), max(t0.y, t1.y)), min(max(t0.z, t1.z), tmax)) * 1.0000004;
    return select(1e30, tn, tn <= tf);
}

fn rt_inv(d: vec3f) -> vec3f {
    let tiny = abs(d) < vec3f(1e-30);
    return select(1.0 / d, select(vec3f(1e30), vec3f(-1e30), d < vec3f(0.0)), tiny);
}

// The watertight ray's permutation and shear (kz: the dominant axis of d).
struct WtRay {
    o: vec3f,
    k: vec3u,
    s: vec3f,
}

fn rt_pick(v: vec3f, i: u32) -> f32 {
    return select(select(v.z, v.y, i == 1u), v.x, i == 0u);
}

fn wt_ray(o: vec3f, d: vec3f) -> WtRay {
    let a = abs(d);
    var kz = 2u;
    if (a.x > a.y) { if (a.x > a.z) { kz = 0u; } } else if (a.y > a.z) { kz = 1u; }
    var kx = (kz + 1u) % 3u;
    var ky = (kx + 1u) % 3u;
    if (rt_pick(d, kz) < 0.0) { let t = kx; kx = ky; ky = t; }
    let dz = rt_pick(d, kz);
    var r: WtRay;
    r.o = o;
    r.k = vec3u(kx, ky, kz);
    r.s = vec3f(rt_pick(d, kx) / dz, rt_pick(d, ky) / dz, 1.0 / dz);
    return r;
}

// (t, b1, b2) of a hit with 0 < t < tmax, or t = -1. An edge or vertex exactly on the ray
// (u, v or w exactly 0) counts for both triangles sharing it (the CPU reference settles it in
// double precision; WGSL has none): never a gap, at worst the same distance twice.
fn wt_hit(r: WtRay, p0: vec3f, p1: vec3f, p2: vec3f, tmax: f32) -> vec3f {
    let a = p0 - r.o;
    let b = p1 - r.o;
    let c = p2 - r.o;
    let az0 = rt_pick(a, r.k.z);
    let bz0 = rt_pick(b, r.k.z);
    let cz0 = rt_pick(c, r.k.z);
    let ax = rt_pick(a, r.k.x) - r.s.x * az0;
    let ay = rt_pick(a, r.k.y) - r.s.y * az0;
    let bx = rt_pick(b, r.k.x) - r.s.x * bz0;
    let by = rt_pick(b, r.k.y) - r.s.y * bz0;
    let cx = rt_pick(c, r.k.x) - r.s.x * cz0;
    let cy = rt_pick(c, r.k.y) - r.s.y * cz0;
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    let none = vec3f(-1.0, 0.0, 0.0);
    if ((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0)) { return none; }
    let det = u + v + w;
    if (det == 0.0) { return none; }
    let t = u * r.s.z * az0 + v * r.s.z * bz0 + w * r.s.z * cz0;
    if (det > 0.0) {
        if (t <= 0.0 || t >= tmax * det) { return none; }
    } else if (t >= 0.0 || t <= tmax * det) { return none; }
    let inv = 1.0 / det;
    return vec3f(t * inv, v * inv, w * inv);
}

fn rt_apply(m: array<vec4f, 3>, p: vec3f, w: f32) -> vec3f {
    let q = vec4f(p, w);
    return vec3f(dot(m[0], q), dot(m[1], q), dot(m[2], q));
}

// Closest hit (any hit with `any`) of the ray with bottom level `ii` before best.t; updates
// best. Returns whether it hit.
fn rt_instance(ii: u32, o_w: vec3f, d_w: vec3f, best: ptr<function, SceneHit>, any: bool) -> bool {
    let inst = bvh_instances[ii];
    let o = rt_apply(inst.to_object, o_w, 1.0);
    let d = rt_apply(inst.to_object, d_w, 0.0);
    let inv_d = rt_inv(d);
    let r = wt_ray(o, d);
    var tmax = (*best).t;
    var found = INVALID;
    var bary = vec2f(0.0);
    var stack: array<u32, BVH_STACK>;
    var stack_t: array<f32, BVH_STACK>;
    var sp = 0u;
    let limit = min(bvh_stack_limit, BVH_STACK);
    var node = inst.root;
    let root = bvh_nodes[node];
    if (rt_box(root.lo, root.hi, o, inv_d, tmax) >= 1e29) { return false; }
    loop {
        let n = bvh_nodes[node];
        var next = INVALID;
        if (n.count > 0u) {
            for (var i = n.a; i < n.a + n.count; i++) {
                let tri = bvh_tris[i];
                let h = wt_hit(r, tri.p0.xyz, tri.p1.xyz, tri.p2.xyz, tmax);
                if (h.x > 0.0) {
                    tmax = h.x;
                    found = i;
                    bary = h.yz;
                }
            }
            if (any && found != INVALID) { break; }
        } else {
            let c0 = bvh_nodes[n.a];
            let c1 = bvh_nodes[n.a + 1u];
            let t0 = rt_box(c0.lo, c0.hi, o, inv_d, tmax);
            let t1 = rt_box(c1.lo, c1.hi, o, inv_d, tmax);
            let near = select(n.a + 1u, n.a, t0 <= t1);
            let tn = min(t0, t1);
            let tf = max(t0, t1);
            if (tn < 1e29) {
                next = near;
                if (tf < 1e29) {
                    if (sp < limit) {
                        stack[sp] = select(n.a, n.a + 1u, t0 <= t1);
                        stack_t[sp] = tf;
                        sp++;
                    } else {
                        rt_overflow++;
                    }
                }
            }
        }
        if (next == INVALID) {
            // Pop the nearest pending subtree still in front of the best hit.
            loop {
                if (sp == 0u) { break; }
                sp--;
                if (stack_t[sp] < tmax) { next = stack[sp]; break; }
            }
            if (next == INVALID) { break; }
        }
        node = next;
    }
    if (found == INVALID) { return false; }
    let tri = bvh_tris[found];
    let b0 = 1.0 - bary.x - bary.y;
    let p_obj = tri.p0.xyz * b0 + tri.p1.xyz * bary.x + tri.p2.xyz * bary.y;
    let ng = normalize(rt_apply(inst.to_world, cross(tri.p1.xyz - tri.p0.xyz, tri.p2.xyz - tri.p0.xyz), 0.0));
    var ns = rt_apply(inst.to_world, tri.n0.xyz * b0 + tri.n1.xyz * bary.x + tri.n2.xyz * bary.y, 0.0);
    if (dot(ns, ns) > 1e-20) { ns = normalize(ns); }
    if (!(dot(ns, ng) > 0.0)) { ns = ng; }
    (*best).t = tmax;
    (*best).p = rt_apply(inst.to_world, p_obj, 1.0);
    (*best).ng = ng;
    (*best).ns = ns;
    (*best).object = inst.object;
    (*best).tri = found;
    (*best).inst = ii;
    (*best).bary = bary;
    return true;
}

// Closed-form hit of analytic object i (not a mesh) with 0 < t < tmax: (t, outward normal), or
// t = -1. The sphere and the cylinder solve with the |o - (o.d) d| form, which keeps distant
// shapes from cancelling.
fn rt_shape(m: MaterialGpu, o: vec3f, d: vec3f, tmax: f32) -> vec4f {
    let none = vec4f(-1.0, 0.0, 0.0, 0.0);
    if (m.kind.z == SHAPE_SPHERE) {
        let oc = o - m.s0.xyz;
        let b = dot(oc, d);
        let h = oc - b * d;
        let r = m.s0.w;
        let disc = r * r - dot(h, h);
        if (disc < 0.0) { return none; }
        let s = sqrt(disc);
        let q = select(-b + s, -b - s, b > 0.0);
        let c2 = dot(oc, oc) - r * r;
        let other = select(0.0, c2 / q, q != 0.0);
        let t0 = min(q, other);
        let t1 = max(q, other);
        let t = select(t1, t0, t0 > 0.0);
        if (t <= 0.0 || t >= tmax) { return none; }
        return vec4f(t, normalize(oc + t * d));
    }
    if (m.kind.z == SHAPE_CYLINDER) {
        let axis = m.s1.xyz;
        let oc = o - m.s0.xyz;
        let dp = d - axis * dot(d, axis);
        let op = oc - axis * dot(oc, axis);
        let a = dot(dp, dp);
        if (a < 1e-20) { return none; }
        let b = dot(op, dp);
        let cl = op - dp * (b / a);
        let disc = (m.s0.w * m.s0.w - dot(cl, cl)) * a;
        if (disc < 0.0) { return none; }
        let s = sqrt(disc);
        for (var k = 0u; k < 2u; k++) {
            let t = (-b + select(-s, s, k == 1u)) / a;
            if (t <= 0.0 || t >= tmax) { continue; }
            let y = dot(oc + d * t, axis);
            if (y < 0.0 || y > m.s1.w) { continue; }
            return vec4f(t, normalize(op + dp * t));
        }
        return none;
    }
    if (m.kind.z == SHAPE_RECTANGLE) {
        let n = m.s1.xyz;
        let dn = dot(d, n);
        if (abs(dn) < 1e-12) { return none; }
        let t = dot(m.s0.xyz - o, n) / dn;
        if (!(t > 0.0 && t < tmax)) { return none; }
        let q = o + d * t - m.s0.xyz;
        if (abs(dot(q, m.s2.xyz)) > 0.5 * m.s2.w || abs(dot(q, m.s3.xyz)) > 0.5 * m.s3.w) { return none; }
        return vec4f(t, n);
    }
    return none;
}

// The nearest surface of the scene along o + t d, 0 < t < tmax.
fn scene_hit(o: vec3f, d: vec3f, tmax: f32) -> SceneHit {
    var best = rt_none();
    best.t = tmax;
    let count = arrayLength(&materials);
    for (var i = 0u; i < count; i++) {
        let m = materials[i];
        if (m.kind.z == SHAPE_MESH) { continue; }
        let h = rt_shape(m, o, d, best.t);
        if (h.x > 0.0) {
            best.t = h.x;
            best.p = o + h.x * d;
            best.ng = h.yzw;
            best.ns = h.yzw;
            best.object = i;
            best.tri = INVALID;
            best.inst = INVALID;
        }
    }
    let ninst = arrayLength(&bvh_instances);
    let inv_d = rt_inv(d);
    for (var ii = 0u; ii < ninst; ii++) {
        let inst = bvh_instances[ii];
        if (inst.object == INVALID) { continue; }
        if (rt_box(inst.lo.xyz, inst.hi.xyz, o, inv_d, best.t) >= 1e29) { continue; }
        rt_instance(ii, o, d, &best, false);
    }
    return best;
}

// Whether anything lies along o + t d with 0 < t < tmax.
fn scene_occluded(o: vec3f, d: vec3f, tmax: f32) -> bool {
    let count = arrayLength(&materials);
    for (var i = 0u; i < count; i++) {
        let m = materials[i];
        if (m.kind.z == SHAPE_MESH) { continue; }
        if (rt_shape(m, o, d, tmax).x > 0.0) { return true; }
    }
    var best = rt_none();
    best.t = tmax;
    let ninst = arrayLength(&bvh_instances);
    let inv_d = rt_inv(d);
    for (var ii = 0u; ii < ninst; ii++) {
        let inst = bvh_instances[ii];
        if (inst.object == INVALID) { continue; }
        if (rt_box(inst.lo.xyz, inst.hi.xyz, o, inv_d, tmax) >= 1e29) { continue; }
        if (rt_instance(ii, o, d, &best, true)) { return true; }
    }
    return false;
}

// Whether anything but object `skip` lies along o + t d, 0 < t < tmax; with `diffuse_only`,
// only diffuse objects count (caustic spheres' occlusion and visibility rays: every object; the
// camera's rays inside a dielectric, `composite`'s inner_receiver: a floor or a stone in it).
fn scene_occluded_except(o: vec3f, d: vec3f, tmax: f32, skip: u32, diffuse_only: bool) -> bool {
    let count = arrayLength(&materials);
    for (var i = 0u; i < count; i++) {
        let m = materials[i];
        if (m.kind.z == SHAPE_MESH || i == skip || (diffuse_only && m.kind.x != KIND_DIFFUSE)) { continue; }
        if (rt_shape(m, o, d, tmax).x > 0.0) { return true; }
    }
    var best = rt_none();
    best.t = tmax;
    let ninst = arrayLength(&bvh_instances);
    let inv_d = rt_inv(d);
    for (var ii = 0u; ii < ninst; ii++) {
        let inst = bvh_instances[ii];
        if (inst.object == INVALID || inst.object == skip) { continue; }
        if (diffuse_only && materials[inst.object].kind.x != KIND_DIFFUSE) { continue; }
        if (rt_box(inst.lo.xyz, inst.hi.xyz, o, inv_d, tmax) >= 1e29) { continue; }
        if (rt_instance(ii, o, d, &best, true)) { return true; }
    }
    return false;
}

// Origin of a ray leaving surface point p (geometric normal ng) along d: moved off the surface
// to the side d goes, by a distance relative to the coordinates' magnitude (as the CPU
// reference's `spawn`).
fn rt_spawn(p: vec3f, ng: vec3f, d: vec3f) -> vec3f {
    let a = abs(p);
    let eps = 2e-5 * (1.0 + max(max(a.x, a.y), a.z));
    return select(p - ng * eps, p + ng * eps, dot(d, ng) >= 0.0);
}

// Derivative of the unit shading normal of a mesh hit for a world displacement dp: the
// interpolated vertex normals' change through the barycentrics (exact for the interpolation
// the tracer and the shading use), normalised, mapped to world space by the rotation.
fn rt_mesh_dn(h: SceneHit, dp: vec3f) -> vec3f {
    let inst = bvh_instances[h.inst];
    let tri = bvh_tris[h.tri];
    let dpo = rt_apply(inst.to_object, dp, 0.0);
    let e1 = tri.p1.xyz - tri.p0.xyz;
    let e2 = tri.p2.xyz - tri.p0.xyz;
    // Barycentric change (db1, db2) with db1 e1 + db2 e2 = dp (least squares in the plane).
    let a00 = dot(e1, e1);
    let a01 = dot(e1, e2);
    let a11 = dot(e2, e2);
    let det = a00 * a11 - a01 * a01;
    if (!(det > 0.0)) { return vec3f(0.0); }
    let r0 = dot(e1, dpo);
    let r1 = dot(e2, dpo);
    let db1 = (a11 * r0 - a01 * r1) / det;
    let db2 = (a00 * r1 - a01 * r0) / det;
    let dn = (tri.n1.xyz - tri.n0.xyz) * db1 + (tri.n2.xyz - tri.n0.xyz) * db2;
    let ni = tri.n0.xyz * (1.0 - h.bary.x - h.bary.y) + tri.n1.xyz * h.bary.x + tri.n2.xyz * h.bary.y;
    let len = length(ni);
    if (!(len > 1e-12)) { return vec3f(0.0); }
    let nh = ni / len;
    let du = (dn - nh * dot(nh, dn)) / len;
    // The instance's linear part is a rotation times a uniform scale s: the rotation is
    // to_world / s, and s = |to_world x|.
    let s = length(rt_apply(inst.to_world, vec3f(1.0, 0.0, 0.0), 0.0));
    return rt_apply(inst.to_world, du, 0.0) / s;
}

// One specular interface of a traced ray (shared by the photon tracer, shared/trace.wgsl, and
// the beam edges, beam_refine.wgsl, so both follow light through the same interfaces). A
// dielectric's Fresnel step: the normal used (the shading normal, or the geometric one where
// the ray meets the shading normal from behind), eta = n_transmitted / n_incident and the
// unpolarised Fresnel reflectance f (1: total internal reflection). `front`: the ray meets the
// geometric normal's side; ns, ng are already turned to face the ray.
struct RtFresnel {
    n: vec3f,
    eta: f32,
    f: f32,
}

fn rt_dielectric_fresnel(mat: MaterialGpu, dir: vec3f, ns: vec3f, ng: vec3f, front: bool) -> RtFresnel {
    let eta = select(mat.a.y / mat.a.x, mat.a.x / mat.a.y, front);
    var n = ns;
    var cos_i = -dot(dir, n);
    if (cos_i <= 0.0) { n = ng; cos_i = -dot(dir, n); }
    return RtFresnel(n, eta, fresnel_dielectric(cos_i, eta));
}

// The reflectance of a mirror or conductor for a ray along dir at shading normal ns.
fn rt_metal_weight(mat: MaterialGpu, dir: vec3f, ns: vec3f) -> vec3f {
    let cos_i = clamp(-dot(dir, ns), 0.0, 1.0);
    if (mat.kind.x == KIND_MIRROR) { return mat.a.rgb; }
    return fresnel_conductor(cos_i, mat.a.rgb, mat.b.rgb);
}

// The new direction at an interface: refracted (eta = n_t / n_i at normal n; about ng where
// the shading normal would send it back; total internal reflection reflects) unless `reflect_it`,
// else reflected (about ng where n would send it below the surface). `reflected` says which it
// took, `n` the normal it used, `eta_rd` the ratio n_i / n_t of a refraction (1 otherwise).
struct RtBounce {
    dir: vec3f,
    n: vec3f,
    eta_rd: f32,
    reflected: bool,
}

fn rt_bounce(dir: vec3f, n_in: vec3f, ng: vec3f, eta: f32, reflect_it: bool) -> RtBounce {
    var n = n_in;
    var new_dir = vec3f(0.0);
    var reflected = reflect_it;
    var eta_rd = 1.0;
    if (!reflected) {
        var t = refract_dir(dir, n, 1.0 / eta);
        if (dot(t.xyz, ng) >= 0.0) { t = refract_dir(dir, ng, 1.0 / eta); n = ng; }
        if (t.w < 0.5) {
            reflected = true;
        } else {
            new_dir = t.xyz;
            eta_rd = 1.0 / eta;
        }
    }
    if (reflected) {
        new_dir = reflect(dir, n);
        if (dot(new_dir, ng) <= 0.0) { n = ng; new_dir = reflect(dir, ng); }
    }
    return RtBounce(new_dir, n, eta_rd, reflected);
}
