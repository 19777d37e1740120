// Stage: sphere_gather. Caustic spheres (Tandianus et al. 2010, section 4, direct sampling):
// per visible diffuse pixel, the caustic irradiance of every (directional light, caustic object,
// blended stored direction) record, looked up in the object's precomputed spheres, added into
// `radiance` and `caustic` as albedo/pi * E. One pass for all lights: the cost is per pixel and
// record, with no light-space work. `src/caustic_spheres/mod.rs` documents the table (and
// `CausticSpheres::sample` is the CPU twin of `sample` here).
// Occlusion: a caustic object's caustic reaches the point only if the segment from the object's
// sphere centre to it meets no other object (the paper's caustic cube map makes this depth test
// from the object's centre; here it is one exact ray per pixel and object through the scene's
// BVH, shared/raytrace.wgsl, skipping the caustic object itself).

#import raytrace
#import sphere_table

struct SphereGatherParams {
    width: u32,
    height: u32,
    records: u32,
    _pad: u32,
    camera: vec4f,
}


@group(0) @binding(0) var<uniform> gp: SphereGatherParams;
@group(0) @binding(1) var eye_pos: texture_2d<f32>;
@group(0) @binding(2) var eye_nrm: texture_2d<f32>;
@group(0) @binding(3) var<storage, read> materials: array<MaterialGpu>;
@group(0) @binding(4) var<storage, read> records: array<SphereRecord>;
@group(0) @binding(5) var<storage, read> table: array<vec4u>;
@group(0) @binding(6) var<storage, read_write> radiance: array<vec4f>;
@group(0) @binding(7) var<storage, read_write> caustic: array<vec4f>;
@group(0) @binding(8) var<storage, read> bvh_nodes: array<BvhNode>;
@group(0) @binding(9) var<storage, read> bvh_tris: array<BvhTri>;
@group(0) @binding(10) var<storage, read> bvh_instances: array<BvhInstance>;
// [0]: occlusion rays (one per pixel and caustic object) that overflowed the BVH stack.
@group(0) @binding(11) var<storage, read_write> gather_stats: array<atomic<u32>>;

// Whether anything but object `skip` lies along o + t d, 0 < t < tmax (scene_occluded with
// one object left out).
fn occluded_except(o: vec3f, d: vec3f, tmax: f32, skip: u32) -> bool {
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

// The world centre of record r's spheres (its object's frame mapped back to the world).
fn world_center(r: SphereRecord) -> vec3f {
    let m = mat3x3f(r.to_obj[0].xyz, r.to_obj[1].xyz, r.to_obj[2].xyz);
    // to_obj = [A | t] rows; world = A^-1 (c - t). A is a similarity: A^-1 = A^T / s^2.
    let t = vec3f(r.to_obj[0].w, r.to_obj[1].w, r.to_obj[2].w);
    let s2 = dot(r.to_obj[0].xyz, r.to_obj[0].xyz);
    return m * (r.center.xyz - t) / s2;
}

// Irradiance of record `r` at world point p on a receiver of world normal n (W/m^2, rgb): a
// blended stored direction (C, d), or with a compiled record (base.z == 2) the object's
// compiled vectors V_c, E_c = max(0, -V_c . n) (section 6 of the paper).
fn record_irradiance(r: SphereRecord, p: vec3f, n: vec3f) -> vec3f {
    let po = vec3f(dot(r.to_obj[0], vec4f(p, 1.0)), dot(r.to_obj[1], vec4f(p, 1.0)), dot(r.to_obj[2], vec4f(p, 1.0)));
    let no = normalize(vec3f(dot(r.to_obj[0].xyz, n), dot(r.to_obj[1].xyz, n), dot(r.to_obj[2].xyz, n)));
    let sm = sphere_lookup(r, po);
    if (r.base.z == 2u) {
        return r.irradiance.rgb
            * vec3f(max(-dot(sm.v0, no), 0.0), max(-dot(sm.v1, no), 0.0), max(-dot(sm.v2, no), 0.0));
    }
    return r.irradiance.rgb * sm.c * max(-dot(sm.d, no), 0.0);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    if (gid.x >= gp.width || gid.y >= gp.height) { return; }
    let pw = textureLoad(eye_pos, vec2i(gid.xy), 0);
    if (pw.w < 0.0) { return; }
    let mat = materials[u32(pw.w)];
    if (mat.kind.x != KIND_DIFFUSE) { return; }
    let p = pw.xyz;
    var n = normalize(textureLoad(eye_nrm, vec2i(gid.xy), 0).xyz);
    if (dot(n, gp.camera.xyz - p) < 0.0) { n = -n; }
    var e = vec3f(0.0);
    var object = INVALID;
    var visible = false;
    for (var i = 0u; i < gp.records; i++) {
        let r = records[i];
        if (r.base.y != object) {
            object = r.base.y;
            let c = world_center(r);
            let to = p - c;
            let dist = length(to);
            rt_overflow = 0u;
            visible = dist > 0.0 && !occluded_except(c, to / dist, dist * (1.0 - 1e-4), object);
            // A ray that overflowed the BVH stack may have missed an occluder: no caustic
            // (conservative), and counted in the frame's statistics.
            if (rt_overflow > 0u) { atomicAdd(&gather_stats[0], 1u); }
            visible = visible && rt_overflow == 0u;
        }
        if (visible) { e += record_irradiance(r, p, n); }
    }
    let lo = mat.a.rgb / PI * e;
    let idx = gid.y * gp.width + gid.x;
    radiance[idx] += vec4f(lo, 0.0);
    caustic[idx] += vec4f(lo, 0.0);
}
