// Stage: shadow_tiles. Per light face, the least and greatest depth of each tile of
// SHADE_TILE x SHADE_TILE texels of the shadow map, widened by two texels on every side (clamped
// to the map): every texel a 3x3 PCF of `shade_receivers` (`shadow`) centred in the tile can
// read. Where the lookup depth is at most the least, every comparison passes (fully lit); where
// it exceeds the greatest, none does (fully shadowed), and the PCF is skipped.
// Recorded once per light when its maps are made (the light's work, not the camera's).
// Inputs: the shadow map (depth, one layer per face), TileParams. Output: (min, max) per tile.

struct TileParams {
    // Shadow map size per face, tiles per side (ceil(size / SHADE_TILE)), faces.
    size: u32,
    tiles: u32,
    faces: u32,
    _pad: u32,
}

@group(0) @binding(0) var<uniform> tp: TileParams;
@group(0) @binding(1) var shadow_map: texture_depth_2d_array;
@group(0) @binding(2) var<storage, read_write> tiles: array<vec2f>;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    if (gid.x >= tp.tiles || gid.y >= tp.tiles || gid.z >= tp.faces) { return; }
    let s = i32(tp.size);
    let x0 = max(i32(gid.x * SHADE_TILE) - 2, 0);
    let y0 = max(i32(gid.y * SHADE_TILE) - 2, 0);
    let x1 = min(i32(gid.x * SHADE_TILE + SHADE_TILE) + 1, s - 1);
    let y1 = min(i32(gid.y * SHADE_TILE + SHADE_TILE) + 1, s - 1);
    var lo = 3.0e38;
    var hi = -3.0e38;
    for (var y = y0; y <= y1; y++) {
        for (var x = x0; x <= x1; x++) {
            let d = textureLoad(shadow_map, vec2i(x, y), i32(gid.z), 0);
            lo = min(lo, d);
            hi = max(hi, d);
        }
    }
    tiles[(gid.z * tp.tiles + gid.y) * tp.tiles + gid.x] = vec2f(lo, hi);
}
