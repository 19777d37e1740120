// Shared photon tracing (imported by photon_trace and the adaptive techniques): from a light
// ray through NDC point `ndc` of face `layer`, carrying `flux`, find where it lands in the
// caustic map. Uses the module-scope bindings every importing stage declares: light, front_pos,
// front_nrm, back_pos, back_nrm (the light's caster buffers), front_pos2, front_nrm2, back_pos2,
// back_nrm2 (their second, depth-peeled layer), recv_pos, recv_nrm, materials, stats.
// With trace_defer set (adaptive caustic maps trace children and book only the photons they
// emit), add_fixed collects the flux per slot in trace_pending instead of adding it to stats.
var<private> trace_defer: bool = false;
// The reflected branch at the first dielectric surface (basic caustic maps trace each cell
// twice when the scene has dielectric casters: the transmitted branch, then this one, each
// weighted by its Fresnel factor). Set by the stage before calling trace_photon.
var<private> trace_reflect: bool = false;
var<private> trace_pending: array<f32, 8>;
// Splat data the tracer leaves in each photon (docs/splatting.md): flux.w = the path signature
// (objects hit and internal reflections, 24 bits; caustic triangles do not span two paths);
// _pad = the beam diameter on the receiver in caustic-map texels from the lens equations (f32
// bits), when light.splat.x asks for it (1 thin lens, 2 thick lens; 0: _pad = 0, which
// adaptive_refine then uses to mark photons that carry a cell quad for splat_quads).
var<private> trace_internal: u32 = 0u;
var<private> lens_exit_p: vec3f;
// Ray differentials (Igehy 1999) of the photon's cell, when light.splat.x == 3
// (`--splat differential`): the position and direction derivatives across the whole cell along
// the grid's two axes, carried through every transfer, refraction and reflection (the surface's
// normal derivative from the analytic shape or the light-space buffers). On landing, the cell's
// image in the caustic map gives the exact first-order beam diameter, which `splat_lens` uses.
var<private> rd_on: bool = false;
// The splat mode the pipeline was built for (light.splat.x: 0 none, 1 thin lens, 2 thick lens,
// 3 ray differentials), or -1: read light.splat.x at run time. A fixed mode compiles the lens and
// differential code out of the modes that do not use it (src/techniques/mod.rs builds the
// tracing pipelines for the frame's mode): on lavapipe, code behind a branch costs its time
// whether or not the branch is taken.
override trace_splat_mode: i32 = -1;
fn splat_mode() -> f32 {
    if (trace_splat_mode >= 0) { return f32(trace_splat_mode); }
    return light.splat.x;
}
fn rd_active() -> bool {
    return rd_on && (trace_splat_mode < 0 || trace_splat_mode == 3);
}
// Whether the light's second caster layer is used (caster meshes, two casters or more; built
// per frame, src/techniques/mod.rs): the casters behind the nearest one, per texel the nearest
// caster of another object (multi-layer deferred refraction, Wyman & Nichols 2009 section 3.1,
// light side). Off, the second-layer code is compiled out and the first layer is bound in its
// place.
override trace_light_layer2: bool = true;
var<private> rd_from: vec3f;
// The tracer (src/settings.rs `Tracer`): false, the papers' image-space tracer (light-space
// caster buffers, marched); true, exact paths through the scene (shared/raytrace.wgsl).
override trace_exact: bool = false;
// Specular interactions an exact path may have before it is given up (`RenderSettings::max_depth`).
override trace_max_depth: u32 = 8u;
// Exact tracer: take the first caster surface from the light's caster front buffer (the papers'
// deferred emission: the texel's tangent plane, refined) instead of tracing the BVH from the
// light (`RenderSettings::first_hit_from_buffer`).
override trace_first_hit_buffer: bool = false;
// The branch reflected at the second interface (exact tracer; set by the stage: the pass that
// traces it). Whether the frame has that pass is bit 2 of trace_covered (its flux is then not
// booked as untraced by the transmitted pass).
var<private> trace_internal_branch: bool = false;
// The residual pass (exact tracer; set by the stage): every Fresnel choice made at random, as
// the CPU reference does, keeping only the paths no deterministic pass follows. Which masks of
// reflections the deterministic passes cover (bit k: the path of mask k, k = 0 transmitted, 1
// reflected at the first surface, 2 reflected at the second), and whether the frame has the
// residual pass (then no pass books untraced branches: the residual pass carries them).
var<private> trace_residual: bool = false;
// The probability of the residual pass's choices along the current path (1 elsewhere).
var<private> residual_prob: f32 = 1.0;
override trace_covered: u32 = 1u;
override trace_residual_pass: bool = false;

// A uniform number in [0, 1) from the photon's key and the interaction's depth
// (common.wgsl `hash_uniform`): the same photon makes the same choices in every run.
fn residual_random(key: u32, depth: u32) -> f32 {
    return hash_uniform(key, depth);
}

// Whether the residual pass drops a path whose Fresnel choices reflected at the depths in
// `chosen`: a deterministic pass follows it.
fn residual_covered(chosen: u32) -> bool {
    return trace_residual && chosen <= 2u && ((trace_covered >> chosen) & 1u) == 1u;
}
// The exact tracer's current surface (surface_dn reads the mesh triangle's normals there).
var<private> exact_hit: SceneHit;
var<private> rd_pu: vec3f;
var<private> rd_pv: vec3f;
var<private> rd_du: vec3f;
var<private> rd_dv: vec3f;
fn add_fixed(slot: u32, value: f32) {
    if (trace_defer) { trace_pending[slot / 2u] += value; return; }
    let v = max(value * light.params.y, 0.0);
    let hi = floor(v / 4294967296.0);
    let lo = u32(v - hi * 4294967296.0);
    let old = atomicAdd(&stats[slot], lo);
    var carry = 0u;
    if (old > 0xffffffffu - lo) { carry = 1u; }
    atomicAdd(&stats[slot + 1u], u32(hi) + carry);
}

fn texel_of(p: vec2f, size: u32) -> vec2i {
    return clamp(vec2i(floor(p)), vec2i(0), vec2i(i32(size) - 1));
}

// Surface point of a light-space geometry buffer hit by the ray o + t d near texel coordinate
// uv (in buffer texels): the ray's intersection with the tangent plane of the nearest texel.
struct Hit {
    p: vec3f,
    n: vec3f,
    object: u32,
}

fn buffer_hit(pos_tex: texture_2d_array<f32>, nrm_tex: texture_2d_array<f32>, layer: u32, uv: vec2f, o: vec3f, d: vec3f) -> Hit {
    var h: Hit;
    h.object = INVALID;
    let g = textureDimensions(pos_tex).x;
    let t = texel_of(uv, g);
    let pw = textureLoad(pos_tex, t, layer, 0);
    if (pw.w < 0.0) { return h; }
    // Bilinear interpolation of position and normal over the four texels around uv that belong
    // to the same object, so that the buffer acts as a smooth surface rather than as flat
    // texel-sized facets (which would show as bands in the caustic).
    let gx = uv - 0.5;
    let base = vec2i(floor(gx));
    let fr = gx - floor(gx);
    var pos = vec3f(0.0);
    var nrm = vec3f(0.0);
    var wsum = 0.0;
    for (var k = 0; k < 4; k++) {
        let off = vec2i(k & 1, k >> 1);
        let tt = clamp(base + off, vec2i(0), vec2i(i32(g) - 1));
        let q = textureLoad(pos_tex, tt, layer, 0);
        if (q.w != pw.w) { continue; }
        let w = select(1.0 - fr.x, fr.x, off.x == 1) * select(1.0 - fr.y, fr.y, off.y == 1);
        pos += w * q.xyz;
        nrm += w * textureLoad(nrm_tex, tt, layer, 0).xyz;
        wsum += w;
    }
    var n = normalize(textureLoad(nrm_tex, t, layer, 0).xyz);
    var p0 = pw.xyz;
    if (wsum > 1e-6 && length(nrm) > 1e-6) {
        n = normalize(nrm);
        p0 = pos / wsum;
    }
    let dn = dot(d, n);
    var p = p0;
    if (abs(dn) > 1e-4) {
        let s = dot(p0 - o, n) / dn;
        if (s > 0.0) { p = o + s * d; }
    }
    h.p = p;
    h.n = n;
    h.object = u32(pw.w);
    return h;
}

// Newton steps toward the true intersection of the ray o + s d with a buffer's surface:
// re-project the current estimate, take the tangent plane there, repeat. Without this the
// normal would be the one at the march sample's texel, up to a step away from the crossing,
// and the caustic shows rings at the march's step boundaries.
fn refine_hit(pos_tex: texture_2d_array<f32>, nrm_tex: texture_2d_array<f32>, layer: u32, h0: Hit, o: vec3f, d: vec3f) -> Hit {
    let g = f32(textureDimensions(pos_tex).x);
    let face = light.faces[layer];
    var h = h0;
    for (var i = 0u; i < 4u; i++) {
        let q = project_face(face, h.p, g);
        if (q.w < 0.5) { break; }
        let h2 = buffer_hit(pos_tex, nrm_tex, layer, q.xy, o, d);
        if (h2.object != h.object) { break; }
        let moved = length(h2.p - h.p);
        h = h2;
        if (moved < 1e-7) { break; }
    }
    return h;
}

// Distance of p from the light along its view (perspective: from the light; orthographic:
// along the light direction).
fn light_depth(face: Face, p: vec3f) -> f32 {
    if (face.origin.w > 0.5) { return dot(p, face.origin.xyz); }
    return length(p - face.origin.xyz);
}

// March the ray o + s d that travels inside a caster (it entered at o) to where it leaves:
// through a back surface (the ray passes behind the back-surface buffer's surface), through a
// front surface (it comes back in front of the front-surface buffer's surface: concave objects,
// rays reflected inside), or across the silhouette (the last back texel seen). Exact position
// from the exit texel's tangent plane. `object` = INVALID when no exit is found.
// The back-surface crossing of o + s d between s0 (in front) and s1 (behind), by bisection on
// the buffer depth, with the normal of the texel where it ends.
fn bisect_exit(back_p: texture_2d_array<f32>, back_n: texture_2d_array<f32>, o: vec3f, d: vec3f, layer: u32, g: f32, s0_in: f32, s1_in: f32) -> Hit {
    let face = light.faces[layer];
    var s0 = s0_in;
    var s1 = s1_in;
    var h: Hit;
    h.object = INVALID;
    for (var i = 0u; i < 10u; i++) {
        let sm = 0.5 * (s0 + s1);
        let p = o + d * sm;
        let q = project_face(face, p, g);
        let bp = textureLoad(back_p, texel_of(q.xy, u32(g)), layer, 0);
        if (bp.w >= 0.0 && light_depth(face, p) >= light_depth(face, bp.xyz)) { s1 = sm; } else { s0 = sm; }
    }
    let p = o + d * s1;
    let q = project_face(face, p, g);
    let t = texel_of(q.xy, u32(g));
    let bp = textureLoad(back_p, t, layer, 0);
    if (bp.w < 0.0) { return h; }
    h.p = p;
    h.n = normalize(textureLoad(back_n, t, layer, 0).xyz);
    h.object = u32(bp.w);
    return h;
}

// The buffers (front_p, front_n, back_p, back_n) are the layer that holds the object traversed:
// the light's first caster layer, or its second for a caster hidden behind another one.
fn march_exit(front_p: texture_2d_array<f32>, front_n: texture_2d_array<f32>, back_p: texture_2d_array<f32>, back_n: texture_2d_array<f32>, o: vec3f, d: vec3f, layer: u32, g: f32) -> Hit {
    var none: Hit;
    none.object = INVALID;
    let face = light.faces[layer];
    let steps = 48u;
    let ds = 2.2 * light.extra.x / f32(steps);
    var last_valid = vec2f(-1.0);
    var prev_front_gap = -1.0;
    // The march only finds the step where something happens (0 nothing: the ray left the view
    // or the steps ran out, 1 it left the silhouette, 2 it passed behind the back surface, 3 a
    // candidate crossing of a front surface); the refinements run outside its loop. (On
    // lavapipe a loop body costs all of its branches on every iteration, taken or not.)
    var k = 1u;
    var event = 0u;
    var q_event = vec2f(0.0);
    loop {
        for (; k <= steps; k++) {
            let p = o + d * (f32(k) * ds);
            let q = project_face(face, p, g);
            if (q.w < 0.5) { break; }
            let t = texel_of(q.xy, u32(g));
            let bp = textureLoad(back_p, t, layer, 0);
            // Left the silhouette between two samples: exit through the last back texel seen.
            if (bp.w < 0.0) { event = 1u; break; }
            last_valid = q.xy;
            let depth = light_depth(face, p);
            if (depth >= light_depth(face, bp.xyz)) { event = 2u; q_event = q.xy; break; }
            // Out through a front surface (concave parts, rays reflected inside): only a genuine
            // crossing counts, from behind the surface to in front of it, on a continuous
            // surface, with the tangent-plane intersection inside the step.
            let fp = textureLoad(front_p, t, layer, 0);
            let gap = depth - light_depth(face, fp.xyz);
            if (k >= 2u && fp.w >= 0.0 && gap <= 0.0 && prev_front_gap > 0.0 && -gap < 2.0 * ds) {
                event = 3u;
                q_event = q.xy;
                prev_front_gap = gap;
                break;
            }
            prev_front_gap = select(-1.0, gap, fp.w >= 0.0);
        }
        if (event != 3u) { break; }
        let h = refine_hit(front_p, front_n, layer, buffer_hit(front_p, front_n, layer, q_event, o, d), o, d);
        let s = dot(h.p - o, d);
        if (h.object != INVALID && s > (f32(k) - 1.5) * ds && s <= (f32(k) + 0.5) * ds) { return h; }
        // Not a crossing within the step: march on.
        event = 0u;
        k++;
    }
    if (event == 0u || (event == 1u && last_valid.x < 0.0)) { return none; }
    let h = refine_hit(back_p, back_n, layer, buffer_hit(back_p, back_n, layer, select(last_valid, q_event, event == 2u), o, d), o, d);
    if (event == 1u) { return h; }
    let s = dot(h.p - o, d);
    if (h.object != INVALID && s > (f32(k) - 1.5) * ds && s < (f32(k) + 0.5) * ds) { return h; }
    // The tangent plane of this texel does not cut the step: refine by bisection between the
    // two samples against the buffer's depth.
    return bisect_exit(back_p, back_n, o, d, layer, g, (f32(k) - 1.0) * ds, f32(k) * ds);
}

// Iterative search for the receiver hit by the ray o + t d in the receiver map (all faces).
// Returns (hit point, 1) or (0, 0).
fn find_receiver(o: vec3f, d: vec3f) -> vec4f {
    let m = f32(light.info.w);
    let nfaces = light.info.x;
    // Where the guess lands on no receiver (the light ray behind the caster misses every
    // receiver), march along the ray in steps of a fraction of the scene's size.
    let step = light.extra.y / 32.0;
    var t = 0.0;
    var p = o;
    var converged_once = false;
    // A single face's view is convex (a frustum or a box), and so is a spot face with its
    // spill face (same eye and axis, the spill face wider: their union is the spill face's
    // frustum): once a sample beyond one inside it is outside, every later sample is too, and
    // the march below would find nothing.
    let convex = nfaces == 1u || u32(light.splat.y) == SPILL_FACE_PRESENT;
    var t_inside = 1e30;
    for (var it = 0u; it < 96u; it++) {
        var found = false;
        var proj = vec4f(0.0);
        var face = 0u;
        for (var f = 0u; f < nfaces; f++) {
            let q = project_face(light.faces[f], p, m);
            if (q.w > 0.5) { proj = q; face = f; found = true; break; }
        }
        if (found) { t_inside = min(t_inside, t); } else if (convex && t > t_inside) { return vec4f(0.0); }
        var r = vec4f(0.0, 0.0, 0.0, -1.0);
        var n = vec3f(0.0);
        if (found) {
            let tx = texel_of(proj.xy, light.info.w);
            r = textureLoad(recv_pos, tx, face, 0);
            n = textureLoad(recv_nrm, tx, face, 0).xyz;
        }
        var t_new = -1.0;
        if (r.w >= 0.0) {
            let dn = dot(d, n);
            t_new = length(r.xyz - o);
            if (abs(dn) > 1e-3) { t_new = dot(r.xyz - o, n) / dn; }
        }
        if (t_new <= 0.0) {
            // No receiver here (or behind the ray): march on.
            t += step;
            if (t > 4.0 * light.extra.y) { return vec4f(0.0); }
            p = o + t * d;
            continue;
        }
        if (abs(t_new - t) <= 1e-5 * t_new) { return vec4f(o + t_new * d, 1.0); }
        t = t_new;
        p = o + t * d;
    }
    return vec4f(0.0);
}


// Solid angle of the image-plane rectangle centred at (u, v) with sides (du, dv), at unit
// distance: the integral of (1 + u^2 + v^2)^(-3/2) by 2 x 2 Gauss-Legendre quadrature. The
// closed form (differences of atan) cancels catastrophically in f32 for small cells (errors of
// about 1 % per cell at a 1024^2 grid); the quadrature is accurate to about du^4 relative, so the
// flux of a cell equals the sum of its children's to about 1e-7 at the coarsest levels.
fn cell_solid_angle(u: f32, v: f32, du: f32, dv: f32) -> f32 {
    let g = 0.28867513; // 1 / (2 sqrt 3)
    var sum = 0.0;
    for (var k = 0u; k < 4u; k++) {
        let x = u + select(-g, g, (k & 1u) == 1u) * du;
        let y = v + select(-g, g, (k & 2u) == 2u) * dv;
        let r2 = 1.0 + x * x + y * y;
        sum += 1.0 / (r2 * sqrt(r2));
    }
    return 0.25 * sum * du * dv;
}

// Flux (W, rgb) of the light-view cell centred at `ndc` with NDC size `cell`: I(w) times the
// cell's solid angle (spot, point), or E times its area (directional).
fn cell_flux(layer: u32, ndc: vec2f, cell: vec2f, d: vec3f) -> vec3f {
    let face = light.faces[layer];
    if (face.origin.w > 0.5) {
        let ex = (face.clip_to_world * vec4f(cell.x, 0.0, 0.0, 0.0)).xyz;
        let ey = (face.clip_to_world * vec4f(0.0, cell.y, 0.0, 0.0)).xyz;
        return light.power.rgb * length(cross(ex, ey));
    }
    let t = light.extra.z;
    let omega = cell_solid_angle(ndc.x * t, ndc.y * t, cell.x * t, cell.y * t);
    return intensity_toward(light, d) * omega;
}

const MAX_BOUNCES: u32 = 4u;
// Total internal reflections followed inside a dielectric before the photon is given up.
const MAX_INTERNAL: u32 = 3u;
const STATUS_OK: u32 = 0u;
const STATUS_NO_EXIT: u32 = 1u;
const STATUS_TIR: u32 = 2u;

// Whether object `obj`, entered at p, is to be traversed through the light's second caster
// layer: it is not the first layer's object at p's texel (of face `layer`), and the second
// layer's front or back buffer holds it there (a caster hidden from the light behind another).
fn in_second_layer(p: vec3f, obj: u32, layer: u32, g: f32) -> bool {
    if (!trace_light_layer2) { return false; }
    let q = project_face(light.faces[layer], p, g);
    if (q.w < 0.5) { return false; }
    let t = texel_of(q.xy, u32(g));
    let f1 = textureLoad(front_pos, t, layer, 0).w;
    if (f1 >= 0.0 && u32(f1) == obj) { return false; }
    let f2 = textureLoad(front_pos2, t, layer, 0).w;
    if (f2 >= 0.0 && u32(f2) == obj) { return true; }
    let b1 = textureLoad(back_pos, t, layer, 0).w;
    if (b1 >= 0.0 && u32(b1) == obj) { return false; }
    let b2 = textureLoad(back_pos2, t, layer, 0).w;
    return b2 >= 0.0 && u32(b2) == obj;
}

struct Interaction {
    o: vec3f,
    d: vec3f,
    flux: vec3f,
    status: u32,
}

// One specular interaction at point p (surface normal n) of a photon travelling along d:
// mirrors and conductors reflect (weighted by their reflectance), dielectrics refract in and out
// (Fresnel transmittance at both interfaces; the exit found in the back-surface buffer).
// `obj` is the object hit: its exit is marched through the caster layer that holds it
// (in_second_layer).
fn interact(mat: MaterialGpu, obj: u32, p: vec3f, n_in: vec3f, d: vec3f, flux_in: vec3f, layer: u32, g: f32) -> Interaction {
    var r: Interaction;
    r.status = STATUS_OK;
    r.o = p;
    r.flux = flux_in;
    var n1 = n_in;
    if (dot(n1, d) > 0.0) { n1 = -n1; }
    let cos1 = -dot(d, n1);
    trace_internal = 0u;
    lens_exit_p = p;
    if (mat.kind.x == KIND_MIRROR) {
        r.flux *= mat.a.rgb;
        r.d = reflect(d, n1);
        rd_interface(mat, p, n1, d, r.d, 1.0, true);
        return r;
    }
    if (mat.kind.x == KIND_CONDUCTOR) {
        r.flux *= fresnel_conductor(cos1, mat.a.rgb, mat.b.rgb);
        r.d = reflect(d, n1);
        rd_interface(mat, p, n1, d, r.d, 1.0, true);
        return r;
    }
    let ior = mat.a.x;
    let ext = mat.a.y;
    r.flux *= 1.0 - fresnel_dielectric(cos1, ior / ext);
    let t1 = refract_dir(d, n1, ext / ior);
    rd_interface(mat, p, n1, d, t1.xyz, ext / ior, false);
    // Inside: march to the exit; on total internal reflection reflect (all the flux) and march
    // on, up to MAX_INTERNAL times. At a partial exit only the transmitted part is followed.
    var p_in = p;
    var t_in = t1.xyz;
    let second = in_second_layer(p, obj, layer, g);
    for (var k = 0u; k <= MAX_INTERNAL; k++) {
        var exit: Hit;
        if (second) {
            exit = march_exit(front_pos2, front_nrm2, back_pos2, back_nrm2, p_in, t_in, layer, g);
        } else {
            exit = march_exit(front_pos, front_nrm, back_pos, back_nrm, p_in, t_in, layer, g);
        }
        if (exit.object == INVALID) { r.status = STATUS_NO_EXIT; return r; }
        var n2 = exit.n;
        if (dot(n2, t_in) < 0.0) { n2 = -n2; }
        // Leaving the refractor: the normal facing the ray is -n2.
        let cos2 = dot(t_in, n2);
        let t2 = refract_dir(t_in, -n2, ior / ext);
        if (rd_active()) { rd_transfer(t_in, dot(exit.p - p_in, t_in), n2); }
        trace_absorb += mat.b.rgb * distance(exit.p, p_in);
        rd_interface(materials[exit.object], exit.p, -n2, t_in, t2.xyz, ior / ext, t2.w < 0.5);
        if (t2.w > 0.5) {
            trace_internal = k;
            lens_exit_p = exit.p;
            r.flux *= 1.0 - fresnel_dielectric(cos2, ext / ior);
            r.o = exit.p;
            r.d = t2.xyz;
            return r;
        }
        p_in = exit.p;
        t_in = reflect(t_in, n2);
    }
    r.status = STATUS_TIR;
    return r;
}

// The reflected branch at a dielectric: the Fresnel-weighted mirror reflection. Other materials
// have no second branch (status NO_EXIT, not booked: the photon simply does not exist).
fn reflect_dielectric(mat: MaterialGpu, p: vec3f, n_in: vec3f, d: vec3f, flux_in: vec3f) -> Interaction {
    var r: Interaction;
    r.status = STATUS_NO_EXIT;
    r.o = p;
    r.flux = vec3f(0.0);
    r.d = d;
    if (mat.kind.x != KIND_DIELECTRIC) { return r; }
    var n1 = n_in;
    if (dot(n1, d) > 0.0) { n1 = -n1; }
    r.flux = flux_in * fresnel_dielectric(-dot(d, n1), mat.a.x / mat.a.y);
    r.d = reflect(d, n1);
    rd_interface(mat, p, n1, d, r.d, 1.0, true);
    r.status = STATUS_OK;
    return r;
}

// The nearest analytic caster the ray meets (see `exact_shape` in shared/shapes.wgsl).
fn exact_caster(o: vec3f, d: vec3f, t_max: f32, leaving: u32) -> Hit {
    let h = exact_shape(o, d, t_max, leaving, true);
    var r: Hit;
    r.p = h.p;
    r.n = h.n;
    r.object = h.object;
    return r;
}

// The first caster surface the ray o + s d (0 < s < t_max) crosses, found by marching through
// the light-space caster front buffer: a crossing is a change of side (in front of / behind the
// buffer's surface, seen from the light) between two samples on the same, continuous surface.
// With the second caster layer, crossings of its front buffer count too (a caster hidden from
// the light behind another one). Exact position from the crossing texel's tangent plane.
// What the march remembers of one front buffer: the last sample's object, side and gap.
struct FrontTrack {
    obj: u32,
    side: f32,
    gap: f32,
}

// Whether front-buffer texel fp (w: object, < 0 for none), sampled at light depth `depth`, shows
// a crossing of the surface the previous sample saw (same object, side changed, both samples
// close to it); updates the track.
fn front_crossing(tr: ptr<function, FrontTrack>, fp: vec4f, depth: f32, face: Face, ds: f32) -> bool {
    if (fp.w < 0.0) {
        (*tr).obj = INVALID;
        return false;
    }
    let gap = depth - light_depth(face, fp.xyz);
    let obj = u32(fp.w);
    let side = sign(gap);
    let crossed = (*tr).obj == obj && side != (*tr).side && abs(gap) < 3.0 * ds && abs((*tr).gap) < 3.0 * ds;
    *tr = FrontTrack(obj, side, gap);
    return crossed;
}

// The faces with caster buffers (front, back and their second layers): all but a spot
// light's spill face, which only receives photons.
fn caster_faces() -> u32 {
    if (u32(light.splat.y) == SPILL_FACE_PRESENT) { return light.info.x - 1u; }
    return light.info.x;
}

fn find_caster(o: vec3f, d: vec3f, t_max: f32) -> Hit {
    var none: Hit;
    none.object = INVALID;
    let g = f32(light.params.w);
    let steps = 64u;
    let reach = min(t_max, 2.2 * light.extra.x);
    let ds = reach / f32(steps);
    var track = FrontTrack(INVALID, 0.0, 0.0);
    var track2 = FrontTrack(INVALID, 0.0, 0.0);
    var found = 0u;
    var s_found = 0.0;
    var q_found = vec2f(0.0);
    var layer_found = 0u;
    for (var k = 2u; k <= steps; k++) {
        let s = f32(k) * ds;
        let p = o + d * s;
        var layer = INVALID;
        var q = vec4f(0.0);
        for (var f = 0u; f < caster_faces(); f++) {
            let qq = project_face(light.faces[f], p, g);
            if (qq.w > 0.5) { q = qq; layer = f; break; }
        }
        if (layer == INVALID) {
            track.obj = INVALID;
            track2.obj = INVALID;
            continue;
        }
        let t = texel_of(q.xy, u32(g));
        let face = light.faces[layer];
        let depth = light_depth(face, p);
        // Both layers are tracked; the first layer wins when both cross in one step.
        if (trace_light_layer2 && front_crossing(&track2, textureLoad(front_pos2, t, layer, 0), depth, face, ds)) {
            found = 2u;
        }
        if (front_crossing(&track, textureLoad(front_pos, t, layer, 0), depth, face, ds)) {
            found = 1u;
        }
        if (found != 0u) {
            s_found = s;
            q_found = q.xy;
            layer_found = layer;
            break;
        }
    }
    // The refinement outside the march's loop (see march_exit).
    if (found == 0u) { return none; }
    var h: Hit;
    if (trace_light_layer2 && found == 2u) {
        h = refine_hit(front_pos2, front_nrm2, layer_found, buffer_hit(front_pos2, front_nrm2, layer_found, q_found, o, d), o, d);
    } else {
        h = refine_hit(front_pos, front_nrm, layer_found, buffer_hit(front_pos, front_nrm, layer_found, q_found, o, d), o, d);
    }
    if (h.object == INVALID) { return none; }
    let sh = dot(h.p - o, d);
    var hh = h;
    if (!(sh > s_found - 2.0 * ds && sh < s_found + ds)) { hh.p = o + d * s_found; }
    if (dot(hh.p - o, d) < 1.5 * ds) { return none; }
    return hh;
}

// Move the differentials along d to the point at distance t, onto its tangent plane (normal n).
fn rd_transfer(d: vec3f, t: f32, n: vec3f) {
    var pu = rd_pu + t * rd_du;
    var pv = rd_pv + t * rd_dv;
    let dn = dot(d, n);
    if (abs(dn) > 1e-6) {
        pu -= d * (dot(pu, n) / dn);
        pv -= d * (dot(pv, n) / dn);
    }
    rd_pu = pu;
    rd_pv = pv;
}

// Derivative of a buffer's stored normal field for the surface displacement dp, from central
// differences of positions and normals over the neighbouring texels of the same object
// (least-squares fit of dp in the two difference vectors).
fn buffer_dn(pos_tex: texture_2d_array<f32>, nrm_tex: texture_2d_array<f32>, layer: u32, t: vec2i, dp: vec3f) -> vec3f {
    let g = i32(textureDimensions(pos_tex).x);
    let c = textureLoad(pos_tex, t, layer, 0);
    let nc = normalize(textureLoad(nrm_tex, t, layer, 0).xyz);
    var e: array<vec3f, 2>;
    var dn: array<vec3f, 2>;
    for (var axis = 0; axis < 2; axis++) {
        let off = select(vec2i(0, 1), vec2i(1, 0), axis == 0);
        var pa = c.xyz;
        var na = nc;
        var pb = c.xyz;
        var nb = nc;
        let ta = t + off;
        let tb = t - off;
        if (all(ta >= vec2i(0)) && all(ta < vec2i(g))) {
            let q = textureLoad(pos_tex, ta, layer, 0);
            if (q.w == c.w) { pa = q.xyz; na = normalize(textureLoad(nrm_tex, ta, layer, 0).xyz); }
        }
        if (all(tb >= vec2i(0)) && all(tb < vec2i(g))) {
            let q = textureLoad(pos_tex, tb, layer, 0);
            if (q.w == c.w) { pb = q.xyz; nb = normalize(textureLoad(nrm_tex, tb, layer, 0).xyz); }
        }
        e[axis] = pa - pb;
        dn[axis] = na - nb;
    }
    let a00 = dot(e[0], e[0]);
    let a01 = dot(e[0], e[1]);
    let a11 = dot(e[1], e[1]);
    let det = a00 * a11 - a01 * a01;
    if (!(det > 1e-6 * a00 * a11)) { return vec3f(0.0); }
    let r0 = dot(e[0], dp);
    let r1 = dot(e[1], dp);
    return ((a11 * r0 - a01 * r1) * dn[0] + (a00 * r1 - a01 * r0) * dn[1]) / det;
}

// Derivative, for the surface displacement dp, of the unit normal `nref` (either orientation)
// of the caster surface with material `mat` at p: exact for analytic spheres, cylinders and
// rectangles, from the light-space caster buffer that holds p (front or back) for meshes: the
// first layer's only (a mesh in the second layer gets the first layer's derivatives there; reading
// the second layer here made photon_trace about 40 % slower on lavapipe, even in the pipelines
// built for other splat modes: measured on dragon_spheres).
fn surface_dn(mat: MaterialGpu, p: vec3f, nref: vec3f, dp_in: vec3f) -> vec3f {
    let dp = dp_in - nref * dot(dp_in, nref);
    if (mat.kind.z == SHAPE_SPHERE) {
        let s = select(-1.0, 1.0, dot(nref, p - mat.s0.xyz) >= 0.0);
        return s * dp / mat.s0.w;
    }
    if (mat.kind.z == SHAPE_CYLINDER) {
        let a = mat.s1.xyz;
        let w = p - mat.s0.xyz;
        let s = select(-1.0, 1.0, dot(nref, w - a * dot(w, a)) >= 0.0);
        return s * (dp - a * dot(dp, a)) / mat.s0.w;
    }
    if (mat.kind.z == SHAPE_RECTANGLE) { return vec3f(0.0); }
    if (trace_exact && exact_hit.tri != INVALID) {
        // The mesh triangle the exact tracer hit at p (a first hit taken from the light's
        // buffer has none: the buffer's derivatives below).
        let s = select(-1.0, 1.0, dot(nref, exact_hit.ns) >= 0.0);
        return s * rt_mesh_dn(exact_hit, dp);
    }
    let g = f32(light.params.w);
    for (var f = 0u; f < caster_faces(); f++) {
        let q = project_face(light.faces[f], p, g);
        if (q.w < 0.5) { continue; }
        let t = texel_of(q.xy, u32(g));
        let fp = textureLoad(front_pos, t, f, 0);
        let bp = textureLoad(back_pos, t, f, 0);
        if (bp.w >= 0.0 && (fp.w < 0.0 || length(bp.xyz - p) < length(fp.xyz - p))) {
            let s = select(-1.0, 1.0, dot(nref, textureLoad(back_nrm, t, f, 0).xyz) >= 0.0);
            return s * buffer_dn(back_pos, back_nrm, f, t, dp);
        }
        if (fp.w < 0.0) { return vec3f(0.0); }
        let s = select(-1.0, 1.0, dot(nref, textureLoad(front_nrm, t, f, 0).xyz) >= 0.0);
        return s * buffer_dn(front_pos, front_nrm, f, t, dp);
    }
    return vec3f(0.0);
}

// Refraction of the differentials (Igehy 1999): d incident, n the unit normal facing it, eta =
// n_incident / n_transmitted, t the refracted direction, dnu / dnv the normal's derivatives.
fn rd_refract(d: vec3f, n: vec3f, eta: f32, t: vec3f, dnu: vec3f, dnv: vec3f) {
    let dn = dot(d, n);
    let tn = dot(t, n);
    let mu = eta * dn - tn;
    let k = eta - eta * eta * dn / tn;
    let ddu = dot(rd_du, n) + dot(d, dnu);
    let ddv = dot(rd_dv, n) + dot(d, dnv);
    rd_du = eta * rd_du - (mu * dnu + k * ddu * n);
    rd_dv = eta * rd_dv - (mu * dnv + k * ddv * n);
}

fn rd_reflect(d: vec3f, n: vec3f, dnu: vec3f, dnv: vec3f) {
    let dn = dot(d, n);
    let ddu = dot(rd_du, n) + dot(d, dnu);
    let ddv = dot(rd_dv, n) + dot(d, dnv);
    rd_du = rd_du - 2.0 * (dn * dnu + ddu * n);
    rd_dv = rd_dv - 2.0 * (dn * dnv + ddv * n);
}

// Refract or reflect the differentials at p (normal n facing the incident ray d).
fn rd_interface(mat: MaterialGpu, p: vec3f, n: vec3f, d: vec3f, out_dir: vec3f, eta: f32, reflected: bool) {
    if (!rd_active()) { return; }
    let dnu = surface_dn(mat, p, n, rd_pu);
    let dnv = surface_dn(mat, p, n, rd_pv);
    if (reflected) { rd_reflect(d, n, dnu, dnv); } else { rd_refract(d, n, eta, out_dir, dnu, dnv); }
}

// Curvature of a caster buffer's surface at buffer texel coordinate uv along the buffer's x and
// y axes, with the normal oriented toward the light: (dn . dp) / |dp|^2 over the neighbouring
// texels of the same object (positive: convex toward the light).
fn buffer_curvature(pos_tex: texture_2d_array<f32>, nrm_tex: texture_2d_array<f32>, layer: u32, uv: vec2f) -> vec2f {
    let g = i32(textureDimensions(pos_tex).x);
    let t = texel_of(uv, u32(g));
    let p0 = textureLoad(pos_tex, t, layer, 0);
    if (p0.w < 0.0) { return vec2f(0.0); }
    let n0r = normalize(textureLoad(nrm_tex, t, layer, 0).xyz);
    let s0 = select(-1.0, 1.0, dot(n0r, to_light(light, p0.xyz).xyz) >= 0.0);
    let n0 = n0r * s0;
    var k = vec2f(0.0);
    for (var axis = 0; axis < 2; axis++) {
        var num = 0.0;
        var den = 0.0;
        for (var side = -1; side <= 1; side += 2) {
            let tt = t + select(vec2i(0, side), vec2i(side, 0), axis == 0);
            if (tt.x < 0 || tt.y < 0 || tt.x >= g || tt.y >= g) { continue; }
            let q = textureLoad(pos_tex, tt, layer, 0);
            if (q.w != p0.w) { continue; }
            let dp = q.xyz - p0.xyz;
            num += dot(normalize(textureLoad(nrm_tex, tt, layer, 0).xyz) * s0 - n0, dp);
            den += dot(dp, dp);
        }
        if (den > 0.0) { k[axis] = num / den; }
    }
    return k;
}

// The optical power (1 / focal length, per buffer axis) of the first specular interaction and
// the principal-plane offsets, from the lens maker's equation (Wyman & Dachsbacher 2008, eq. 2)
// with the front and back radii of curvature estimated from the light-space normals (thin
// lens; light.splat.x = 2: the thick-lens equations with the thickness front -> exit), or the
// mirror equation. Returns (power x, power y, h1 (front-side principal plane behind the front
// surface), 1) with h2 folded into h1's sign convention: see lens_diameter.
var<private> lens_h2: f32 = 0.0;
fn lens_power(mat: MaterialGpu, layer: u32, uv: vec2f, d: vec3f, p_front: vec3f, g: f32) -> vec4f {
    let kf = buffer_curvature(front_pos, front_nrm, layer, uv);
    lens_h2 = 0.0;
    if (mat.kind.x != KIND_DIELECTRIC) {
        // Mirror equation: 1/f = 2/R for a mirror concave toward the light (curvature < 0).
        return vec4f(-2.0 * kf, 0.0, 1.0);
    }
    let n = mat.a.x / mat.a.y;
    let q = project_face(light.faces[layer], lens_exit_p, g);
    let kb = buffer_curvature(back_pos, back_nrm, layer, q.xy);
    if (splat_mode() < 1.5) {
        return vec4f((n - 1.0) * (kf - kb), 0.0, 1.0);
    }
    let t = length(lens_exit_p - p_front);
    let p = (n - 1.0) * (kf - kb + (n - 1.0) * t * kf * kb / n);
    // Principal planes (mean over the axes): h1 behind the front vertex, h2 before the back one.
    let pm = 0.5 * (p.x + p.y);
    var h1 = 0.0;
    if (abs(pm) > 1e-6) {
        h1 = -(n - 1.0) * t * 0.5 * (kb.x + kb.y) / (n * pm);
        lens_h2 = (n - 1.0) * t * 0.5 * (kf.x + kf.y) / (n * pm);
    }
    return vec4f(p, h1, 1.0);
}

// Distance from the light to p (infinite for directional lights).
fn light_dist(face: Face, p: vec3f) -> f32 {
    if (face.origin.w > 0.5) { return 1e30; }
    return length(p - face.origin.xyz);
}

// Beam diameter on the receiver (eq. 7): D0 |d_front / (d_front + d_bg) (d_bg - d_image) /
// d_image| per axis with 1/d_image = power - 1/d_front, the geometric mean of the two axes.
fn lens_diameter(lens: vec4f, d_front_in: f32, d_bg_in: f32, d0: f32) -> f32 {
    let d_front = d_front_in + lens.z;
    let d_bg = max(d_bg_in + lens_h2, 0.0);
    let inv_front = select(1.0 / d_front, 0.0, d_front_in >= 1e29);
    let rho = abs(d_bg * (lens.xy - inv_front) - 1.0) / (1.0 + d_bg * inv_front);
    return d0 * sqrt(rho.x * rho.y);
}

// Ray differentials on landing: transfer onto the receiver's tangent plane at hit (normal from
// the receiver buffer at map texel uv), project the cell's image into the caustic map (size m)
// and return its diameter in texels: the square root of its area.
fn beam_diameter(f: u32, hit: vec3f, dir: vec3f, m: f32, uv: vec2f) -> f32 {
    let face = light.faces[f];
    let nr = textureLoad(recv_nrm, texel_of(uv, u32(m)), f, 0).xyz;
    var n = nr;
    if (dot(n, n) < 1e-12) { n = -dir; }
    rd_transfer(dir, dot(hit - rd_from, dir), normalize(n));
    let qu = project_face(face, hit + 0.5 * rd_pu, m).xy - project_face(face, hit - 0.5 * rd_pu, m).xy;
    let qv = project_face(face, hit + 0.5 * rd_pv, m).xy - project_face(face, hit - 0.5 * rd_pv, m).xy;
    let area = abs(qu.x * qv.y - qu.y * qv.x);
    if (!(area < 1e30)) { return 0.0; }
    return sqrt(area);
}

// The photon that lands at receiver point p travelling along dir with `flux` (path signature
// sig): its caustic-map position and splat data (the lens equations' beam diameter, lens being
// the first caster's optical power and lens_front its first surface point, or the ray
// differentials' footprint), booked as landed, or as outside the map where no face sees p.
// In a medium (light.medium_lo.w > 0; stages that import `trace` import `medium` before it and
// bind the density grid as `density_grid`): the photon's optical path (length in the medium's
// box, times the density where a grid gives one, marched in medium_sigma_t.w steps per segment)
// outside dielectrics, from the light
// (a directional light: from where its line leaves the box, `light_path_start`) through every
// segment between interfaces that does not run inside a dielectric, to the receiver. The photon
// lands with its flux times exp(-sigma_t * length), so the caustic map holds the light that
// arrives, as the CPU reference's does (the straight line from the light, which its consumers
// used before, runs through the glass: the caustic under a ball lost e^(-sigma_t * 2R)).
var<private> trace_fog: f32 = 0.0;

fn fog_add(a: vec3f, b: vec3f) {
    if (light.medium_lo.w > 1.5) {
        trace_fog += grid_optical_depth(density_grid, a, b, light.medium_lo.xyz, light.medium_hi.xyz, u32(light.medium_sigma_t.w));
    } else if (light.medium_lo.w > 0.5) {
        trace_fog += box_length(a, b, light.medium_lo.xyz, light.medium_hi.xyz);
    }
}

// The photon's optical depth (rgb) inside absorbing dielectrics: the sum of absorption
// coefficient times length over its segments inside them (Beer–Lambert); land_photon applies it.
var<private> trace_absorb: vec3f = vec3f(0.0);

// The first segment: from the light to the first caster point p.
fn fog_begin(p: vec3f) {
    trace_fog = 0.0;
    trace_absorb = vec3f(0.0);
    if (light.medium_lo.w > 0.5) { fog_add(light_path_start(light, p, light.medium_lo.xyz, light.medium_hi.xyz), p); }
}

fn land_photon(layer: u32, p: vec3f, dir: vec3f, flux_in: vec3f, sig: u32, lens: vec4f, lens_front: vec3f, cell: vec2f) -> Photon {
    var out: Photon;
    out.face = INVALID;
    out.flux = vec4f(0.0);
    // The bookkeeping counts the optics' flux; the map gets what the medium lets through.
    let total = flux_in.r + flux_in.g + flux_in.b;
    var flux = flux_in;
    if (light.medium_lo.w > 0.5) { flux *= exp(-light.medium_sigma_t.rgb * trace_fog); }
    if (any(trace_absorb > vec3f(0.0))) { flux *= exp(-trace_absorb); }
    let m = f32(light.info.w);
    for (var f = 0u; f < light.info.x; f++) {
        let q = project_face(light.faces[f], p, m);
        if (q.w > 0.5) {
            out.pos = q.xy;
            out.face = f;
            out.flux = vec4f(flux, f32(sig));
            if (splat_mode() > 0.5 && splat_mode() < 2.5 && lens.w > 0.0) {
                let d_front = light_dist(light.faces[layer], lens_front);
                out._pad = bitcast<u32>(lens_diameter(lens, d_front, length(p - lens_exit_p), cell.x * 0.5 * m));
            }
            if (rd_active()) {
                // A residual-pass photon stands for the cells around it whose photons chose
                // other paths: one in 1/residual_prob of its neighbours takes its path, so its
                // footprint spans sqrt(1/residual_prob) cells per axis (energy is unchanged:
                // splats are normalised). Without this, the residual light lands as sparse dots.
                let spread = inverseSqrt(clamp(residual_prob, 1e-4, 1.0));
                out._pad = bitcast<u32>(beam_diameter(f, p, dir, m, q.xy) * spread);
            }
            add_fixed(2u, total);
            return out;
        }
    }
    add_fixed(10u, total);
    return out;
}

// Trace the photon of the light-view cell centred at `ndc` (NDC size `cell`) of face `layer`.
// Returns face = INVALID when it carries no caustic (missed the casters, lost on the way).
// Adds its flux to the bookkeeping in `stats`.
fn trace_photon_image(layer: u32, ndc: vec2f, cell: vec2f) -> Photon {
    var out: Photon;
    out.face = INVALID;
    out.flux = vec4f(0.0);
    let face = light.faces[layer];
    let ray = light_ray(face, ndc);
    let a = ray.o;
    let d = ray.d;

    let g = f32(light.params.w);
    let uv = vec2f(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5) * g;
    let front = buffer_hit(front_pos, front_nrm, layer, uv, a, d);
    if (front.object == INVALID) { return out; }
    let mat = materials[front.object];
    if (mat.kind.y == 0u || mat.kind.x == KIND_DIFFUSE) { return out; }

    var flux = cell_flux(layer, ndc, cell, d);
    let total_in = flux.r + flux.g + flux.b;
    if (total_in <= 0.0) { return out; }
    fog_begin(front.p);
    // The cell's rays: across the whole cell along each grid axis (central differences).
    rd_begin(layer, ndc, cell, a);
    // Flux onto the casters is booked once, by the transmitted branch.
    if (!trace_reflect) { add_fixed(0u, total_in); }

    var o = front.p;
    var dir = d;
    var hit_p = front.p;
    var hit_n = front.n;
    var obj = front.object;
    // Up to MAX_BOUNCES specular interactions: the first at the caster seen by the light, the
    // later ones wherever the outgoing ray meets another caster surface on its way to the
    // receiver (the inside of a mirror ring, a second glass object).
    var sig = 0u;
    var lens = vec4f(0.0);
    for (var bounce = 0u; bounce < MAX_BOUNCES; bounce++) {
        if (rd_active()) { rd_transfer(dir, dot(hit_p - rd_from, dir), hit_n); }
        var r: Interaction;
        if (bounce == 0u && trace_reflect) {
            r = reflect_dielectric(materials[obj], hit_p, hit_n, dir, flux);
            if (r.status != STATUS_OK) { return out; }
        } else {
            r = interact(materials[obj], obj, hit_p, hit_n, dir, flux, layer, g);
        }
        sig = (sig * 31u + obj * 8u + trace_internal + 1u) & 0xffffffu;
        if (bounce == 0u && !trace_reflect && splat_mode() > 0.5 && splat_mode() < 2.5 && r.status == STATUS_OK) {
            lens = lens_power(materials[obj], layer, uv, d, front.p, g);
        }
        if (r.status == STATUS_NO_EXIT) { add_fixed(4u, r.flux.r + r.flux.g + r.flux.b); return out; }
        if (r.status == STATUS_TIR) { add_fixed(6u, r.flux.r + r.flux.g + r.flux.b); return out; }
        o = r.o;
        dir = r.d;
        flux = r.flux;
        rd_from = o;
        let total = flux.r + flux.g + flux.b;
        let hit = find_receiver(o + dir * 1e-4, dir);
        var t_recv = 1e30;
        if (hit.w > 0.5) { t_recv = length(hit.xyz - o); }
        var next: Hit;
        next.object = INVALID;
        if (light.extra.w > 0.5 && bounce + 1u < MAX_BOUNCES) {
            // Analytic casters exactly; meshes by marching through the light's caster buffer.
            next = exact_caster(o, dir, t_recv, obj);
            if (light.extra.w > 1.5) {
                var reach = t_recv;
                if (next.object != INVALID) { reach = dot(next.p - o, dir); }
                let m = find_caster(o, dir, reach);
                if (m.object != INVALID && materials[m.object].kind.z == SHAPE_MESH) { next = m; }
            }
        }
        // (o is where the photon left the last interface: outside any dielectric)
        if (next.object != INVALID) {
            fog_add(o, next.p);
            hit_p = next.p;
            hit_n = next.n;
            obj = next.object;
            continue;
        }
        // Landing (a further caster after the last bounce followed is ignored).
        if (hit.w < 0.5) { add_fixed(8u, total); return out; }
        fog_add(o, hit.xyz);
        return land_photon(layer, hit.xyz, dir, flux, sig, lens, front.p, cell);
    }
    return out;
}

// The light's ray through NDC point ndc of a face: from the near plane, unit direction.
struct LightRay {
    o: vec3f,
    d: vec3f,
}

fn light_ray(face: Face, ndc: vec2f) -> LightRay {
    let a4 = face.clip_to_world * vec4f(ndc, 0.0, 1.0);
    let b4 = face.clip_to_world * vec4f(ndc, 1.0, 1.0);
    let a = a4.xyz / a4.w;
    return LightRay(a, normalize(b4.xyz / b4.w - a));
}

// The setup both tracers share for the photon of a cell: the ray differentials across the
// cell (light.splat.x == 3), from the light ray (a, d) through the cell's centre.
fn rd_begin(layer: u32, ndc: vec2f, cell: vec2f, a: vec3f) {
    rd_on = splat_mode() > 2.5;
    if (!rd_active()) { return; }
    let face = light.faces[layer];
    let hu = vec2f(0.5 * cell.x, 0.0);
    let hv = vec2f(0.0, 0.5 * cell.y);
    let ray = array<vec2f, 4>(ndc + hu, ndc - hu, ndc + hv, ndc - hv);
    var ro: array<vec3f, 4>;
    var rdir: array<vec3f, 4>;
    for (var k = 0u; k < 4u; k++) {
        let r = light_ray(face, ray[k]);
        ro[k] = r.o;
        rdir[k] = r.d;
    }
    rd_pu = ro[0] - ro[1];
    rd_pv = ro[2] - ro[3];
    rd_du = rdir[0] - rdir[1];
    rd_dv = rdir[2] - rdir[3];
    rd_from = a;
}

// The photon of the light-view cell at `ndc` on its exact path: from the light through the
// scene (shared/raytrace.wgsl: meshes by their BVH, analytic shapes in closed form) to the
// first diffuse surface, with refraction and reflection at every interface (shading normals
// as the CPU reference uses them), total internal reflection, up to trace_max_depth specular
// interactions, any number of casters in any arrangement.
// Fresnel: the flux splits deterministically at every dielectric interface: a photon follows
// one branch of the tree of paths (transmitted, weighted 1 - F, except where the branch mask
// says reflected, weighted F; total internal reflection reflects all), so that neighbouring
// photons take the same branch and caustic triangles stay continuous. The transmitted path
// and (trace_reflect) the path reflected at the first surface are traced; the flux of the
// other branches (light reflected inside a dielectric and leaving later) is not, as in the
// image-space tracer: it is the part of the CPU reference's caustic the GPU lacks.
// (Choosing the branch at random per photon, as the CPU reference does, is unbiased but
// breaks the caustic triangles between neighbours that chose differently.) Bookkeeping as trace_photon_image: 0 onto
// casters, 2 landed, 6 lost after trace_max_depth interactions, 8 left the scene, 10 landed
// outside the map, 14 the branches not followed.
fn trace_photon_exact(layer: u32, ndc: vec2f, cell: vec2f) -> Photon {
    var out: Photon;
    out.face = INVALID;
    out.flux = vec4f(0.0);
    let face = light.faces[layer];
    let ray = light_ray(face, ndc);
    let a = ray.o;
    let d = ray.d;
    let g = f32(light.params.w);
    let uv = vec2f(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5) * g;

    var h = rt_none();
    if (trace_first_hit_buffer) {
        let fb = buffer_hit(front_pos, front_nrm, layer, uv, a, d);
        if (fb.object == INVALID) { return out; }
        let fr = refine_hit(front_pos, front_nrm, layer, fb, a, d);
        if (fr.object == INVALID) { return out; }
        h.p = fr.p;
        h.ng = fr.n;
        h.ns = fr.n;
        h.object = fr.object;
        h.t = dot(fr.p - a, d);
    } else {
        h = scene_hit(a, d, 1e30);
    }
    if (h.object == INVALID) { return out; }
    let first = h;
    let mat0 = materials[h.object];
    if (mat0.kind.y == 0u || mat0.kind.x == KIND_DIFFUSE) { return out; }
    var flux = cell_flux(layer, ndc, cell, d);
    let total_in = flux.r + flux.g + flux.b;
    if (total_in <= 0.0) { return out; }
    fog_begin(first.p);
    rd_begin(layer, ndc, cell, a);
    // Booked once, by the transmitted branch's pass.
    if (!trace_reflect && !trace_internal_branch && !trace_residual) { add_fixed(0u, total_in); }
    let branch = u32(trace_reflect) | (u32(trace_internal_branch) << 1u);
    let key = (bitcast<u32>(ndc.x) * 2654435761u) ^ (bitcast<u32>(ndc.y) * 2246822519u) ^ (layer * 3266489917u);
    var chosen = 0u;
    residual_prob = 1.0;

    var dir = d;
    var sig = 0u;
    var lens_ready = false;
    // The absorption coefficient of the dielectric the photon travels in (as the CPU
    // reference's: set going into a dielectric, cleared going out, kept by mirrors).
    var sigma = vec3f(0.0);
    lens_exit_p = first.p;
    var depth = 0u;
    loop {
        let mat = materials[h.object];
        // The internal branch's pass carries only paths that took its branch (at depth 1):
        // the others are the transmitted pass's.
        if (trace_internal_branch && depth == 1u && mat.kind.x != KIND_DIELECTRIC) { return out; }
        if (mat.kind.x == KIND_DIFFUSE) { break; }
        if (depth >= trace_max_depth) {
            if (trace_internal_branch && depth <= 1u || residual_covered(chosen)) { return out; }
            add_fixed(6u, flux.r + flux.g + flux.b);
            return out;
        }
        exact_hit = h;
        if (rd_active()) { rd_transfer(dir, dot(h.p - rd_from, dir), h.ng); }
        let front = dot(dir, h.ng) < 0.0;
        let ng = select(-h.ng, h.ng, front);
        let ns = select(-h.ns, h.ns, front);
        // The interface step (shared/raytrace.wgsl, as the beam edges': beam_refine.wgsl).
        var n = ns;
        var reflected = true;
        var eta = 1.0;
        if (mat.kind.x == KIND_MIRROR || mat.kind.x == KIND_CONDUCTOR) {
            flux *= rt_metal_weight(mat, dir, ns);
        } else {
            let fz = rt_dielectric_fresnel(mat, dir, ns, ng, front);
            n = fz.n;
            eta = fz.eta;
            let f = fz.f;
            // The branch of this interface: reflected where the branch mask says so (bit 0:
            // trace_reflect), transmitted otherwise; total internal reflection reflects all.
            let want = depth < 32u && ((branch >> depth) & 1u) == 1u;
            // Total internal reflection at depth 1: the transmitted pass reflects it all.
            if (trace_internal_branch && depth == 1u && f >= 1.0) { return out; }
            reflected = want || f >= 1.0;
            var kept = select(1.0 - f, select(f, 1.0, f >= 1.0), reflected);
            if (trace_residual) {
                // A random choice with the Fresnel probabilities: the whole flux follows it.
                reflected = f >= 1.0 || residual_random(key, depth) < f;
                if (f < 1.0) { residual_prob *= select(1.0 - f, f, reflected); }
                if (reflected && f < 1.0) { chosen |= 1u << min(depth, 31u); }
                kept = 1.0;
            }
            // The branch not followed (after the first surface, whose other branch is the
            // reflected pass's; at the second, the internal pass's when it runs): untraced,
            // unless the residual pass carries it.
            let other_pass = depth == 1u && ((trace_covered >> 2u) & 1u) == 1u && !trace_reflect;
            if (depth > 0u && kept < 1.0 && !other_pass && !trace_residual_pass) {
                add_fixed(14u, (1.0 - kept) * (flux.r + flux.g + flux.b));
            }
            flux *= kept;
        }
        let bz = rt_bounce(dir, n, ng, eta, reflected);
        n = bz.n;
        reflected = bz.reflected;
        let new_dir = bz.dir;
        let eta_rd = bz.eta_rd;
        rd_interface(mat, h.p, n, dir, new_dir, eta_rd, reflected);
        sig = (sig * 31u + h.object * 8u + u32(reflected) * 2u + u32(front) + 1u) & 0xffffffu;
        // The lens equations' exit: where the photon first leaves the first object.
        if (!lens_ready && depth > 0u && !reflected && !front && h.object == first.object) {
            lens_exit_p = h.p;
            lens_ready = true;
        }
        dir = new_dir;
        var o = rt_spawn(h.p, h.ng, dir);
        if (trace_first_hit_buffer && depth == 0u) {
            // A buffer's surface is the rasterized one, up to a tessellation's sagitta inside the
            // true shape: leave it by more than that gap (1/500 of the casters' radius), or the
            // next ray meets the true surface right away.
            o = h.p + h.ng * select(-1.0, 1.0, dot(dir, h.ng) >= 0.0) * 2e-3 * light.extra.x;
        }
        rd_from = h.p;
        depth++;
        if (flux.r + flux.g + flux.b <= 0.0) { return out; }
        // Inside a dielectric after entering it, or reflecting inside it: no medium there.
        let inside = mat.kind.x == KIND_DIELECTRIC && (front != reflected);
        if (mat.kind.x == KIND_DIELECTRIC) { sigma = select(vec3f(0.0), mat.b.rgb, inside); }
        let seg_from = h.p;
        h = scene_hit(o, dir, 1e30);
        if (h.object == INVALID) {
            if (trace_internal_branch && depth <= 1u || residual_covered(chosen)) { return out; }
            add_fixed(8u, flux.r + flux.g + flux.b);
            return out;
        }
        if (!inside) { fog_add(o, h.p); }
        trace_absorb += sigma * distance(seg_from, h.p);
    }
    if (residual_covered(chosen)) { return out; }
    let total = flux.r + flux.g + flux.b;
    var lens = vec4f(0.0);
    if (splat_mode() > 0.5 && splat_mode() < 2.5 && !trace_reflect) {
        lens = lens_power(materials[first.object], layer, uv, d, first.p, g);
    }
    return land_photon(layer, h.p, dir, flux, sig, lens, first.p, cell);
}

// The photon of the light-view cell centred at `ndc` (NDC size `cell`) of face `layer`, by
// the tracer the pipeline was built for. Returns face = INVALID when it carries no caustic.
// Stack overflows of the exact tracer are counted in stats word 12.
fn trace_photon(layer: u32, ndc: vec2f, cell: vec2f) -> Photon {
    if (trace_exact) {
        rt_overflow = 0u;
        let p = trace_photon_exact(layer, ndc, cell);
        if (rt_overflow > 0u) { atomicAdd(&stats[12u], rt_overflow); }
        return p;
    }
    return trace_photon_image(layer, ndc, cell);
}
