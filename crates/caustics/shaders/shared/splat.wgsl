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
