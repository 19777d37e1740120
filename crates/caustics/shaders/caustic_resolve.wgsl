// Stage: caustic_resolve. Turns the fixed-point flux of each caustic-map texel into irradiance
// (W/m^2): flux / the receiver area the texel covers (from the receiver map's position and
// normal at the texel). Texels with no receiver get 0.

struct ResolveParams {
    count: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> light: LightGpu;
@group(0) @binding(1) var<uniform> rp: ResolveParams;
@group(0) @binding(2) var<storage, read> accum: array<u32>;
@group(0) @binding(3) var recv_pos: texture_2d_array<f32>;
@group(0) @binding(4) var recv_nrm: texture_2d_array<f32>;
@group(0) @binding(5) var<storage, read_write> irradiance: array<vec4f>;

fn fixed_to_f32(lo: u32, hi: u32) -> f32 {
    return (f32(hi) * 4294967296.0 + f32(lo)) / light.params.y;
}

@compute @workgroup_size(256)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    if (gid.x >= rp.count) { return; }
    let m = light.info.w;
    let face = gid.x / (m * m);
    let rem = gid.x % (m * m);
    let t = vec2i(i32(rem % m), i32(rem / m));
    let b = gid.x * 6u;
    let flux = vec3f(fixed_to_f32(accum[b], accum[b + 1u]), fixed_to_f32(accum[b + 2u], accum[b + 3u]), fixed_to_f32(accum[b + 4u], accum[b + 5u]));
    let r = textureLoad(recv_pos, t, face, 0);
    var e = vec3f(0.0);
    if (r.w >= 0.0) {
        let n = normalize(textureLoad(recv_nrm, t, face, 0).xyz);
        e = flux / texel_area(light.faces[face], r.xyz, n, f32(m));
    }
    irradiance[gid.x] = vec4f(e, 0.0);
}
