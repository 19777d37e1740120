// Stage: splat_multires_blend. Per texel, the multi-resolution caustic map's value (Wyman &
// Dachsbacher 2008, section 4.1): start from the largest splat's intensity; for each smaller
// radius (11, 7, 3 texels across), blend toward it with the cubic Bernstein interpolant
// 3t^2 - 2t^3 of its photon count (t = 0 at 8 photons, 1 at 16), and only where the smaller
// splat increases the intensity. pass 0 writes the blend into `accum` (the caustic map) and sums
// per face the flux before (largest splat: exactly the photons' flux) and after; pass 1 rescales
// every texel of the face by before / after, so the map holds the photons' flux exactly once
// (the blend alone is biased upward by its "only where brighter" rule).

struct BlendParams {
    count: u32,
    pass_index: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> light: LightGpu;
@group(0) @binding(1) var<uniform> bp: BlendParams;
@group(0) @binding(2) var<storage, read_write> accum: array<u32>;
@group(0) @binding(3) var<storage, read> flux0: array<u32>;
@group(0) @binding(4) var<storage, read> flux1: array<u32>;
@group(0) @binding(5) var<storage, read> flux2: array<u32>;
@group(0) @binding(6) var<storage, read> counts: array<u32>;
// Per face: (before lo, before hi, after lo, after hi), fixed point, r + g + b.
@group(0) @binding(7) var<storage, read_write> sums: array<atomic<u32>>;

const MIN_PHOTONS: f32 = 8.0;
const MAX_PHOTONS: f32 = 16.0;

fn to_f32(lo: u32, hi: u32) -> f32 {
    return f32(hi) * 4294967296.0 + f32(lo);
}

fn sum64(word: u32, v_in: f32) {
    let w = fixed_words(max(v_in, 0.0));
    let old = atomicAdd(&sums[word], w.x);
    atomicAdd(&sums[word + 1u], w.y + fixed_carry(old, w.x));
}

fn store(b: u32, v: vec3f) {
    for (var c = 0u; c < 3u; c++) {
        let w = fixed_words(max(v[c], 0.0));
        accum[b + 2u * c] = w.x;
        accum[b + 2u * c + 1u] = w.y;
    }
}

fn read3(b: u32, which: u32) -> vec3f {
    var v = vec3f(0.0);
    for (var c = 0u; c < 3u; c++) {
        let w = b + 2u * c;
        switch which {
            case 0u: { v[c] = to_f32(flux0[w], flux0[w + 1u]); }
            case 1u: { v[c] = to_f32(flux1[w], flux1[w + 1u]); }
            case 2u: { v[c] = to_f32(flux2[w], flux2[w + 1u]); }
            default: { v[c] = to_f32(accum[w], accum[w + 1u]); }
        }
    }
    return v;
}

@compute @workgroup_size(256)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    if (gid.x >= bp.count) { return; }
    let m = light.info.w;
    let face = gid.x / (m * m);
    let b = gid.x * 6u;
    if (bp.pass_index == 1u) {
        let before = to_f32(atomicLoad(&sums[face * 4u]), atomicLoad(&sums[face * 4u + 1u]));
        let after = to_f32(atomicLoad(&sums[face * 4u + 2u]), atomicLoad(&sums[face * 4u + 3u]));
        if (after <= 0.0) { return; }
        store(b, read3(b, 3u) * (before / after));
        return;
    }
    var e = read3(b, 3u);
    let total = e.r + e.g + e.b;
    if (total <= 0.0) { return; }
    for (var k = 0; k < 3; k++) {
        let i = u32(2 - k);
        let small = read3(b, i);
        if (small.r + small.g + small.b <= e.r + e.g + e.b) { continue; }
        let t = clamp((f32(counts[gid.x * 4u + i]) - MIN_PHOTONS) / (MAX_PHOTONS - MIN_PHOTONS), 0.0, 1.0);
        let w = t * t * (3.0 - 2.0 * t);
        e = mix(e, small, w);
    }
    store(b, e);
    sum64(face * 4u, total);
    sum64(face * 4u + 2u, e.r + e.g + e.b);
}
