// Stage: medium_scatter. Direct light in a homogeneous participating medium (scene `medium`),
// seen by the camera, for one light (spot, point or directional). Per pixel, the camera ray from the camera
// to the first surface it sees (the nearer of the eye's diffuse and specular buffers; the far
// side of the medium's box when it sees nothing), clipped to the box:
//   - with `mp.flags & 1` (the first light's dispatch), the composited image (full and
//     caustic-only) is multiplied by the transmittance exp(-sigma_t d) along that segment;
//   - the single-scattered light of this light is added to the full image: a midpoint rule in
//     `mp.steps` equal steps of
//       sigma_s phase(cos) I(w)/r^2 exp(-sigma_t (r_in_box + s_in_box)) V,
//     V from the light's shadow map (one bilinear comparison, one texel toward the light);
//     for a directional light of irradiance E (W/m^2) travelling along L, E in place of
//     I(w)/r^2, the scattering angle's cosine L . (-d), and r_in_box the part inside the box of
//     the line from x back toward the light (its light enters the box from the vacuum outside;
//     the orthographic shadow map covers the scene's bounding sphere, and a point outside its
//     footprint sees the light past every object).
// A spot light's rule runs over the part of the segment inside its cone only (`cone_clip`).
// With `medium_segments` (a second dispatch per light, indirect over `composite`'s list of
// specular pixels) the same rule runs along the segments `composite` kept of the paths beyond
// each pixel's specular surface (`EyeSegment`, shared/medium.wgsl), weighted by the path's
// weight; `composite` attenuated what those paths see.
// Heterogeneous media (`mp.grid == 1`, a density grid in `density_grid`): sigma(x) = rho(x) sigma;
// the same midpoint rule gives the camera ray's optical depth (the attenuation) and, per step,
// rho sigma_s phase I/r^2 exp(-sigma_t (tau_light + tau_camera)) V, tau_light by a ray march of
// `mp.light_steps` steps toward the light (`grid_optical_depth`).

#import medium
#import scene

struct MediumParams {
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
    // bit 0: attenuate the image first; bit 1: add this light's in-scattering
    flags: u32,
    shadow_size: u32,
    // 1: heterogeneous (read `density`); 0: homogeneous (closed-form transmittance)
    grid: u32,
    // heterogeneous: ray-march steps of each transmittance toward the light
    light_steps: u32,
    _pad0: u32,
}

@group(0) @binding(0) var<uniform> light: LightGpu;
@group(0) @binding(1) var<uniform> mp: MediumParams;
@group(0) @binding(2) var recv_pos: texture_2d<f32>;
@group(0) @binding(3) var spec_pos: texture_2d<f32>;
@group(0) @binding(4) var shadow_map: texture_depth_2d_array;
@group(0) @binding(5) var shadow_sampler: sampler_comparison;
@group(0) @binding(6) var<storage, read_write> out_full: array<vec4f>;
@group(0) @binding(7) var<storage, read_write> out_caustic: array<vec4f>;
// `composite`'s list of specular pixels, its length (count[3]) and the segments it kept.
@group(0) @binding(8) var<storage, read> spec_list: array<u32>;
@group(0) @binding(9) var<storage, read> spec_count: array<u32, 4>;
@group(0) @binding(10) var<storage, read> segments: array<EyeSegment>;
override medium_segments: bool = false;

fn phase(cos_t: f32) -> f32 {
    return hg_phase(cos_t, mp.sigma_s.w);
}

// Whether the light reaches x (0..1): the shadow map of the face that holds x, depth clamped
// to the map's range (a point beyond the far plane is lit where no object covers its texel).
fn visibility(x: vec3f, to_l: vec3f) -> f32 {
    let s = f32(mp.shadow_size);
    for (var f = 0u; f < light.info.x; f++) {
        let face = light.faces[f];
        let c0 = face.world_to_clip * vec4f(x, 1.0);
        if (c0.w <= 0.0) { continue; }
        let n0 = c0.xyz / c0.w;
        if (abs(n0.x) > 1.0 || abs(n0.y) > 1.0) { continue; }
        return shadow_point(shadow_map, shadow_sampler, face, f, x, to_l, s);
    }
    return 1.0;
}

// The light arriving at x, before the medium's attenuation: its travel direction `wl`, its
// irradiance `e` on a plane facing it (W/m^2: a directional light's irradiance, a spot's or
// point light's I(w)/r^2) and its visibility `vis` (0: none arrives).
struct Incident {
    wl: vec3f,
    e: vec3f,
    vis: f32,
}

fn incident(x: vec3f) -> Incident {
    var wl: vec3f;
    var e: vec3f;
    if (light.info.y == LIGHT_DIRECTIONAL) {
        wl = normalize(light.axis.xyz);
        e = light.power.rgb;
    } else {
        let v = light.faces[0].origin.xyz - x;
        let rl = length(v);
        if (rl <= 1e-6) { return Incident(vec3f(0.0), vec3f(0.0), 0.0); }
        wl = -v / rl;
        e = intensity_toward(light, wl) / (rl * rl);
    }
    if (all(e <= vec3f(0.0))) { return Incident(wl, e, 0.0); }
    return Incident(wl, e, visibility(x, -wl));
}

// Whether x lies in the spot's cone (its light is zero outside: `intensity_toward`).
fn in_cone(x: vec3f) -> bool {
    let v = x - light.faces[0].origin.xyz;
    return dot(v, light.axis.xyz) >= length(v) * cos(light.axis.w);
}

// The part of [seg.x, seg.y] of the camera ray cam + t d inside a spot light's cone (a convex
// set, so one interval; empty: y <= x). The midpoint rule then runs over light only: at the
// cone's edge the integrand jumps, and a rule across it leaves bands that follow where the edge
// falls between its points (arcs across the shaft).
fn cone_clip(cam: vec3f, d: vec3f, seg: vec2f) -> vec2f {
    let a = light.axis.xyz;
    let c2 = cos(light.axis.w) * cos(light.axis.w);
    let v = cam - light.faces[0].origin.xyz;
    let da = dot(d, a);
    let va = dot(v, a);
    // (va + t da)^2 - c2 |v + t d|^2 = qa t^2 + qb t + qc (on the cone's surface and its mirror)
    let qa = da * da - c2;
    let qb = 2.0 * (va * da - c2 * dot(v, d));
    let qc = va * va - c2 * dot(v, v);
    // Cut [seg.x, seg.y] at the roots inside it; the pieces whose midpoints are in the cone
    // make the interval.
    var cuts = array<f32, 4>(seg.x, seg.y, seg.y, seg.y);
    var n = 1u;
    if (abs(qa) > 1e-12) {
        let disc = qb * qb - 4.0 * qa * qc;
        if (disc >= 0.0) {
            let sq = sqrt(disc);
            // The stable pair of roots.
            let q = -0.5 * (qb + select(-sq, sq, qb >= 0.0));
            var r0 = q / qa;
            var r1 = select(r0, qc / q, q != 0.0);
            if (r1 < r0) { let t = r0; r0 = r1; r1 = t; }
            if (r0 > seg.x && r0 < seg.y) { cuts[n] = r0; n++; }
            if (r1 > seg.x && r1 < seg.y && r1 > cuts[n - 1u]) { cuts[n] = r1; n++; }
        }
    } else if (abs(qb) > 1e-12) {
        let r = -qc / qb;
        if (r > seg.x && r < seg.y) { cuts[n] = r; n++; }
    }
    cuts[n] = seg.y;
    var lo = seg.y;
    var hi = seg.x;
    for (var i = 0u; i < n; i++) {
        if (in_cone(cam + d * (0.5 * (cuts[i] + cuts[i + 1u])))) {
            lo = min(lo, cuts[i]);
            hi = max(hi, cuts[i + 1u]);
        }
    }
    return vec2f(lo, hi);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3u, @builtin(workgroup_id) wg: vec3u, @builtin(local_invocation_index) li: u32) {
    if (medium_segments) {
        along_segments(wg.x * 64u + li);
        return;
    }
    if (gid.x >= mp.width || gid.y >= mp.height) { return; }
    let idx = gid.y * mp.width + gid.x;
    let cam = mp.camera.xyz;
    let d = pixel_ray(mp.clip_to_world, cam, gid.xy, mp.width, mp.height);
    // The first surface along the pixel's ray.
    let t_max = first_surface(recv_pos, spec_pos, vec2i(gid.xy), cam);
    let seg = box_clip(cam, d, t_max, mp.lo.xyz, mp.hi.xyz);
    if (seg.y <= seg.x) { return; }
    if (mp.grid != 0u) {
        heterogeneous(idx, cam, d, seg);
        return;
    }
    if ((mp.flags & 1u) != 0u) {
        let tr = exp(-mp.sigma_t.rgb * (seg.y - seg.x));
        out_full[idx] = vec4f(out_full[idx].rgb * tr, out_full[idx].a);
        out_caustic[idx] = vec4f(out_caustic[idx].rgb * tr, out_caustic[idx].a);
    }
    if ((mp.flags & 2u) == 0u) { return; }
    out_full[idx] += vec4f(homogeneous_scatter(cam, d, seg), 0.0);
}

// The light scattered toward o along o + t d over `seg` (its part in the box; the
// transmittance toward o starts at seg.x) in a homogeneous medium.
fn homogeneous_scatter(o: vec3f, d: vec3f, seg: vec2f) -> vec3f {
    // A spot light's single scattering only where the ray is in its cone.
    var lit = seg;
    if (light.info.y == LIGHT_SPOT) {
        lit = cone_clip(o, d, seg);
        if (lit.y <= lit.x) { return vec3f(0.0); }
    }
    let n = max(mp.steps, 1u);
    let dt = (lit.y - lit.x) / f32(n);
    var acc = vec3f(0.0);
    for (var i = 0u; i < n; i++) {
        let t = lit.x + (f32(i) + 0.5) * dt;
        let x = o + d * t;
        let inc = incident(x);
        if (inc.vis <= 0.0) { continue; }
        let lp = light_path_start(light, x, mp.lo.xyz, mp.hi.xyz);
        let tr = exp(-mp.sigma_t.rgb * (box_length(lp, x, mp.lo.xyz, mp.hi.xyz) + (t - seg.x)));
        acc += inc.e * phase(dot(inc.wl, -d)) * tr * inc.vis;
    }
    return mp.sigma_s.rgb * acc * dt;
}

// The segments `composite` kept for listed specular pixel `i`: this light's single scattering
// along each, weighted by its path's weight, added to the pixel's full image.
fn along_segments(i: u32) {
    if (i >= spec_count[3] || (mp.flags & 2u) == 0u) { return; }
    var add = vec3f(0.0);
    for (var k = 0u; k < EYE_SEGMENTS; k++) {
        let e = segments[i * EYE_SEGMENTS + k];
        if (!(e.o.w > 0.0)) { continue; }
        let o = e.o.xyz;
        let d = segment_dir(e);
        let seg = box_clip(o, d, e.o.w, mp.lo.xyz, mp.hi.xyz);
        if (seg.y <= seg.x) { continue; }
        if (mp.grid != 0u) {
            add += e.w * heterogeneous_along(o, d, seg, true, false).l;
        } else {
            add += e.w * homogeneous_scatter(o, d, seg);
        }
    }
    let idx = spec_list[i];
    out_full[idx] += vec4f(add, 0.0);
}

// The pixel `idx`'s camera ray cam + t d over the segment `seg` in a heterogeneous medium:
// attenuation (flag 1) and this light's single scattering (flag 2).
fn heterogeneous(idx: u32, cam: vec3f, d: vec3f, seg: vec2f) {
    let a = heterogeneous_along(cam, d, seg, (mp.flags & 2u) != 0u, (mp.flags & 1u) != 0u);
    if ((mp.flags & 1u) != 0u) {
        let tr = exp(-mp.sigma_t.rgb * a.tau);
        out_full[idx] = vec4f(out_full[idx].rgb * tr, out_full[idx].a);
        out_caustic[idx] = vec4f(out_caustic[idx].rgb * tr, out_caustic[idx].a);
    }
    if ((mp.flags & 2u) != 0u) {
        out_full[idx] += vec4f(a.l, 0.0);
    }
}

struct Along {
    // The light scattered toward the ray's origin.
    l: vec3f,
    // The optical depth (density units) of the whole segment.
    tau: f32,
}

// The ray o + t d over `seg` in a heterogeneous medium: (`scatter`) this light's single
// scattering toward o and (`whole`) the whole segment's optical depth, one midpoint rule in
// `mp.steps` steps for both.
fn heterogeneous_along(o: vec3f, d: vec3f, seg: vec2f, scatter: bool, whole: bool) -> Along {
    let lo = mp.lo.xyz;
    let hi = mp.hi.xyz;
    // A spot light's rule runs inside its cone (`cone_clip`); the attenuation then takes the
    // whole segment's optical depth by a march of its own, and the rule starts from the
    // optical depth before the cone.
    var lit = seg;
    if (scatter && light.info.y == LIGHT_SPOT) { lit = cone_clip(o, d, seg); }
    let clipped = lit.x != seg.x || lit.y != seg.y;
    let n = max(mp.steps, 1u);
    let dt = max(lit.y - lit.x, 0.0) / f32(n);
    // Optical depth (density integral) from the segment's start to the current step's start.
    var tau = 0.0;
    var acc = vec3f(0.0);
    if (lit.y > lit.x) {
        if (lit.x > seg.x) { tau = grid_optical_depth(density_grid, o + d * seg.x, o + d * lit.x, lo, hi, n); }
        for (var i = 0u; i < n; i++) {
            let t = lit.x + (f32(i) + 0.5) * dt;
            let x = o + d * t;
            let rho = grid_density(density_grid, x, lo, hi);
            let tau_here = tau + 0.5 * rho * dt;
            tau += rho * dt;
            if (!scatter || rho <= 0.0) { continue; }
            let inc = incident(x);
            if (inc.vis <= 0.0) { continue; }
            let tau_l = grid_optical_depth(density_grid, x, light_path_start(light, x, lo, hi), lo, hi, mp.light_steps);
            let tr = exp(-mp.sigma_t.rgb * (tau_l + tau_here));
            acc += rho * inc.e * phase(dot(inc.wl, -d)) * tr * inc.vis;
        }
    }
    var r: Along;
    r.l = mp.sigma_s.rgb * acc * dt;
    r.tau = tau;
    if (clipped && whole) { r.tau = grid_optical_depth(density_grid, o + d * seg.x, o + d * seg.y, lo, hi, n); }
    return r;
}
