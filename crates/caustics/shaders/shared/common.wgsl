// Shared WGSL: structs the host writes (mirrored in src/gpu/types.rs, checked by a test),
// optics (Fresnel, refraction), light-space projection and fixed-point helpers.
// Prepended to every stage by src/gpu/shaders.rs.

// One face of a light view (see src/lightspace.rs).
struct Face {
    world_to_clip: mat4x4f,
    clip_to_world: mat4x4f,
    // Light position (perspective) or the direction light travels (orthographic); w = 1 if orthographic.
    origin: vec4f,
}

// A light view: up to 6 faces, plus the light itself.
struct LightGpu {
    faces: array<Face, 6>,
    // x = face count, y = kind (0 spot, 1 point, 2 directional), z = photon grid size N, w = caustic map size M
    info: vec4u,
    // rgb = intensity (W/sr) or irradiance (W/m^2); a = cos of the spot cone angle
    power: vec4f,
    // xyz = spot axis / light direction; w = cone angle (radians)
    axis: vec4f,
    // x = falloff start (radians), y = fixed-point scale (units per watt), z = Gaussian sigma (texels), w = gbuffer size G
    params: vec4f,
    // x = bounding radius of the casters (m), y = bounding radius of the scene (m),
    // z = tan of half the perspective faces' field of view, w = 1 if a photon leaving a caster
    // can meet a caster again (anything but a lone sphere), else 0
    extra: vec4f,
    // x = beam diameters from the lens equations for the splat (0 off, 1 thin lens, 2 thick
    // lens; src/splat.rs), y = SPILL_FACE_PRESENT if the last face is a spot light's spill face
    // (receives photons, has no caster buffers; else 0), z = a spot light's profile (0 linear
    // in the angle, 1 glTF's curve: `intensity_toward`), w unused
    splat: vec4f,
    // The NDC rectangle (lo.x, lo.y, hi.x, hi.y) photon_trace spreads its N x N grid over: the
    // casters' box for a directional light under the basic technique, else (-1, -1, 1, 1).
    crop: vec4f,
    // The medium's box (medium_lo.w: 0 none, 1 homogeneous, 2 a density grid; with one, photons
    // carry their path's transmittance into the caustic map, shared/trace.wgsl `land_photon`)
    // and sigma_t (rgb, 1/m; w: the grid's march steps per path segment).
    medium_lo: vec4f,
    medium_hi: vec4f,
    medium_sigma_t: vec4f,
}

// A traced photon: where it lands in the caustic map (continuous texel coordinates, face) and
// its flux (W, rgb). face = INVALID: no caustic.
struct Photon {
    pos: vec2f,
    face: u32,
    _pad: u32,
    flux: vec4f,
}

// The scene's BVH (src/accel.rs, shared/raytrace.wgsl). A node: count == 0: inner, children
// a and a + 1; otherwise a leaf of `count` triangles from a.
struct BvhNode {
    lo: vec3f,
    a: u32,
    hi: vec3f,
    count: u32,
}

// A triangle in leaf order: positions (p0.w: the mesh's triangle index, f32 bits) and vertex
// shading normals, in the scene file's pose.
struct BvhTri {
    p0: vec4f,
    p1: vec4f,
    p2: vec4f,
    n0: vec4f,
    n1: vec4f,
    n2: vec4f,
}

// A mesh object of the top level: world -> BVH space and back (rows of 3 x 4 matrices), world
// bounds, root node, first triangle, object index (INVALID: no instance).
struct BvhInstance {
    to_object: array<vec4f, 3>,
    to_world: array<vec4f, 3>,
    lo: vec4f,
    hi: vec4f,
    root: u32,
    first_tri: u32,
    object: u32,
    _pad: u32,
}

// Per-object material, indexed by object id.
struct MaterialGpu {
    // x = kind (0 diffuse, 1 dielectric, 2 mirror, 3 conductor), y = caster (1/0),
    // z = analytic shape (0 none: mesh, 1 sphere, 2 cylinder, 3 rectangle)
    kind: vec4u,
    // diffuse: albedo; dielectric: (ior, ext_ior, -, -); mirror: reflectance; conductor: eta
    a: vec4f,
    // conductor: k; dielectric: absorption coefficient of the inside (1/m, rgb)
    b: vec4f,
    // The object's analytic shape, for exact intersection: sphere (centre, radius); cylinder
    // (base, radius), (axis, height); rectangle (centre, -), (normal, -), (u, size u), (v, size v).
    s0: vec4f,
    s1: vec4f,
    s2: vec4f,
    s3: vec4f,
}

const KIND_DIFFUSE: u32 = 0u;
const KIND_DIELECTRIC: u32 = 1u;
const KIND_MIRROR: u32 = 2u;
const KIND_CONDUCTOR: u32 = 3u;
// MaterialGpu.kind.z: the object's analytic shape (none for meshes).
const SHAPE_MESH: u32 = 0u;
const SHAPE_SPHERE: u32 = 1u;
const SHAPE_CYLINDER: u32 = 2u;
const SHAPE_RECTANGLE: u32 = 3u;
// Side of the tiles (texels) of `caustic_mask` and `shadow_tiles`, read by `shade_receivers`.
const SHADE_TILE: u32 = 8u;

// LightGpu.info.y: the light's kind.
const LIGHT_SPOT: u32 = 0u;
const LIGHT_POINT: u32 = 1u;
const LIGHT_DIRECTIONAL: u32 = 2u;
// LightGpu.splat.y: the light's last face is a spill face (lightspace::spill_face).
const SPILL_FACE_PRESENT: u32 = 1u;
// BeamParams.flags (src/gpu/types.rs): trace the reflected branches; the medium has a density
// grid; light can cross the medium from one specular object to another; count the hull draws'
// fragments (one-shot renders); the beams' ends light surfaces (the energy cutoff leaves the
// beams landing on an object whole).
const BEAM_FLAG_REFLECTION: u32 = 1u;
const BEAM_FLAG_GRID: u32 = 2u;
const BEAM_FLAG_CHAINS: u32 = 4u;
const BEAM_FLAG_FRAGMENTS: u32 = 8u;
const BEAM_FLAG_SURFACE: u32 = 16u;
const INVALID: u32 = 0xffffffffu;
const PI: f32 = 3.14159265358979;

// Unpolarised Fresnel reflectance of a dielectric interface; eta = n_t / n_i.
fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let c = clamp(cos_i, 0.0, 1.0);
    let s2 = (1.0 - c * c) / (eta * eta);
    if (s2 >= 1.0) { return 1.0; }
    let ct = sqrt(1.0 - s2);
    let rs = (c - eta * ct) / (c + eta * ct);
    let rp = (eta * c - ct) / (eta * c + ct);
    return 0.5 * (rs * rs + rp * rp);
}

// Unpolarised Fresnel reflectance of a conductor with complex IOR eta + i k (per channel).
fn fresnel_conductor(cos_i: f32, eta: vec3f, k: vec3f) -> vec3f {
    let c = clamp(cos_i, 0.0, 1.0);
    let c2 = c * c;
    let s2 = 1.0 - c2;
    let e2 = eta * eta;
    let k2 = k * k;
    let t0 = e2 - k2 - vec3f(s2);
    let a2b2 = sqrt(t0 * t0 + 4.0 * e2 * k2);
    let t1 = a2b2 + vec3f(c2);
    let a = sqrt(max(0.5 * (a2b2 + t0), vec3f(0.0)));
    let t2 = 2.0 * c * a;
    let rs = (t1 - t2) / (t1 + t2);
    let t3 = c2 * a2b2 + vec3f(s2 * s2);
    let t4 = t2 * s2;
    let rp = rs * (t3 - t4) / (t3 + t4);
    return 0.5 * (rp + rs);
}

// Refraction of unit d through a surface with unit normal n facing against d; eta = n_i / n_t.
// Returns vec4(direction, 1) or vec4(0) on total internal reflection.
fn refract_dir(d: vec3f, n: vec3f, eta: f32) -> vec4f {
    let c = -dot(d, n);
    let k = 1.0 - eta * eta * (1.0 - c * c);
    if (k < 0.0) { return vec4f(0.0); }
    return vec4f(normalize(eta * d + (eta * c - sqrt(k)) * n), 1.0);
}

// Project a world point into face f: returns (texel x, texel y, ndc depth, inside?1:0) for a
// size x size map.
fn project_face(face: Face, p: vec3f, size: f32) -> vec4f {
    let c = face.world_to_clip * vec4f(p, 1.0);
    if (c.w <= 0.0) { return vec4f(0.0, 0.0, 0.0, 0.0); }
    let ndc = c.xyz / c.w;
    let inside = abs(ndc.x) <= 1.0 && abs(ndc.y) <= 1.0 && ndc.z >= 0.0 && ndc.z <= 1.0;
    return vec4f((ndc.x * 0.5 + 0.5) * size, (0.5 - ndc.y * 0.5) * size, ndc.z, select(0.0, 1.0, inside));
}

// Texel coordinates, in face `dst` of an M x M map, of the direction through texel coordinates
// `pos` of face `src` (which may lie beyond its map): perspective faces on one eye (a point
// light's cube), so a direction maps to a point of any face it lies in front of, and straight
// lines stay straight. z = 1 where the direction lies in front of `dst` (less than about 84
// degrees off its axis), else 0.
fn texel_in_face(src: Face, dst: Face, pos: vec2f, m: f32) -> vec3f {
    // A point on the ray on the far plane: far from the eye, so the direction is precise.
    let h = src.clip_to_world * vec4f(2.0 * pos.x / m - 1.0, 1.0 - 2.0 * pos.y / m, 1.0, 1.0);
    let p = h.xyz / h.w;
    let c = dst.world_to_clip * vec4f(p, 1.0);
    if (c.w <= 0.1 * distance(p, src.origin.xyz)) { return vec3f(0.0); }
    let ndc = c.xy / c.w;
    return vec3f((ndc.x * 0.5 + 0.5) * m, (0.5 - ndc.y * 0.5) * m, 1.0);
}

// The distance along unit u from p over which face's depth (ndc z, a float in [0, 1]) changes by
// 8 ulps of a float near 1 (2^-24 each): what a shadow lookup's offset toward the light must add
// for the rounding of the stored and the looked-up depths. A perspective face's depth is
// 1 - near / z far from its near plane, so one ulp spans a world distance growing as z² / near
// (1.5 mm at 5 m with the near plane at 1 mm: more than a 4096² map's texel there).
// d(c.z / c.w) = (dz c.w - c.z dw) / c.w² along u.
fn depth_precision(face: Face, p: vec3f, u: vec3f) -> f32 {
    let c = face.world_to_clip * vec4f(p, 1.0);
    let dc = face.world_to_clip * vec4f(u, 0.0);
    let rate = abs(dc.z * c.w - c.z * dc.w) / max(c.w * c.w, 1e-30);
    return 8.0 * 5.9604645e-8 / max(rate, 1e-30);
}

// Direction from p toward the light (unit), and distance (infinite for directional lights).
fn to_light(light: LightGpu, p: vec3f) -> vec4f {
    if (light.info.y == LIGHT_DIRECTIONAL) { return vec4f(-light.axis.xyz, 1e30); }
    let o = light.faces[0].origin.xyz;
    let v = o - p;
    let d = length(v);
    return vec4f(v / d, d);
}

// Radiant intensity (W/sr) of a spot or point light toward unit direction dir (from the light).
fn intensity_toward(light: LightGpu, dir: vec3f) -> vec3f {
    if (light.info.y == LIGHT_POINT) { return light.power.rgb; }
    let cone = light.axis.w;
    let start = light.params.x;
    if (light.splat.z > 0.5) {
        // KHR_lights_punctual's curve (`SpotProfile::Gltf`): t² with t linear in the cosine.
        let inner = cos(start);
        let t = clamp((dot(dir, light.axis.xyz) - light.power.w) / max(inner - light.power.w, 0.001), 0.0, 1.0);
        return light.power.rgb * (t * t);
    }
    let angle = acos(clamp(dot(dir, light.axis.xyz), -1.0, 1.0));
    var f = 1.0;
    if (angle >= cone) { f = 0.0; } else if (angle > start) { f = (cone - angle) / (cone - start); }
    return light.power.rgb * f;
}

// Area on a receiver (at p, unit normal n) covered by one texel of face f of an M x M map.
fn texel_area(face: Face, p: vec3f, n: vec3f, m: f32) -> f32 {
    let c = face.world_to_clip * vec4f(p, 1.0);
    let ndc = c.xyz / c.w;
    let d = 2.0 / m;
    let q0 = face.clip_to_world * vec4f(ndc, 1.0);
    let qx = face.clip_to_world * vec4f(ndc + vec3f(d, 0.0, 0.0), 1.0);
    let qy = face.clip_to_world * vec4f(ndc + vec3f(0.0, d, 0.0), 1.0);
    let p0 = q0.xyz / q0.w;
    let px = qx.xyz / qx.w;
    let py = qy.xyz / qy.w;
    var tl = -face.origin.xyz;
    if (face.origin.w < 0.5) { tl = normalize(face.origin.xyz - p); }
    let perp = abs(dot(cross(px - p0, py - p0), tl));
    return perp / max(abs(dot(n, tl)), 1e-4);
}

// 64-bit fixed point (two u32 words, low then high): sums that do not depend on the order their
// terms arrive in (the caustic maps, the splat and emitter sums). A non-negative v as its two
// words, rounded down.
fn fixed_words(v: f32) -> vec2u {
    let hi = floor(v / 4294967296.0);
    return vec2u(u32(v - hi * 4294967296.0), u32(hi));
}

// The carry into the high word when lo is added to a low word that held `old` (atomicAdd's result).
fn fixed_carry(old: u32, lo: u32) -> u32 {
    return select(0u, 1u, old > 0xffffffffu - lo);
}

// A uniform number in [0, 1) from a key and a second number (a PCG hash of both): the random
// Fresnel choices of the photon tracer's residual pass (shared/trace.wgsl) and of the beams'
// residual branch (shared/beam_trace.wgsl), the same in every run.
fn hash_uniform(key: u32, n: u32) -> f32 {
    var s = key ^ (n * 2891336453u + 12345u);
    s = s * 747796405u + 2891336453u;
    s = ((s >> ((s >> 28u) + 4u)) ^ s) * 277803737u;
    s = (s >> 22u) ^ s;
    return f32(s >> 8u) * (1.0 / 16777216.0);
}

// Shadow-map lookups shared by the stages that read a light's shadow map (`shadow_map`: one
// layer per face, depth; `ss`: a comparison sampler).

// Where a receiver point p (unit normal n, unit `to_l` toward the light) is looked up in `face`
// of a size x size shadow map: offset along n and toward the light by its texels (one texel's
// width at p across the light's ray), and the depth's rounding (`depth_precision`, capped at 8
// texels). The normal offset: the 3x3 PCF's bilinear taps reach texel centres up to 1.5 texels
// beyond the lookup's own ray, where a receiver lit at a grazing angle (sine s of the light's
// angle to it) lies farther from the light by 1.5 texels * cos / s; lifting p off the surface by
// d brings it d / s nearer along its ray, so d must exceed 1.5 texels * cos: 2.5 * cos where that
// is more than 1.5 (a point light 5 cm above a floor drew the floor in rings of acne). For
// perspective faces only: a directional light's texels are one size everywhere, and there the
// larger offset moved the shadow edges of glass_sphere_studio's low lights (HDR-FLIP against
// the CPU reference 0.0523 -> 0.0528) with no acne to remove.
fn shadow_lookup_point(face: Face, p: vec3f, n: vec3f, to_l: vec3f, size: f32) -> vec3f {
    let texel = sqrt(texel_area(face, p, to_l, size));
    let prec = min(depth_precision(face, p, to_l), 8.0 * texel);
    var lift = 1.5;
    if (face.origin.w < 0.5) { lift = max(1.5, 2.5 * sqrt(max(1.0 - dot(n, to_l) * dot(n, to_l), 0.0))); }
    return p + n * (lift * texel) + to_l * (1.0 * texel + prec);
}

// 3x3 PCF around q (texel x, texel y, ndc depth: `project_face` of an offset point) in layer f
// of a size x size map: the fraction of the comparisons that pass, of the taps inside the face
// (a tap past its edge would read the edge texels, clamped, for a direction they do not hold:
// at a cube's seams that drew lines).
fn shadow_pcf(shadow_map: texture_depth_2d_array, ss: sampler_comparison, q: vec4f, f: u32, size: f32) -> f32 {
    var vis = 0.0;
    var taps = 0.0;
    for (var y = -1; y <= 1; y++) {
        for (var x = -1; x <= 1; x++) {
            let uv = (q.xy + vec2f(f32(x), f32(y))) / size;
            if (any(uv < vec2f(0.0)) || any(uv > vec2f(1.0))) { continue; }
            vis += textureSampleCompareLevel(shadow_map, ss, uv, f, q.z);
            taps += 1.0;
        }
    }
    if (taps == 0.0) { return 1.0; }
    return vis / taps;
}

// Whether the light reaches the medium point x through face f (0..1): one bilinear comparison
// one texel toward the light (`to_l`), depth clamped to the map's range (a point beyond the far
// plane is lit where no object covers its texel).
fn shadow_point(shadow_map: texture_depth_2d_array, ss: sampler_comparison, face: Face, f: u32, x: vec3f, to_l: vec3f, size: f32) -> f32 {
    let texel = sqrt(texel_area(face, x, to_l, size));
    let c = face.world_to_clip * vec4f(x + to_l * texel, 1.0);
    if (c.w <= 0.0) { return 1.0; }
    let ndc = c.xyz / c.w;
    let uv = vec2f(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5);
    return textureSampleCompareLevel(shadow_map, ss, uv, f, clamp(ndc.z, 0.0, 1.0));
}
