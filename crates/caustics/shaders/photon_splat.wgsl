// Stage: photon_splat. Splats each photon's flux into the caustic map with a Gaussian kernel of
// sigma texels (WebGPU has no point sizes: compute atomics). The kernel's weights are normalised
// over the texels inside the map, so a photon's whole flux lands in the map.
// Accumulation is in 64-bit fixed point (two u32 words, carry propagated), so the sum does not
// depend on the order photons arrive in: bit-identical maps run to run.
// Layout of `accum`: per face, per texel, per channel (r, g, b): (lo, hi).
// The photon count is read from a storage buffer whose first three words are the (indirect)
// dispatch arguments: the adaptive techniques write count and arguments on the GPU.

struct SplatParams {
    groups_x: u32,
    groups_y: u32,
    groups_z: u32,
    count: u32,
}

@group(0) @binding(0) var<uniform> light: LightGpu;
@group(0) @binding(1) var<storage, read> sp: SplatParams;
@group(0) @binding(2) var<storage, read> photons: array<Photon>;
@group(0) @binding(3) var<storage, read_write> accum: array<atomic<u32>>;

fn add64(word: u32, value: f32) {
    let v = max(value, 0.0);
    let hi = floor(v / 4294967296.0);
    let lo = u32(v - hi * 4294967296.0);
    if (lo == 0u && hi == 0.0) { return; }
    let old = atomicAdd(&accum[word], lo);
    var carry = 0u;
    if (old > 0xffffffffu - lo) { carry = 1u; }
    let h = u32(hi) + carry;
    if (h != 0u) { atomicAdd(&accum[word + 1u], h); }
}

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) nwg: vec3u, @builtin(local_invocation_index) lid: u32) {
    let index = (wg.y * nwg.x + wg.x) * 64u + lid;
    if (index >= sp.count) { return; }
    let ph = photons[index];
    if (ph.face == INVALID) { return; }
    let m = i32(light.info.w);
    let sigma = light.params.z;
    let r = i32(ceil(3.0 * sigma));
    let c = vec2i(floor(ph.pos));
    var wsum = 0.0;
    for (var y = -r; y <= r; y++) {
        for (var x = -r; x <= r; x++) {
            let t = c + vec2i(x, y);
            if (t.x < 0 || t.y < 0 || t.x >= m || t.y >= m) { continue; }
            let dd = vec2f(t) + 0.5 - ph.pos;
            let d2 = dot(dd, dd);
            if (d2 > 9.0 * sigma * sigma) { continue; }
            wsum += exp(-0.5 * d2 / (sigma * sigma));
        }
    }
    if (wsum <= 0.0) { return; }
    let scale = light.params.y / wsum;
    for (var y = -r; y <= r; y++) {
        for (var x = -r; x <= r; x++) {
            let t = c + vec2i(x, y);
            if (t.x < 0 || t.y < 0 || t.x >= m || t.y >= m) { continue; }
            let dd = vec2f(t) + 0.5 - ph.pos;
            let d2 = dot(dd, dd);
            if (d2 > 9.0 * sigma * sigma) { continue; }
            let w = exp(-0.5 * d2 / (sigma * sigma)) * scale;
            let texel = (ph.face * u32(m) + u32(t.y)) * u32(m) + u32(t.x);
            let base = texel * 6u;
            add64(base, ph.flux.r * w);
            add64(base + 2u, ph.flux.g * w);
            add64(base + 4u, ph.flux.b * w);
        }
    }
}
