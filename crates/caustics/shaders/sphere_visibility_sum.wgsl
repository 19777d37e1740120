// Stage: sphere_visibility_sum. Per caustic object and environment (sub-)region, the fraction
// of the region's luminance weight L·Ω whose rays `sphere_visibility` found free: the sums of
// `crate::raycast::region_visibility`, in the same order and the same arithmetic (f64 sums,
// the f64 quotient rounded to f32), with f64 emulated on u32 pairs (WGSL has no f64 on most
// devices, and a device's own f64 division need not round correctly), so that the weights the
// caustic sphere records get are the bits the CPU computes. The weights are finite and
// non-negative (no subnormals, no infinities: texel radiance times solid angle).

// [0]: rays per object, [1]: parts (regions or sub-regions), [2]: caustic objects.
@group(0) @binding(0) var<storage, read> vis_sizes: array<u32>;
// Per part: its first ray, its ray count, and the f64 bits (lo, hi) of its total weight.
@group(0) @binding(1) var<storage, read> vis_parts: array<vec4u>;
// Per ray: its weight's f64 bits (lo, hi).
@group(0) @binding(2) var<storage, read> vis_weights: array<vec2u>;
@group(0) @binding(3) var<storage, read> vis_blocked: array<u32>;
// Per caustic object and part (object-major): the visible fraction.
@group(0) @binding(4) var<storage, read_write> visibility: array<f32>;

// u64 as (lo, hi).
fn u64_add(a: vec2u, b: vec2u) -> vec2u {
    let lo = a.x + b.x;
    return vec2u(lo, a.y + b.y + select(0u, 1u, lo < a.x));
}

fn u64_sub(a: vec2u, b: vec2u) -> vec2u {
    return vec2u(a.x - b.x, a.y - b.y - select(0u, 1u, a.x < b.x));
}

fn u64_lt(a: vec2u, b: vec2u) -> bool {
    return a.y < b.y || (a.y == b.y && a.x < b.x);
}

fn u64_zero(a: vec2u) -> bool {
    return a.x == 0u && a.y == 0u;
}

fn u64_shl(a: vec2u, n: u32) -> vec2u {
    if (n == 0u) { return a; }
    if (n >= 64u) { return vec2u(0u); }
    if (n >= 32u) { return vec2u(0u, a.x << (n - 32u)); }
    return vec2u(a.x << n, (a.y << n) | (a.x >> (32u - n)));
}

fn u64_shr(a: vec2u, n: u32) -> vec2u {
    if (n == 0u) { return a; }
    if (n >= 64u) { return vec2u(0u); }
    if (n >= 32u) { return vec2u(a.y >> (n - 32u), 0u); }
    return vec2u((a.x >> n) | (a.y << (32u - n)), a.y >> n);
}

// The 53-bit significand of a normal f64.
fn f64_mant(a: vec2u) -> vec2u {
    return vec2u(a.x, (a.y & 0xFFFFFu) | 0x100000u);
}

// a + b, rounded to nearest even, for finite non-negative normal (or zero) f64s.
fn f64_add(a_in: vec2u, b_in: vec2u) -> vec2u {
    var a = a_in;
    var b = b_in;
    if (u64_lt(a, b)) { a = b_in; b = a_in; }
    if (u64_zero(b)) { return a; }
    var e = a.y >> 20u;
    let d = e - (b.y >> 20u);
    // Three bits below the significands: guard, round and sticky.
    let ma = u64_shl(f64_mant(a), 3u);
    var mb = u64_shl(f64_mant(b), 3u);
    if (d >= 64u) {
        mb = vec2u(1u, 0u);
    } else if (d > 0u) {
        let kept = u64_shr(mb, d);
        let lost = !u64_zero(u64_sub(mb, u64_shl(kept, d)));
        mb = vec2u(kept.x | select(0u, 1u, lost), kept.y);
    }
    var m = u64_add(ma, mb);
    if (m.y >= (1u << 24u)) {
        let s = m.x & 1u;
        m = u64_shr(m, 1u);
        m.x |= s;
        e += 1u;
    }
    let grs = m.x & 7u;
    m = u64_shr(m, 3u);
    if (grs > 4u || (grs == 4u && (m.x & 1u) == 1u)) { m = u64_add(m, vec2u(1u, 0u)); }
    if (m.y >= (1u << 21u)) {
        m = u64_shr(m, 1u);
        e += 1u;
    }
    return vec2u(m.x, (e << 20u) | (m.y & 0xFFFFFu));
}

// (a / b) as f32: the f64 quotient rounded to nearest even, then rounded to f32 (Rust's
// `(a / b) as f32`), for finite non-negative normal (or zero) a and b > 0 (a quotient below
// f32's normal range gives 0).
fn f64_div_f32(a: vec2u, b: vec2u) -> f32 {
    if (u64_zero(a)) { return 0.0; }
    var e = i32(a.y >> 20u) - i32(b.y >> 20u);
    var r = f64_mant(a);
    let mb = f64_mant(b);
    if (u64_lt(r, mb)) {
        r = u64_shl(r, 1u);
        e -= 1;
    }
    // 55 quotient bits (the significand, a guard bit, one more), the rest in r (sticky).
    var q = vec2u(0u);
    for (var i = 0u; i < 55u; i++) {
        q = u64_shl(q, 1u);
        if (!u64_lt(r, mb)) {
            r = u64_sub(r, mb);
            q.x |= 1u;
        }
        r = u64_shl(r, 1u);
    }
    let low = q.x & 3u;
    q = u64_shr(q, 2u);
    if (low == 3u || (low == 2u && (!u64_zero(r) || (q.x & 1u) == 1u))) { q = u64_add(q, vec2u(1u, 0u)); }
    if (q.y >= (1u << 21u)) {
        q = u64_shr(q, 1u);
        e += 1;
    }
    // The f64 q 2^(e - 52) to f32: 24 of its 53 bits, nearest even.
    let drop = q.x & 0x1FFFFFFFu;
    var m = u64_shr(q, 29u).x;
    if (drop > 0x10000000u || (drop == 0x10000000u && (m & 1u) == 1u)) { m += 1u; }
    if (m >= (1u << 24u)) {
        m >>= 1u;
        e += 1;
    }
    let be = e + 127;
    if (be <= 0) { return 0.0; }
    return bitcast<f32>((u32(be) << 23u) | (m & 0x7FFFFFu));
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    let rays = vis_sizes[0];
    let parts = vis_sizes[1];
    let i = gid.x;
    if (i >= parts * vis_sizes[2]) { return; }
    let part = vis_parts[i % parts];
    let all = part.zw;
    let row = (i / parts) * rays;
    var free = vec2u(0u);
    for (var k = part.x; k < part.x + part.y; k++) {
        if (vis_blocked[row + k] == 0u) { free = f64_add(free, vis_weights[k]); }
    }
    visibility[i] = select(1.0, f64_div_f32(free, all), !u64_zero(all));
}
