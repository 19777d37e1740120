// Stage: photon_trace. Basic caustic maps (Wyman & Nichols 2009, section 2; Shah et al. 2007):
// one photon per cell of a dense N x N grid over one face of the light view. Each photon reads
// the caster front/back geometry buffers (light space) at its cell, refracts at the front and
// back surface (image-space two-interface approximation, refined by re-projecting the exit point
// into the back-surface buffer), or reflects once off a mirror or conductor, then finds the
// receiver it hits by an iterative search in the receiver position map (light space).
// Flux: I(w) * dw of the photon's cell (spot, point) or E * cell area (directional), times the
// Fresnel transmittance at each interface (reflectance for mirrors and conductors).
// Total internal reflection at the back surface ends the photon; its flux is counted as lost.
// Output: one Photon per grid cell of the batch (face = INVALID when it carries no caustic).

struct TraceParams {
    face: u32,
    batch_offset: u32,
    batch_count: u32,
    _pad: u32,
}

struct Photon {
    // texel coordinates in the caustic map (continuous), and the face
    pos: vec2f,
    face: u32,
    _pad: u32,
    flux: vec4f,
}

@group(0) @binding(0) var<uniform> light: LightGpu;
@group(0) @binding(1) var<uniform> tp: TraceParams;
@group(0) @binding(2) var front_pos: texture_2d_array<f32>;
@group(0) @binding(3) var front_nrm: texture_2d_array<f32>;
@group(0) @binding(4) var back_pos: texture_2d_array<f32>;
@group(0) @binding(5) var back_nrm: texture_2d_array<f32>;
@group(0) @binding(6) var recv_pos: texture_2d_array<f32>;
@group(0) @binding(7) var recv_nrm: texture_2d_array<f32>;
@group(0) @binding(8) var<storage, read> materials: array<MaterialGpu>;
@group(0) @binding(9) var<storage, read_write> photons: array<Photon>;
// Fixed-point flux totals (lo, hi word pairs, r + g + b): 0 emitted onto casters, 2 landed in
// the map, 4 lost for want of a back surface, 6 lost to total internal reflection, 8 lost for
// want of a receiver, 10 landed outside the map.
@group(0) @binding(10) var<storage, read_write> stats: array<atomic<u32>>;

fn add_fixed(slot: u32, value: f32) {
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
    let n = normalize(textureLoad(nrm_tex, t, layer, 0).xyz);
    let dn = dot(d, n);
    var p = pw.xyz;
    if (abs(dn) > 1e-4) {
        let s = dot(pw.xyz - o, n) / dn;
        if (s > 0.0) { p = o + s * d; }
    }
    h.p = p;
    h.n = n;
    h.object = u32(pw.w);
    return h;
}

// Distance of p from the light along its view (perspective: from the light; orthographic:
// along the light direction).
fn light_depth(face: Face, p: vec3f) -> f32 {
    if (face.origin.w > 0.5) { return dot(p, face.origin.xyz); }
    return length(p - face.origin.xyz);
}

fn march_back(o: vec3f, d: vec3f, layer: u32, g: f32) -> Hit {
    var none: Hit;
    none.object = INVALID;
    let face = light.faces[layer];
    let steps = 96u;
    let ds = 2.2 * light.extra.x / f32(steps);
    var last_valid = vec2f(-1.0);
    for (var k = 1u; k <= steps; k++) {
        let p = o + d * (f32(k) * ds);
        let q = project_face(face, p, g);
        if (q.w < 0.5) { break; }
        let t = texel_of(q.xy, u32(g));
        let bp = textureLoad(back_pos, t, layer, 0);
        if (bp.w < 0.0) {
            // Left the silhouette between two samples: exit through the last back texel seen.
            if (last_valid.x < 0.0) { return none; }
            return buffer_hit(back_pos, back_nrm, layer, last_valid, o, d);
        }
        last_valid = q.xy;
        if (light_depth(face, p) >= light_depth(face, bp.xyz)) {
            let h = buffer_hit(back_pos, back_nrm, layer, q.xy, o, d);
            let s = dot(h.p - o, d);
            if (h.object != INVALID && s > (f32(k) - 1.5) * ds && s < (f32(k) + 0.5) * ds) { return h; }
            var hh = h;
            hh.p = p;
            return hh;
        }
    }
    return none;
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
    for (var it = 0u; it < 96u; it++) {
        var found = false;
        var proj = vec4f(0.0);
        var face = 0u;
        for (var f = 0u; f < nfaces; f++) {
            let q = project_face(light.faces[f], p, m);
            if (q.w > 0.5) { proj = q; face = f; found = true; break; }
        }
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

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    if (gid.x >= tp.batch_count) { return; }
    let index = tp.batch_offset + gid.x;
    let n_grid = light.info.z;
    let i = index % n_grid;
    let j = index / n_grid;
    var out: Photon;
    out.face = INVALID;
    out.flux = vec4f(0.0);
    photons[gid.x] = out;

    let face = light.faces[tp.face];
    let ndc = vec2f((2.0 * (f32(i) + 0.5) / f32(n_grid)) - 1.0, 1.0 - 2.0 * (f32(j) + 0.5) / f32(n_grid));
    let a4 = face.clip_to_world * vec4f(ndc, 0.0, 1.0);
    let b4 = face.clip_to_world * vec4f(ndc, 1.0, 1.0);
    let a = a4.xyz / a4.w;
    let b = b4.xyz / b4.w;
    let d = normalize(b - a);

    let g = f32(light.params.w);
    let uv = vec2f((f32(i) + 0.5) / f32(n_grid), (f32(j) + 0.5) / f32(n_grid)) * g;
    let front = buffer_hit(front_pos, front_nrm, tp.face, uv, a, d);
    if (front.object == INVALID) { return; }
    let mat = materials[front.object];
    if (mat.kind.y == 0u || mat.kind.x == KIND_DIFFUSE) { return; }

    // Flux of this photon's cell.
    var flux: vec3f;
    let cell = 2.0 / f32(n_grid);
    if (face.origin.w > 0.5) {
        // Orthographic: the cell's area perpendicular to the light.
        let ex = (face.clip_to_world * vec4f(cell, 0.0, 0.0, 0.0)).xyz;
        let ey = (face.clip_to_world * vec4f(0.0, cell, 0.0, 0.0)).xyz;
        flux = light.power.rgb * length(cross(ex, ey));
    } else {
        // Solid angle of the cell: its area on the image plane at unit distance times cos^3.
        let axis4 = face.clip_to_world * vec4f(0.0, 0.0, 1.0, 1.0);
        let axis = normalize(axis4.xyz / axis4.w - face.origin.xyz);
        let c0 = face.clip_to_world * vec4f(ndc, 1.0, 1.0);
        let cx = face.clip_to_world * vec4f(ndc + vec2f(cell, 0.0), 1.0, 1.0);
        let cy = face.clip_to_world * vec4f(ndc + vec2f(0.0, cell), 1.0, 1.0);
        let p0 = c0.xyz / c0.w;
        let far_d = dot(p0 - face.origin.xyz, axis);
        let area = length(cross(cx.xyz / cx.w - p0, cy.xyz / cy.w - p0)) / (far_d * far_d);
        let cos_a = dot(d, axis);
        flux = intensity_toward(light, d) * area * cos_a * cos_a * cos_a;
    }
    let total_in = flux.r + flux.g + flux.b;
    if (total_in <= 0.0) { return; }
    add_fixed(0u, total_in);

    var o = front.p;
    var dir = d;
    var n1 = front.n;
    if (dot(n1, d) > 0.0) { n1 = -n1; }
    let cos1 = -dot(d, n1);
    if (mat.kind.x == KIND_MIRROR) {
        flux *= mat.a.rgb;
        dir = reflect(d, n1);
    } else if (mat.kind.x == KIND_CONDUCTOR) {
        flux *= fresnel_conductor(cos1, mat.a.rgb, mat.b.rgb);
        dir = reflect(d, n1);
    } else {
        let ior = mat.a.x;
        let ext = mat.a.y;
        flux *= 1.0 - fresnel_dielectric(cos1, ior / ext);
        let t1 = refract_dir(d, n1, ext / ior);
        // Back surface: march the refracted ray through the light-space back-surface buffer
        // until it passes behind the back surface (or leaves its silhouette), then take the
        // exact intersection with that texel's tangent plane.
        let back = march_back(o, t1.xyz, tp.face, g);
        if (back.object == INVALID) { add_fixed(4u, flux.r + flux.g + flux.b); return; }
        var n2 = back.n;
        if (dot(n2, t1.xyz) < 0.0) { n2 = -n2; }
        // Leaving the refractor: the normal facing the ray is -n2.
        let cos2 = dot(t1.xyz, n2);
        let f2 = fresnel_dielectric(cos2, ext / ior);
        let t2 = refract_dir(t1.xyz, -n2, ior / ext);
        if (t2.w < 0.5) { add_fixed(6u, flux.r + flux.g + flux.b); return; }
        flux *= 1.0 - f2;
        o = back.p;
        dir = t2.xyz;
    }
    let total = flux.r + flux.g + flux.b;
    let hit = find_receiver(o + dir * 1e-4, dir);
    if (hit.w < 0.5) { add_fixed(8u, total); return; }
    let m = f32(light.info.w);
    for (var f = 0u; f < light.info.x; f++) {
        let q = project_face(light.faces[f], hit.xyz, m);
        if (q.w > 0.5) {
            out.pos = q.xy;
            out.face = f;
            out.flux = vec4f(flux, 0.0);
            photons[gid.x] = out;
            add_fixed(2u, total);
            return;
        }
    }
    add_fixed(10u, total);
}
