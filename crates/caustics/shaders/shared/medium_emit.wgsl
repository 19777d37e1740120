// Shared WGSL (`#import medium_emit`, after `#import medium_bounce`): point emitters binned from
// samples of light scattered in the medium (`medium_bounce_beams`:
// the beams' light; `medium_bounce_glow`: the surfaces' light), for `medium_bounce_surfaces`.
// A stage using these declares `light` (LightGpu), `ep` (EmitParams), `sums` (atomic u32
// words: per bin EMIT_WORDS, then the samples' range of distances: two words) and `vpls` (the
// emitters, one per bin).
// Samples are binned by where they lie as the light sees them: the block of the light face
// that holds x (`ep.grid`^2 blocks per face; a point no face holds goes to the nearest block of
// face 0) and one of `ep.slices` slices of distance from the light (a directional light: along
// its direction) over the range the samples span. Per bin, 64-bit fixed-point sums (two u32
// words, as the caustic map's: the same bits whatever order the samples arrive in) of the flux
// (rgb), and of the grey flux times the position (normalized to the box), its square and the
// direction.

struct EmitParams {
    // The medium's box and coefficients: rgb = sigma_s (w = Henyey-Greenstein g), sigma_t.
    lo: vec4f,
    hi: vec4f,
    sigma_s: vec4f,
    sigma_t: vec4f,
    // Blocks per side of a light face, the light's faces, the bins (faces * grid^2 * slices),
    // slices per block.
    grid: u32,
    faces: u32,
    bins: u32,
    slices: u32,
    // The fixed-point scale (units per W: the light's `params.y`).
    scale: f32,
    // 1: heterogeneous (density grid), 0: homogeneous.
    heterogeneous: u32,
    // `medium_bounce_glow`: the light's first surface VPL and its VPLs.
    vpl_offset: u32,
    vpl_count: u32,
    // 1: the emitters' light is caustic light (their `caustic` = their flux).
    caustic: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// Per bin: flux r, g, b; grey flux times the normalized position x, y, z, its square x, y, z
// and (direction + 1) / 2 x, y, z: 12 sums of two words.
const EMIT_WORDS: u32 = 24u;

// (The 64-bit fixed-point add of `shared/splat.wgsl`'s `add64` and `trace.wgsl`'s `add_fixed`,
// on this stage's `sums`: WGSL passes no pointer to a storage array of atomics to a shared
// function without the unrestricted-pointer-parameters extension.)
fn emit_add(word: u32, value: f32) {
    let w = fixed_words(max(value * ep.scale, 0.0));
    if (w.x == 0u && w.y == 0u) { return; }
    let h = w.y + fixed_carry(atomicAdd(&sums[word], w.x), w.x);
    if (h != 0u) { atomicAdd(&sums[word + 1u], h); }
}

fn emit_read(word: u32) -> f32 {
    return (f32(atomicLoad(&sums[word])) + f32(atomicLoad(&sums[word + 1u])) * 4294967296.0) / ep.scale;
}

// The block (face, bx, by) that holds x.
fn emit_block(x: vec3f) -> vec3u {
    let g = f32(ep.grid);
    for (var f = 0u; f < ep.faces; f++) {
        let c = light.faces[f].world_to_clip * vec4f(x, 1.0);
        if (c.w <= 0.0) { continue; }
        let n = c.xy / c.w;
        if (abs(n.x) > 1.0 || abs(n.y) > 1.0) { continue; }
        let b = clamp(vec2i(floor((vec2f(n.x, -n.y) * 0.5 + 0.5) * g)), vec2i(0), vec2i(i32(ep.grid) - 1));
        return vec3u(f, u32(b.x), u32(b.y));
    }
    let c = light.faces[0].world_to_clip * vec4f(x, 1.0);
    let n = clamp(c.xy / max(abs(c.w), 1e-12), vec2f(-1.0), vec2f(1.0));
    let b = clamp(vec2i(floor((vec2f(n.x, -n.y) * 0.5 + 0.5) * g)), vec2i(0), vec2i(i32(ep.grid) - 1));
    return vec3u(0u, u32(b.x), u32(b.y));
}

// The distance from the light that slices the bins (a directional light: along its direction,
// from the box's centre; negative values are fine, the range is the samples').
fn emit_distance(x: vec3f) -> f32 {
    if (light.info.y == LIGHT_DIRECTIONAL) {
        return dot(x - 0.5 * (ep.lo.xyz + ep.hi.xyz), normalize(light.axis.xyz)) + length(ep.hi.xyz - ep.lo.xyz);
    }
    return length(x - light.faces[0].origin.xyz);
}

// `emit_pass` 0: widen the range of distances by the sample at x (atomic maxima of the f32 bits:
// positive floats order as their bits; the minimum as the complement's maximum).
fn emit_range(x: vec3f) {
    let range_at = ep.bins * EMIT_WORDS;
    let d = emit_distance(x);
    atomicMax(&sums[range_at], ~bitcast<u32>(d));
    atomicMax(&sums[range_at + 1u], bitcast<u32>(d));
}

// `emit_pass` 1: add a sample (flux rgb, W, at x, leaving by the phase function about `dir`).
fn emit_deposit(x: vec3f, flux: vec3f, dir: vec3f) {
    let grey = (flux.r + flux.g + flux.b) / 3.0;
    if (!(grey > 0.0)) { return; }
    let range_at = ep.bins * EMIT_WORDS;
    let d_lo = bitcast<f32>(~atomicLoad(&sums[range_at]));
    let d_span = bitcast<f32>(atomicLoad(&sums[range_at + 1u])) - d_lo;
    var slice = 0u;
    if (d_span > 0.0) { slice = min(u32(max((emit_distance(x) - d_lo) / d_span, 0.0) * f32(ep.slices)), ep.slices - 1u); }
    let blk = emit_block(x);
    let bin = ((blk.x * ep.grid + blk.z) * ep.grid + blk.y) * ep.slices + slice;
    let w = bin * EMIT_WORDS;
    let u = clamp((x - ep.lo.xyz) / (ep.hi.xyz - ep.lo.xyz), vec3f(0.0), vec3f(1.0));
    let m = (dir + 1.0) * 0.5;
    emit_add(w, flux.r);
    emit_add(w + 2u, flux.g);
    emit_add(w + 4u, flux.b);
    for (var k = 0u; k < 3u; k++) {
        emit_add(w + 6u + 2u * k, grey * u[k]);
        emit_add(w + 12u + 2u * k, grey * u[k] * u[k]);
        emit_add(w + 18u + 2u * k, grey * m[k]);
    }
}

// `emit_pass` 2: bin `bin`'s emitter: full = the flux, caustic = 0 (light scattered in the
// medium before it reaches a surface is not the caustic map's first diffuse hit) or, with
// `ep.caustic`, the flux, position = the flux-weighted mean, r2 = 2 * the weighted variance +
// (slice length)^2 / 12 (one slice: no range, 0), nrm = the flux-weighted mean direction.
fn emit_resolve(bin: u32) {
    if (bin >= ep.bins) { return; }
    let w = bin * EMIT_WORDS;
    let flux = vec3f(emit_read(w), emit_read(w + 2u), emit_read(w + 4u));
    var v = Vpl(vec4f(0.0), vec4f(0.0, 0.0, 1.0, 0.0), vec4f(0.0), vec4f(0.0));
    // (the grey flux the moments were weighted by: the same sums)
    let grey = (flux.r + flux.g + flux.b) / 3.0;
    if (grey > 0.0) {
        let size = ep.hi.xyz - ep.lo.xyz;
        var mean = vec3f(0.0);
        var var_w = 0.0;
        var m = vec3f(0.0);
        for (var k = 0u; k < 3u; k++) {
            let mu = emit_read(w + 6u + 2u * k) / grey;
            let m2 = emit_read(w + 12u + 2u * k) / grey;
            mean[k] = mu;
            var_w += max(m2 - mu * mu, 0.0) * size[k] * size[k];
            m[k] = emit_read(w + 18u + 2u * k) / grey * 2.0 - 1.0;
        }
        let range_at = ep.bins * EMIT_WORDS;
        var slice_len = 0.0;
        if (ep.slices > 1u) {
            let d_lo = bitcast<f32>(~atomicLoad(&sums[range_at]));
            slice_len = (bitcast<f32>(atomicLoad(&sums[range_at + 1u])) - d_lo) / f32(ep.slices);
        }
        var dir = vec3f(0.0, 0.0, 1.0);
        if (dot(m, m) > 1e-12) { dir = normalize(m); }
        v.pos = vec4f(ep.lo.xyz + mean * size, 2.0 * var_w + slice_len * slice_len / 12.0);
        v.nrm = vec4f(dir, 0.0);
        v.full = vec4f(flux, 0.0);
        if (ep.caustic != 0u) { v.caustic = v.full; }
    }
    vpls[bin] = v;
}
