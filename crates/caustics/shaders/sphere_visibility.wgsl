// Stage: sphere_visibility. Caustic spheres under an environment (Tandianus et al. 2010,
// section 5): per caustic object and ray, whether the ray from the object's centre toward one
// texel of an environment region meets another object (any hit through the scene's BVH and
// analytic shapes, shared/raytrace.wgsl, the object itself left out: what
// `crate::raycast::region_visibility` casts with `ray_query` on a copy of the scene without the
// object). Recorded into the frame when the objects, the environment's rotation or its
// segmentation changed; `sphere_visibility_sum` turns the flags into each region's visible
// fraction. `src/caustic_spheres/visibility.rs` documents the buffers.

#import raytrace
#import scene

// [0]: rays per object, [1]: caustic objects.
@group(0) @binding(0) var<storage, read> vis_sizes: array<u32>;
// Per caustic object: its centre (xyz, world) and its index (w).
@group(0) @binding(1) var<storage, read> vis_centres: array<vec4f>;
// Per ray: its unit direction (xyz, world) and t_max (w).
@group(0) @binding(2) var<storage, read> vis_dirs: array<vec4f>;
// Per caustic object and ray (object-major): 1 where something is in the way.
@group(0) @binding(3) var<storage, read_write> vis_blocked: array<u32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    let rays = vis_sizes[0];
    let i = gid.y * (65535u * 64u) + gid.x;
    if (i >= rays * vis_sizes[1]) { return; }
    let c = vis_centres[i / rays];
    let r = vis_dirs[i % rays];
    rt_overflow = 0u;
    vis_blocked[i] = select(0u, 1u, scene_occluded_except(c.xyz, r.xyz, r.w, u32(c.w), false));
}
