// Stage: caustic_mask. Per light face, one word per tile of SHADE_TILE x SHADE_TILE texels of the
// caustic irradiance map: 1 where the tile, widened by one texel on its high sides, holds a
// texel with a non-zero (or NaN) colour component, else 0. A bilinear lookup of
// `shade_receivers` (`caustic_at`) whose base texel lies in the tile reads only texels of the
// widened tile, so where the word is 0 the lookup's result is exactly 0 and is skipped.
// Recorded once per light when its maps are made (the light's work, not the camera's).
// Inputs: irradiance (vec4 per texel, faces x M x M), MaskParams. Output: mask (u32 per tile).

struct MaskParams {
    // Caustic map size M per face, tiles per side (ceil(M / SHADE_TILE)), faces.
    size: u32,
    tiles: u32,
    faces: u32,
    _pad: u32,
}

@group(0) @binding(0) var<uniform> mp: MaskParams;
@group(0) @binding(1) var<storage, read> irradiance: array<vec4f>;
@group(0) @binding(2) var<storage, read_write> mask: array<u32>;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    if (gid.x >= mp.tiles || gid.y >= mp.tiles || gid.z >= mp.faces) { return; }
    let m = mp.size;
    let x0 = gid.x * SHADE_TILE;
    let y0 = gid.y * SHADE_TILE;
    let x1 = min(x0 + SHADE_TILE, m - 1u);
    let y1 = min(y0 + SHADE_TILE, m - 1u);
    var any_light = 0u;
    for (var y = y0; y <= y1; y++) {
        let row = (gid.z * m + y) * m;
        for (var x = x0; x <= x1; x++) {
            let e = irradiance[row + x].rgb;
            // NaN != 0, so a NaN texel marks its tile too.
            if (any(e != vec3f(0.0))) { any_light = 1u; }
        }
    }
    mask[(gid.z * mp.tiles + gid.y) * mp.tiles + gid.x] = any_light;
}
