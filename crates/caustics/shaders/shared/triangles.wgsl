// Shared by the caustic-triangle splats (caustic_triangles over the dense grid, splat_quads over
// the adaptive hierarchy's cell quads): a triangle's flux spread uniformly over its area in the
// caustic map, by the exact area of the triangle inside each texel (polygon clipping). Parts
// outside the map and rounding go to the texel of its centroid (clamped), so the whole flux
// lands exactly once. Uses `light` and `deposit` (shared/splat.wgsl): import splat first.

fn cross2(a: vec2f, b: vec2f) -> f32 {
    return a.x * b.y - a.y * b.x;
}

// Integral over x in [0, 1] of clamp(y, 0, 1) along the segment p -> q (signed: negative when
// it runs towards -x). With G(y) = integral of clamp(y, 0, 1) dy, a straight piece gives
// (G(y1) - G(y0)) / slope; a (nearly) flat one clamp(y) times its length.
fn clamped_g(y: f32) -> f32 {
    return select(select(y - 0.5, 0.5 * y * y, y <= 1.0), 0.0, y <= 0.0);
}

fn edge_integral(p: vec2f, q: vec2f) -> f32 {
    let dx = q.x - p.x;
    if (dx == 0.0) { return 0.0; }
    let x0 = clamp(min(p.x, q.x), 0.0, 1.0);
    let x1 = clamp(max(p.x, q.x), 0.0, 1.0);
    if (x1 <= x0) { return 0.0; }
    let slope = (q.y - p.y) / dx;
    let y0 = p.y + (x0 - p.x) * slope;
    let y1 = p.y + (x1 - p.x) * slope;
    var v = 0.0;
    if (abs(y1 - y0) < 1e-4) {
        v = clamp(0.5 * (y0 + y1), 0.0, 1.0) * (x1 - x0);
    } else {
        v = (clamped_g(y1) - clamped_g(y0)) / slope;
    }
    return select(-v, v, dx > 0.0);
}

// Area of triangle (a, b, c) inside the unit square with corner t, by Green's theorem: minus the
// boundary integral of clamp(y, 0, 1) dx over x in [0, 1]. Loop-free on purpose: with a
// polygon-clipping loop inside the texel loops, large triangles got areas too large on llvmpipe
// (Mesa 22.3), and maps that depended on which triangles shared a SIMD group, from identical
// inputs (deterministic with one thread). The likely cause, inferred, not read in Mesa's
// source: llvmpipe's cap of 65535 iterations per loop nest and SIMD group cut the clipping
// short.
fn clipped_area(a: vec2f, b: vec2f, c: vec2f, t: vec2f) -> f32 {
    // Relative to the square's corner: the map coordinates (hundreds of texels) would swamp
    // the area of small triangles.
    let p0 = a - t;
    let p1 = b - t;
    let p2 = c - t;
    return abs(edge_integral(p0, p1) + edge_integral(p1, p2) + edge_integral(p2, p0));
}

fn triangle(face: u32, a: vec2f, b: vec2f, c: vec2f, flux: vec3f) {
    let m = i32(light.info.w);
    let mf = f32(m);
    if (light.info.x == 6u && (any(min(a, min(b, c)) < vec2f(0.0)) || any(max(a, max(b, c)) > vec2f(mf)))) {
        triangle_cube(face, a, b, c, flux);
        return;
    }
    triangle_in_face(face, a, b, c, flux, 1.0);
}

// `flux`, the part of a triangle's flux that lands in face `face`'s map (`share` of the
// triangle's area there lies inside the map), spread over the texels the triangle (a, b, c)
// covers by exact clipped area, renormalised to the share; rounding (and a triangle of no area,
// or inside one texel) goes to the texel of its centroid (clamped).
fn triangle_in_face(face: u32, a: vec2f, b: vec2f, c: vec2f, flux: vec3f, share: f32) {
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
            deposit(face, vec2i(x, y), flux * (w / share));
        }
    }
    if (wsum < share) { deposit(face, centroid, flux * (1.0 - wsum / share)); }
}

// The share of triangle (a, b, c) (texel coordinates of one face) inside the m x m map: 1 for
// a triangle of no area whose centroid lies in the map, else 0 for one.
fn map_share(a: vec2f, b: vec2f, c: vec2f, m: f32) -> f32 {
    let area = 0.5 * abs(cross2(b - a, c - a));
    if (area < 1e-6) {
        let g = (a + b + c) / 3.0;
        return select(0.0, 1.0, all(g >= vec2f(0.0)) && all(g < vec2f(m)));
    }
    // The map as the unit square (scaled coordinates): one clipping of the whole triangle.
    return clamp(clipped_area(a / m, b / m, c / m, vec2f(0.0)) * m * m / area, 0.0, 1.0);
}

// A caustic triangle of a point light's cube (or a spot light's wider than a face) that leaves
// its face's map: given in face f's texel coordinates, extended past the map, it crosses a seam
// of the cube. Each face g the triangle's corners lie in front of receives the part of the
// triangle inside g's map, re-projected into g (exact clipped area per texel, as `triangle`),
// the shares normalised so that the whole flux lands once. Without it the quads across a seam
// fell back to Gaussians held inside one face, drawing the seams as bright and dark lines.
fn triangle_cube(f: u32, a: vec2f, b: vec2f, c: vec2f, flux: vec3f) {
    let m = i32(light.info.w);
    let mf = f32(m);
    var share: array<f32, 6>;
    var total = 0.0;
    for (var g = 0u; g < 6u; g++) {
        share[g] = 0.0;
        let ga = texel_in_face(light.faces[f], light.faces[g], a, mf);
        let gb = texel_in_face(light.faces[f], light.faces[g], b, mf);
        let gc = texel_in_face(light.faces[f], light.faces[g], c, mf);
        if (ga.z == 0.0 || gb.z == 0.0 || gc.z == 0.0) { continue; }
        share[g] = map_share(ga.xy, gb.xy, gc.xy, mf);
        total += share[g];
    }
    if (total <= 0.0) {
        deposit(f, clamp(vec2i(floor((a + b + c) / 3.0)), vec2i(0), vec2i(m - 1)), flux);
        return;
    }
    for (var g = 0u; g < 6u; g++) {
        if (share[g] <= 0.0) { continue; }
        let ga = texel_in_face(light.faces[f], light.faces[g], a, mf).xy;
        let gb = texel_in_face(light.faces[f], light.faces[g], b, mf).xy;
        let gc = texel_in_face(light.faces[f], light.faces[g], c, mf).xy;
        triangle_in_face(g, ga, gb, gc, flux * (share[g] / total), share[g]);
    }
}
