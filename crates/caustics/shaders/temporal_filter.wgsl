// Stage: temporal_filter. Blends one light's caustic irradiance maps (all faces) over frames.
// Per texel: the new raw map N, the previous frame's raw map P and the filtered history H.
// 1. Rejection by photon-map change: the 3x3 box sums of N and P (luminance r+g+b) differ by
//    more than `threshold` times the larger (sub-texel jitter of photons moves flux between
//    neighbours, which the 3x3 sum does not see; a caustic that moved, appeared or vanished
//    changes it). Rejected texels, and every texel when there is no history, take N.
// 2. Otherwise H is clamped per channel to the min/max of N's 3x3 neighbourhood (the standard TAA
//    clamp: no value the new frame does not support survives), then out = h + alpha (N - h).
//    When N == H the result is N bit for bit (N - h = 0), so a static sequence is the input.
// The result is written to `history` in place (each invocation reads and writes only its own
// history texel); the host then copies N to `previous` and `history` to the renderer's map.

struct TemporalParams {
    size: u32,
    faces: u32,
    has_history: u32,
    _pad: u32,
    alpha: f32,
    threshold: f32,
    _pad1: f32,
    _pad2: f32,
}

@group(0) @binding(0) var<uniform> tp: TemporalParams;
@group(0) @binding(1) var<storage, read> current: array<vec4f>;
@group(0) @binding(2) var<storage, read> previous: array<vec4f>;
@group(0) @binding(3) var<storage, read_write> history: array<vec4f>;
// [0]: texels whose history was rejected, [1]: texels blended.
@group(0) @binding(4) var<storage, read_write> counters: array<atomic<u32>>;

fn index_of(x: i32, y: i32, face: u32) -> u32 {
    let m = tp.size;
    return (face * m + u32(y)) * m + u32(x);
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    let m = tp.size;
    if (gid.x >= m || gid.y >= m || gid.z >= tp.faces) { return; }
    let face = gid.z;
    let i = index_of(i32(gid.x), i32(gid.y), face);
    let n = current[i].rgb;
    if (tp.has_history == 0u) {
        history[i] = vec4f(n, 0.0);
        atomicAdd(&counters[0], 1u);
        return;
    }
    var lo = n;
    var hi = n;
    var sum_n = 0.0;
    var sum_p = 0.0;
    // Fixed order: the sums are the same on every run.
    for (var dy = -1; dy <= 1; dy++) {
        for (var dx = -1; dx <= 1; dx++) {
            let x = i32(gid.x) + dx;
            let y = i32(gid.y) + dy;
            if (x < 0 || y < 0 || x >= i32(m) || y >= i32(m)) { continue; }
            let j = index_of(x, y, face);
            let c = current[j].rgb;
            let p = previous[j].rgb;
            lo = min(lo, c);
            hi = max(hi, c);
            sum_n += c.r + c.g + c.b;
            sum_p += p.r + p.g + p.b;
        }
    }
    let changed = abs(sum_n - sum_p) > tp.threshold * max(sum_n, sum_p);
    if (changed || tp.alpha >= 1.0) {
        history[i] = vec4f(n, 0.0);
        atomicAdd(&counters[0], 1u);
        return;
    }
    let h = clamp(history[i].rgb, lo, hi);
    history[i] = vec4f(h + tp.alpha * (n - h), 0.0);
    atomicAdd(&counters[1], 1u);
}
