// Shared WGSL (`#import photon_walk`): photons on random walks from a light, for the stages
// that follow light through the whole scene (`medium_ms_trace`, `indirect_trace`): the walk's
// random numbers (a PCG stream per photon, in `rng_state`) and its start by the light's
// emission, and what a surface does to it. The importing stage declares `light: LightGpu` and
// imports `raytrace` and `scene` before this module.

var<private> rng_state: u32;

// Seed photon `i`'s stream: its index and the seed through one PCG step.
fn walk_seed(i: u32, seed: u32) {
    rng_state = (i ^ (seed * 2654435769u)) * 747796405u + 2891336453u;
    rng_state = ((rng_state >> ((rng_state >> 28u) + 4u)) ^ rng_state) * 277803737u;
}

fn rnd() -> f32 {
    rng_state = rng_state * 747796405u + 2891336453u;
    var s = rng_state;
    s = ((s >> ((s >> 28u) + 4u)) ^ s) * 277803737u;
    s = (s >> 22u) ^ s;
    return f32(s >> 8u) * (1.0 / 16777216.0);
}

// An orthonormal pair perpendicular to unit a.
fn ms_basis(a: vec3f) -> mat2x3f {
    let t = normalize(cross(select(vec3f(1.0, 0.0, 0.0), vec3f(0.0, 1.0, 0.0), abs(a.x) > 0.9), a));
    return mat2x3f(t, cross(a, t));
}

// A direction at cosine c to unit a, at azimuth phi.
fn ms_around(a: vec3f, c: f32, phi: f32) -> vec3f {
    let b = ms_basis(a);
    let s = sqrt(max(1.0 - c * c, 0.0));
    return normalize(a * c + (b[0] * cos(phi) + b[1] * sin(phi)) * s);
}

// A photon leaving the light: origin, direction, flux (W).
struct WalkStart {
    o: vec3f,
    d: vec3f,
    flux: vec3f,
}

// One of `photons` photons, emitted by the light's intensity over its cone (a spot), the
// sphere (a point light) or `disk` (xyz centre, w radius, m: beyond the scene, facing a
// directional light).
fn walk_emit(disk: vec4f, photons: u32) -> WalkStart {
    let n = f32(max(photons, 1u));
    var w: WalkStart;
    if (light.info.y == LIGHT_DIRECTIONAL) {
        w.d = normalize(light.axis.xyz);
        let r = disk.w * sqrt(rnd());
        let phi = 2.0 * PI * rnd();
        let b = ms_basis(w.d);
        w.o = disk.xyz - w.d * (disk.w + 1.0) + (b[0] * cos(phi) + b[1] * sin(phi)) * r;
        w.flux = light.power.rgb * (PI * disk.w * disk.w) / n;
    } else {
        w.o = light.faces[0].origin.xyz;
        if (light.info.y == LIGHT_SPOT) {
            let cc = cos(light.axis.w);
            let c = 1.0 - rnd() * (1.0 - cc);
            w.d = ms_around(light.axis.xyz, c, 2.0 * PI * rnd());
            w.flux = intensity_toward(light, w.d) * (2.0 * PI * (1.0 - cc)) / n;
        } else {
            w.d = ms_around(vec3f(0.0, 0.0, 1.0), 1.0 - 2.0 * rnd(), 2.0 * PI * rnd());
            w.flux = light.power.rgb * (4.0 * PI) / n;
        }
    }
    return w;
}

// The absorption coefficient (1/m, rgb) of the dielectric the photon travels in: set by
// walk_surface when it goes into one (refracted in or reflected inside), cleared when it goes out
// (the ext_ior side is clear), kept by mirrors, conductors and diffuse bounces.
var<private> walk_sigma: vec3f = vec3f(0.0);

// Beer–Lambert transmittance along a segment of length t inside the current dielectric
// (exactly 1 where it is clear).
fn walk_absorbed(t: f32) -> vec3f {
    if (any(walk_sigma > vec3f(0.0))) { return exp(-walk_sigma * t); }
    return vec3f(1.0);
}

// The photon (at o, along d, carrying flux) meets the surface of hit h: a diffuse surface
// bounces it by the cosine with Russian roulette by the albedo's largest channel (at most 0.95),
// a mirror or conductor reflects it with its colour, a dielectric reflects or refracts it by
// Fresnel; then it leaves the surface. `in_medium`: whether it travels outside the dielectrics
// after (a medium's part). False: absorbed (the roulette ended it).
fn walk_surface(h: SceneHit, o: ptr<function, vec3f>, d: ptr<function, vec3f>, flux: ptr<function, vec3f>, in_medium: ptr<function, bool>) -> bool {
    let mat = materials[h.object];
    let front = dot(*d, h.ng) < 0.0;
    let ng = select(-h.ng, h.ng, front);
    let ns = select(-h.ns, h.ns, front);
    if (mat.kind.x == KIND_DIFFUSE) {
        let a = mat.a.rgb;
        let keep = min(max(max(a.r, a.g), a.b), 0.95);
        if (rnd() >= keep) { return false; }
        *flux *= a / keep;
        let u1 = rnd();
        *d = ms_around(ng, sqrt(1.0 - u1), 2.0 * PI * rnd());
        *o = rt_spawn(h.p, h.ng, *d);
        *in_medium = true;
        return true;
    }
    var n = ns;
    var eta = 1.0;
    var reflect_it = true;
    if (mat.kind.x == KIND_MIRROR || mat.kind.x == KIND_CONDUCTOR) {
        *flux *= rt_metal_weight(mat, *d, ns);
    } else {
        let fz = rt_dielectric_fresnel(mat, *d, ns, ng, front);
        n = fz.n;
        eta = fz.eta;
        reflect_it = rnd() < fz.f;
    }
    let bz = rt_bounce(*d, n, ng, eta, reflect_it);
    // Inside a dielectric after entering it, or reflecting inside it: no medium there.
    *in_medium = !(mat.kind.x == KIND_DIELECTRIC && (front != bz.reflected));
    if (mat.kind.x == KIND_DIELECTRIC) { walk_sigma = select(vec3f(0.0), mat.b.rgb, !*in_medium); }
    *d = bz.dir;
    *o = rt_spawn(h.p, h.ng, *d);
    return true;
}
