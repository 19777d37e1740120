// Stage: splat_multires. Adaptive multi-resolution splatting (Wyman & Dachsbacher 2008, section
// 4.1): each photon is splatted once over its largest footprint; every texel of it receives the
// photon's flux under four truncated Gaussians of radii r_i = RADII[i] * splat sigma (about 3, 7,
// 11 and 15 texels across at sigma 1, the paper's point sizes), each normalised over the texels
// inside the map (every intensity map holds the whole flux), and a count per radius of the
// photons whose footprint covers it. splat_multires_blend chooses per texel.
// Maps: intensity of radius 3 in `accum` (the caustic map itself), radii 0..2 in flux0..flux2
// (same layout), counts in `counts` (4 u32 per texel).

#import splat
#import splat_photons

@group(0) @binding(4) var<storage, read_write> flux0: array<atomic<u32>>;
@group(0) @binding(5) var<storage, read_write> flux1: array<atomic<u32>>;
@group(0) @binding(6) var<storage, read_write> flux2: array<atomic<u32>>;
@group(0) @binding(7) var<storage, read_write> counts: array<atomic<u32>>;

const RADII: vec4f = vec4f(1.5, 3.5, 5.5, 7.5);

fn add_to(map: u32, word: u32, value: f32) {
    let w = fixed_words(max(value, 0.0));
    if (w.x == 0u && w.y == 0u) { return; }
    var old = 0u;
    switch map {
        case 0u: { old = atomicAdd(&flux0[word], w.x); }
        case 1u: { old = atomicAdd(&flux1[word], w.x); }
        case 2u: { old = atomicAdd(&flux2[word], w.x); }
        default: { old = atomicAdd(&accum[word], w.x); }
    }
    let h = w.y + fixed_carry(old, w.x);
    if (h == 0u) { return; }
    switch map {
        case 0u: { atomicAdd(&flux0[word + 1u], h); }
        case 1u: { atomicAdd(&flux1[word + 1u], h); }
        case 2u: { atomicAdd(&flux2[word + 1u], h); }
        default: { atomicAdd(&accum[word + 1u], h); }
    }
}

// Truncated Gaussian of radius r (sigma = r / 2).
fn kernel(d2: f32, r: f32) -> f32 {
    if (d2 > r * r) { return 0.0; }
    return exp(-2.0 * d2 / (r * r));
}

// The four kernels' weights (radii) at texel t for a photon at continuous texel position pos: 0
// outside the m x m map.
fn kernels(t: vec2i, pos: vec2f, radii: vec4f, m: i32) -> vec4f {
    var k = vec4f(0.0);
    if (t.x < 0 || t.y < 0 || t.x >= m || t.y >= m) { return k; }
    let dd = vec2f(t) + 0.5 - pos;
    let d2 = dot(dd, dd);
    for (var i = 0u; i < 4u; i++) { k[i] = kernel(d2, radii[i]); }
    return k;
}

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) nwg: vec3u, @builtin(local_invocation_index) lid: u32) {
    let index = splat_index(wg, nwg, lid);
    if (index == INVALID) { return; }
    let ph = photons[index];
    let m = i32(light.info.w);
    let radii = RADII * light.params.z;
    let rr = i32(ceil(radii.w));
    let c = vec2i(floor(ph.pos));
    var wsum = vec4f(0.0);
    for (var y = -rr; y <= rr; y++) {
        for (var x = -rr; x <= rr; x++) {
            let k = kernels(c + vec2i(x, y), ph.pos, radii, m);
            for (var i = 0u; i < 4u; i++) { wsum[i] += k[i]; }
        }
    }
    let s = light.params.y;
    let cn = clamp(c, vec2i(0), vec2i(m - 1));
    for (var i = 0u; i < 4u; i++) {
        if (wsum[i] <= 0.0) {
            // Radius below half a texel: the nearest texel takes it all.
            let b = texel_index(ph.face, cn) * 6u;
            add_to(i, b, ph.flux.r * s);
            add_to(i, b + 2u, ph.flux.g * s);
            add_to(i, b + 4u, ph.flux.b * s);
            atomicAdd(&counts[texel_index(ph.face, cn) * 4u + i], 1u);
        }
    }
    for (var y = -rr; y <= rr; y++) {
        for (var x = -rr; x <= rr; x++) {
            let t = c + vec2i(x, y);
            let k = kernels(t, ph.pos, radii, m);
            let tex = texel_index(ph.face, t);
            for (var i = 0u; i < 4u; i++) {
                if (k[i] <= 0.0 || wsum[i] <= 0.0) { continue; }
                let w = k[i] / wsum[i] * s;
                add_to(i, tex * 6u, ph.flux.r * w);
                add_to(i, tex * 6u + 2u, ph.flux.g * w);
                add_to(i, tex * 6u + 4u, ph.flux.b * w);
                atomicAdd(&counts[tex * 4u + i], 1u);
            }
        }
    }
}
