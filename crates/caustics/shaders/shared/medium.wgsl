// Shared WGSL (`#import medium`): the homogeneous medium's box (scene `medium`).

// The part [t0, t1] of the ray o + t d (0 <= t <= t_max) inside the box lo..hi; t0 >= t1 if none.
fn box_clip(o: vec3f, d: vec3f, t_max: f32, lo: vec3f, hi: vec3f) -> vec2f {
    var t0 = 0.0;
    var t1 = t_max;
    for (var k = 0; k < 3; k++) {
        if (abs(d[k]) < 1e-12) {
            if (o[k] < lo[k] || o[k] > hi[k]) { return vec2f(1.0, 0.0); }
            continue;
        }
        let a = (lo[k] - o[k]) / d[k];
        let b = (hi[k] - o[k]) / d[k];
        t0 = max(t0, min(a, b));
        t1 = min(t1, max(a, b));
    }
    return vec2f(t0, t1);
}

// Length of the segment from a to b inside the box lo..hi.
fn box_length(a: vec3f, b: vec3f, lo: vec3f, hi: vec3f) -> f32 {
    let v = b - a;
    let l = length(v);
    if (l <= 0.0) { return 0.0; }
    let c = box_clip(a, v / l, l, lo, hi);
    return max(c.y - c.x, 0.0);
}
