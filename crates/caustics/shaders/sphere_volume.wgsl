// Stage: sphere_volume. Volumetric caustics from caustic spheres (Tandianus et al. 2010,
// issue 15 item 5) in a homogeneous medium: per pixel, the camera ray from the camera to the
// first surface it sees (the nearer of the eye's diffuse and specular buffers; the far side of
// the medium's box when it sees nothing), clipped to the box, marched in `vp.steps` equal
// steps (midpoint rule, deterministic). At each step x, per record (directional light, caustic
// object, blended stored direction) the spheres' stored value C(x) is the caustic light's
// fluence per unit irradiance of the light (`docs/caustic-spheres.md`, "Volumetric caustics from
// the spheres": a photon crossing a thin shell of thickness h at angle a to its normal runs
// h/|cos a| inside it, so sum Phi/(A |cos a|) is the track-length estimate of the fluence),
// and single scattering toward the camera adds
//     sigma_s phase(d . w_o) E C(x) T_light(x) T_eye(x) dt
// with d the stored flux-weighted mean travel direction, w_o toward the camera,
// T_eye = exp(-sigma_t (t - t_in)), T_light = exp(-sigma_t l), l the medium path of the light
// from the box to the plane 2/3 r_min before the object's centre along the light's direction
// (where a ball's cross-section meets it on average) plus from the innermost sphere to x along
// the ray from the centre (the path through the object and its bend are not followed). Steps within r_min of an object's centre (the object itself; no medium inside a
// dielectric) get nothing from it. No occlusion test between the object and x. The result is
// added to the full and the caustic-only image after `medium_scatter` attenuated them.

#import medium
#import sphere_table

struct SphereVolumeParams {
    clip_to_world: mat4x4f,
    camera: vec4f,
    // The medium's box.
    lo: vec4f,
    hi: vec4f,
    // rgb = sigma_s (1/m), w = Henyey-Greenstein g (0: isotropic)
    sigma_s: vec4f,
    // rgb = sigma_t = sigma_s + sigma_a (1/m)
    sigma_t: vec4f,
    width: u32,
    height: u32,
    steps: u32,
    records: u32,
}

@group(0) @binding(0) var<uniform> vp: SphereVolumeParams;
@group(0) @binding(1) var recv_pos: texture_2d<f32>;
@group(0) @binding(2) var spec_pos: texture_2d<f32>;
@group(0) @binding(3) var<storage, read> records: array<SphereRecord>;
@group(0) @binding(4) var<storage, read> table: array<vec4u>;
@group(0) @binding(5) var<storage, read_write> out_full: array<vec4f>;
@group(0) @binding(6) var<storage, read_write> out_caustic: array<vec4f>;

fn phase(cos_t: f32) -> f32 {
    return hg_phase(cos_t, vp.sigma_s.w);
}

// An object-frame direction v of record r in the world (to_obj is a similarity A: A^-1 v is
// along A^T v).
fn to_world_dir(r: SphereRecord, v: vec3f) -> vec3f {
    let m = mat3x3f(r.to_obj[0].xyz, r.to_obj[1].xyz, r.to_obj[2].xyz);
    return normalize(m * v);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    if (gid.x >= vp.width || gid.y >= vp.height) { return; }
    let idx = gid.y * vp.width + gid.x;
    let cam = vp.camera.xyz;
    let d = pixel_ray(vp.clip_to_world, cam, gid.xy, vp.width, vp.height);
    let t_max = first_surface(recv_pos, spec_pos, vec2i(gid.xy), cam);
    let lo = vp.lo.xyz;
    let hi = vp.hi.xyz;
    let seg = box_clip(cam, d, t_max, lo, hi);
    if (seg.y <= seg.x || vp.records == 0u) { return; }
    let n = max(vp.steps, 1u);
    let dt = (seg.y - seg.x) / f32(n);
    let st = vp.sigma_t.rgb;
    // The box's extent: a point beyond it along any direction from inside.
    let far = 2.0 * length(hi - lo) + 1.0;
    var acc = vec3f(0.0);
    for (var k = 0u; k < vp.records; k++) {
        let r = records[k];
        // World: the light's travel direction, the spheres' centre and r_min.
        let l = to_world_dir(r, r.axes[2].xyz);
        let m = mat3x3f(r.to_obj[0].xyz, r.to_obj[1].xyz, r.to_obj[2].xyz);
        let tr = vec3f(r.to_obj[0].w, r.to_obj[1].w, r.to_obj[2].w);
        let s2 = dot(r.to_obj[0].xyz, r.to_obj[0].xyz);
        let c = m * (r.center.xyz - tr) / s2;
        let rmin = r.center.w / sqrt(s2);
        // The light's path in the medium up to the object: to the plane 2/3 r_min before
        // the centre, where a ball's cross-section meets the light on average (the mean of
        // sqrt(R^2 - rho^2) over the disc is 2R/3).
        let into = box_length(c - l * (far + length(c - cam)), c - l * (rmin * 2.0 / 3.0), lo, hi);
        for (var i = 0u; i < n; i++) {
            let t = seg.x + (f32(i) + 0.5) * dt;
            let x = cam + d * t;
            let po = vec3f(dot(r.to_obj[0], vec4f(x, 1.0)), dot(r.to_obj[1], vec4f(x, 1.0)), dot(r.to_obj[2], vec4f(x, 1.0)));
            if (length(po - r.center.xyz) <= r.center.w) { continue; }
            let sm = sphere_lookup(r, po);
            if (all(sm.c <= vec3f(0.0))) { continue; }
            let dw = to_world_dir(r, sm.d);
            let u = normalize(x - c);
            let out = box_length(c + u * rmin, x, lo, hi);
            let trans = exp(-st * (into + out + (t - seg.x)));
            acc += r.irradiance.rgb * sm.c * phase(dot(dw, -d)) * trans;
        }
    }
    let add = vp.sigma_s.rgb * acc * dt;
    out_full[idx] += vec4f(add, 0.0);
    out_caustic[idx] += vec4f(add, 0.0);
}
