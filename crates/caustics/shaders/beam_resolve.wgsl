// Stage: beam_resolve. beam_raster's image of the volume caustic added to both frame images
// (the full image and the caustic-only one: the volume caustic is caustic light).

@group(0) @binding(0) var volume: texture_2d<f32>;
@group(0) @binding(1) var<storage, read_write> out_full: array<vec4f>;
@group(0) @binding(2) var<storage, read_write> out_caustic: array<vec4f>;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    let size = textureDimensions(volume);
    if (gid.x >= size.x || gid.y >= size.y) { return; }
    let c = textureLoad(volume, vec2i(gid.xy), 0);
    if (all(c.rgb == vec3f(0.0))) { return; }
    let idx = gid.y * size.x + gid.x;
    out_full[idx] += vec4f(c.rgb, 0.0);
    out_caustic[idx] += vec4f(c.rgb, 0.0);
}
