// Shared WGSL of the rasterization stages (raster, raster_peel): the view uniform, the vertex
// shader and the geometry-buffer outputs (target 0 = world position and object id, target 1 =
// shading normal). Vertices are in the pose of the scene file; `transforms` moves each object
// (identity until it is moved, which leaves every vertex bit for bit).

struct RasterView {
    world_to_clip: mat4x4f,
}

struct ObjectTransform {
    model: mat4x4f,
    normal: mat4x4f,
}

@group(0) @binding(0) var<uniform> view: RasterView;
@group(0) @binding(3) var<storage, read> transforms: array<ObjectTransform>;

struct VsOut {
    @builtin(position) clip: vec4f,
    @location(0) world: vec3f,
    @location(1) normal: vec3f,
    @location(2) @interpolate(flat) object: u32,
}

@vertex
fn vs_main(@location(0) position: vec3f, @location(1) normal: vec3f, @location(2) object: u32) -> VsOut {
    var o: VsOut;
    let t = transforms[object];
    let world = (t.model * vec4f(position, 1.0)).xyz;
    o.clip = view.world_to_clip * vec4f(world, 1.0);
    o.world = world;
    o.normal = (t.normal * vec4f(normal, 0.0)).xyz;
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
