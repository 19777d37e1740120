// Shared WGSL (`#import medium_multiple`): the multiple-scattering grid of the medium
// (src/medium_multiple/, docs/media.md "Multiple scattering"): its parameters and cells.

// `gpu::types::MsParams`: one record for the three stages (`medium_ms_trace`,
// `medium_ms_resolve`, `medium_ms_view`).
struct MsParams {
    // The camera's inverse view-projection (`medium_ms_view`).
    clip_to_world: mat4x4f,
    camera: vec4f,
    // The medium's box.
    lo: vec4f,
    hi: vec4f,
    // rgb = sigma_s (1/m), w = Henyey-Greenstein g
    sigma_s: vec4f,
    // rgb = sigma_t (1/m), w = the majorant of the free-flight sampling (1/m: the density
    // grid's largest value times the largest channel of sigma_t)
    sigma_t: vec4f,
    // A directional light's photons start on this disk (xyz centre, w radius, m), facing it,
    // beyond every object and the box.
    disk: vec4f,
    // xyz = cells per axis, w = 1 with a density grid
    dims: vec4u,
    // Photons of this light and the seed of their random numbers.
    photons: u32,
    seed: u32,
    _pad0: u32,
    _pad1: u32,
    // `medium_ms_view`: the image and its ray march.
    width: u32,
    height: u32,
    steps: u32,
    // Events per photon path at most (scattering, surfaces).
    max_events: u32,
}

// The cell that holds x (clamped to the grid).
fn ms_cell(x: vec3f) -> u32 {
    let d = vec3i(mp.dims.xyz);
    let c = clamp(vec3i(floor((x - mp.lo.xyz) / (mp.hi.xyz - mp.lo.xyz) * vec3f(d))), vec3i(0), d - 1);
    return u32(c.x + d.x * (c.y + d.y * c.z));
}

// Each cell's volume (m^3).
fn ms_cell_volume() -> f32 {
    let s = (mp.hi.xyz - mp.lo.xyz) / vec3f(mp.dims.xyz);
    return s.x * s.y * s.z;
}

// Fixed-point units per watt of one light's sums: 2^20 per watt of its photons' largest
// nominal flux (intensity times the solid angle it fills, or irradiance times the disk, over
// the photon count), so a photon's deposit keeps 20 bits and a cell sums 2^44 photons.
fn ms_scale(l: LightGpu) -> f32 {
    var spread = 4.0 * PI;
    if (l.info.y == LIGHT_SPOT) { spread = 2.0 * PI * (1.0 - cos(l.axis.w)); }
    if (l.info.y == LIGHT_DIRECTIONAL) { spread = PI * mp.disk.w * mp.disk.w; }
    let nominal = max(max(l.power.r, l.power.g), l.power.b) * spread / f32(max(mp.photons, 1u));
    return 1048576.0 / max(nominal, 1e-30);
}
