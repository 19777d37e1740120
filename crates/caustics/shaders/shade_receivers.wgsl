// Stage: shade_receivers. Radiance of the diffuse surfaces the camera sees, for one light:
// albedo/pi * (direct irradiance * shadow + caustic irradiance). Direct irradiance is I cos/d^2
// (spot, point) or E cos (directional); the shadow map holds every object, casters included, so
// light through glass arrives only as caustic. Shadows: 3x3 PCF with a normal offset. Caustics:
// bilinear in the light-space irradiance map, over the texels whose receiver point is the
// shaded point (so caustics do not leak onto surfaces the light cannot see).
// In a medium, the direct light is attenuated by the transmittance from the light (a
// directional light: from where its line back from the point leaves the medium's box) to the
// point: exp(-sigma_t d) in a homogeneous medium, the ray march `grid_optical_depth` in
// `medium_grid.y` steps through the density grid in a heterogeneous one. The caustic is not:
// the photons carried their own path's transmittance into the map (shared/trace.wgsl,
// `land_photon`; the straight line would run through the caster). Run once per light; adds into `radiance` (full) and `caustic` (caustic light only).
// An environment region's light spreads its caustic over the region's sub-directions
// (`taps`, src/env_taps.rs); every other light has no taps.
// Tiles (`sp.tiles`, RenderSettings::shading_tiles): per tile of SHADE_TILE^2 texels, whether the
// caustic map has light there (`caustic_mask`) and the shadow map's depth range (`shadow_tiles`),
// made once with the light's maps: a caustic lookup whose texels are all zero returns 0 without
// reading them, and a PCF whose texels all pass or all fail returns 1 or 0 without sampling.
// Where they skip, the result is what the full lookup gives (0 exactly; a PCF of nine
// comparisons that all pass is 9/9 = 1), so the image is the same.

#import medium
#import scene

struct ShadeParams {
    width: u32,
    height: u32,
    shadow_size: u32,
    // 1: skip work by the light's tiles (caustic_mask, shadow_tiles); 0: always do it.
    tiles: u32,
    camera: vec4f,
    // The medium's box (w = 1 if the scene has a medium, else 0) and sigma_t (1/m).
    medium_lo: vec4f,
    medium_hi: vec4f,
    sigma_t: vec4f,
    // x = 1 with a density grid (heterogeneous medium), y = ray-march steps toward the light.
    medium_grid: vec4u,
}

@group(0) @binding(0) var<uniform> light: LightGpu;
@group(0) @binding(1) var<uniform> sp: ShadeParams;
@group(0) @binding(2) var eye_pos: texture_2d<f32>;
@group(0) @binding(3) var eye_nrm: texture_2d<f32>;
@group(0) @binding(4) var shadow_map: texture_depth_2d_array;
@group(0) @binding(5) var shadow_sampler: sampler_comparison;
@group(0) @binding(6) var recv_pos: texture_2d_array<f32>;
@group(0) @binding(7) var<storage, read> irradiance: array<vec4f>;
@group(0) @binding(8) var<storage, read_write> radiance: array<vec4f>;
@group(0) @binding(9) var<storage, read_write> caustic: array<vec4f>;
@group(0) @binding(10) var<uniform> taps: EnvTaps;
@group(0) @binding(11) var<storage, read> caustic_mask: array<u32>;
@group(0) @binding(12) var<storage, read> shadow_tiles: array<vec2f>;

// An environment region's sub-directions (src/env_taps.rs): rows of R_k^T (R_k turns the
// light's direction to sub-direction k) and the sub-region's weight (rgb). Array size =
// gpu::types::MAX_ENV_TAPS (the struct sizes are checked equal by tests/shaders.rs).
struct EnvTap {
    r0: vec4f,
    r1: vec4f,
    r2: vec4f,
    weight: vec4f,
}

struct EnvTaps {
    centre: vec4f,
    info: vec4u,
    taps: array<EnvTap, 32>,
}

fn face_of(p: vec3f, size: f32) -> vec4f {
    for (var f = 0u; f < light.info.x; f++) {
        let q = project_face(light.faces[f], p, size);
        if (q.w > 0.5) { return vec4f(q.xyz, f32(f)); }
    }
    return vec4f(-1.0);
}

fn shadow(p: vec3f, n: vec3f) -> f32 {
    let s = f32(sp.shadow_size);
    let q0 = face_of(p, s);
    if (q0.w < 0.0) { return 1.0; }
    let f = u32(q0.w);
    let l = to_light(light, p);
    let po = shadow_lookup_point(light.faces[f], p, n, l.xyz, s);
    let q = project_face(light.faces[f], po, s);
    if (q.w < 0.5) { return 1.0; }
    if (sp.tiles != 0u) {
        // Every texel the 3x3 PCF reads lies within two texels of floor(q.xy), in the widened
        // tile of shadow_tiles. project_face keeps q.z in [0, 1].
        let n_t = (sp.shadow_size + SHADE_TILE - 1u) / SHADE_TILE;
        let c = min(vec2u(q.xy), vec2u(sp.shadow_size - 1u)) / SHADE_TILE;
        let r = shadow_tiles[(f * n_t + c.y) * n_t + c.x];
        if (q.z <= r.x) { return 1.0; }
        if (q.z > r.y) { return 0.0; }
    }
    return shadow_pcf(shadow_map, shadow_sampler, q, f, s);
}

fn caustic_at(p: vec3f, n: vec3f) -> vec3f {
    let m = light.info.w;
    let q = face_of(p, f32(m));
    if (q.w < 0.0) { return vec3f(0.0); }
    let f = u32(q.w);
    let l = to_light(light, p);
    let texel = sqrt(texel_area(light.faces[f], p, l.xyz, f32(m)));
    let g = q.xy - 0.5;
    let base = vec2i(floor(g));
    if (sp.tiles != 0u) {
        // The lookup reads texels base and base + 1 (base >= -1), all in the tile of
        // max(base, 0) widened by a texel: none lit there, the result is 0.
        let n_t = (m + SHADE_TILE - 1u) / SHADE_TILE;
        let c = vec2u(max(base, vec2i(0))) / SHADE_TILE;
        if (caustic_mask[(f * n_t + c.y) * n_t + c.x] == 0u) { return vec3f(0.0); }
    }
    let fr = g - floor(g);
    // Same surface: the texel's receiver point lies within 4 texels of p. Under a grazing light
    // the bilinear neighbours' points lie up to 1.5 texels / cos apart along the surface (cos of
    // the light's angle to the normal): where none lies within 4 texels, those within that reach
    // (and 4 texels of p's tangent plane) are taken instead. (Taking them always blurred sharp
    // caustics under low lights; taking none drew stripes of no caustic.)
    var r = caustic_bilinear(f, base, fr, p, n, 4.0 * texel, 1e30);
    let wide = 1.5 / max(abs(dot(n, l.xyz)), 0.05);
    if (r.w <= 1e-6 && wide > 4.0) { r = caustic_bilinear(f, base, fr, p, n, wide * texel, 4.0 * texel); }
    if (r.w <= 1e-6) { return vec3f(0.0); }
    return r.rgb / r.w;
}

// The bilinear lookup of `caustic_at` over the texels whose receiver point lies within `reach`
// of p and within `plane` of p's tangent plane: the weighted sum and the weights' sum (w).
fn caustic_bilinear(f: u32, base: vec2i, fr: vec2f, p: vec3f, n: vec3f, reach: f32, plane: f32) -> vec4f {
    let m = light.info.w;
    var acc = vec3f(0.0);
    var wsum = 0.0;
    for (var k = 0; k < 4; k++) {
        let o = vec2i(k & 1, k >> 1);
        let t = base + o;
        if (t.x < 0 || t.y < 0 || t.x >= i32(m) || t.y >= i32(m)) { continue; }
        let r = textureLoad(recv_pos, t, f, 0);
        if (r.w < 0.0) { continue; }
        let off = r.xyz - p;
        if (length(off) > reach || abs(dot(off, n)) > plane) { continue; }
        let w = select(1.0 - fr.x, fr.x, o.x == 1) * select(1.0 - fr.y, fr.y, o.y == 1);
        acc += w * irradiance[(f * m + u32(t.y)) * m + u32(t.x)].rgb;
        wsum += w;
    }
    return vec4f(acc, wsum);
}

// The pixel's footprint on the receiver: the steps to the neighbouring pixels' positions on the
// same object (zero along an axis where neither neighbour lies on it).
struct Footprint { dx: vec3f, dy: vec3f }

fn pixel_footprint(p: vec3f, px: vec2i, object: f32) -> Footprint {
    let size = vec2i(i32(sp.width), i32(sp.height));
    var dx = vec3f(0.0);
    var dy = vec3f(0.0);
    let r = textureLoad(eye_pos, clamp(px + vec2i(1, 0), vec2i(0), size - 1), 0);
    let l = textureLoad(eye_pos, clamp(px - vec2i(1, 0), vec2i(0), size - 1), 0);
    let d = textureLoad(eye_pos, clamp(px + vec2i(0, 1), vec2i(0), size - 1), 0);
    let u = textureLoad(eye_pos, clamp(px - vec2i(0, 1), vec2i(0), size - 1), 0);
    if (r.w == object && px.x + 1 < size.x) { dx = r.xyz - p; } else if (l.w == object && px.x > 0) { dx = p - l.xyz; }
    if (d.w == object && px.y + 1 < size.y) { dy = d.xyz - p; } else if (u.w == object && px.y > 0) { dy = p - u.xyz; }
    return Footprint(dx, dy);
}

// The camera's box pixel filter over the caustic map: average 3 x 3 bilinear lookups spread over
// the pixel's footprint on the receiver (from the neighbouring pixels' positions on the same
// object). Without it, a caustic sharper than a pixel would be point-sampled at the pixel centre
// and its peak overstated.
fn caustic_box(p: vec3f, n: vec3f, px: vec2i, object: f32) -> vec3f {
    let fp = pixel_footprint(p, px, object);
    let dx = fp.dx;
    let dy = fp.dy;
    var acc = vec3f(0.0);
    for (var j = 0; j < 3; j++) {
        for (var i = 0; i < 3; i++) {
            let o = (f32(i) + 0.5) / 3.0 - 0.5;
            let q = (f32(j) + 0.5) / 3.0 - 0.5;
            acc += caustic_at(p + o * dx + q * dy, n);
        }
    }
    return acc / 9.0;
}

// The caustic of an environment region spread over its sub-directions (src/env_taps.rs): per
// tap k, the point p (at the k-th point of an R2 sequence over the pixel's footprint) turned by
// R_k^T about the casters' centre c, followed from c to the tangent plane at p (f = c + s q'),
// the map read there, scaled by s^3 (a source at c: cos/r^2 on the plane, r_f = s r_p and
// cos_p / cos_f = s) and by the weight.
fn caustic_taps(p: vec3f, n: vec3f, px: vec2i, object: f32) -> vec3f {
    let fp = pixel_footprint(p, px, object);
    let dx = fp.dx;
    let dy = fp.dy;
    let c = taps.centre.xyz;
    var acc = vec3f(0.0);
    for (var k = 0u; k < min(taps.info.x, 32u); k++) {
        let t = taps.taps[k];
        let o = fract(vec2f(0.5) + f32(k) * vec2f(0.7548777, 0.5698403)) - 0.5;
        let ps = p + o.x * dx + o.y * dy;
        let q = ps - c;
        let qr = vec3f(dot(t.r0.xyz, q), dot(t.r1.xyz, q), dot(t.r2.xyz, q));
        let a = dot(n, q);
        let b = dot(n, qr);
        // The turned point must lie on the plane's side of c that p does.
        if (a * b <= 0.0) { continue; }
        let s = a / b;
        acc += t.weight.rgb * caustic_at(c + s * qr, n) * (s * s * s);
    }
    return acc;
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    if (gid.x >= sp.width || gid.y >= sp.height) { return; }
    let pw = textureLoad(eye_pos, vec2i(gid.xy), 0);
    if (pw.w < 0.0) { return; }
    let mat = materials[u32(pw.w)];
    if (mat.kind.x != KIND_DIFFUSE) { return; }
    let p = pw.xyz;
    var n = normalize(textureLoad(eye_nrm, vec2i(gid.xy), 0).xyz);
    if (dot(n, sp.camera.xyz - p) < 0.0) { n = -n; }
    let l = to_light(light, p);
    let cos_t = dot(n, l.xyz);
    if (cos_t <= 0.0) { return; }
    var e_direct: vec3f;
    if (light.info.y == LIGHT_DIRECTIONAL) {
        e_direct = light.power.rgb * cos_t;
    } else {
        e_direct = intensity_toward(light, -l.xyz) * cos_t / (l.w * l.w);
    }
    var e = vec3f(0.0);
    if (any(e_direct > vec3f(0.0))) { e = e_direct * shadow(p, n); }
    var ec: vec3f;
    if (taps.info.x > 0u) {
        ec = caustic_taps(p, n, vec2i(gid.xy), pw.w);
    } else {
        ec = caustic_box(p, n, vec2i(gid.xy), pw.w);
    }
    if (sp.medium_lo.w > 0.5) {
        var tr: vec3f;
        if (sp.medium_grid.x == 0u) {
            let lp = light_path_start(light, p, sp.medium_lo.xyz, sp.medium_hi.xyz);
            tr = exp(-sp.sigma_t.rgb * box_length(lp, p, sp.medium_lo.xyz, sp.medium_hi.xyz));
        } else {
            let lp = light_path_start(light, p, sp.medium_lo.xyz, sp.medium_hi.xyz);
            let od = grid_optical_depth(density_grid, lp, p, sp.medium_lo.xyz, sp.medium_hi.xyz, sp.medium_grid.y);
            tr = exp(-sp.sigma_t.rgb * od);
        }
        // (Only the direct light: the photons carried their own path's transmittance into the
        // caustic map, shared/trace.wgsl.)
        e *= tr;
    }
    let albedo = mat.a.rgb / PI;
    let idx = gid.y * sp.width + gid.x;
    radiance[idx] += vec4f(albedo * (e + ec), 0.0);
    caustic[idx] += vec4f(albedo * ec, 0.0);
}
