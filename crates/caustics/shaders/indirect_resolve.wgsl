// Stage: indirect_resolve. One light's cache sums (`indirect_trace`) added to the cache's cells
// in watts (dispatched per light in the lights' order: the same bits every run): per slot,
// rgb flux and the weight, the weighted position and the weighted normal (src/indirect/).

#import indirect

@group(0) @binding(0) var<uniform> light: LightGpu;
@group(0) @binding(1) var<uniform> ip: IndirectParams;
@group(0) @binding(2) var<storage, read> keys: array<u32>;
@group(0) @binding(3) var<storage, read> sums: array<u32>;
// Per slot: (flux rgb W, weight), (weight * position), (weight * normal).
@group(0) @binding(4) var<storage, read_write> cells: array<vec4f>;

var<private> inv_scale: f32;

fn fixed_at(word: u32) -> f32 {
    return (f32(sums[word + 1u]) * 4294967296.0 + f32(sums[word])) * inv_scale;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u, @builtin(num_workgroups) nwg: vec3u) {
    let s = gid.y * nwg.x * 64u + gid.x;
    if (s >= ip.capacity) { return; }
    let key = keys[s];
    if (key == 0u) { return; }
    inv_scale = 1.0 / ic_scale(light);
    let base = s * IC_SUM_WORDS;
    let w = fixed_at(base + 6u);
    if (!(w > 0.0)) { return; }
    let corner = ip.origin.xyz + vec3f(ic_key_coord(key)) * ip.origin.w;
    let frac = vec3f(fixed_at(base + 8u), fixed_at(base + 10u), fixed_at(base + 12u));
    let nn = vec3f(fixed_at(base + 14u), fixed_at(base + 16u), fixed_at(base + 18u));
    let flux = vec3f(fixed_at(base), fixed_at(base + 2u), fixed_at(base + 4u));
    cells[s * 3u] += vec4f(flux, w);
    cells[s * 3u + 1u] += vec4f(corner * w + frac * ip.origin.w, 0.0);
    cells[s * 3u + 2u] += vec4f(2.0 * nn - vec3f(w), 0.0);
}
