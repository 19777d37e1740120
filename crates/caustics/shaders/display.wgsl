// Stage: display. The radiance image tone-mapped for a screen, as `caustics render` writes PNGs
// (docs/scene-format.md): exposure, the ACES fit of Narkowicz 2015, the sRGB curve; stored in
// an Rgba8Unorm texture (the viewer and engines draw it as it is).
// Inputs: radiance (vec4 per pixel, W/(m² sr)), DisplayParams. Output: the display texture.

struct DisplayParams {
    width: u32,
    height: u32,
    exposure: f32,
    _pad: u32,
}

@group(0) @binding(0) var<uniform> dp: DisplayParams;
@group(0) @binding(1) var<storage, read> radiance: array<vec4f>;
@group(0) @binding(2) var display: texture_storage_2d<rgba8unorm, write>;

fn srgb_encode(y: f32) -> f32 {
    if (y <= 0.0031308) { return 12.92 * y; }
    return 1.055 * pow(y, 1.0 / 2.4) - 0.055;
}

fn tonemap(v: f32) -> f32 {
    let x = max(v * dp.exposure, 0.0);
    var y = clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
    // Infinite radiance shows white, as the CPU tone map does.
    if (!(y == y) || x > 3.0e38) { y = 1.0; }
    return srgb_encode(y);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3u) {
    if (id.x >= dp.width || id.y >= dp.height) { return; }
    let c = radiance[id.y * dp.width + id.x].rgb;
    textureStore(display, vec2i(id.xy), vec4f(tonemap(c.r), tonemap(c.g), tonemap(c.b), 1.0));
}
