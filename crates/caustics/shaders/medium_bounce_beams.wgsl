// Stage: medium_bounce_beams. The light one light's beams (the volume caustic, `beam_refine`)
// scatter in the medium, gathered into point emitters ("beam VPLs") for
// `medium_bounce_surfaces`, which lights the diffuse surfaces the camera sees with it
// (light -> glass -> fog -> floor -> camera: the floor around a volume caustic glows with it).
//
// Each listed beam is sampled at BEAM_EMIT_SAMPLES midpoints of equal height along the line of
// its barycentre (base c = the corners' mean, travel s = the mean of the edges' directions
// scaled to unit height, to the mean of the edges' end heights). A sample x inside the medium's
// box scatters
//   flux = sigma_s(x) * F * exp(-sigma_t * (tau_pre + tau(c -> x))) * dl
// (F the beam's flux, tau_pre the mean optical depth from the light to its base, dl the
// sample's length along the line), leaving by the phase function about the line's direction.
// Samples are binned by where they lie as the light sees them: the block of the light face that
// holds x (the `medium_bounce_grid`^2 blocks of `medium_bounce_lights`; a point no face holds
// goes to the nearest block of face 0) and one of BEAM_EMIT_SLICES slices of distance from the
// light over the range the samples span. Per bin, 64-bit fixed-point sums (two u32 words, as
// the caustic map's: the same bits whatever order the beams arrive in) of the flux (rgb), and
// of the grey flux times the position (normalized to the box), its square and the direction.
//
// `emit_pass` 0, per beam: the samples' range of distances (atomic max of the f32 bits: positive
//   floats order as their bits; the minimum as the complement's maximum).
// `emit_pass` 1, per beam: the sums.
// `emit_pass` 2, per bin: the VPL: full = the flux, caustic = 0 (the fog's caustic light on
//   a surface is not the first diffuse hit of the caustic's light: not in the caustic-only
//   image), position = the flux-weighted mean, r2 = 2 * the weighted variance + (slice
//   length)^2 / 12, nrm = the flux-weighted mean direction of travel.

#import beams
#import medium
#import beam_medium
#import medium_bounce

struct BeamEmitParams {
    // Blocks per side of a light face, the light's faces, the bins (faces * grid^2 * slices).
    grid: u32,
    faces: u32,
    bins: u32,
    _pad: u32,
    // The fixed-point scale (units per W of grey flux: the light's `params.y`).
    scale: f32,
    _pad1: f32,
    _pad2: f32,
    _pad3: f32,
}

@group(0) @binding(0) var<storage, read> bp: BeamParams;
@group(0) @binding(1) var<uniform> light: LightGpu;
@group(0) @binding(2) var<uniform> ep: BeamEmitParams;
@group(0) @binding(3) var<storage, read> beams: array<BeamGpu>;
@group(0) @binding(4) var<storage, read> order: array<u32>;
@group(0) @binding(5) var<storage, read> stats: array<u32>;
// Per bin BEAM_EMIT_WORDS words (emit_pass 1, 2); then the range's two words.
@group(0) @binding(6) var<storage, read_write> sums: array<atomic<u32>>;
@group(0) @binding(7) var<storage, read_write> vpls: array<Vpl>;
@group(0) @binding(8) var density_grid: texture_3d<f32>;

override emit_pass: u32 = 0u;

const BEAM_EMIT_SAMPLES: u32 = 8u;
const BEAM_EMIT_SLICES: u32 = 16u;
// Per bin: flux r, g, b; grey flux times the normalized position x, y, z, its square x, y, z
// and (direction + 1) / 2 x, y, z: 12 sums of two words.
const BEAM_EMIT_WORDS: u32 = 24u;

// (c, s, the sample spacing in height, the sample count's end height) of beam b's barycentre.
struct Line {
    c: vec3f,
    s: vec3f,
    dy: f32,
    pre: f32,
}

fn line_of(b: BeamGpu) -> Line {
    let bs = beam_space(b);
    var l: Line;
    l.c = (bs.v[0] + bs.v[1] + bs.v[2]) / 3.0;
    l.s = (bs.s[0] + bs.s[1] + bs.s[2]) / 3.0;
    l.dy = max((bs.yend.x + bs.yend.y + bs.yend.z) / 3.0, 0.0) / f32(BEAM_EMIT_SAMPLES);
    l.pre = (b.v0.w + b.v1.w + b.v2.w) / 3.0;
    return l;
}

fn add_fixed(word: u32, value: f32) {
    let v = max(value * ep.scale, 0.0);
    let hi = floor(v / 4294967296.0);
    let lo = u32(v - hi * 4294967296.0);
    if (lo == 0u && hi == 0.0) { return; }
    let old = atomicAdd(&sums[word], lo);
    var carry = 0u;
    if (old > 0xffffffffu - lo) { carry = 1u; }
    let h = u32(hi) + carry;
    if (h != 0u) { atomicAdd(&sums[word + 1u], h); }
}

fn read_fixed(word: u32) -> f32 {
    return (f32(atomicLoad(&sums[word])) + f32(atomicLoad(&sums[word + 1u])) * 4294967296.0) / ep.scale;
}

// The block (face, bx, by) that holds x.
fn block_of(x: vec3f) -> vec3u {
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

fn light_distance(x: vec3f) -> f32 {
    return length(x - light.faces[0].origin.xyz);
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    let range_at = ep.bins * BEAM_EMIT_WORDS;
    if (emit_pass == 2u) {
        resolve(gid.x, range_at);
        return;
    }
    let count = min(stats[1u + BS_ORDERED], bp.capacity);
    if (gid.x >= count) { return; }
    let b = beams[order[gid.x]];
    if (all(b.flux.rgb <= vec3f(0.0))) { return; }
    let l = line_of(b);
    if (!(l.dy > 0.0)) { return; }
    let dl = l.dy * length(l.s);
    let dir = normalize(l.s);
    var d_lo = 0.0;
    var d_span = 0.0;
    if (emit_pass == 1u) {
        d_lo = bitcast<f32>(~atomicLoad(&sums[range_at]));
        d_span = bitcast<f32>(atomicLoad(&sums[range_at + 1u])) - d_lo;
    }
    let lo = bp.lo.xyz;
    let size = bp.hi.xyz - bp.lo.xyz;
    for (var i = 0u; i < BEAM_EMIT_SAMPLES; i++) {
        let x = l.c + l.s * ((f32(i) + 0.5) * l.dy);
        if (any(x < lo) || any(x > bp.hi.xyz)) { continue; }
        let d = light_distance(x);
        if (emit_pass == 0u) {
            atomicMax(&sums[range_at], ~bitcast<u32>(d));
            atomicMax(&sums[range_at + 1u], bitcast<u32>(d));
            continue;
        }
        let tr = exp(-bp.sigma_t.rgb * (l.pre + beam_depth(l.c, x)));
        let flux = bp.sigma_s.rgb * beam_density(x) * b.flux.rgb * tr * dl;
        let grey = (flux.r + flux.g + flux.b) / 3.0;
        if (!(grey > 0.0)) { continue; }
        var slice = 0u;
        if (d_span > 0.0) { slice = min(u32(max((d - d_lo) / d_span, 0.0) * f32(BEAM_EMIT_SLICES)), BEAM_EMIT_SLICES - 1u); }
        let blk = block_of(x);
        let bin = ((blk.x * ep.grid + blk.z) * ep.grid + blk.y) * BEAM_EMIT_SLICES + slice;
        let w = bin * BEAM_EMIT_WORDS;
        let u = clamp((x - lo) / size, vec3f(0.0), vec3f(1.0));
        let m = (dir + 1.0) * 0.5;
        add_fixed(w, flux.r);
        add_fixed(w + 2u, flux.g);
        add_fixed(w + 4u, flux.b);
        for (var k = 0u; k < 3u; k++) {
            add_fixed(w + 6u + 2u * k, grey * u[k]);
            add_fixed(w + 12u + 2u * k, grey * u[k] * u[k]);
            add_fixed(w + 18u + 2u * k, grey * m[k]);
        }
    }
}

fn resolve(bin: u32, range_at: u32) {
    if (bin >= ep.bins) { return; }
    let w = bin * BEAM_EMIT_WORDS;
    let flux = vec3f(read_fixed(w), read_fixed(w + 2u), read_fixed(w + 4u));
    var v = Vpl(vec4f(0.0), vec4f(0.0, 0.0, 1.0, 0.0), vec4f(0.0), vec4f(0.0));
    // (the grey flux the moments were weighted by: the same sums)
    let grey = (flux.r + flux.g + flux.b) / 3.0;
    if (grey > 0.0) {
        let size = bp.hi.xyz - bp.lo.xyz;
        var mean = vec3f(0.0);
        var var_w = 0.0;
        var m = vec3f(0.0);
        for (var k = 0u; k < 3u; k++) {
            let mu = read_fixed(w + 6u + 2u * k) / grey;
            let m2 = read_fixed(w + 12u + 2u * k) / grey;
            mean[k] = mu;
            var_w += max(m2 - mu * mu, 0.0) * size[k] * size[k];
            m[k] = read_fixed(w + 18u + 2u * k) / grey * 2.0 - 1.0;
        }
        let d_lo = bitcast<f32>(~atomicLoad(&sums[range_at]));
        let slice_len = (bitcast<f32>(atomicLoad(&sums[range_at + 1u])) - d_lo) / f32(BEAM_EMIT_SLICES);
        var dir = vec3f(0.0, 0.0, 1.0);
        if (dot(m, m) > 1e-12) { dir = normalize(m); }
        v.pos = vec4f(bp.lo.xyz + mean * size, 2.0 * var_w + slice_len * slice_len / 12.0);
        v.nrm = vec4f(dir, 0.0);
        v.full = vec4f(flux, 0.0);
    }
    vpls[bin] = v;
}
