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

// Whether anything but object `skip` lies along o + t d, 0 < t < tmax (`scene_occluded` over
// the scene without object `skip`; `occluded_except` of sphere_gather).
fn occluded_but(o: vec3f, d: vec3f, tmax: f32, skip: u32) -> bool {
    let count = arrayLength(&materials);
    for (var i = 0u; i < count; i++) {
        let m = materials[i];
        if (m.kind.z == SHAPE_MESH || i == skip) { continue; }
        if (rt_shape(m, o, d, tmax).x > 0.0) { return true; }
    }
    var best = rt_none();
    best.t = tmax;
    let ninst = arrayLength(&bvh_instances);
    let inv_d = rt_inv(d);
    for (var ii = 0u; ii < ninst; ii++) {
        let inst = bvh_instances[ii];
        if (inst.object == INVALID || inst.object == skip) { continue; }
        if (rt_box(inst.lo.xyz, inst.hi.xyz, o, inv_d, tmax) >= 1e29) { continue; }
        if (rt_instance(ii, o, d, &best, true)) { return true; }
    }
    return false;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    let rays = vis_sizes[0];
    let i = gid.y * (65535u * 64u) + gid.x;
    if (i >= rays * vis_sizes[1]) { return; }
    let c = vis_centres[i / rays];
    let r = vis_dirs[i % rays];
    rt_overflow = 0u;
    vis_blocked[i] = select(0u, 1u, occluded_but(c.xyz, r.xyz, r.w, u32(c.w)));
}
