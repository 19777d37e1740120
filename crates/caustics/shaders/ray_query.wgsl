// Stage: ray_query. Closest hit (or any hit) of a batch of rays with the whole scene through
// the exact tracer's structures (shared/raytrace.wgsl): what the photon tracer sees, for tests
// against brute force and for tools (picking).

#import raytrace
#import scene

struct RayQuery {
    // o.w: t_max
    o: vec4f,
    d: vec4f,
}

struct RayResult {
    t: f32,
    object: u32,
    // The mesh's triangle index (INVALID for analytic shapes and misses).
    triangle: u32,
    // Stack overflows on this ray (0 unless the BVH is deeper than the stack).
    overflows: u32,
    ng: vec4f,
}

struct QueryParams {
    count: u32,
    any_hit: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<storage, read> rays: array<RayQuery>;
@group(0) @binding(1) var<storage, read_write> results: array<RayResult>;
@group(0) @binding(2) var<uniform> qp: QueryParams;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    let i = gid.x;
    if (i >= qp.count) { return; }
    let r = rays[i];
    var out: RayResult;
    out.t = -1.0;
    out.object = INVALID;
    out.triangle = INVALID;
    rt_overflow = 0u;
    if (qp.any_hit == 1u) {
        if (scene_occluded(r.o.xyz, r.d.xyz, r.o.w)) { out.t = 0.0; out.object = 0u; }
    } else {
        let h = scene_hit(r.o.xyz, r.d.xyz, r.o.w);
        if (h.object != INVALID) {
            out.t = h.t;
            out.object = h.object;
            out.ng = vec4f(h.ng, 0.0);
            if (h.tri != INVALID) { out.triangle = bitcast<u32>(bvh_tris[h.tri].p0.w); }
        }
    }
    out.overflows = rt_overflow;
    results[i] = out;
}
