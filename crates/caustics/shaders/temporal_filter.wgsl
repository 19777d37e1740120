// Stage: temporal_filter. Blends one light's caustic irradiance maps (all faces) over frames.
// Per texel: the new raw map N, the previous frame's raw map P and the filtered history H.
// Step 0 (blend), per texel, into `scratch`:
// 1. Rejection by photon-map change: the 3x3 box sums of N and P (luminance r+g+b) differ by
//    more than `threshold` times the larger (sub-texel jitter of photons moves flux between
//    neighbours, which the 3x3 sum does not see; a caustic that moved, appeared or vanished
//    changes it). With flag bit 0 the test is also made around each of the 8 neighbours (a
//    texel next to a changed one is rejected too). Rejected texels, and every texel when there
//    is no history, take N.
// 2. Otherwise H is clamped per channel to the min/max of N's 3x3 neighbourhood (the standard TAA
//    clamp: no value the new frame does not support survives), then B = h + alpha (N - h).
//    When N == H the result is N bit for bit (N - h = 0), so a static sequence is the input.
// Step 1 (flux), per texel, into `history`: with a flux radius r > 0 (flags >> 1), the blend's
// change D = B - N is balanced over the (2r+1)^2 texels around the texel: where the window's
// positive changes exceed its negative ones, the texel's positive change is scaled by neg/pos,
// and the other way round (per channel). The blend then only moves flux between nearby texels
// (where photon jitter flickers); a caustic that moves does not lose or gain flux by lagging, and
// a ghost (positive change with no negative one nearby) is removed. Static: D = 0, out = N.
// With r = 0, B. The host then copies N to `previous` and `history` to the renderer's map.

struct TemporalParams {
    size: u32,
    faces: u32,
    has_history: u32,
    // 0: blend, 1: flux.
    stage: u32,
    alpha: f32,
    threshold: f32,
    // Bit 0: dilate the rejection over the 3x3 neighbourhood; bits 1..: the flux radius r.
    flags: u32,
    _pad: u32,
}

@group(0) @binding(0) var<uniform> tp: TemporalParams;
@group(0) @binding(1) var<storage, read> current: array<vec4f>;
@group(0) @binding(2) var<storage, read> previous: array<vec4f>;
@group(0) @binding(3) var<storage, read_write> history: array<vec4f>;
@group(0) @binding(4) var<storage, read_write> scratch: array<vec4f>;
// [0]: texels whose history was rejected, [1]: texels blended.
@group(0) @binding(5) var<storage, read_write> counters: array<atomic<u32>>;

fn index_of(x: i32, y: i32, face: u32) -> u32 {
    let m = tp.size;
    return (face * m + u32(y)) * m + u32(x);
}

fn inside(x: i32, y: i32) -> bool {
    return x >= 0 && y >= 0 && x < i32(tp.size) && y < i32(tp.size);
}

fn blend(gid: vec3u, i: u32) {
    let m = tp.size;
    let face = gid.z;
    let n = current[i].rgb;
    if (tp.has_history == 0u) {
        scratch[i] = vec4f(n, 0.0);
        atomicAdd(&counters[0], 1u);
        return;
    }
    // The 3x3 neighbourhood of N: range per channel (the clamp).
    var lo = n;
    var hi = n;
    // Luminance (r+g+b) of N and P over the 3x3 window, or 5x5 when the rejection is dilated
    // (the 3x3 sums around each texel of the 3x3 neighbourhood). Zero outside the map and the
    // window (function-scope arrays start zeroed). Fixed order: the same on every run.
    let r = select(0, 1, (tp.flags & 1u) != 0u);
    var ln: array<f32, 25>;
    var lp: array<f32, 25>;
    for (var dy = -1 - r; dy <= 1 + r; dy++) {
        for (var dx = -1 - r; dx <= 1 + r; dx++) {
            let x = i32(gid.x) + dx;
            let y = i32(gid.y) + dy;
            let k = (dy + 2) * 5 + dx + 2;
            ln[k] = 0.0;
            lp[k] = 0.0;
            if (!inside(x, y)) { continue; }
            let j = index_of(x, y, face);
            let c = current[j].rgb;
            let p = previous[j].rgb;
            ln[k] = c.r + c.g + c.b;
            lp[k] = p.r + p.g + p.b;
            if (abs(dx) <= 1 && abs(dy) <= 1) {
                lo = min(lo, c);
                hi = max(hi, c);
            }
        }
    }
    var changed = false;
    for (var cy = 2 - r; cy <= 2 + r; cy++) {
        for (var cx = 2 - r; cx <= 2 + r; cx++) {
            var sum_n = 0.0;
            var sum_p = 0.0;
            for (var dy = -1; dy <= 1; dy++) {
                for (var dx = -1; dx <= 1; dx++) {
                    let k = (cy + dy) * 5 + cx + dx;
                    sum_n += ln[k];
                    sum_p += lp[k];
                }
            }
            changed = changed || abs(sum_n - sum_p) > tp.threshold * max(sum_n, sum_p);
        }
    }
    if (changed || tp.alpha >= 1.0) {
        scratch[i] = vec4f(n, 0.0);
        atomicAdd(&counters[0], 1u);
        return;
    }
    let h = clamp(history[i].rgb, lo, hi);
    scratch[i] = vec4f(h + tp.alpha * (n - h), 0.0);
    atomicAdd(&counters[1], 1u);
}

fn flux(gid: vec3u, i: u32) {
    let b = scratch[i].rgb;
    let r = i32(tp.flags >> 1u);
    if (r == 0) {
        history[i] = vec4f(b, 0.0);
        return;
    }
    // The blend's change of the new map, D = B - N, positive (flux the blend added) and
    // negative (flux it removed) parts over the window; the side in excess is scaled down so that
    // the window's changes balance. Texels the blend did not change are not touched.
    var pos = vec3f(0.0);
    var neg = vec3f(0.0);
    for (var dy = -r; dy <= r; dy++) {
        for (var dx = -r; dx <= r; dx++) {
            let x = i32(gid.x) + dx;
            let y = i32(gid.y) + dy;
            if (!inside(x, y)) { continue; }
            let j = index_of(x, y, gid.z);
            let d = scratch[j].rgb - current[j].rgb;
            pos += max(d, vec3f(0.0));
            neg += max(-d, vec3f(0.0));
        }
    }
    let n = current[i].rgb;
    let d = b - n;
    let kp = select(vec3f(0.0), min(vec3f(1.0), neg / pos), pos > vec3f(0.0));
    let kn = select(vec3f(0.0), min(vec3f(1.0), pos / neg), neg > vec3f(0.0));
    history[i] = vec4f(n + max(d, vec3f(0.0)) * kp - max(-d, vec3f(0.0)) * kn, 0.0);
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    let m = tp.size;
    if (gid.x >= m || gid.y >= m || gid.z >= tp.faces) { return; }
    let i = index_of(i32(gid.x), i32(gid.y), gid.z);
    if (tp.stage == 0u) {
        blend(gid, i);
    } else {
        flux(gid, i);
    }
}
