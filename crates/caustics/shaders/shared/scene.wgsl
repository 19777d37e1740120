// Shared WGSL: the scene's bind group (group 1), the resources of the scene on the GPU
// (src/geometry.rs, `SceneGroup`): made once per geometry upload and set by every stage that
// imports this module, whichever of them its `main` reads. Its layout is this declaration
// (one bind group layout for every pipeline that uses it, src/gpu/layout.rs).
// Per object: material and analytic shape (shared/raytrace.wgsl, shared/shapes.wgsl).
@group(1) @binding(0) var<storage, read> materials: array<MaterialGpu>;
// The exact tracer's BVH (shared/raytrace.wgsl; src/accel.rs).
@group(1) @binding(1) var<storage, read> bvh_nodes: array<BvhNode>;
@group(1) @binding(2) var<storage, read> bvh_tris: array<BvhTri>;
@group(1) @binding(3) var<storage, read> bvh_instances: array<BvhInstance>;
// The medium's density grid (1 x 1 x 1 holding 1 without one; shared/medium.wgsl).
@group(1) @binding(4) var density_grid: texture_3d<f32>;
// The environment map (linear radiance; 1 x 1 black without one; shared/environment.wgsl).
@group(1) @binding(5) var env_map: texture_2d<f32>;
