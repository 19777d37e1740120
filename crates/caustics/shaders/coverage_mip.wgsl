// Stage: coverage_mip. One level of a mip chain of coverage counts. Level 0: 1 where the caster
// front buffer holds a caster (source 0: adaptive caustic maps test clusters against it), or
// where a photon of a dense tile landed (source 1: hierarchical caustic maps). Level l > 0: the
// sum of the 2 x 2 texels below. A cluster of photons is irrelevant exactly when its count is 0.

struct CoverParams {
    face: u32,
    level: u32,
    size: u32,
    src: u32,
    dst: u32,
    source: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> cp: CoverParams;
@group(0) @binding(1) var front_pos: texture_2d_array<f32>;
@group(0) @binding(2) var<storage, read> tile: array<Photon>;
@group(0) @binding(3) var<storage, read_write> cover: array<u32>;

// Exact tracer: a texel is covered when any of its 3 x 3 neighbours holds a caster. The exact
// tracer hits the true shapes, which reach up to a texel beyond their rasterized silhouette (a
// tessellated sphere, a texel centre just outside a triangle); without this the adaptive
// hierarchy would skip photons the dense grid traces.
override cover_dilate: bool = false;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    let s = cp.size;
    if (gid.x >= s || gid.y >= s) { return; }
    var c = 0u;
    if (cp.level == 0u) {
        if (cp.source == 0u) {
            c = select(0u, 1u, textureLoad(front_pos, vec2i(gid.xy), cp.face, 0).w >= 0.0);
            if (cover_dilate) {
                for (var k = 0; k < 9; k++) {
                    let t = clamp(vec2i(gid.xy) + vec2i(k % 3 - 1, k / 3 - 1), vec2i(0), vec2i(i32(s) - 1));
                    if (textureLoad(front_pos, t, cp.face, 0).w >= 0.0) { c = 1u; }
                }
            }
        } else {
            c = select(0u, 1u, tile[gid.y * s + gid.x].face != INVALID);
        }
    } else {
        let w = 2u * s;
        let b = cp.src + 2u * gid.y * w + 2u * gid.x;
        c = cover[b] + cover[b + 1u] + cover[b + w] + cover[b + w + 1u];
    }
    cover[cp.dst + gid.y * s + gid.x] = c;
}
