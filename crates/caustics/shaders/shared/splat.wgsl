// Shared by the splat stages (photon_splat, splat_lens, splat_multires, splat_quads,
// caustic_triangles): 64-bit fixed-point accumulation into `accum` (per face, per texel, per
// channel: (lo, hi) word pairs), the texel index, and a normalised Gaussian splat. Uses the
// module-scope bindings `light` and `accum` (shared/splat_photons.wgsl, or the stage's own).

// Photon count of a splat dispatch, after the (indirect) dispatch arguments that the adaptive
// techniques write on the GPU.
struct SplatParams {
    groups_x: u32,
    groups_y: u32,
    groups_z: u32,
    count: u32,
}

fn add64(word: u32, value: f32) {
    let w = fixed_words(max(value, 0.0));
    if (w.x == 0u && w.y == 0u) { return; }
    let h = w.y + fixed_carry(atomicAdd(&accum[word], w.x), w.x);
    if (h != 0u) { atomicAdd(&accum[word + 1u], h); }
}

fn texel_index(face: u32, t: vec2i) -> u32 {
    let m = light.info.w;
    return (face * m + u32(t.y)) * m + u32(t.x);
}

// Add flux (W, rgb) to texel t of face `face`.
fn deposit(face: u32, t: vec2i, flux: vec3f) {
    let base = texel_index(face, t) * 6u;
    let s = light.params.y;
    add64(base, flux.r * s);
    add64(base + 2u, flux.g * s);
    add64(base + 4u, flux.b * s);
}

// A Gaussian splat of standard deviation sigma texels (cut at 3 sigma) at continuous texel
// position pos, its weights normalised over the texels inside the map: the whole flux lands.
// The unnormalised weight of texel t (0 outside the m x m map or beyond 3 sigma).
fn gauss_weight(t: vec2i, pos: vec2f, sigma: f32, m: i32) -> f32 {
    if (t.x < 0 || t.y < 0 || t.x >= m || t.y >= m) { return 0.0; }
    let dd = vec2f(t) + 0.5 - pos;
    let d2 = dot(dd, dd);
    if (d2 > 9.0 * sigma * sigma) { return 0.0; }
    return exp(-0.5 * d2 / (sigma * sigma));
}

fn gauss_splat(face: u32, pos: vec2f, flux: vec3f, sigma: f32) {
    let m = i32(light.info.w);
    let r = i32(ceil(3.0 * sigma));
    if (light.info.x == 6u && (any(pos - 3.0 * sigma < vec2f(0.0)) || any(pos + 3.0 * sigma > vec2f(f32(m))))) {
        gauss_splat_cube(face, pos, flux, sigma);
        return;
    }
    let c = vec2i(floor(pos));
    var wsum = 0.0;
    for (var y = -r; y <= r; y++) {
        for (var x = -r; x <= r; x++) {
            wsum += gauss_weight(c + vec2i(x, y), pos, sigma, m);
        }
    }
    if (wsum <= 0.0) {
        // No texel centre within the cut (sigma below half a texel): the nearest texel.
        deposit(face, clamp(c, vec2i(0), vec2i(m - 1)), flux);
        return;
    }
    for (var y = -r; y <= r; y++) {
        for (var x = -r; x <= r; x++) {
            let t = c + vec2i(x, y);
            let w = gauss_weight(t, pos, sigma, m);
            if (w > 0.0) { deposit(face, t, flux * (w / wsum)); }
        }
    }
}

// The texel box of face g that the square [lo, hi] of face f's texel coordinates (extended past
// its map) covers, clamped to the map: (x0, y0, x1, y1), empty (x1 < x0) where g sees none of it
// or some corner lies behind g.
fn cube_box(f: u32, g: u32, lo: vec2f, hi: vec2f, m: i32) -> vec4i {
    let empty = vec4i(0, 0, -1, -1);
    if (f == g) {
        return vec4i(max(vec2i(floor(lo)), vec2i(0)), min(vec2i(floor(hi)), vec2i(m - 1)));
    }
    var a = vec2f(1e30);
    var b = vec2f(-1e30);
    for (var k = 0u; k < 4u; k++) {
        let c = vec2f(select(lo.x, hi.x, (k & 1u) != 0u), select(lo.y, hi.y, (k & 2u) != 0u));
        let t = texel_in_face(light.faces[f], light.faces[g], c, f32(m));
        if (t.z == 0.0) { return empty; }
        a = min(a, t.xy);
        b = max(b, t.xy);
    }
    let x0 = max(vec2i(floor(a)), vec2i(0));
    let x1 = min(vec2i(floor(b)), vec2i(m - 1));
    if (any(x1 < x0)) { return empty; }
    return vec4i(x0, x1);
}

// The weight of texel t of face g for a Gaussian at pos in face f's (extended) coordinates:
// the texel's centre taken into f's coordinates.
fn cube_weight(f: u32, g: u32, t: vec2i, pos: vec2f, sigma: f32, m: i32) -> f32 {
    if (f == g) { return gauss_weight(t, pos, sigma, m); }
    let c = texel_in_face(light.faces[g], light.faces[f], vec2f(t) + 0.5, f32(m));
    if (c.z == 0.0) { return 0.0; }
    let dd = c.xy - pos;
    let d2 = dot(dd, dd);
    if (d2 > 9.0 * sigma * sigma) { return 0.0; }
    return exp(-0.5 * d2 / (sigma * sigma));
}

// A Gaussian splat of a point light's cube that reaches past its face's edge: the texels of
// every face it covers, weighed in face f's coordinates extended past its map, normalised over
// all of them (the whole flux lands once). Held inside one face, the part past the edge was
// pressed into the face's last texels: lines along the cube's seams.
fn gauss_splat_cube(f: u32, pos: vec2f, flux: vec3f, sigma: f32) {
    let m = i32(light.info.w);
    let lo = pos - 3.0 * sigma;
    let hi = pos + 3.0 * sigma;
    var boxes: array<vec4i, 6>;
    var wsum = 0.0;
    for (var g = 0u; g < 6u; g++) {
        boxes[g] = cube_box(f, g, lo, hi, m);
        for (var y = boxes[g].y; y <= boxes[g].w; y++) {
            for (var x = boxes[g].x; x <= boxes[g].z; x++) {
                wsum += cube_weight(f, g, vec2i(x, y), pos, sigma, m);
            }
        }
    }
    if (wsum <= 0.0) {
        deposit(f, clamp(vec2i(floor(pos)), vec2i(0), vec2i(m - 1)), flux);
        return;
    }
    for (var g = 0u; g < 6u; g++) {
        for (var y = boxes[g].y; y <= boxes[g].w; y++) {
            for (var x = boxes[g].x; x <= boxes[g].z; x++) {
                let w = cube_weight(f, g, vec2i(x, y), pos, sigma, m);
                if (w > 0.0) { deposit(g, vec2i(x, y), flux * (w / wsum)); }
            }
        }
    }
}
