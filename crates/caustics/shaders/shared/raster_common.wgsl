// Shared WGSL of the rasterization stages (raster, raster_peel): the view uniform, the vertex
// shader and the geometry-buffer outputs (target 0 = world position and object id, target 1 =
// shading normal).

struct RasterView {
    world_to_clip: mat4x4f,
}

@group(0) @binding(0) var<uniform> view: RasterView;

struct VsOut {
    @builtin(position) clip: vec4f,
    @location(0) world: vec3f,
    @location(1) normal: vec3f,
    @location(2) @interpolate(flat) object: u32,
}

@vertex
fn vs_main(@location(0) position: vec3f, @location(1) normal: vec3f, @location(2) object: u32) -> VsOut {
    var o: VsOut;
    o.clip = view.world_to_clip * vec4f(position, 1.0);
    o.world = position;
    o.normal = normal;
    o.object = object;
    return o;
}

struct FsOut {
    @location(0) position: vec4f,
    @location(1) normal: vec4f,
}

fn gbuffer_out(v: VsOut) -> FsOut {
    var o: FsOut;
    o.position = vec4f(v.world, f32(v.object));
    o.normal = vec4f(normalize(v.normal), 0.0);
    return o;
}
