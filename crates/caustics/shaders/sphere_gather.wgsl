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
// Pixel footprint: the tables are looked up at gp.samples^2 points spread over the pixel (a box
// filter, as the reference's photon splats; with many records the points are dealt out over
// them in turn, so that they cost no more lookups), on the receiver's tangent plane, the footprint
// taken from the neighbouring pixels' receiver points on the same object (one side, the other,
// or none at an edge: then the centre only along that axis); one occlusion ray per pixel and
// object, from its centre. A focus narrower than a pixel is then not missed or overstated by
// where the pixel's centre falls.
// In a homogeneous medium a direct record's light is attenuated along its path, approximated as
// in sphere_volume: from the box to the plane 2/3 r_min before the object's centre along the
// light, then from the innermost sphere straight to the receiver (the path inside the object
// has no medium; the camera's path is medium_scatter's). Compiled records (all lights summed)
// are not attenuated.

#import raytrace
#import medium
#import sphere_table
#import scene

struct SphereGatherParams {
    width: u32,
    height: u32,
    records: u32,
    // Points per pixel side of the box filter (1: the pixel's centre only).
    samples: u32,
    camera: vec4f,
    // A homogeneous medium's box (medium_lo.w = 1; 0: none) and sigma_t (rgb, 1/m); sigma_t.w:
    // the irradiance luminance from which a record gets every point of the box filter.
    medium_lo: vec4f,
    medium_hi: vec4f,
    sigma_t: vec4f,
}


@group(0) @binding(0) var<uniform> gp: SphereGatherParams;
@group(0) @binding(1) var eye_pos: texture_2d<f32>;
@group(0) @binding(2) var eye_nrm: texture_2d<f32>;
@group(0) @binding(4) var<storage, read> records: array<SphereRecord>;
@group(0) @binding(5) var<storage, read> table: array<vec4u>;
@group(0) @binding(6) var<storage, read_write> radiance: array<vec4f>;
@group(0) @binding(7) var<storage, read_write> caustic: array<vec4f>;
// [0]: occlusion rays (one per pixel and caustic object) that overflowed the BVH stack.
@group(0) @binding(11) var<storage, read_write> gather_stats: array<atomic<u32>>;

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

// The transmittance of direct record r's light in the medium on its way to the receiver at p
// (world): exp(-sigma_t (into + out)), `into` the light's path in the box up to the plane 2/3
// r_min before the spheres' centre (a ball's cross-section meets parallel light 2R/3 deep on
// average), `out` from the innermost sphere to p along the ray from the centre.
fn light_transmittance(r: SphereRecord, p: vec3f) -> vec3f {
    let lo = gp.medium_lo.xyz;
    let hi = gp.medium_hi.xyz;
    let m = mat3x3f(r.to_obj[0].xyz, r.to_obj[1].xyz, r.to_obj[2].xyz);
    let l = normalize(m * r.axes[2].xyz);
    let c = world_center(r);
    let rmin = r.center.w / length(r.to_obj[0].xyz);
    let far = 2.0 * length(hi - lo) + length(c - p) + 1.0;
    let into = box_length(c - l * far, c - l * (rmin * 2.0 / 3.0), lo, hi);
    let to = p - c;
    let dist = length(to);
    var out = 0.0;
    if (dist > rmin) { out = box_length(c + to / dist * rmin, p, lo, hi); }
    return exp(-gp.sigma_t.rgb * (into + out));
}

// Lookups per pixel up to which every record is looked up at every point of the box filter.
const FULL_FILTER: u32 = 256u;

// The receiver's step to the neighbouring pixel along `axis` (one pixel), on the surface of
// object `obj` near the tangent plane (p, n): the forward neighbour, else the backward one
// negated, else zero.
fn footprint_step(px: vec2i, axis: vec2i, p: vec3f, n: vec3f, obj: f32) -> vec3f {
    let size = vec2i(i32(gp.width), i32(gp.height));
    for (var k = 0; k < 2; k++) {
        let s = select(-1, 1, k == 0);
        let q = px + axis * s;
        if (any(q < vec2i(0)) || any(q >= size)) { continue; }
        let qw = textureLoad(eye_pos, q, 0);
        if (qw.w != obj) { continue; }
        let v = qw.xyz - p;
        // Off the tangent plane by more than a tenth of the step: another sheet of the surface.
        if (abs(dot(v, n)) > 0.1 * length(v)) { continue; }
        return v * f32(s);
    }
    return vec3f(0.0);
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
    let px = vec2i(gid.xy);
    let dx = footprint_step(px, vec2i(1, 0), p, n, pw.w);
    let dy = footprint_step(px, vec2i(0, 1), p, n, pw.w);
    let ns = max(gp.samples, 1u);
    let inv = 1.0 / f32(ns);
    // Every record at all ns^2 points while that is at most FULL_FILTER lookups per pixel;
    // beyond, the records that carry at least gp.sigma_t.w of irradiance luminance (a 32nd of
    // all records', set by the CPU: at most 32 of them, a sun's) at all points, the others one
    // point each, dealt out in turn (record i at point i mod ns^2): the records of one light
    // (its three blended directions, an environment region's sub-directions) lie together and
    // cover the pixel between them.
    let nss = ns * ns;
    let all_full = gp.records * nss <= FULL_FILTER;
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
            visible = dist > 0.0 && !scene_occluded_except(c, to / dist, dist * (1.0 - 1e-4), object, false);
            // A ray that overflowed the BVH stack may have missed an occluder: no caustic
            // (conservative), and counted in the frame's statistics.
            if (rt_overflow > 0u) { atomicAdd(&gather_stats[0], 1u); }
            visible = visible && rt_overflow == 0u;
        }
        if (!visible) { continue; }
        var tr = vec3f(1.0);
        if (gp.medium_lo.w > 0.5 && r.base.z != 2u) { tr = light_transmittance(r, p); }
        let lum = r.irradiance.r + r.irradiance.g + r.irradiance.b;
        let full = all_full || lum >= gp.sigma_t.w;
        let per = select(1u, nss, full);
        var er = vec3f(0.0);
        for (var j = 0u; j < per; j++) {
            let k = select(i % nss, j, full);
            let u = (f32(k % ns) + 0.5) * inv - 0.5;
            let v = (f32(k / ns) + 0.5) * inv - 0.5;
            er += record_irradiance(r, p + dx * u + dy * v, n);
        }
        e += er * (1.0 / f32(per)) * tr;
    }
    let lo = mat.a.rgb / PI * e;
    let idx = gid.y * gp.width + gid.x;
    radiance[idx] += vec4f(lo, 0.0);
    caustic[idx] += vec4f(lo, 0.0);
}
