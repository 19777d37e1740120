// Stage: sphere_trace. The precomputation of caustic spheres on the GPU
// (`caustic_spheres::build`, src/caustic_spheres/build.rs): photons of a unit-irradiance
// directional light travelling along one stored direction, traced through one caustic object
// alone by the exact tracer (shared/raytrace.wgsl: the object's BVH or analytic shape), every
// specular interaction up to the depth limit, each dielectric's Fresnel choice made at random
// (hash_uniform of the photon and depth; the flux stays whole), total internal reflection
// reflecting. A photon that leaves the object after at least one interaction is written to its
// own slot (origin, direction, flux; the CPU deposits them in photon order, as the CPU
// reference's `escaping` does for its photons).
// Photons start on a disc perpendicular to the light, covering the object's bounding sphere,
// at a 2D Hammersley point (i + 0.5)/n, radical inverse of i (shifted per direction) mapped by
// the concentric map.

#import raytrace
#import scene

// [0]: centre (xyz), disc radius (w); [1]: the light's travel direction (xyz), the distance
// back from the centre to the disc (w); [2], [3]: the disc's axes (xyz); [2].w: flux per photon
// (m^2 per W/m^2), [3].w: t_max (infinity).
@group(0) @binding(0) var<storage, read> trace_frame: array<vec4f>;
// [0]: photons in the direction, [1]: the first photon of this dispatch, [2]: photons in this
// dispatch, [3]: the depth limit, [4]: the direction's seed.
@group(0) @binding(1) var<storage, read> trace_counts: array<u32>;
// Per photon of the dispatch, three vec4: origin (xyz; w = 1 when it escaped, else 0),
// direction, flux (rgb).
@group(0) @binding(2) var<storage, read_write> escaped: array<vec4f>;

fn concentric_disc(u: vec2f) -> vec2f {
    let o = 2.0 * u - vec2f(1.0);
    if (o.x == 0.0 && o.y == 0.0) { return vec2f(0.0); }
    if (abs(o.x) > abs(o.y)) {
        let th = PI / 4.0 * (o.y / o.x);
        return o.x * vec2f(cos(th), sin(th));
    }
    let th = PI / 2.0 - PI / 4.0 * (o.x / o.y);
    return o.y * vec2f(cos(th), sin(th));
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    let k = gid.y * (65535u * 64u) + gid.x;
    if (k >= trace_counts[2]) { return; }
    let n = trace_counts[0];
    let i = trace_counts[1] + k;
    let seed = trace_counts[4];
    let c = trace_frame[0];
    let l = trace_frame[1];
    let du = trace_frame[2];
    let dv = trace_frame[3];
    // Hammersley: stratified along the first axis, the radical inverse (Cranley-Patterson
    // shifted by the seed) along the second.
    let u = vec2f((f32(i) + 0.5) / f32(n), f32((reverseBits(i) + seed) >> 8u) / 16777216.0);
    let p = concentric_disc(u) * c.w;
    var o = c.xyz + du.xyz * p.x + dv.xyz * p.y - l.xyz * l.w;
    var d = l.xyz;
    var f = vec3f(du.w);
    let key = (i * 2654435761u) ^ (seed * 2246822519u);
    let out = 3u * k;
    escaped[out] = vec4f(0.0);
    for (var depth = 0u; depth < trace_counts[3]; depth++) {
        rt_overflow = 0u;
        let h = scene_hit(o, d, dv.w);
        if (h.object == INVALID) {
            if (depth > 0u) {
                escaped[out] = vec4f(o, 1.0);
                escaped[out + 1u] = vec4f(d, 0.0);
                escaped[out + 2u] = vec4f(f, 0.0);
            }
            return;
        }
        let mat = materials[h.object];
        if (mat.kind.x == KIND_DIFFUSE) { return; }
        let front = dot(d, h.ng) < 0.0;
        let ng = select(-h.ng, h.ng, front);
        let ns = select(-h.ns, h.ns, front);
        var n_used = ns;
        var eta = 1.0;
        var reflected = true;
        if (mat.kind.x == KIND_MIRROR || mat.kind.x == KIND_CONDUCTOR) {
            f *= rt_metal_weight(mat, d, ns);
        } else {
            let fz = rt_dielectric_fresnel(mat, d, ns, ng, front);
            n_used = fz.n;
            eta = fz.eta;
            reflected = fz.f >= 1.0 || hash_uniform(key, depth) < fz.f;
        }
        let bz = rt_bounce(d, n_used, ng, eta, reflected);
        d = bz.dir;
        o = rt_spawn(h.p, h.ng, d);
        if (max(max(f.r, f.g), f.b) <= 0.0) { return; }
    }
}
