// Shared WGSL (`#import photon_walk`): photons on random walks from a light, for the stages
// that follow light through the whole scene (`medium_ms_trace`, `indirect_trace`): the walk's
// random numbers (a PCG stream per photon, in `rng_state`) and its start by the light's
// emission. The importing stage declares `light: LightGpu`.

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
