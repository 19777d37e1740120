// Stage: composite. The final image: shaded diffuse surfaces where the camera sees them, and
// for specular surfaces image-space reflection and refraction (Wyman 2005; Wyman & Nichols 2009
// section 3.1): the camera ray refracts at the front surface (camera front buffer), exits at the
// back surface found in the camera back buffer (tangent-plane intersection, re-projected a few
// times), and the exit ray and the reflected ray find the diffuse surface they hit by an
// iterative screen-space search in the camera receiver buffer; what they find is weighted by the
// Fresnel terms. Rays the screen-space search cannot place (off screen, or onto a pixel with no
// diffuse surface) see the environment (`shared/environment.wgsl`; black without one), as do
// pixels where the camera sees no surface.
// Multi-layer deferred refraction: analytic specular objects behind the first layer are
// intersected exactly; specular meshes behind it are found in the camera's second-layer buffers
// (front and back, depth-peeled per object by `raster_peel`) and refracted through the same way.
// In a scene with a medium (`composite_medium`), the rays beyond the first specular surface are
// attenuated by it along every segment they travel outside the dielectrics, and each specular
// pixel keeps its EYE_SEGMENTS heaviest segments (`shared/medium.wgsl`) for the medium's stages
// to add the light scattered along them; the camera ray's own segment to the specular surface
// is `medium_scatter`'s.

#import shapes
#import raytrace
#import environment
#import medium
#import scene

struct CompositeParams {
    world_to_clip: mat4x4f,
    clip_to_world: mat4x4f,
    camera: vec4f,
    env_rotation: vec4f,
    width: u32,
    height: u32,
    // 1 when the scene has specular meshes: else the second-layer buffers are empty.
    layer2: u32,
    // The closed dielectric object the camera is in, plus 1 (a camera under water); 0: none.
    camera_inside: u32,
    // The medium (`composite_medium`): its box, w of `medium_hi` 1 for a density grid; sigma_t
    // (1/m), w = the midpoint rule's steps along a segment in a density grid.
    medium_lo: vec4f,
    medium_hi: vec4f,
    medium_sigma_t: vec4f,
}

// The parameters are read from a storage buffer into a private copy: lavapipe (Mesa 22.3)
// inlines the uniforms that decide branches and recompiles the stage with LLVM at binds where
// that shrinks it (seconds of CPU per camera frame, camera-dependent and so not steady); it
// never inlines storage buffers. What inlining removed is removed by the constants below.
@group(0) @binding(0) var<storage, read> cp_in: CompositeParams;
var<private> cp: CompositeParams;
// The pixels whose nearest surface is specular, listed by the first pass (`composite_pass` 0:
// diffuse pixels and the environment done, specular ones listed) and shaded by the second
// (`composite_pass` 1, dispatched indirectly over the list): on a device that runs the lanes of
// a SIMD group through both sides of a branch (llvmpipe), only the listed pixels pay for the
// image-space refraction. `spec_count`: x workgroups of 64 for the indirect dispatch, 1, 1, and
// the number of pixels listed.
@group(0) @binding(15) var<storage, read_write> spec_list: array<u32>;
@group(0) @binding(16) var<storage, read_write> spec_count: array<atomic<u32>, 4>;
override composite_pass: u32 = 0u;
// Whether the scene has specular meshes (CompositeParams::layer2: else the second-layer buffers
// are empty and their march is compiled out) and an environment (else env_rotation.z = 0 and
// the environment's lookups are compiled out).
override composite_layer2: bool = true;
override composite_env: bool = true;
// Whether the scene has a medium: else the segments are neither attenuated nor kept.
override composite_medium: bool = false;
@group(0) @binding(1) var recv_pos: texture_2d<f32>;
@group(0) @binding(2) var recv_nrm: texture_2d<f32>;
@group(0) @binding(3) var spec_pos: texture_2d<f32>;
@group(0) @binding(4) var spec_nrm: texture_2d<f32>;
@group(0) @binding(5) var back_pos: texture_2d<f32>;
@group(0) @binding(6) var back_nrm: texture_2d<f32>;
@group(0) @binding(7) var<storage, read> radiance: array<vec4f>;
@group(0) @binding(8) var<storage, read> caustic_in: array<vec4f>;
@group(0) @binding(9) var<storage, read_write> out_full: array<vec4f>;
@group(0) @binding(10) var<storage, read_write> out_caustic: array<vec4f>;
@group(0) @binding(11) var spec2_pos: texture_2d<f32>;
@group(0) @binding(12) var spec2_nrm: texture_2d<f32>;
@group(0) @binding(13) var back2_pos: texture_2d<f32>;
@group(0) @binding(14) var back2_nrm: texture_2d<f32>;
// The kept segments (`composite_medium`), EYE_SEGMENTS per listed specular pixel.
@group(0) @binding(17) var<storage, read_write> segments: array<EyeSegment>;

// The specular pixel's heaviest segments so far, and the medium's transmittance from the camera
// to its specular surface (in the kept weights: the segments' light is added after
// `medium_scatter` attenuates the pixel).
var<private> kept: array<EyeSegment, EYE_SEGMENTS>;
var<private> kept_n: u32;
var<private> t_cam: vec3f;

// The medium's transmittance along o + s d, 0 <= s <= t (its part inside the box).
fn transmittance(o: vec3f, d: vec3f, t: f32) -> vec3f {
    if (!composite_medium) { return vec3f(1.0); }
    let lo = cp.medium_lo.xyz;
    let hi = cp.medium_hi.xyz;
    let c = box_clip(o, d, t, lo, hi);
    if (c.y <= c.x) { return vec3f(1.0); }
    var tau = c.y - c.x;
    if (cp.medium_hi.w != 0.0) {
        tau = grid_optical_depth(density_grid, o + d * c.x, o + d * c.y, lo, hi, u32(cp.medium_sigma_t.w));
    }
    return exp(-cp.medium_sigma_t.rgb * tau);
}

// A segment o + s d, 0 <= s <= t, of a camera path of weight w (from the specular surface the
// pixel sees) outside the dielectrics: kept when among the pixel's EYE_SEGMENTS heaviest;
// returns its transmittance.
fn segment(o: vec3f, d: vec3f, t: f32, w: vec3f) -> vec3f {
    if (!composite_medium) { return vec3f(1.0); }
    var e: EyeSegment;
    e.o = vec4f(o, t);
    e.w = w * t_cam;
    e.dir = oct_encode(d);
    let heavy = max(max(e.w.x, e.w.y), e.w.z);
    if (heavy > 0.0) {
        if (kept_n < EYE_SEGMENTS) {
            kept[kept_n] = e;
            kept_n++;
        } else {
            // The lightest kept one gives way to a heavier one (the first of equals stays).
            var j = 0u;
            var light = 3.0e38;
            for (var k = 0u; k < EYE_SEGMENTS; k++) {
                let wk = kept[k].w;
                let m = max(max(wk.x, wk.y), wk.z);
                if (m < light) {
                    light = m;
                    j = k;
                }
            }
            if (heavy > light) { kept[j] = e; }
        }
    }
    return transmittance(o, d, t);
}

// Beer–Lambert transmittance along a length s inside the dielectric m (its absorption
// coefficient in b.rgb; exactly 1 where it is clear).
fn absorbed_in(m: MaterialGpu, s: f32) -> vec3f {
    if (m.kind.x == KIND_DIELECTRIC && any(m.b.rgb > vec3f(0.0))) { return exp(-m.b.rgb * s); }
    return vec3f(1.0);
}

// The radiance the screen-space search finds along o + s d (`trace_receivers_t`), attenuated by
// the medium; the segment is kept with weight w.
fn receivers(o: vec3f, d: vec3f, w: vec3f) -> vec3f {
    let r = trace_receivers_t(o, d);
    return segment(o, d, r.w, w) * r.rgb;
}

fn to_pixel(p: vec3f) -> vec3f {
    let c = cp.world_to_clip * vec4f(p, 1.0);
    if (c.w <= 0.0) { return vec3f(-1.0); }
    let ndc = c.xyz / c.w;
    if (abs(ndc.x) > 1.0 || abs(ndc.y) > 1.0) { return vec3f(-1.0); }
    return vec3f((ndc.x * 0.5 + 0.5) * f32(cp.width), (0.5 - ndc.y * 0.5) * f32(cp.height), 1.0);
}

fn pix(q: vec2f) -> vec2i {
    return clamp(vec2i(floor(q)), vec2i(0), vec2i(i32(cp.width) - 1, i32(cp.height) - 1));
}

// Radiance of the diffuse surface hit by the ray o + t d, by screen-space search, and the
// distance to it (1e30 when the search finds nothing: then the environment along d).
fn trace_receivers_t(o: vec3f, d: vec3f) -> vec4f {
    var t = -1.0;
    var p = o + d * 0.05;
    for (var it = 0u; it < 16u; it++) {
        let q = to_pixel(p);
        if (q.z < 0.0) { return vec4f(env_radiance(d, cp.env_rotation), 1e30); }
        let px = pix(q.xy);
        let r = textureLoad(recv_pos, px, 0);
        if (r.w < 0.0) { return vec4f(env_radiance(d, cp.env_rotation), 1e30); }
        let n = textureLoad(recv_nrm, px, 0).xyz;
        let dn = dot(d, n);
        var t_new = length(r.xyz - o);
        if (abs(dn) > 1e-3) { t_new = dot(r.xyz - o, n) / dn; }
        if (t_new <= 0.0) { return vec4f(env_radiance(d, cp.env_rotation), 1e30); }
        if (abs(t_new - t) <= 1e-4 * t_new) {
            return vec4f(radiance[u32(px.y) * cp.width + u32(px.x)].rgb, t_new);
        }
        t = t_new;
        p = o + t * d;
    }
    let q = to_pixel(p);
    if (q.z < 0.0) { return vec4f(env_radiance(d, cp.env_rotation), 1e30); }
    let px = pix(q.xy);
    return vec4f(radiance[u32(px.y) * cp.width + u32(px.x)].rgb, t);
}

// Radiance along a ray leaving the specular object `leaving`: analytic specular objects on its
// way (spheres, open cylinders, rectangles, intersected exactly) reflect or refract it, up to
// three more times (multi-layer refraction: glass seen through glass, glass in a mirror);
// specular meshes behind the first layer are found in the second-layer buffers and refracted
// through (`mesh_interaction`); otherwise it sees the diffuse surface the screen-space search
// finds. `wr`: the weight of the returned radiance in the pixel (for the kept segments' weights;
// the medium attenuates every segment).
fn shade_ray(o_in: vec3f, d_in: vec3f, leaving_in: u32, wr: vec3f) -> vec3f {
    var o = o_in;
    var d = d_in;
    var leaving = leaving_in;
    var w = vec3f(1.0);
    var l = vec3f(0.0);
    for (var k = 0u; k < 3u; k++) {
        let rec = trace_receivers_t(o, d);
        let h = exact_shape(o, d, rec.w, leaving, false);
        let mh = find_layer2(o, d, min(rec.w, h.t), leaving);
        if (mh.ok) {
            w *= segment(o, d, distance(o, mh.p), wr * w);
            let r = mesh_interaction(mh, d, wr * w);
            l += w * r.l;
            w *= r.w;
            if (!r.ok) { return l; }
            o = r.o;
            d = r.d;
            leaving = mh.object;
            continue;
        }
        if (h.object == INVALID) { return l + w * (segment(o, d, rec.w, wr * w) * rec.rgb); }
        w *= segment(o, d, h.t, wr * w);
        let m = materials[h.object];
        var n = h.n;
        if (dot(n, d) > 0.0) { n = -n; }
        let cos1 = -dot(d, n);
        if (m.kind.x == KIND_MIRROR) {
            w *= m.a.rgb;
            d = reflect(d, n);
        } else if (m.kind.x == KIND_CONDUCTOR) {
            w *= fresnel_conductor(cos1, m.a.rgb, m.b.rgb);
            d = reflect(d, n);
        } else {
            let ior = m.a.x;
            let ext = m.a.y;
            let f1 = fresnel_dielectric(cos1, ior / ext);
            l += w * f1 * receivers(h.p, reflect(d, n), wr * w * f1);
            w *= 1.0 - f1;
            let t1 = refract_dir(d, n, ext / ior);
            if (m.kind.z != SHAPE_SPHERE) {
                // Open cylinders and rectangles have no inside: a thin sheet, out the other side.
                w *= 1.0 - f1;
            } else {
                // Sphere: the far root, then out (total internal reflection: the ray is lost).
                let c = m.s0.xyz;
                let wv = h.p - c;
                let b = dot(wv, t1.xyz);
                let cc = dot(wv, wv) - m.s0.w * m.s0.w;
                let t_exit = -b + sqrt(max(b * b - cc, 0.0));
                let pe = h.p + t_exit * t1.xyz;
                let ne = normalize(pe - c);
                let t2 = refract_dir(t1.xyz, -ne, ior / ext);
                if (t2.w < 0.5) { return l; }
                w *= (1.0 - fresnel_dielectric(dot(t1.xyz, ne), ext / ior)) * absorbed_in(m, t_exit);
                o = pe;
                d = t2.xyz;
                leaving = h.object;
                continue;
            }
        }
        o = h.p;
        leaving = h.object;
    }
    return l + w * receivers(o, d, wr * w);
}

struct EyeHit {
    p: vec3f,
    n: vec3f,
    ok: bool,
    object: u32,
}

fn tangent_hit(pos_tex: texture_2d<f32>, nrm_tex: texture_2d<f32>, q: vec2f, o: vec3f, d: vec3f) -> EyeHit {
    var h: EyeHit;
    let pw = textureLoad(pos_tex, pix(q), 0);
    h.ok = pw.w >= 0.0;
    h.object = u32(max(pw.w, 0.0));
    h.n = normalize(textureLoad(nrm_tex, pix(q), 0).xyz);
    h.p = pw.xyz;
    let dn = dot(d, h.n);
    if (abs(dn) > 1e-4) {
        let t = dot(pw.xyz - o, h.n) / dn;
        if (t > 0.0) { h.p = o + t * d; }
    }
    return h;
}

// March step along o + s d: about 1.5 pixels on screen.
fn screen_step(o: vec3f, d: vec3f) -> f32 {
    let q0 = to_pixel(o);
    let eps = 1e-3;
    let q1 = to_pixel(o + d * eps);
    var px_per_m = 200.0;
    if (q0.z > 0.0 && q1.z > 0.0) { px_per_m = max(length(q1.xy - q0.xy) / eps, 1.0); }
    return clamp(1.5 / px_per_m, 1e-4, 0.05);
}

// March a ray travelling inside a specular object (it entered at o) through the camera's
// back-surface and front-surface buffers of the first layer, about 1.5 pixels a step, to where
// it leaves: behind the back surface, in front of the front surface (concave parts), or across
// the silhouette.
fn march_exit_eye(o: vec3f, d: vec3f) -> EyeHit {
    return march_exit_in(o, d, spec_pos, spec_nrm, back_pos, back_nrm);
}

fn march_exit_in(o: vec3f, d: vec3f, spec_pos: texture_2d<f32>, spec_nrm: texture_2d<f32>, back_pos: texture_2d<f32>, back_nrm: texture_2d<f32>) -> EyeHit {
    var none: EyeHit;
    none.ok = false;
    let ds = screen_step(o, d);
    let cam = cp.camera.xyz;
    var last = vec2f(-1.0);
    for (var k = 1u; k <= 256u; k++) {
        let p = o + d * (f32(k) * ds);
        let q = to_pixel(p);
        if (q.z < 0.0) { return none; }
        let bp = textureLoad(back_pos, pix(q.xy), 0);
        if (bp.w < 0.0) {
            if (last.x < 0.0) { return none; }
            return tangent_hit(back_pos, back_nrm, last, o, d);
        }
        last = q.xy;
        let dist = length(p - cam);
        if (dist >= length(bp.xyz - cam)) { return tangent_hit(back_pos, back_nrm, q.xy, o, d); }
        if (k >= 3u) {
            let fp = textureLoad(spec_pos, pix(q.xy), 0);
            if (fp.w >= 0.0 && dist <= length(fp.xyz - cam)) { return tangent_hit(spec_pos, spec_nrm, q.xy, o, d); }
        }
    }
    return none;
}

// The second-layer specular mesh the ray o + s d (0 < s < t_max) enters, other than `leaving`:
// marched about 1.5 pixels a step through the second-layer buffers; a sample between a mesh's
// front and back surfaces (seen from the camera) after one outside is an entry, placed exactly
// on the front texel's tangent plane.
fn find_layer2(o: vec3f, d: vec3f, t_max: f32, leaving: u32) -> EyeHit {
    var none: EyeHit;
    none.ok = false;
    if (!composite_layer2 || cp.layer2 == 0u) { return none; }
    let ds = screen_step(o, d);
    let cam = cp.camera.xyz;
    var was_outside = false;
    for (var k = 1u; k <= 256u; k++) {
        let s = f32(k) * ds;
        if (s >= t_max) { break; }
        let p = o + d * s;
        let q = to_pixel(p);
        if (q.z < 0.0) { break; }
        let px = pix(q.xy);
        let fp = textureLoad(spec2_pos, px, 0);
        var inside = false;
        if (fp.w >= 0.0 && u32(fp.w) != leaving) {
            let dist = length(p - cam);
            let bp = textureLoad(back2_pos, px, 0);
            let behind_front = dist >= length(fp.xyz - cam);
            let before_back = bp.w < 0.0 || dist <= length(bp.xyz - cam) + ds;
            inside = behind_front && before_back;
        }
        if (inside && was_outside) {
            var h = tangent_hit(spec2_pos, spec2_nrm, q.xy, o, d);
            if (dot(h.p - o, d) <= 0.0) { h.p = p; }
            return h;
        }
        was_outside = !inside;
    }
    return none;
}

struct MeshResult {
    l: vec3f,
    w: vec3f,
    o: vec3f,
    d: vec3f,
    ok: bool,
}

// A second-layer mesh hit by the ray along d: mirrors and conductors reflect; dielectrics add
// the Fresnel-reflected receivers, refract in, march to the exit through the second-layer
// buffers (total internal reflection followed up to three times) and refract out. Returns the
// radiance gathered (l), the weight of what follows (w) and the continuing ray (o, d), ok =
// false when the ray is lost.
// `wr`: the weight of the ray along d in the pixel (for the kept segments).
fn mesh_interaction(h: EyeHit, d: vec3f, wr: vec3f) -> MeshResult {
    var r: MeshResult;
    r.l = vec3f(0.0);
    r.w = vec3f(1.0);
    r.ok = false;
    let m = materials[h.object];
    var n = h.n;
    if (dot(n, d) > 0.0) { n = -n; }
    let cos1 = -dot(d, n);
    r.o = h.p;
    if (m.kind.x == KIND_MIRROR || m.kind.x == KIND_CONDUCTOR) {
        r.w = select(fresnel_conductor(cos1, m.a.rgb, m.b.rgb), m.a.rgb, m.kind.x == KIND_MIRROR);
        r.d = reflect(d, n);
        r.ok = true;
        return r;
    }
    let ior = m.a.x;
    let ext = m.a.y;
    let f1 = fresnel_dielectric(cos1, ior / ext);
    r.l = f1 * receivers(h.p, reflect(d, n), wr * f1);
    r.w = vec3f(1.0 - f1);
    var p_in = h.p;
    var t_in = refract_dir(d, n, ext / ior).xyz;
    for (var k = 0u; k < 4u; k++) {
        let exit = march_exit_in(p_in, t_in, spec2_pos, spec2_nrm, back2_pos, back2_nrm);
        if (!exit.ok) { return r; }
        var n2 = exit.n;
        if (dot(n2, t_in) < 0.0) { n2 = -n2; }
        r.w *= absorbed_in(m, distance(exit.p, p_in));
        let t2 = refract_dir(t_in, -n2, ior / ext);
        if (t2.w > 0.5) {
            r.w *= 1.0 - fresnel_dielectric(dot(t_in, n2), ext / ior);
            r.o = exit.p;
            r.d = t2.xyz;
            r.ok = true;
            return r;
        }
        p_in = exit.p;
        t_in = reflect(t_in, n2);
    }
    return r;
}

// Where a ray travelling inside the glass object `obj` (at p, along d) leaves it. A sphere: its
// far root, exactly (wherever the sphere's back lies: off screen, or hidden). A mesh: marched
// through the camera's first-layer buffers (`march_exit_eye`); where that finds no exit (the
// back surface off screen or hidden behind something else), the exact BVH tracer
// (`shared/raytrace.wgsl`) from just inside the surface, kept when what it meets is this object.
fn exit_from_inside(obj: u32, m: MaterialGpu, p: vec3f, d: vec3f, march: bool) -> EyeHit {
    var h: EyeHit;
    h.ok = false;
    h.object = obj;
    if (m.kind.z == SHAPE_SPHERE) {
        let c = m.s0.xyz;
        let wv = p - c;
        let b = dot(wv, d);
        let cc = dot(wv, wv) - m.s0.w * m.s0.w;
        let t = -b + sqrt(max(b * b - cc, 0.0));
        if (!(t > 0.0)) { return h; }
        h.p = p + t * d;
        h.n = normalize(h.p - c);
        h.ok = true;
        return h;
    }
    if (march) {
        let marched = march_exit_eye(p, d);
        if (marched.ok) { return marched; }
    }
    rt_overflow = 0u;
    let a = abs(p);
    let o = p + d * (2e-5 * (1.0 + max(max(a.x, a.y), a.z)));
    let sh = scene_hit(o, d, 1e30);
    // A hit the tracer may have missed (its stack overflowed) or another object: no exit (the
    // pixel is black where the light is lost, unless `inner_receiver` shows the other object:
    // it is named in `object`, its point in `p`).
    if (rt_overflow != 0u) { return h; }
    if (sh.object != obj) {
        h.object = sh.object;
        h.p = sh.p;
        return h;
    }
    h.p = sh.p;
    h.n = sh.ns;
    h.ok = true;
    return h;
}

// The shaded radiance of the diffuse point p where the camera sees it (its pixel's receiver
// within 4 pixels' width there); w = -1 where the camera does not see it.
fn seen_radiance(p: vec3f) -> vec4f {
    let q = to_pixel(p);
    if (q.z > 0.0) {
        let px = pix(q.xy);
        let rp = textureLoad(recv_pos, px, 0);
        // A pixel's width at p: 2 w / (height P11), P11 the length of the clip matrix's y row.
        let m = cp.world_to_clip;
        let p11 = length(vec3f(m[0][1], m[1][1], m[2][1]));
        let w = (m * vec4f(p, 1.0)).w;
        let tol = 8.0 * w / (f32(cp.height) * p11);
        if (rp.w >= 0.0 && distance(rp.xyz, p) <= tol) {
            return vec4f(radiance[u32(px.y) * cp.width + u32(px.x)].rgb, 0.0);
        }
    }
    return vec4f(0.0, 0.0, 0.0, -1.0);
}

// The radiance of a diffuse surface met by a ray travelling inside the dielectric `obj` (at o,
// along d) before it leaves it at `exit` (a pool's floor under water, a stone in a glass
// block); w = -1 where the ray leaves first or no exit was found. Whether something lies there
// is the exact tracer's answer (a diffuse object along the ray before the exit); what the ray
// sees is the screen-space search's in the camera's receiver buffer, which holds the diffuse
// surfaces without the specular objects and so sees through the water to the floor (near a
// silhouette, where the search does not settle, the surface it ends on).
// `exact`: the exit came from the exact tracer alone (`exit_from_inside` without the march), so
// a ray that met another object first names it: a diffuse one is what the ray sees.
fn inner_receiver(obj: u32, o: vec3f, d: vec3f, exit: EyeHit, exact: bool) -> vec4f {
    let miss = vec4f(0.0, 0.0, 0.0, -1.0);
    if (!exit.ok) {
        if (!exact || exit.object == obj || exit.object >= arrayLength(&materials)) { return miss; }
        if (materials[exit.object].kind.x != KIND_DIFFUSE) { return miss; }
        // The exact point where the camera sees it; else the screen-space search.
        let v = seen_radiance(exit.p);
        if (v.w >= 0.0) { return vec4f(v.rgb, distance(o, exit.p)); }
        let r = trace_receivers_t(o, d);
        if (!(r.w < 1e30)) { return miss; }
        return vec4f(r.rgb, r.w);
    }
    let a = abs(o);
    let o2 = o + d * (2e-5 * (1.0 + max(max(a.x, a.y), a.z)));
    rt_overflow = 0u;
    if (!scene_occluded_except(o2, d, distance(o, exit.p), obj, true) || rt_overflow != 0u) { return miss; }
    let r = trace_receivers_t(o, d);
    if (!(r.w < 1e30)) { return miss; }
    return vec4f(r.rgb, r.w);
}

fn load_params() {
    cp = cp_in;
    if (!composite_env) { cp.env_rotation.z = 0.0; }
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3u, @builtin(workgroup_id) wg: vec3u, @builtin(local_invocation_index) li: u32) {
    load_params();
    if (composite_pass == 1u) {
        let i = wg.x * 64u + li;
        if (i >= atomicLoad(&spec_count[3])) { return; }
        let idx = spec_list[i];
        specular_pixel(vec2i(vec2u(idx % cp.width, idx / cp.width)), idx);
        if (composite_medium) {
            // (the empty slots cleared: the stages read every slot)
            for (var k = 0u; k < EYE_SEGMENTS; k++) {
                var e = kept[k];
                if (k >= kept_n) { e.o = vec4f(0.0); }
                segments[i * EYE_SEGMENTS + k] = e;
            }
        }
        return;
    }
    if (gid.x >= cp.width || gid.y >= cp.height) { return; }
    let idx = gid.y * cp.width + gid.x;
    let px = vec2i(gid.xy);
    let r = textureLoad(recv_pos, px, 0);
    let s = textureLoad(spec_pos, px, 0);
    let cam = cp.camera.xyz;
    let spec_in_front = s.w >= 0.0 && (r.w < 0.0 || length(s.xyz - cam) < length(r.xyz - cam));
    if (r.w < 0.0 && s.w < 0.0) {
        // No surface: the environment along the pixel centre's camera ray.
        let ndc = vec2f((f32(gid.x) + 0.5) / f32(cp.width) * 2.0 - 1.0, 1.0 - (f32(gid.y) + 0.5) / f32(cp.height) * 2.0);
        let q = cp.clip_to_world * vec4f(ndc, 0.5, 1.0);
        out_full[idx] = vec4f(env_radiance(q.xyz / q.w - cam, cp.env_rotation), 0.0);
        out_caustic[idx] = vec4f(0.0);
        return;
    }
    if (!spec_in_front) {
        out_full[idx] = radiance[idx];
        out_caustic[idx] = caustic_in[idx];
        return;
    }
    out_caustic[idx] = vec4f(0.0);
    let k = atomicAdd(&spec_count[3], 1u);
    if (k % 64u == 0u) { atomicAdd(&spec_count[0], 1u); }
    if (k == 0u) {
        atomicStore(&spec_count[1], 1u);
        atomicStore(&spec_count[2], 1u);
    }
    spec_list[k] = idx;
}

// The radiance along a ray travelling inside the dielectric `obj` from p_in along t_in, with
// weight w_in: a diffuse surface inside before the exit (a pool's floor under water, a stone in
// a glass block) is what it sees; else it refracts out at the exit, or reflects totally and goes
// on, up to four times. `march`: find mesh exits through the camera's buffers first (rays that
// entered from outside).
fn inside_ray(obj: u32, mat: MaterialGpu, p0: vec3f, t0: vec3f, w_in: f32, march: bool) -> vec3f {
    let ior = mat.a.x;
    let ext = mat.a.y;
    var l = vec3f(0.0);
    var p_in = p0;
    var t_in = t0;
    // (the absorption inside along the segments so far)
    var w = vec3f(w_in);
    for (var k = 0u; k < 4u; k++) {
        let exit = exit_from_inside(obj, mat, p_in, t_in, march);
        let inner = inner_receiver(obj, p_in, t_in, exit, !march);
        if (inner.w >= 0.0) {
            l += w * absorbed_in(mat, inner.w) * inner.rgb;
            break;
        }
        if (!exit.ok) { break; }
        w *= absorbed_in(mat, distance(exit.p, p_in));
        var n2 = exit.n;
        if (dot(n2, t_in) < 0.0) { n2 = -n2; }
        let cos2 = dot(t_in, n2);
        let t2 = refract_dir(t_in, -n2, ior / ext);
        if (t2.w > 0.5) {
            let f2 = fresnel_dielectric(cos2, ext / ior);
            l += w * (1.0 - f2) * shade_ray(exit.p, t2.xyz, obj, w * (1.0 - f2));
            break;
        }
        p_in = exit.p;
        t_in = reflect(t_in, n2);
    }
    return l;
}

// A pixel whose nearest surface is specular (listed by the first pass).
fn specular_pixel(px: vec2i, idx: u32) {
    let s = textureLoad(spec_pos, px, 0);
    let cam = cp.camera.xyz;
    let obj = u32(s.w);
    let mat = materials[obj];
    var p = s.xyz;
    let d = normalize(p - cam);
    var n = normalize(textureLoad(spec_nrm, px, 0).xyz);
    // An analytic object is entered exactly: the pixel's ray (through the rasterized point) meets
    // the shape itself, not its tessellation (a ray that misses it, at the tessellated silhouette,
    // keeps the rasterized point).
    if (mat.kind.z != SHAPE_MESH) {
        let e = rt_shape(mat, cam, d, 1e30);
        if (e.x > 0.0) {
            p = cam + e.x * d;
            n = e.yzw;
        }
    }
    if (dot(n, d) > 0.0) { n = -n; }
    kept_n = 0u;
    t_cam = vec3f(1.0);
    if (composite_medium) { t_cam = transmittance(cam, d, distance(cam, p)); }
    let cos1 = -dot(d, n);
    let refl = reflect(d, n);
    var l = vec3f(0.0);
    if (mat.kind.x == KIND_MIRROR) {
        l = mat.a.rgb * shade_ray(p, refl, obj, mat.a.rgb);
    } else if (mat.kind.x == KIND_CONDUCTOR) {
        let fc = fresnel_conductor(cos1, mat.a.rgb, mat.b.rgb);
        l = fc * shade_ray(p, refl, obj, fc);
    } else if (mat.kind.x == KIND_DIELECTRIC && obj + 1u == cp.camera_inside) {
        // The camera is inside the object (under water): its ray meets the surface from inside,
        // refracts out (unless totally reflected) and reflects back in. What the reflection
        // meets inside is found as after a total internal reflection below, but the exit by the
        // exact tracer: the camera's buffers march rays that entered from outside.
        let ior = mat.a.x;
        let ext = mat.a.y;
        let t = refract_dir(d, n, ior / ext);
        var f = 1.0;
        if (t.w > 0.5) {
            f = fresnel_dielectric(cos1, ext / ior);
            l = (1.0 - f) * shade_ray(p, t.xyz, obj, vec3f(1.0 - f));
        }
        l += inside_ray(obj, mat, p, refl, f, false);
    } else if (mat.kind.x == KIND_DIELECTRIC) {
        let ior = mat.a.x;
        let ext = mat.a.y;
        let f1 = fresnel_dielectric(cos1, ior / ext);
        l = f1 * shade_ray(p, refl, obj, vec3f(f1));
        let t1 = refract_dir(d, n, ext / ior);
        if (mat.kind.z == SHAPE_CYLINDER || mat.kind.z == SHAPE_RECTANGLE) {
            // Open cylinders and rectangles have no inside: a thin sheet, out the other side
            // (as `shade_ray` treats them behind the first layer).
            l += (1.0 - f1) * (1.0 - f1) * shade_ray(p, d, obj, vec3f((1.0 - f1) * (1.0 - f1)));
        } else {
            // Inside: to the exit (exactly for a sphere; marched through the camera's buffers
            // for a mesh, with the exact BVH tracer where the march finds none); total internal
            // reflection followed up to three times.
            l += inside_ray(obj, mat, p, t1.xyz, 1.0 - f1, true);
        }
    }
    out_full[idx] = vec4f(l, 0.0);
}
