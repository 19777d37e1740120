// Shared WGSL (`#import medium`): the homogeneous medium's box (scene `medium`).

// The part [t0, t1] of the ray o + t d (0 <= t <= t_max) inside the box lo..hi; t0 >= t1 if none.
fn box_clip(o: vec3f, d: vec3f, t_max: f32, lo: vec3f, hi: vec3f) -> vec2f {
    var t0 = 0.0;
    var t1 = t_max;
    for (var k = 0; k < 3; k++) {
        if (abs(d[k]) < 1e-12) {
            if (o[k] < lo[k] || o[k] > hi[k]) { return vec2f(1.0, 0.0); }
            continue;
        }
        let a = (lo[k] - o[k]) / d[k];
        let b = (hi[k] - o[k]) / d[k];
        t0 = max(t0, min(a, b));
        t1 = min(t1, max(a, b));
    }
    return vec2f(t0, t1);
}

// Length of the segment from a to b inside the box lo..hi.
fn box_length(a: vec3f, b: vec3f, lo: vec3f, hi: vec3f) -> f32 {
    let v = b - a;
    let l = length(v);
    if (l <= 0.0) { return 0.0; }
    let c = box_clip(a, v / l, l, lo, hi);
    return max(c.y - c.x, 0.0);
}

// Where the light's path to x starts: the spot's or point light's position; for a directional
// light (kind 2, travelling along `light.axis`) a point on the line back from x toward the
// light beyond the box lo..hi (its light enters the box from the vacuum outside: the path's
// part inside the box, `box_length` or `grid_optical_depth` from there to x, is the whole
// medium path).
fn light_path_start(light: LightGpu, x: vec3f, lo: vec3f, hi: vec3f) -> vec3f {
    if (light.info.y == LIGHT_DIRECTIONAL) {
        let far = length(hi - lo) + length(x - clamp(x, lo, hi)) + 1.0;
        return x - normalize(light.axis.xyz) * far;
    }
    return light.faces[0].origin.xyz;
}

// Heterogeneous media (scene `medium.density`): the density grid as an R32Float 3D texture
// (`passes::upload_density`; 1×1×1 holding 1 for a homogeneous medium), read with textureLoad.

// Trilinear density at x between voxel centres lo + (i + 1/2)/res (hi - lo), clamped to the
// outermost ones: the arithmetic of `DensityGrid::lookup` (crates/caustics/src/scene/density.rs).
fn grid_density(grid: texture_3d<f32>, x: vec3f, lo: vec3f, hi: vec3f) -> f32 {
    let dims = vec3i(textureDimensions(grid));
    let p = (x - lo) / (hi - lo) * vec3f(dims) - 0.5;
    let f = floor(p);
    let t = p - f;
    let m = dims - 1;
    let a = clamp(vec3i(f), vec3i(0), m);
    let b = clamp(vec3i(f) + 1, vec3i(0), m);
    let c000 = textureLoad(grid, vec3i(a.x, a.y, a.z), 0).r;
    let c100 = textureLoad(grid, vec3i(b.x, a.y, a.z), 0).r;
    let c010 = textureLoad(grid, vec3i(a.x, b.y, a.z), 0).r;
    let c110 = textureLoad(grid, vec3i(b.x, b.y, a.z), 0).r;
    let c001 = textureLoad(grid, vec3i(a.x, a.y, b.z), 0).r;
    let c101 = textureLoad(grid, vec3i(b.x, a.y, b.z), 0).r;
    let c011 = textureLoad(grid, vec3i(a.x, b.y, b.z), 0).r;
    let c111 = textureLoad(grid, vec3i(b.x, b.y, b.z), 0).r;
    let c00 = c000 + (c100 - c000) * t.x;
    let c10 = c010 + (c110 - c010) * t.x;
    let c01 = c001 + (c101 - c001) * t.x;
    let c11 = c011 + (c111 - c011) * t.x;
    let c0 = c00 + (c10 - c00) * t.y;
    let c1 = c01 + (c11 - c01) * t.y;
    return c0 + (c1 - c0) * t.z;
}

// Optical depth in density units (the integral of the density) along the part of the segment
// a -> b inside the box lo..hi: a midpoint rule in `steps` equal steps over that part
// (deterministic; the transmittance is exp(-sigma_t * it)).
fn grid_optical_depth(grid: texture_3d<f32>, a: vec3f, b: vec3f, lo: vec3f, hi: vec3f, steps: u32) -> f32 {
    let v = b - a;
    let l = length(v);
    if (l <= 0.0) { return 0.0; }
    let dir = v / l;
    let c = box_clip(a, dir, l, lo, hi);
    if (c.y <= c.x) { return 0.0; }
    let n = max(steps, 1u);
    let dt = (c.y - c.x) / f32(n);
    var s = 0.0;
    for (var i = 0u; i < n; i++) {
        s += grid_density(grid, a + dir * (c.x + (f32(i) + 0.5) * dt), lo, hi);
    }
    return s * dt;
}

// The unit direction from the camera at cam through the centre of pixel gid of a width x height
// image (clip_to_world: the inverse of the camera's view-projection).
fn pixel_ray(clip_to_world: mat4x4f, cam: vec3f, gid: vec2u, width: u32, height: u32) -> vec3f {
    let ndc = vec2f((f32(gid.x) + 0.5) / f32(width) * 2.0 - 1.0, 1.0 - (f32(gid.y) + 0.5) / f32(height) * 2.0);
    let q = clip_to_world * vec4f(ndc, 0.5, 1.0);
    return normalize(q.xyz / q.w - cam);
}

// The distance from the camera at cam to the first surface pixel px sees: the nearer of the
// eye's diffuse and specular buffers' points (w < 0: none); 1e30 where it sees neither.
fn first_surface(recv_pos: texture_2d<f32>, spec_pos: texture_2d<f32>, px: vec2i, cam: vec3f) -> f32 {
    var t_max = 1e30;
    let r = textureLoad(recv_pos, px, 0);
    let sp = textureLoad(spec_pos, px, 0);
    if (r.w >= 0.0) { t_max = min(t_max, length(r.xyz - cam)); }
    if (sp.w >= 0.0) { t_max = min(t_max, length(sp.xyz - cam)); }
    return t_max;
}

// The Henyey-Greenstein phase function (1/sr) of asymmetry g at the scattering angle's cosine
// (g = 0: isotropic, 1 / (4 pi)).
fn hg_phase(cos_t: f32, g: f32) -> f32 {
    if (g == 0.0) { return 0.25 / PI; }
    let den = max(1.0 + g * g - 2.0 * g * cos_t, 1e-12);
    return (1.0 - g * g) / (4.0 * PI * den * sqrt(den));
}

// The camera paths' segments in the medium beyond the first specular surface
// (`gpu::types::EyeSegmentGpu`): `composite` keeps, per specular pixel it shades, the
// `EYE_SEGMENTS` heaviest segments its reflected and refracted rays travel outside the
// dielectrics (from a specular surface to the next surface, or out of the scene), in slots
// listed index * EYE_SEGMENTS + j (the index in `composite`'s list of specular pixels); the
// medium's stages add the light each scatters toward the camera (`medium_scatter`,
// `medium_bounce`, `beam_gather`), weighted by `w`.
const EYE_SEGMENTS: u32 = 2u;

struct EyeSegment {
    // xyz: where the segment starts (on a specular surface); w: its length (1e30: it leaves
    // the scene; 0: an empty slot).
    o: vec4f,
    // The path's weight from the camera to o (Fresnel factors, a mirror's colour, the
    // medium's transmittance along the camera ray and the segments before it).
    w: vec3f,
    // The unit direction, octahedral (`oct_encode`).
    dir: u32,
}

// A unit direction as an octahedral map point in [-1, 1]^2 (Meyer et al. 2010), as 2 x 16-bit
// snorm (at most about 1e-4 rad off).
fn oct_encode(d: vec3f) -> u32 {
    var p = d.xy / (abs(d.x) + abs(d.y) + abs(d.z));
    if (d.z < 0.0) {
        let s = select(vec2f(-1.0), vec2f(1.0), p >= vec2f(0.0));
        p = (1.0 - abs(p.yx)) * s;
    }
    return pack2x16snorm(p);
}

fn oct_decode(bits: u32) -> vec3f {
    let p = unpack2x16snorm(bits);
    var d = vec3f(p, 1.0 - abs(p.x) - abs(p.y));
    if (d.z < 0.0) {
        let s = select(vec2f(-1.0), vec2f(1.0), d.xy >= vec2f(0.0));
        d = vec3f((1.0 - abs(d.yx)) * s, d.z);
    }
    return normalize(d);
}

fn segment_dir(s: EyeSegment) -> vec3f {
    return oct_decode(s.dir);
}
