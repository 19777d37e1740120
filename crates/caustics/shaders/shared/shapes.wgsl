// Shared WGSL: exact intersection of the analytic shapes (spheres, open cylinders, rectangles)
// described in `MaterialGpu` (s0..s3). Needs a `materials: array<MaterialGpu>` binding in the
// importing stage. Imported by photon_trace, adaptive_refine (through trace) and composite.

struct ShapeHit {
    p: vec3f,
    n: vec3f,
    t: f32,
    object: u32,
}

// The nearest analytic specular object (sphere, open cylinder, rectangle; with `casters_only`,
// caustic casters only) the ray o + t d meets with
// 1e-4 < t < t_max, intersected exactly; `n` is the shape's outward normal. `leaving` is the
// object the ray leaves: o lies on its rasterized surface, a little off the analytic one, so the
// root near t = 0 is skipped: a sphere or a rectangle cannot be met again on the way out, a
// cylinder only beyond a hundredth of its radius.
fn exact_shape(o: vec3f, d: vec3f, t_max: f32, leaving: u32, casters_only: bool) -> ShapeHit {
    var best: ShapeHit;
    best.object = INVALID;
    best.t = t_max;
    var t_best = t_max;
    let eps = 1e-4;
    let count = arrayLength(&materials);
    for (var i = 0u; i < count; i++) {
        let m = materials[i];
        if ((casters_only && m.kind.y == 0u) || m.kind.x == KIND_DIFFUSE || m.kind.z == SHAPE_MESH) { continue; }
        if (i == leaving && m.kind.z != SHAPE_CYLINDER) { continue; }
        var t_min = eps;
        if (i == leaving) { t_min = max(eps, 0.01 * m.s0.w); }
        var t = -1.0;
        var n = vec3f(0.0);
        if (m.kind.z == SHAPE_SPHERE) {
            let w = o - m.s0.xyz;
            let b = dot(w, d);
            let c = dot(w, w) - m.s0.w * m.s0.w;
            let disc = b * b - c;
            if (disc >= 0.0) {
                let q = sqrt(disc);
                var tt = -b - q;
                if (tt <= eps) { tt = -b + q; }
                if (tt > eps) { t = tt; n = normalize(w + tt * d); }
            }
        } else if (m.kind.z == SHAPE_CYLINDER) {
            let axis = m.s1.xyz;
            let w = o - m.s0.xyz;
            let dp = d - axis * dot(d, axis);
            let wp = w - axis * dot(w, axis);
            let a = dot(dp, dp);
            if (a > 1e-12) {
                let b = dot(wp, dp);
                let c = dot(wp, wp) - m.s0.w * m.s0.w;
                let disc = b * b - a * c;
                if (disc >= 0.0) {
                    let q = sqrt(disc);
                    for (var k = 0u; k < 2u; k++) {
                        let tt = (-b + select(-q, q, k == 1u)) / a;
                        let h = dot(w + tt * d, axis);
                        if (tt > t_min && h >= 0.0 && h <= m.s1.w) { t = tt; n = normalize(wp + tt * dp); break; }
                    }
                }
            }
        } else if (m.kind.z == SHAPE_RECTANGLE) {
            let nn = m.s1.xyz;
            let dn = dot(d, nn);
            if (abs(dn) > 1e-8) {
                let tt = dot(m.s0.xyz - o, nn) / dn;
                let l = o + tt * d - m.s0.xyz;
                if (tt > eps && abs(dot(l, m.s2.xyz)) <= 0.5 * m.s2.w && abs(dot(l, m.s3.xyz)) <= 0.5 * m.s3.w) { t = tt; n = nn; }
            }
        }
        if (t > eps && t < t_best) {
            t_best = t;
            best.t = t;
            best.p = o + t * d;
            best.n = n;
            best.object = i;
        }
    }
    return best;
}

