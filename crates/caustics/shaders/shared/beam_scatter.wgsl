// Shared WGSL (`#import beam_scatter`, after `#import beams`, `#import medium` and
// `#import beam_medium`): the single scattering of one beam's light toward the camera in one
// pixel (Liktor & Dachsbacher 2011, section 5, equations 2-5, after Ernst et al. 2005), for
// beam_gather (a pixel's loop over the ordered beams) and beam_raster (a fragment of the beam's
// hull). A stage importing it declares `bp` (BeamParams), `recv_pos` and `spec_pos` (the eye's
// receiver and specular positions), `recv_nrm` and `spec_nrm` (their normals), `beams`, `foot`
// and `density_grid`. Per beam, the pixel centre's ray from the camera to the first
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
// plane through its edges' ends (the receivers), and beyond its clip plane (`beam_clip`: the
// surface the light leaves, where make_beam extended the edges back behind it). The pixel's camera ray ends at the first
// surface (a hard clip: the exact interval needs no soft clipping). Each pixel averages
// `bp.pixel_samples`^2 stratified rays (the box pixel filter). Across the pixel the first
// surface is its tangent plane at the centre ray's point (`PixelView::plane`): the rays through
// other points of the pixel, and the footprint below, end there. (A plane facing the camera
// through that point cut the fog above a floor seen at a grazing angle short in the far half
// of the pixel: 9 % too little light in the pixel rows where a shaft meets the floor.)
//
// The pixel's footprint (`foot`, BeamSettings::footprint): where a beam's cross-section, seen
// from the camera, is narrower than `foot.x` pixels (near a focus: the caustic's singular lines,
// which rays through points of the pixel would hit or miss), its light is not sampled by the
// pixel's rays but integrated over the pixel's whole footprint in beam space, where 1 / A(y)
// cancels: a point (barycentrics w of the section, height y) fills the volume A(y) dmu dy
// (mu: the barycentric measure, 1 over the section), so the pixel receives
//   sigma_s phase Phi T dmu dy / (cos theta dist^2 z^3 pix_area)
// (dist: to the camera; z: the cosine of its direction with the view axis; pix_area: the
// pixel's area on the image plane at unit distance; the same measure as the rays' average).
// The section is `foot.y`^2 lines of constant w (the centroids of its midpoint subdivision, each
// mu = 1 / foot.y^2); each line, a straight segment in y, is clipped exactly to the pixel's
// square, its first surface's tangent plane and the medium's box (all linear in y in clip space)
// and integrated by the two-point Gauss rule (the integrand is smooth). The rays then skip
// those heights: every point of a beam is counted by exactly one of the two.


// Roots of c2 u^2 + c1 u + c0 in (0, len), appended to `cuts` (count in `n`).
fn add_roots(c: vec3f, len: f32, cuts: ptr<function, array<f32, 16>>, n: ptr<function, u32>) {
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
        if (r[k] > 0.0 && r[k] < len && *n < 13u) {
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

// The heights y (an interval; empty: x >= y) where the beam's cross-section, projected across
// the direction from the camera, has every side shorter than foot.x pixels at the distance of
// the beam's centroid line nearest the camera (`tan_pix`: a pixel's width at unit distance).
// Each side is |a + y b| across the view (convex in y), so the set is one interval. (No loops
// here and in the footprint integral: lavapipe ends an invocation's loops after some 65536
// iterations in all, see record_gather_chunks.)
fn thin_range(bs: BeamSpace, cam: vec3f, tan_pix: f32) -> vec2f {
    if (foot.x <= 0.0) { return vec2f(1.0, 0.0); }
    let ymax = max(bs.yend.x, max(bs.yend.y, bs.yend.z));
    let c0 = (bs.v[0] + bs.v[1] + bs.v[2]) / 3.0;
    let c1 = (bs.s[0] + bs.s[1] + bs.s[2]) / 3.0;
    let yc = clamp(dot(cam - c0, c1) / max(dot(c1, c1), 1e-20), 0.0, ymax);
    let to = c0 + yc * c1 - cam;
    let dist = length(to);
    if (dist <= 0.0) { return vec2f(1.0, 0.0); }
    let u = to / dist;
    let rr = foot.x * tan_pix * dist;
    var r = vec2f(0.0, ymax);
    side_range(&r, bs.v[1] - bs.v[0], bs.s[1] - bs.s[0], u, rr);
    side_range(&r, bs.v[2] - bs.v[1], bs.s[2] - bs.s[1], u, rr);
    side_range(&r, bs.v[0] - bs.v[2], bs.s[0] - bs.s[2], u, rr);
    return r;
}

// Narrow r to the y where the side a + y b, across the unit direction u, is at most rr long.
fn side_range(r: ptr<function, vec2f>, a: vec3f, b: vec3f, u: vec3f, rr: f32) {
    let pa = a - dot(a, u) * u;
    let pb = b - dot(b, u) * u;
    // qa y^2 + 2 qb y + qc <= 0
    let qa = dot(pb, pb);
    let qb = dot(pa, pb);
    let qc = dot(pa, pa) - rr * rr;
    if (qa <= 1e-12 * (abs(qc) + rr * rr)) {
        // (the side's length hardly changes with y)
        if (qc > 0.0) { *r = vec2f(1.0, 0.0); }
        return;
    }
    let disc = qb * qb - qa * qc;
    if (disc <= 0.0) {
        *r = vec2f(1.0, 0.0);
        return;
    }
    let sq = sqrt(disc);
    (*r).x = max((*r).x, (-qb - sq) / qa);
    (*r).y = min((*r).y, (-qb + sq) / qa);
}

// The radiance the beam scatters toward the camera along o + u d, 0 <= u <= len, at heights
// within `hr` and outside `thin` (those the footprint integral takes); the camera's box entry
// is at u = -eye_in (the transmittance toward the camera starts there), the ray's origin at
// `eye` (the camera, or the start of a segment beyond a specular surface: a density grid's
// optical depth toward the camera is marched from there).
fn beam_radiance(b: BeamGpu, bs: BeamSpace, thin: vec2f, hr: vec2f, o: vec3f, d: vec3f, len: f32, eye_in: f32, eye: vec3f) -> vec3f {
    let v = bs.v;
    let dir = bs.dir;
    let nrm = bs.nrm;
    let s = bs.s;
    let yend = bs.yend;
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
    var cuts: array<f32, 16>;
    var n = 0u;
    cuts[0] = 0.0;
    n = 1u;
    for (var k = 0; k < 3; k++) { add_roots(ek[k], len, &cuts, &n); }
    // Where the cross-section's area passes through zero (a focus) the barycentrics change
    // sign without any edge function doing so: a cut too. Twice the signed section area at
    // height y, S(y) (section_area), is zero at the foci's heights (beam_foci: from the base,
    // well conditioned near a focus, unlike the sum of the edge functions' quadratics in the
    // ray parameter, whose coefficients are those of the ray's whole length); the ray crosses
    // them at u = (f - y0) / yr. (beam_hull splits a beam's hull at the same heights: the
    // pieces of a ray end there exactly, each in one part.)
    let kq = bs.kq;
    // The clip plane (beam_clip): a cut where the ray crosses it.
    let f0 = dot(bs.cn, o) - bs.cd;
    let f1 = dot(bs.cn, d);
    if (f1 != 0.0) {
        let u = -f0 / f1;
        if (u > 0.0 && u < len) { cuts[n] = u; n++; }
    }
    if (yr != 0.0) {
        let u = -y0 / yr;
        if (u > 0.0 && u < len) { cuts[n] = u; n++; }
        let uf = (bs.foci - y0) / yr;
        if (uf.x > 0.0 && uf.x < len) { cuts[n] = uf.x; n++; }
        if (uf.y > 0.0 && uf.y < len) { cuts[n] = uf.y; n++; }
        if (thin.y > thin.x) {
            let ua = (thin.x - y0) / yr;
            let ub = (thin.y - y0) / yr;
            if (ua > 0.0 && ua < len) { cuts[n] = ua; n++; }
            if (ub > 0.0 && ub < len) { cuts[n] = ub; n++; }
        }
    }
    cuts[n] = len;
    n++;
    // Sort the cuts (insertion sort; at most 14).
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
        let ym = y0 + um * yr;
        // (hr: the heights of the hull's part, from its lower focus to the next, half open)
        if (!same_sign(em) || ym < max(hr.x, 0.0) || ym >= hr.y || (ym >= thin.x && ym <= thin.y) || f0 + um * f1 < 0.0) { continue; }
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
            // (the direction of the beam's line of constant barycentrics, along which its flux
            // flows: beam_surface.wgsl)
            let dl = normalize(w.x * s[0] + w.y * s[1] + w.z * s[2]);
            let cos_t = max(dot(nrm, dl), 1e-4);
            let base = w.x * v[0] + w.y * v[1] + w.z * v[2];
            let pre = w.x * b.v0.w + w.y * b.v1.w + w.z * b.v2.w;
            var tr: vec3f;
            if (beam_has_grid()) {
                tr = exp(-bp.sigma_t.rgb * (pre + beam_depth(base, x) + beam_depth(eye, x))) * beam_density(x);
            } else {
                let sl = box_length(base, x, bp.lo.xyz, bp.hi.xyz);
                tr = exp(-bp.sigma_t.rgb * (pre + sl + eye_in + u));
            }
            // The smooth factors at the midpoint, times the exact integral of 1/A over the step
            // (A = |S| / 2, S a quadratic in u): the pole of 1/A at a focus is integrated, not
            // sampled.
            let ya = y0 + u0 * yr;
            let yb = ya + du * yr;
            let sa = kq.x + ya * (kq.y + ya * kq.z);
            let sm = kq.x + y * (kq.y + y * kq.z);
            let sb = kq.x + yb * (kq.y + yb * kq.z);
            acc += phi / cos_t * hg_phase(dot(dl, -d), g) * tr * (2.0 * inv_quadratic_integral(sa, sm, sb, du));
        }
    }
    return bp.sigma_s.rgb * acc;
}

// Keep the y of a line o + y s where f0 + f1 y >= 0.
fn clip_lin(r: ptr<function, vec2f>, f0: f32, f1: f32) {
    if (f1 > 0.0) {
        (*r).x = max((*r).x, -f0 / f1);
    } else if (f1 < 0.0) {
        (*r).y = min((*r).y, -f0 / f1);
    } else if (f0 < 0.0) {
        *r = vec2f(1.0, 0.0);
    }
}

// Length of the segment from a to b inside the box lo..hi (box_length without its loop).
fn seg_in_box(a: vec3f, b: vec3f) -> f32 {
    let v = b - a;
    let inv = 1.0 / select(v, vec3f(1e-30), abs(v) < vec3f(1e-30));
    let ta = (bp.lo.xyz - a) * inv;
    let tb = (bp.hi.xyz - a) * inv;
    let lo = min(ta, tb);
    let hi = max(ta, tb);
    let t0 = max(max(lo.x, lo.y), max(lo.z, 0.0));
    let t1 = min(min(hi.x, hi.y), min(hi.z, 1.0));
    return max(t1 - t0, 0.0) * length(v);
}

// The centroids (barycentrics a, b) of the midpoint subdivision of a triangle into n^2 triangles,
// n = 1 to 4 (starting at (n - 1) n (2n - 1) / 6): upward ones at ((i + 1/3) / n, (j + 1/3) / n),
// downward ones at ((i + 2/3) / n, (j + 2/3) / n).
const LINES: array<vec2f, 30> = array<vec2f, 30>(
    vec2f(0.33333334, 0.33333334),
    vec2f(0.16666667, 0.16666667), vec2f(0.6666667, 0.16666667), vec2f(0.16666667, 0.6666667), vec2f(0.33333334, 0.33333334),
    vec2f(0.11111111, 0.11111111), vec2f(0.44444445, 0.11111111), vec2f(0.7777778, 0.11111111),
    vec2f(0.11111111, 0.44444445), vec2f(0.44444445, 0.44444445), vec2f(0.11111111, 0.7777778),
    vec2f(0.22222222, 0.22222222), vec2f(0.5555556, 0.22222222), vec2f(0.22222222, 0.5555556),
    vec2f(0.083333336, 0.083333336), vec2f(0.33333334, 0.083333336), vec2f(0.5833333, 0.083333336), vec2f(0.8333333, 0.083333336),
    vec2f(0.083333336, 0.33333334), vec2f(0.33333334, 0.33333334), vec2f(0.5833333, 0.33333334),
    vec2f(0.083333336, 0.5833333), vec2f(0.33333334, 0.5833333), vec2f(0.083333336, 0.8333333),
    vec2f(0.16666667, 0.16666667), vec2f(0.41666666, 0.16666667), vec2f(0.6666667, 0.16666667),
    vec2f(0.16666667, 0.41666666), vec2f(0.41666666, 0.41666666), vec2f(0.16666667, 0.6666667),
);

// The light of the beam's heights `thin` in pixel `px` (its top-left corner), integrated over
// the pixel's footprint (see the top of this file); `v`: the pixel's view (its first surface).
// Each line's clipped piece (inside one pixel's frustum: a short, smooth integrand) by the
// two-point Gauss rule.
fn beam_footprint(b: BeamGpu, bs: BeamSpace, thin: vec2f, px: vec2f, v: PixelView) -> vec3f {
    // (`thin`: the heights to integrate, within the hull part's)
    let cam = bp.camera.xyz;
    let wf = f32(bp.width);
    let hf = f32(bp.height);
    // The pixel's square in NDC.
    let x0 = px.x / wf * 2.0 - 1.0;
    let x1 = (px.x + 1.0) / wf * 2.0 - 1.0;
    let yt = 1.0 - px.y / hf * 2.0;
    let yb = 1.0 - (px.y + 1.0) / hf * 2.0;
    let nl = u32(clamp(foot.y, 1.0, 4.0));
    let first = (nl - 1u) * nl * (2u * nl - 1u) / 6u;
    let g = bp.sigma_s.w;
    let pre3 = vec3f(b.v0.w, b.v1.w, b.v2.w);
    var acc = vec3f(0.0);
    for (var li = 0u; li < nl * nl; li++) {
        let ab = LINES[first + li];
        let w = vec3f(ab, 1.0 - ab.x - ab.y);
        let o = w.x * bs.v[0] + w.y * bs.v[1] + w.z * bs.v[2];
        let sd = w.x * bs.s[0] + w.y * bs.s[1] + w.z * bs.s[2];
        var r = vec2f(max(thin.x, 0.0), min(thin.y, dot(w, bs.yend)));
        let c0 = bp.world_to_clip * vec4f(o, 1.0);
        let c1 = bp.world_to_clip * vec4f(sd, 0.0);
        // In front of the camera, inside the pixel's square.
        clip_lin(&r, c0.w - 1e-6, c1.w);
        clip_lin(&r, c0.x - x0 * c0.w, c1.x - x0 * c1.w);
        clip_lin(&r, x1 * c0.w - c0.x, x1 * c1.w - c1.x);
        clip_lin(&r, c0.y - yb * c0.w, c1.y - yb * c1.w);
        clip_lin(&r, yt * c0.w - c0.y, yt * c1.w - c1.y);
        // Beyond the clip plane (beam_clip), on the camera's side of the first surface's tangent
        // plane (where the pixel's rays end), inside the medium.
        clip_lin(&r, dot(bs.cn, o) - bs.cd, dot(bs.cn, sd));
        clip_lin(&r, dot(v.plane.xyz, o) - v.plane.w, dot(v.plane.xyz, sd));
        clip_lin(&r, o.x - bp.lo.x, sd.x);
        clip_lin(&r, bp.hi.x - o.x, -sd.x);
        clip_lin(&r, o.y - bp.lo.y, sd.y);
        clip_lin(&r, bp.hi.y - o.y, -sd.y);
        clip_lin(&r, o.z - bp.lo.z, sd.z);
        clip_lin(&r, bp.hi.z - o.z, -sd.z);
        if (r.y <= r.x) { continue; }
        let dl = normalize(sd);
        let cos_t = max(dot(bs.nrm, dl), 1e-4);
        let pre = dot(w, pre3);
        acc += footprint_piece(o, sd, r.x, r.y, pre, dl, g, cam, v.fwd) / cos_t;
    }
    let inv_n = 1.0 / f32(nl);
    return bp.sigma_s.rgb * b.flux.rgb * acc * (inv_n * inv_n);
}

// The integral of footprint_point over the heights ya to yb of the line (the two-point Gauss
// rule; 0 where empty).
fn footprint_piece(o: vec3f, sd: vec3f, ya: f32, yb: f32, pre: f32, dl: vec3f, g: f32, cam: vec3f, fwd: vec3f) -> vec3f {
    if (yb <= ya) { return vec3f(0.0); }
    let hw = 0.5 * (yb - ya);
    let mid = 0.5 * (ya + yb);
    let p = footprint_point(o, sd, mid - 0.57735027 * hw, pre, dl, g, cam, fwd)
        + footprint_point(o, sd, mid + 0.57735027 * hw, pre, dl, g, cam, fwd);
    return p * hw;
}

// phase T / (dist^2 z^3) at height y of the line o + y sd.
fn footprint_point(o: vec3f, sd: vec3f, y: f32, pre: f32, dl: vec3f, g: f32, cam: vec3f, fwd: vec3f) -> vec3f {
    let x = o + y * sd;
    let tv = x - cam;
    let dist2 = dot(tv, tv);
    let vd = tv * inverseSqrt(dist2);
    let z = dot(vd, fwd);
    var tr: vec3f;
    if (beam_has_grid()) {
        tr = exp(-bp.sigma_t.rgb * (pre + beam_depth(o, x) + beam_depth(cam, x))) * beam_density(x);
    } else {
        tr = exp(-bp.sigma_t.rgb * (pre + seg_in_box(o, x) + seg_in_box(cam, x)));
    }
    return hg_phase(dot(dl, -vd), g) * tr / (dist2 * z * z * z);
}

// The unit camera ray through image point p (pixels, (0, 0) the top-left corner).
fn ray_of(p: vec2f) -> vec3f {
    let ndc = vec2f(p.x / f32(bp.width) * 2.0 - 1.0, 1.0 - p.y / f32(bp.height) * 2.0);
    let q = bp.clip_to_world * vec4f(ndc, 0.5, 1.0);
    return normalize(q.xyz / q.w - bp.camera.xyz);
}

// What a pixel's rays need of the camera: the first surface's tangent plane at the pixel
// centre's ray (dot(plane.xyz, x) = plane.w, the normal toward the camera; no surface: a zero
// normal and plane.w = -1, which every point passes), the centre's ray, the view axis, a pixel's
// size on the image plane at unit distance, and the pixel's cone around its centre ray.
struct PixelView {
    plane: vec4f,
    centre: vec3f,
    fwd: vec3f,
    pw: f32,
    ph: f32,
    tan_half: f32,
    sec_half: f32,
}

fn pixel_view(px: vec2u) -> PixelView {
    var v: PixelView;
    let cam = bp.camera.xyz;
    // The first surface the pixel centre's ray meets (the nearer of the eye's diffuse and
    // specular buffers, one point per pixel) and its tangent plane there: the sub-pixel rays
    // and the footprint end at it. (Shading normals, oriented toward the camera; a surface seen
    // edge-on gives a plane through the camera, which keeps the half of the pixel off it.)
    v.plane = vec4f(0.0, 0.0, 0.0, -1.0);
    let r = textureLoad(recv_pos, vec2i(px), 0);
    let sp = textureLoad(spec_pos, vec2i(px), 0);
    v.centre = ray_of(vec2f(px) + 0.5);
    var depth = 1e30;
    var hit = vec3f(0.0);
    var nrm = vec3f(0.0);
    let seen = r.w >= 0.0 || sp.w >= 0.0;
    if (r.w >= 0.0) {
        depth = dot(r.xyz - cam, v.centre);
        hit = r.xyz;
        nrm = textureLoad(recv_nrm, vec2i(px), 0).xyz;
    }
    if (sp.w >= 0.0 && dot(sp.xyz - cam, v.centre) < depth) {
        hit = sp.xyz;
        nrm = textureLoad(spec_nrm, vec2i(px), 0).xyz;
    }
    if (seen) {
        // (a zero or unusable normal: the plane facing the camera)
        if (!(dot(nrm, nrm) > 1e-12)) { nrm = -v.centre; }
        let n = normalize(nrm) * select(-1.0, 1.0, dot(nrm, cam - hit) >= 0.0);
        v.plane = vec4f(n, dot(n, hit));
    }
    let half = 0.5 * vec2f(f32(bp.width), f32(bp.height));
    v.fwd = ray_of(half);
    let ex = ray_of(half + vec2f(1.0, 0.0));
    let ey = ray_of(half + vec2f(0.0, 1.0));
    v.pw = length(ex / dot(ex, v.fwd) - v.fwd);
    v.ph = length(ey / dot(ey, v.fwd) - v.fwd);
    // (a bound: a pixel is widest at the image's centre)
    v.tan_half = 0.5 * sqrt(v.pw * v.pw + v.ph * v.ph);
    v.sec_half = sqrt(1.0 + v.tan_half * v.tan_half);
    return v;
}

// Beam `bi`'s light in pixel `px`, added to `acc`. The box pixel filter: ns x ns stratified
// rays (a volume caustic's focal line is thinner than a pixel: the pixel centre alone would miss
// or overweight it); where the beam is thinner than foot.x pixels, the footprint integral
// instead. Only points of the beam at `heights` over its base count (beam_raster: the part of
// the beam its hull bounds, beam_hull splitting a beam at its foci; beam_gather: all).
fn beam_pixel(bi: u32, px: vec2u, v: PixelView, heights: vec2f, acc: ptr<function, vec3f>) {
    let cam = bp.camera.xyz;
    // The bounding sphere against the pixel's cone first (only it is read for the beams the
    // pixel misses).
    let bound = beams[bi].bound;
    let oc = bound.xyz - cam;
    let tb = dot(oc, v.centre);
    let perp2 = max(dot(oc, oc) - tb * tb, 0.0);
    let reach = bound.w * v.sec_half + max(tb, 0.0) * v.tan_half;
    if (perp2 > reach * reach) { return; }
    let b = beams[bi];
    let bs = beam_space(b);
    let thin = thin_range(bs, cam, v.pw);
    // (the footprint integral's heights within the part's)
    let thin_part = vec2f(max(thin.x, heights.x), min(thin.y, heights.y));
    let ns = max(bp.pixel_samples, 1u);
    let inv_rays = 1.0 / f32(ns * ns);
    for (var si = 0u; si < ns * ns; si++) {
        let sub = vec2f(f32(si % ns), f32(si / ns));
        let d = ray_of(vec2f(px) + (sub + 0.5) / f32(ns));
        // (to the first surface's tangent plane, where the ray goes toward it)
        let toward = -dot(v.plane.xyz, d);
        let t_max = select(1e30, max(dot(v.plane.xyz, cam) - v.plane.w, 0.0) / toward, toward > 0.0);
        let seg = box_clip(cam, d, t_max, bp.lo.xyz, bp.hi.xyz);
        if (seg.y <= seg.x) { continue; }
        // The ray against the bounding sphere.
        let t = bound_span(bound, cam, d, seg);
        if (t.y > t.x) {
            *acc += inv_rays * beam_radiance(b, bs, thin, heights, cam + d * t.x, d, t.y - t.x, t.x - seg.x, cam);
        }
    }
    if (thin_part.y > thin_part.x) {
        *acc += beam_footprint(b, bs, thin_part, vec2f(px), v) / (v.pw * v.ph);
    }
}

// Beam `bi`'s light along a camera path's segment beyond a specular surface, o + t d over `seg`
// (its part in the box), added to `acc`: the ray alone (no footprint: the pixel's footprint
// after glass is not tracked, so a focal line thinner than the pixel is point-sampled there).
fn beam_segment(bi: u32, o: vec3f, d: vec3f, seg: vec2f, acc: ptr<function, vec3f>) {
    let t = bound_span(beams[bi].bound, o, d, seg);
    if (t.y <= t.x) { return; }
    let b = beams[bi];
    *acc += beam_radiance(b, beam_space(b), vec2f(1.0, 0.0), vec2f(0.0, 3.0e38), o + d * t.x, d, t.y - t.x, t.x - seg.x, o);
}

// The part of `seg` of the ray o + t d inside a beam's bounding sphere `bound` (centre xyz,
// radius w): (t0, t1), empty (t1 <= t0) where the ray misses it.
fn bound_span(bound: vec4f, o: vec3f, d: vec3f, seg: vec2f) -> vec2f {
    let oc = bound.xyz - o;
    let tc = dot(oc, d);
    let h2 = bound.w * bound.w - (dot(oc, oc) - tc * tc);
    if (h2 <= 0.0) { return vec2f(1.0, 0.0); }
    let hh = sqrt(h2);
    return vec2f(max(tc - hh, seg.x), min(tc + hh, seg.y));
}
