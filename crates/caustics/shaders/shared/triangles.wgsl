// Shared by the caustic-triangle splats (caustic_triangles over the dense grid, splat_quads over
// the adaptive hierarchy's cell quads): a triangle's flux spread uniformly over its area in the
// caustic map, by the exact area of the triangle inside each texel (polygon clipping). Parts
// outside the map and rounding go to the texel of its centroid (clamped), so the whole flux
// lands exactly once. Uses `light` and `deposit` (shared/splat.wgsl): import splat first.

fn cross2(a: vec2f, b: vec2f) -> f32 {
    return a.x * b.y - a.y * b.x;
}

// Area of triangle (a, b, c) inside the unit square with corner t: the triangle is clipped
// (Sutherland-Hodgman) against the square's four sides, then the shoelace formula.
fn clipped_area(a: vec2f, b: vec2f, c: vec2f, t: vec2f) -> f32 {
    // Relative to the square's corner: f32 shoelace sums of absolute map coordinates (hundreds
    // of texels) would swamp the area of small triangles.
    var src: array<vec2f, 8>;
    var dst: array<vec2f, 8>;
    src[0] = a - t;
    src[1] = b - t;
    src[2] = c - t;
    var n = 3u;
    for (var side = 0u; side < 4u; side++) {
        let axis = side / 2u;
        let greater = (side & 1u) == 0u;
        let bound = select(1.0, 0.0, greater);
        var k = 0u;
        for (var i = 0u; i < n; i++) {
            let p = src[i];
            let q = src[(i + 1u) % n];
            let dp = select(bound - p[axis], p[axis] - bound, greater);
            let dq = select(bound - q[axis], q[axis] - bound, greater);
            if (dp >= 0.0) {
                dst[k] = p;
                k++;
            }
            if ((dp >= 0.0) != (dq >= 0.0)) {
                dst[k] = mix(p, q, dp / (dp - dq));
                k++;
            }
        }
        n = k;
        for (var i = 0u; i < n; i++) { src[i] = dst[i]; }
    }
    if (n < 3u) { return 0.0; }
    var s = 0.0;
    for (var i = 0u; i < n; i++) {
        s += cross2(src[i], src[(i + 1u) % n]);
    }
    return abs(0.5 * s);
}

fn triangle(face: u32, a: vec2f, b: vec2f, c: vec2f, flux: vec3f) {
    let m = i32(light.info.w);
    let centroid = clamp(vec2i(floor((a + b + c) / 3.0)), vec2i(0), vec2i(m - 1));
    let area = 0.5 * abs(cross2(b - a, c - a));
    let lo = max(vec2i(floor(min(a, min(b, c)))), vec2i(0));
    let hi = min(vec2i(floor(max(a, max(b, c)))), vec2i(m - 1));
    if (area < 1e-6 || all(lo == hi)) {
        deposit(face, centroid, flux);
        return;
    }
    var wsum = 0.0;
    for (var y = lo.y; y <= hi.y; y++) {
        for (var x = lo.x; x <= hi.x; x++) {
            let w = clipped_area(a, b, c, vec2f(f32(x), f32(y))) / area;
            if (w <= 0.0) { continue; }
            wsum += w;
            deposit(face, vec2i(x, y), flux * w);
        }
    }
    if (wsum < 1.0) { deposit(face, centroid, flux * (1.0 - wsum)); }
}
