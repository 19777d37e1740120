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

struct SphereGatherParams {
    width: u32,
    height: u32,
    records: u32,
    _pad: u32,
    camera: vec4f,
}

struct SphereRecord {
    // world -> the object's frame (the scene file's pose): rows of a 3x4 matrix.
    to_obj: array<vec4f, 3>,
    // The stored pattern's frame rotated onto the light: R a, R b, R w (w the stored direction).
    axes: array<vec4f, 3>,
    // Rows of R: a stored mean direction d appears as R d.
    rot: array<vec4f, 3>,
    // Sphere centre (xyz) and r_min (w).
    center: vec4f,
    // r_max, sphere count s, longitudes W, latitudes H.
    shape: vec4f,
    // Blend weight times the light's irradiance (W/m^2, rgb).
    irradiance: vec4f,
    // x: the table index of the stored direction's first cell; y: the caustic object's index;
    // z: 1 for half floats (one vec4u per cell: C and d as f16 pairs), 0 for f32 (two vec4u of
    // f32 bits per cell).
    base: vec4u,
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

fn cell(base: u32, sphere: u32, row: u32, col: u32, w: u32, h: u32, stride: u32) -> u32 {
    return base + ((sphere * h + row) * w + col) * stride;
}

// Irradiance of record `r` at world point p on a receiver of world normal n (W/m^2, rgb).
fn record_irradiance(r: SphereRecord, p: vec3f, n: vec3f) -> vec3f {
    let po = vec3f(dot(r.to_obj[0], vec4f(p, 1.0)), dot(r.to_obj[1], vec4f(p, 1.0)), dot(r.to_obj[2], vec4f(p, 1.0)));
    let no = normalize(vec3f(dot(r.to_obj[0].xyz, n), dot(r.to_obj[1].xyz, n), dot(r.to_obj[2].xyz, n)));
    let q = po - r.center.xyz;
    let rad = length(q);
    if (rad <= 0.0) { return vec3f(0.0); }
    let loc = vec3f(dot(r.axes[0].xyz, q), dot(r.axes[1].xyz, q), dot(r.axes[2].xyz, q)) / rad;
    let s = u32(r.shape.y);
    let w = u32(r.shape.z);
    let h = u32(r.shape.w);
    let r_min = r.center.w;
    let r_max = r.shape.x;
    // Outside the spheres: 1/r^2 from the nearest one.
    var rr = rad;
    var fall = 1.0;
    if (rad < r_min) { rr = r_min; fall = (r_min / rad) * (r_min / rad); }
    if (rad > r_max) { rr = r_max; fall = (r_max / rad) * (r_max / rad); }
    // Equation (1) inverted: the sphere parameter.
    let fs = sqrt(max((rr - r_min) / (r_max - r_min), 0.0)) * f32(s - 1u);
    let s0 = min(u32(floor(fs)), s - 2u);
    let ws = clamp(fs - f32(s0), 0.0, 1.0);
    // Latitude (warped, theta = pi t^2) and longitude, cell centres at +0.5.
    let th = atan2(length(loc.xy), loc.z);
    let ft = sqrt(th / PI) * f32(h) - 0.5;
    var ph = atan2(loc.y, loc.x);
    if (ph < 0.0) { ph += 2.0 * PI; }
    let fp = ph / (2.0 * PI) * f32(w) - 0.5;
    let r0 = floor(ft);
    let wr = ft - r0;
    let c0 = floor(fp);
    let wc = fp - c0;
    let rows = vec2u(u32(clamp(i32(r0), 0, i32(h) - 1)), u32(clamp(i32(r0) + 1, 0, i32(h) - 1)));
    let iw = i32(w);
    let cols = vec2u(u32(((i32(c0) % iw) + iw) % iw), u32(((i32(c0) + 1) % iw + iw) % iw));
    var c = vec3f(0.0);
    var d = vec3f(0.0);
    let half = r.base.z == 1u;
    let stride = select(2u, 1u, half);
    for (var k = 0u; k < 8u; k++) {
        let si = k & 1u;
        let ri = (k >> 1u) & 1u;
        let ci = (k >> 2u) & 1u;
        let wt = select(1.0 - ws, ws, si == 1u) * select(1.0 - wr, wr, ri == 1u) * select(1.0 - wc, wc, ci == 1u);
        if (wt == 0.0) { continue; }
        let at = cell(r.base.x, s0 + si, rows[ri], cols[ci], w, h, stride);
        var ce: vec3f;
        var de: vec3f;
        if (half) {
            let v = table[at];
            ce = vec3f(unpack2x16float(v.x), unpack2x16float(v.y).x);
            de = vec3f(unpack2x16float(v.z), unpack2x16float(v.w).x);
        } else {
            ce = bitcast<vec4f>(table[at]).rgb;
            de = bitcast<vec4f>(table[at + 1u]).xyz;
        }
        c += ce * wt;
        d += de * (wt * (ce.r + ce.g + ce.b));
    }
    if (dot(d, d) <= 0.0) { return vec3f(0.0); }
    let dn = normalize(d);
    let dw = vec3f(dot(r.rot[0].xyz, dn), dot(r.rot[1].xyz, dn), dot(r.rot[2].xyz, dn));
    let cos_t = max(-dot(dw, no), 0.0);
    return r.irradiance.rgb * c * (fall * cos_t);
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
