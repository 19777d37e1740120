// Stage: beam_gather. The single scattering of the beams' light toward the camera (Liktor &
// Dachsbacher 2011, section 5, equations 2-5, after Ernst et al. 2005), one thread per pixel
// over the ordered beam list (beam_order): every beam is met once per pixel ray, so a camera inside
// a beam counts it once too. Per beam, the pixel centre's ray from the camera to the first
// surface it sees (the nearer of the eye's diffuse and specular buffers), clipped to the
// medium's box, is tested against the beam's bounding sphere, then intersected with the beam
// exactly: in beam space (the base triangle's plane, edges scaled to unit height y) the
// cross-section at height y is the triangle q_i(y) = v_i + y d_i / (n . d_i), and along the ray
// its three edge functions are quadratics in the ray parameter, so the ray's pieces inside the
// beam lie between their roots. Each piece is integrated in `bp.samples` steps of
//   sigma_s phase(d . -w) Phi / (A(y) cos theta) exp(-sigma_t (l_light + s)) exp(-sigma_t t_eye),
// the smooth factors at each step's midpoint times the exact integral of 1 / A over the step
// (A is a quadratic in the ray parameter: near a focus the midpoint rule would sample its pole),
// A(y) the cross-section's area (a quadratic in y), theta the angle between the interpolated
// edge direction d and the base normal (Phi / A(y) is the irradiance of the cross-section's
// plane; over cos theta, the fluence of the beam's light), l_light the in-medium length of the
// light's path up to the base (interpolated), s the in-medium length from the base to the
// point, t_eye from the camera's box entry to the point. A point lies in the beam up to the
// plane through its edges' ends (the receivers). The pixel's camera ray ends at the first
// surface (a hard clip: the exact interval needs no soft clipping). Each pixel averages
// `bp.pixel_samples`^2 stratified rays (the box pixel filter).

#import beams
#import medium

@group(0) @binding(0) var<uniform> bp: BeamParams;
@group(0) @binding(1) var recv_pos: texture_2d<f32>;
@group(0) @binding(2) var spec_pos: texture_2d<f32>;
@group(0) @binding(3) var<storage, read> beams: array<BeamGpu>;
@group(0) @binding(4) var<storage, read> order: array<u32>;
@group(0) @binding(5) var<storage, read> stats: array<u32>;
@group(0) @binding(6) var<storage, read_write> out_full: array<vec4f>;
@group(0) @binding(7) var<storage, read_write> out_caustic: array<vec4f>;
// The chunk of the ordered list this dispatch gathers: beams offset .. offset + base_count.
// One dispatch per chunk, in order: lavapipe was measured to stop a pixel's loop after about
// 65536 loop iterations in all (some 950 beams), so a pixel never loops over all beams at once.
@group(0) @binding(8) var<uniform> chunk: BeamLevel;

// Roots of c2 u^2 + c1 u + c0 in (0, len), appended to `cuts` (count in `n`).
fn add_roots(c: vec3f, len: f32, cuts: ptr<function, array<f32, 12>>, n: ptr<function, u32>) {
    var r = vec2f(-1.0);
    let scale = abs(c.x) * len * len + abs(c.y) * len + abs(c.z);
    if (abs(c.z) * len * len <= 1e-7 * scale) {
        if (c.y != 0.0) { r.x = -c.x / c.y; }
    } else {
        let disc = c.y * c.y - 4.0 * c.z * c.x;
        if (disc < 0.0) { return; }
        let q = -0.5 * (c.y + select(-1.0, 1.0, c.y >= 0.0) * sqrt(disc));
        r.x = q / c.z;
        if (q != 0.0) { r.y = c.x / q; }
    }
    for (var k = 0; k < 2; k++) {
        if (r[k] > 0.0 && r[k] < len && *n < 10u) {
            (*cuts)[*n] = r[k];
            *n += 1u;
        }
    }
}

// The integral of 1 / |S(u)| over a step [u0, u0 + h] of length h, S a quadratic without a
// root inside the step (the pieces are cut at its roots), given by its values at the start,
// middle and end. S in Bernstein form over the step,
// S(t) = Sa (1 - t)^2 + 2 P t (1 - t) + Sb t^2, and t = x / (1 + x) turn it into
// h * integral over x in [0, inf) of dx / (Sa + 2 P x + Sb x^2) = h * I with D = Sa Sb - P^2:
// I = atan2(sqrt(D), P) / sqrt(D) (D > 0), atanh(q / P) / q, q = sqrt(-D) (D < 0), and
// (1 - D / (3 P^2)) / P near D = 0 (both series agree there). A root at an end (a ray through
// a focus line) makes the integral diverge logarithmically: the ends are kept off zero.
fn inv_quadratic_integral(s_a: f32, s_m: f32, s_b: f32, h: f32) -> f32 {
    let sg = select(-1.0, 1.0, s_m >= 0.0);
    let sm = sg * s_m;
    if (sm <= 0.0) { return 0.0; }
    let sa = max(sg * s_a, 1e-6 * sm);
    let sb = max(sg * s_b, 1e-6 * sm);
    let p = 2.0 * sm - 0.5 * (sa + sb);
    let dd = sa * sb - p * p;
    var i = 0.0;
    if (p > 0.0 && abs(dd) < 1e-4 * p * p) {
        i = (1.0 - dd / (3.0 * p * p)) / p;
    } else if (dd > 0.0) {
        let r = sqrt(dd);
        i = atan2(r, p) / r;
    } else {
        // (p > 0 here: S has no root in the step)
        let q = sqrt(-dd);
        // atanh(q / p) / q, with p - q = Sa Sb / (p + q) (no cancellation).
        i = 0.5 * log((p + q) * (p + q) / (sa * sb)) / q;
    }
    return h * i;
}

// The edge functions (twice the signed areas of the sub-triangles, opposite corners 0, 1, 2)
// of point x in the beam's section at height y (corners v_i + y s_i).
fn edge_fns(v: array<vec3f, 3>, s: array<vec3f, 3>, nrm: vec3f, x: vec3f, y: f32) -> vec3f {
    let q0 = v[0] + y * s[0];
    let q1 = v[1] + y * s[1];
    let q2 = v[2] + y * s[2];
    return vec3f(dot(nrm, cross(q2 - q1, x - q1)), dot(nrm, cross(q0 - q2, x - q2)), dot(nrm, cross(q1 - q0, x - q0)));
}

// All three of the same sign (and not all zero): inside the section.
fn same_sign(e: vec3f) -> bool {
    return (all(e >= vec3f(0.0)) || all(e <= vec3f(0.0))) && any(e != vec3f(0.0));
}

// The radiance the beam scatters toward the camera along o + u d, 0 <= u <= len; the camera's
// box entry is at u = -eye_in (the transmittance toward the camera starts there).
fn beam_radiance(b: BeamGpu, o: vec3f, d: vec3f, len: f32, eye_in: f32) -> vec3f {
    let v = array<vec3f, 3>(b.v0.xyz, b.v1.xyz, b.v2.xyz);
    let dir = array<vec3f, 3>(b.d0.xyz, b.d1.xyz, b.d2.xyz);
    var nrm = normalize(cross(v[1] - v[0], v[2] - v[0]));
    if (dot(nrm, dir[0] + dir[1] + dir[2]) < 0.0) { nrm = -nrm; }
    var s: array<vec3f, 3>;
    var yend: vec3f;
    for (var i = 0; i < 3; i++) {
        let c = dot(nrm, dir[i]);
        s[i] = dir[i] / c;
        yend[i] = select(b.d0.w, select(b.d1.w, b.d2.w, i == 2), i >= 1) * c;
    }
    let y0 = dot(o - v[0], nrm);
    let yr = dot(d, nrm);
    // Edge functions E_k(u) (edge i -> j opposite vertex k) as quadratics (c0, c1, c2).
    var ek: array<vec3f, 3>;
    for (var k = 0; k < 3; k++) {
        let i = (k + 1) % 3;
        let j = (k + 2) % 3;
        let p0 = (v[j] - v[i]) + y0 * (s[j] - s[i]);
        let p1 = yr * (s[j] - s[i]);
        let q0 = o - v[i] - y0 * s[i];
        let q1 = d - yr * s[i];
        ek[k] = vec3f(dot(nrm, cross(p0, q0)), dot(nrm, cross(p0, q1) + cross(p1, q0)), dot(nrm, cross(p1, q1)));
    }
    var cuts: array<f32, 12>;
    var n = 0u;
    cuts[0] = 0.0;
    n = 1u;
    for (var k = 0; k < 3; k++) { add_roots(ek[k], len, &cuts, &n); }
    // Where the cross-section's area passes through zero (a focus) the barycentrics change
    // sign without any edge function doing so: a cut too.
    // Twice the signed section area at height y: S(y) = kq.x + y kq.y + y^2 kq.z (Ernst et al.
    // 2005), from the base (well conditioned near a focus, unlike the sum of the edge
    // functions' quadratics in the ray parameter, whose coefficients are those of the ray's
    // whole length); along the ray, a quadratic in u.
    let ka = v[1] - v[0];
    let kb = s[1] - s[0];
    let kc = v[2] - v[0];
    let kd = s[2] - s[0];
    let kq = vec3f(dot(nrm, cross(ka, kc)), dot(nrm, cross(ka, kd) + cross(kb, kc)), dot(nrm, cross(kb, kd)));
    add_roots(vec3f(kq.x + y0 * (kq.y + y0 * kq.z), yr * (kq.y + 2.0 * kq.z * y0), kq.z * yr * yr), len, &cuts, &n);
    if (yr != 0.0) {
        let u = -y0 / yr;
        if (u > 0.0 && u < len) { cuts[n] = u; n++; }
    }
    cuts[n] = len;
    n++;
    // Sort the cuts (insertion sort; at most 11).
    for (var a = 1u; a < n; a++) {
        let x = cuts[a];
        var c = a;
        while (c > 0u && cuts[c - 1u] > x) { cuts[c] = cuts[c - 1u]; c--; }
        cuts[c] = x;
    }
    let phi = b.flux.rgb;
    let g = bp.sigma_s.w;
    var acc = vec3f(0.0);
    let m = max(bp.samples, 1u);
    for (var p = 0u; p + 1u < n; p++) {
        let ua = cuts[p];
        let ub = cuts[p + 1u];
        if (ub <= ua) { continue; }
        // Inside at the piece's midpoint? (The edge functions from the section's corners at
        // the point's height: the polynomials' cancellation near a focus, where all three
        // vanish, would open spurious slivers "inside" between their rounded roots.)
        let um = 0.5 * (ua + ub);
        let em = edge_fns(v, s, nrm, o + d * um, y0 + um * yr);
        if (!same_sign(em) || y0 + um * yr < 0.0) { continue; }
        let du = (ub - ua) / f32(m);
        for (var q = 0u; q < m; q++) {
            let u0 = ua + f32(q) * du;
            let u = u0 + 0.5 * du;
            let y = y0 + u * yr;
            let x = o + d * u;
            let e = edge_fns(v, s, nrm, x, y);
            if (!same_sign(e)) { continue; }
            let w = e / (e.x + e.y + e.z);
            if (y < 0.0 || y > dot(w, yend)) { continue; }
            let dl = normalize(w.x * dir[0] + w.y * dir[1] + w.z * dir[2]);
            let cos_t = max(dot(nrm, dl), 1e-4);
            let base = w.x * v[0] + w.y * v[1] + w.z * v[2];
            let pre = w.x * b.v0.w + w.y * b.v1.w + w.z * b.v2.w;
            let sl = box_length(base, x, bp.lo.xyz, bp.hi.xyz);
            let tr = exp(-bp.sigma_t.rgb * (pre + sl + eye_in + u));
            // The smooth factors at the midpoint, times the exact integral of 1/A over the step
            // (A = |S| / 2, S a quadratic in u): the pole of 1/A at a focus is integrated, not
            // sampled.
            let ya = y0 + u0 * yr;
            let yb = ya + du * yr;
            let sa = kq.x + ya * (kq.y + ya * kq.z);
            let sm = kq.x + y * (kq.y + y * kq.z);
            let sb = kq.x + yb * (kq.y + yb * kq.z);
            acc += phi / cos_t * bm_phase(dot(dl, -d), g) * tr * (2.0 * inv_quadratic_integral(sa, sm, sb, du));
        }
    }
    return bp.sigma_s.rgb * acc;
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    if (gid.x >= bp.width || gid.y >= bp.height) { return; }
    let idx = gid.y * bp.width + gid.x;
    let px = vec2i(gid.xy);
    let cam = bp.camera.xyz;
    // The first surface's distance along the pixel centre's ray (the eye buffers hold one
    // point per pixel): the sub-pixel rays end at the plane through it facing the camera.
    var depth = 1e30;
    let r = textureLoad(recv_pos, px, 0);
    let sp = textureLoad(spec_pos, px, 0);
    let centre = ray_of(vec2f(gid.xy) + 0.5);
    if (r.w >= 0.0) { depth = min(depth, dot(r.xyz - cam, centre)); }
    if (sp.w >= 0.0) { depth = min(depth, dot(sp.xyz - cam, centre)); }
    let count = min(stats[1u + BS_ORDERED], bp.capacity);
    if (chunk.offset >= count) { return; }
    // The box pixel filter: ns x ns stratified rays (a volume caustic's focal line is thinner
    // than a pixel: the pixel centre alone would miss or overweight it).
    let ns = max(bp.pixel_samples, 1u);
    var acc = vec3f(0.0);
    for (var si = 0u; si < ns * ns; si++) {
        let sub = vec2f(f32(si % ns), f32(si / ns));
        let d = ray_of(vec2f(gid.xy) + (sub + 0.5) / f32(ns));
        let t_max = select(1e30, depth / max(dot(d, centre), 1e-6), depth < 1e29);
        let seg = box_clip(cam, d, t_max, bp.lo.xyz, bp.hi.xyz);
        if (seg.y > seg.x) {
            acc += gather_ray(cam, d, seg, count);
        }
    }
    acc /= f32(ns * ns);
    if (all(acc == vec3f(0.0))) { return; }
    out_full[idx] += vec4f(acc, 0.0);
    out_caustic[idx] += vec4f(acc, 0.0);
}

// The beams' light along the camera ray cam + t d, seg.x <= t <= seg.y (its part in the box).
fn gather_ray(cam: vec3f, d: vec3f, seg: vec2f, count: u32) -> vec3f {
    var acc = vec3f(0.0);
    let end = min(count, chunk.offset + chunk.base_count);
    for (var k = chunk.offset; k < end; k++) {
        let bi = order[k];
        // The bounding sphere first (only it is read for the beams the ray misses).
        let bound = beams[bi].bound;
        let oc = cam - bound.xyz;
        let tb = -dot(oc, d);
        let h2 = bound.w * bound.w - (dot(oc, oc) - tb * tb);
        if (h2 > 0.0) {
            let h = sqrt(h2);
            let t0 = max(tb - h, seg.x);
            let t1 = min(tb + h, seg.y);
            if (t1 > t0) {
                acc += beam_radiance(beams[bi], cam + d * t0, d, t1 - t0, t0 - seg.x);
            }
        }
    }
    return acc;
}

// The unit camera ray through image point p (pixels, (0, 0) the top-left corner).
fn ray_of(p: vec2f) -> vec3f {
    let ndc = vec2f(p.x / f32(bp.width) * 2.0 - 1.0, 1.0 - p.y / f32(bp.height) * 2.0);
    let q = bp.clip_to_world * vec4f(ndc, 0.5, 1.0);
    return normalize(q.xyz / q.w - bp.camera.xyz);
}
