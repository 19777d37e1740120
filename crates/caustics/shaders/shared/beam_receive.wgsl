// Shared WGSL (`#import beam_receive`, after `#import beams`, `#import medium` and
// `#import beam_medium`): surface caustics from beams (Liktor & Dachsbacher 2011, section 5.3;
// the point-in-volume test of Ernst et al. 2005), one beam's light on one pixel's surface point,
// for beam_surface (a pixel's loop over the ordered beams) and beam_surface_raster (a fragment
// of the beam's hull). A stage importing it declares `bp` (BeamParams), `recv_pos` and
// `recv_nrm` (the eye's receiver positions and normals), `beams`, `materials` and
// `density_grid`.
//
// The pixel's first diffuse surface point p (eye receiver buffers: position, object, normal n)
// is lit by a beam when
//   - the beam's three edges land on p's object (beam_refine keeps a beam only when they land
//     on one object: a point on another receiver, in the shadow of the one the beam ends on, is
//     not lit), and p lies near the beam's end (its height over the base within the edges' end
//     heights, widened by half the end triangle's size: the interpolated end is not the
//     receiver's surface where that is curved), and
//   - p lies in the beam's cross-section at its height y over the base plane (the section's
//     corners at y, barycentrics w all of one sign).
// It then receives the irradiance
//   E = Phi / A(y) * (-n . d) / (n_b . d) * exp(-sigma_t (l + s)),
// A(y) the section's area (Phi / A(y): the flux per unit area of the base-parallel plane), d the
// direction of the beam's line through p (constant barycentrics), n_b the base normal (over
// n_b . d: per unit area across the light; times -n . d: on the receiver), l the in-medium length of the light's path up to the
// base (interpolated), s the in-medium length from the base to p (the transmittance toward the
// camera is applied afterwards by medium_scatter, as for every surface). The radiance
// albedo / pi * E is added to the eye's radiance and caustic accumulators before composite, so
// the caustic is seen through glass and in mirrors as the photon map's is.
//
// The box pixel filter: the pixel's n x n stratified sub-pixel rays (n = bp.surface_samples)
// meet p's tangent plane at n^2 points, each tested in the beams, and E is their mean. A beam's
// light is uniform over its section, so the pixel's value is the area fraction of its footprint
// each beam covers, times that beam's irradiance. A beam whose end (the triangle of its edges'
// ends, on the receiver) covers less than SPLAT_PIXELS pixels of the image is integrated over
// the pixel exactly instead: its flux spread evenly over its end triangle, times the fraction
// of the triangle's image inside the pixel's square (the triangle clipped to the square):
// E = Phi T area(image triangle within the pixel) / area(end triangle), the end triangle
// projected along the beam onto the pixel's tangent plane first. Such a beam (near its
// focus: A(y) small and 1/A(y) steep) would otherwise light a few of the n^2 points strongly or
// none: speckle around the right mean. Each beam takes one of the two ways for every pixel (the
// choice depends on the beam alone), so none is counted twice.


const MAX_SUB: u32 = 64u;

// Beams whose end triangle covers fewer image pixels are integrated over the pixel exactly.
const SPLAT_PIXELS: f32 = 4.0;

// A convex polygon in image space (a triangle clipped by up to four lines: at most 7 corners).
struct Poly {
    p: array<vec2f, 8>,
    n: u32,
}

// The part of `poly` where sgn * (x[axis] - bound) >= 0 (Sutherland-Hodgman).
fn clip_poly(poly_in: Poly, axis: u32, bound: f32, sgn: f32) -> Poly {
    var poly = poly_in;
    var out: Poly;
    out.n = 0u;
    for (var i = 0u; i < poly.n; i++) {
        let a = poly.p[i];
        let b = poly.p[(i + 1u) % poly.n];
        let da = sgn * (a[axis] - bound);
        let db = sgn * (b[axis] - bound);
        if (da >= 0.0 && out.n < 8u) {
            out.p[out.n] = a;
            out.n++;
        }
        if ((da >= 0.0) != (db >= 0.0) && out.n < 8u) {
            out.p[out.n] = mix(a, b, da / (da - db));
            out.n++;
        }
    }
    return out;
}

// Area of triangle (a, b, c) inside the square [lo, lo + 1]^2 (image pixels).
fn overlap_area(a: vec2f, b: vec2f, c: vec2f, lo: vec2f) -> f32 {
    var poly: Poly;
    poly.p[0] = a;
    poly.p[1] = b;
    poly.p[2] = c;
    poly.n = 3u;
    poly = clip_poly(poly, 0u, lo.x, 1.0);
    poly = clip_poly(poly, 0u, lo.x + 1.0, -1.0);
    poly = clip_poly(poly, 1u, lo.y, 1.0);
    poly = clip_poly(poly, 1u, lo.y + 1.0, -1.0);
    var area = 0.0;
    for (var i = 0u; i < poly.n; i++) {
        let u = poly.p[i];
        let v = poly.p[(i + 1u) % poly.n];
        area += u.x * v.y - u.y * v.x;
    }
    return 0.5 * abs(area);
}

// World point x in image pixels ((0, 0) the top-left corner), w < 0 behind the camera.
fn to_image(x: vec3f) -> vec3f {
    let c = bp.world_to_clip * vec4f(x, 1.0);
    if (c.w <= 0.0) { return vec3f(0.0, 0.0, -1.0); }
    let ndc = c.xy / c.w;
    return vec3f((ndc.x + 1.0) * 0.5 * f32(bp.width), (1.0 - ndc.y) * 0.5 * f32(bp.height), 1.0);
}

// A small beam's irradiance over pixel `px` (the beam's end triangle on the receiver, its flux
// spread evenly over it, clipped to the pixel), or -1 when the beam is not small (then the
// point test is used).
fn small_beam(b: BeamGpu, px: vec2f, p: vec3f, n: vec3f, near: f32) -> vec3f {
    let e0 = b.v0.xyz + b.d0.xyz * b.d0.w;
    let e1 = b.v1.xyz + b.d1.xyz * b.d1.w;
    let e2 = b.v2.xyz + b.d2.xyz * b.d2.w;
    let i0 = to_image(e0);
    let i1 = to_image(e1);
    let i2 = to_image(e2);
    if (min(i0.z, min(i1.z, i2.z)) < 0.0) { return vec3f(-1.0); }
    let img = 0.5 * abs((i1.x - i0.x) * (i2.y - i0.y) - (i1.y - i0.y) * (i2.x - i0.x));
    if (img >= SPLAT_PIXELS) { return vec3f(-1.0); }
    // (a small beam: from here on it is this way or nothing)
    let c = (e0 + e1 + e2) / 3.0;
    let dm = normalize(b.d0.xyz + b.d1.xyz + b.d2.xyz);
    // Its end must be the surface this pixel sees (not hidden behind it), lit from the front.
    let size = max(max(length(e1 - e0), length(e2 - e1)), length(e0 - e2));
    let dn = dot(n, dm);
    if (length(c - p) > near + size || dn >= 0.0) { return vec3f(0.0); }
    // The end triangle projected along the beam onto p's tangent plane: where its light lands
    // on this surface. (The edges' ends lie on the receiver for a beam over three traced
    // edges, and the projection moves them nowhere on a plane; a thin beam's (`thin_beam`)
    // ends lie on a copy of its base, oblique to the receiver: its own area and image put 7 %
    // too much of the glass dragon's light on the floor.)
    let f0 = e0 + dm * (dot(n, p - e0) / dn);
    let f1 = e1 + dm * (dot(n, p - e1) / dn);
    let f2 = e2 + dm * (dot(n, p - e2) / dn);
    let world = 0.5 * length(cross(f1 - f0, f2 - f0));
    let j0 = to_image(f0);
    let j1 = to_image(f1);
    let j2 = to_image(f2);
    if (world <= 0.0 || min(j0.z, min(j1.z, j2.z)) < 0.0) { return vec3f(0.0); }
    let ov = overlap_area(j0.xy, j1.xy, j2.xy, px);
    if (ov <= 0.0) { return vec3f(0.0); }
    let base = (b.v0.xyz + b.v1.xyz + b.v2.xyz) / 3.0;
    let pre = (b.v0.w + b.v1.w + b.v2.w) / 3.0;
    let tr = exp(-bp.sigma_t.rgb * (pre + beam_depth(base, c)));
    return b.flux.rgb * tr * (ov / world);
}

// The unit camera ray through image point q (pixels, (0, 0) the top-left corner).
fn ray_of(q: vec2f) -> vec3f {
    let ndc = vec2f(q.x / f32(bp.width) * 2.0 - 1.0, 1.0 - q.y / f32(bp.height) * 2.0);
    let c = bp.clip_to_world * vec4f(ndc, 0.5, 1.0);
    return normalize(c.xyz / c.w - bp.camera.xyz);
}

// The irradiance beam b gives point x (on its landing object, unit normal n facing the camera).
fn beam_irradiance(b: BeamGpu, x: vec3f, n: vec3f) -> vec3f {
    let v = array<vec3f, 3>(b.v0.xyz, b.v1.xyz, b.v2.xyz);
    let dir = array<vec3f, 3>(b.d0.xyz, b.d1.xyz, b.d2.xyz);
    let t_end = vec3f(b.d0.w, b.d1.w, b.d2.w);
    let nrm = beam_normal(v, dir);
    let c = vec3f(dot(nrm, dir[0]), dot(nrm, dir[1]), dot(nrm, dir[2]));
    if (any(c <= vec3f(0.0))) { return vec3f(0.0); }
    let s = array<vec3f, 3>(dir[0] / c.x, dir[1] / c.y, dir[2] / c.z);
    // (behind the surface the light leaves: a rebased beam's edges run inside the object there)
    let cp = beam_clip(b, v, s, nrm);
    if (dot(cp.xyz, x) < cp.w) { return vec3f(0.0); }
    let y = dot(x - v[0], nrm);
    // Near the end: within the edges' end heights, widened by half the end triangle's size.
    let yend = t_end * c;
    let e0 = v[0] + dir[0] * t_end.x;
    let e1 = v[1] + dir[1] * t_end.y;
    let e2 = v[2] + dir[2] * t_end.z;
    let tol = 0.5 * max(max(length(e1 - e0), length(e2 - e1)), length(e0 - e2)) + 1e-4 * max(yend.x, max(yend.y, yend.z));
    if (y < max(min(yend.x, min(yend.y, yend.z)) - tol, 0.0) || y > max(yend.x, max(yend.y, yend.z)) + tol) {
        return vec3f(0.0);
    }
    // The section's corners at height y, and p's edge functions (twice the signed areas of the
    // sub-triangles opposite each corner).
    let q0 = v[0] + y * s[0];
    let q1 = v[1] + y * s[1];
    let q2 = v[2] + y * s[2];
    let e = vec3f(dot(nrm, cross(q2 - q1, x - q1)), dot(nrm, cross(q0 - q2, x - q2)), dot(nrm, cross(q1 - q0, x - q0)));
    let inside = (all(e >= vec3f(0.0)) || all(e <= vec3f(0.0))) && any(e != vec3f(0.0));
    if (!inside) { return vec3f(0.0); }
    let area2 = abs(e.x + e.y + e.z);
    if (area2 <= 0.0) { return vec3f(0.0); }
    let w = e / (e.x + e.y + e.z);
    // The direction of the beam's line through p (constant barycentrics w over the heights:
    // p(w, y) = sum w_i (v_i + y s_i)), along which its flux flows: with it, the irradiance the
    // beam gives any surface across it integrates to its flux exactly. (The mean of the edges'
    // unit directions is not that line's direction where the edges diverge.)
    let dl = normalize(w.x * s[0] + w.y * s[1] + w.z * s[2]);
    let cos_r = -dot(n, dl);
    if (cos_r <= 0.0) { return vec3f(0.0); }
    let cos_b = max(dot(nrm, dl), 1e-4);
    let base = w.x * v[0] + w.y * v[1] + w.z * v[2];
    let pre = w.x * b.v0.w + w.y * b.v1.w + w.z * b.v2.w;
    let tr = exp(-bp.sigma_t.rgb * (pre + beam_depth(base, x)));
    // (A = area2 / 2)
    return b.flux.rgb * (2.0 / area2) * (cos_r / cos_b) * tr;
}

// What a pixel's surface point needs of the camera and the eye buffers: its diffuse surface
// point p (object, albedo, normal n facing the camera), the footprint's points and their
// distance bound from p, and how far from p a small beam's end may lie.
struct SurfacePixel {
    lit: bool,
    object: u32,
    albedo: vec3f,
    p: vec3f,
    n: vec3f,
    m: u32,
    reach: f32,
    near: f32,
    pts: array<vec3f, MAX_SUB>,
}

fn surface_pixel(gid: vec2u) -> SurfacePixel {
    var sp: SurfacePixel;
    sp.lit = false;
    let px = vec2i(gid);
    let pw = textureLoad(recv_pos, px, 0);
    if (pw.w < 0.0) { return sp; }
    sp.object = u32(pw.w);
    let mat = materials[sp.object];
    if (mat.kind.x != KIND_DIFFUSE) { return sp; }
    sp.lit = true;
    sp.albedo = mat.a.rgb;
    let p = pw.xyz;
    sp.p = p;
    let cam = bp.camera.xyz;
    var n = normalize(textureLoad(recv_nrm, px, 0).xyz);
    if (dot(n, cam - p) < 0.0) { n = -n; }
    sp.n = n;
    // The footprint's points: the sub-pixel rays on p's tangent plane (p itself where a ray
    // meets the plane so obliquely that its point is more than 8 pixels away), and their
    // distance bound from p.
    let ns = clamp(bp.surface_samples, 1u, 8u);
    sp.m = ns * ns;
    sp.reach = 0.0;
    let dist = length(p - cam);
    let centre = ray_of(vec2f(gid) + 0.5);
    let pixel = dist * length(ray_of(vec2f(gid) + vec2f(1.5, 0.5)) - centre);
    let hn = dot(n, p - cam);
    for (var k = 0u; k < sp.m; k++) {
        let sub = (vec2f(f32(k % ns), f32(k / ns)) + 0.5) / f32(ns);
        let d = ray_of(vec2f(gid) + sub);
        let dn = dot(n, d);
        var q = p;
        if (ns > 1u && abs(dn) > 1e-3) {
            let t = hn / dn;
            if (t > 0.0) { q = cam + d * t; }
        }
        // (a ray almost along the plane: its point stays at p)
        if (length(q - p) > 8.0 * pixel) { q = p; }
        sp.pts[k] = q;
        sp.reach = max(sp.reach, length(q - p));
    }
    // How far from p a small beam's end may lie and still cover part of this pixel: two pixel
    // widths on the surface, stretched where it is seen obliquely.
    sp.near = 2.0 * pixel / max(abs(dot(n, centre)), 0.1);
    return sp;
}

// Beam `bi`'s light on pixel `gid`'s surface point: a small beam's exact share of the pixel
// added to `splat`, another beam's irradiance at the footprint's points added to `acc` (their
// mean is taken by the caller).
fn surface_beam(bi: u32, gid: vec2u, sp: ptr<function, SurfacePixel>, acc: ptr<function, vec3f>, splat: ptr<function, vec3f>) {
    // The bounding sphere against the footprint's, and the landing object, first.
    let bound = beams[bi].bound;
    let r = bound.w + max((*sp).reach, (*sp).near);
    let oc = (*sp).p - bound.xyz;
    if (dot(oc, oc) > r * r || beams[bi].info.x != (*sp).object) { return; }
    let b = beams[bi];
    let small = small_beam(b, vec2f(gid), (*sp).p, (*sp).n, (*sp).near);
    if (small.x >= 0.0) {
        *splat += small;
        return;
    }
    for (var j = 0u; j < (*sp).m; j++) {
        *acc += beam_irradiance(b, (*sp).pts[j], (*sp).n);
    }
}

// The radiance the beams' irradiance gives the pixel's surface point.
fn surface_radiance(sp: ptr<function, SurfacePixel>, acc: vec3f, splat: vec3f) -> vec3f {
    return (*sp).albedo / PI * (acc / f32((*sp).m) + splat);
}
