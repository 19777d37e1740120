// Stage: raster. Rasterizes scene triangles into geometry buffers, for the light views (receiver
// maps, caster front/back buffers, shadow maps) and for the camera.
// Inputs: vertex buffer (position, normal, object id), a view uniform.
// Outputs: target 0 = (world position, object id), target 1 = (shading normal, 0); depth.

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

@fragment
fn fs_main(v: VsOut) -> FsOut {
    var o: FsOut;
    o.position = vec4f(v.world, f32(v.object));
    o.normal = vec4f(normalize(v.normal), 0.0);
    return o;
}
