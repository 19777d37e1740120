// Stage: medium_ms_resolve. Two variants:
// - one light's multiple-scattering sums (`medium_ms_trace`) added to the grid's cells in watts
//   (dispatched per light in the lights' order: the same bits every run);
// - `ms_emitters`, once after the last light: every 2 x 2 x 2 block of cells becomes one
//   isotropic point emitter for `medium_bounce_surfaces` (the surfaces the medium's multiply
//   scattered light reaches): the block's power, at the power-weighted mean of its cells'
//   centres, spread over r^2 = 2/3 of the summed per-axis variance (its cells' spread and each
//   cell's own, h^2 / 12 per axis: a full block of side 2h gives (2h)^2 / 6, the disk of the
//   same spread, as the other emitters, src/medium_bounce.rs).

#import medium_bounce
#import medium_multiple

@group(0) @binding(0) var<uniform> light: LightGpu;
@group(0) @binding(1) var<uniform> mp: MsParams;
@group(0) @binding(2) var<storage, read> sums: array<u32>;
// Per cell, rgb = the power it scatters (W).
@group(0) @binding(3) var<storage, read_write> cells: array<vec4f>;
@group(0) @binding(4) var<storage, read_write> vpls: array<Vpl>;
override ms_emitters: bool = false;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    if (ms_emitters) {
        emitter(gid.x);
        return;
    }
    let count = mp.dims.x * mp.dims.y * mp.dims.z;
    let c = gid.x;
    if (c >= count) { return; }
    let inv = 1.0 / ms_scale(light);
    var p = vec3f(0.0);
    for (var ch = 0u; ch < 3u; ch++) {
        p[ch] = (f32(sums[c * 6u + ch * 2u + 1u]) * 4294967296.0 + f32(sums[c * 6u + ch * 2u])) * inv;
    }
    cells[c] = vec4f(cells[c].rgb + p, 0.0);
}

// Cells per side of an emitter block (`gpu::types::MS_BLOCK`).
const MS_BLOCK: u32 = 2u;
fn emitter(e: u32) {
    let ed = (mp.dims.xyz + MS_BLOCK - 1u) / MS_BLOCK;
    if (e >= ed.x * ed.y * ed.z) { return; }
    let b = vec3u(e % ed.x, (e / ed.x) % ed.y, e / (ed.x * ed.y)) * MS_BLOCK;
    let size = (mp.hi.xyz - mp.lo.xyz) / vec3f(mp.dims.xyz);
    var power = vec3f(0.0);
    var w = 0.0;
    var m1 = vec3f(0.0);
    var m2 = vec3f(0.0);
    for (var k = 0u; k < MS_BLOCK * MS_BLOCK * MS_BLOCK; k++) {
        let c = b + vec3u(k % MS_BLOCK, (k / MS_BLOCK) % MS_BLOCK, k / (MS_BLOCK * MS_BLOCK));
        if (any(c >= mp.dims.xyz)) { continue; }
        let pc = cells[c.x + mp.dims.x * (c.y + mp.dims.y * c.z)].rgb;
        // Relative to the block's first cell's centre.
        let x = (vec3f(c - b)) * size;
        let wc = pc.r + pc.g + pc.b;
        power += pc;
        w += wc;
        m1 += wc * x;
        m2 += wc * x * x;
    }
    let origin = mp.lo.xyz + (vec3f(b) + 0.5) * size;
    if (!(w > 0.0)) {
        vpls[e] = Vpl(vec4f(origin, 0.0), vec4f(0.0, 0.0, 1.0, 0.0), vec4f(0.0), vec4f(0.0));
        return;
    }
    let mean = m1 / w;
    let var_axes = max(m2 / w - mean * mean, vec3f(0.0)) + size * size / 12.0;
    let r2 = 2.0 / 3.0 * (var_axes.x + var_axes.y + var_axes.z);
    vpls[e] = Vpl(vec4f(origin + mean, r2), vec4f(0.0, 0.0, 1.0, 0.0), vec4f(power, 0.0), vec4f(0.0));
}
