// Stage: medium_ms_trace. The medium's multiple scattering, photons' part (src/medium_multiple/,
// docs/media.md "Multiple scattering"): `mp.photons` photons of one light, each on its own
// random walk (a deterministic PCG stream per photon): emitted by the light's intensity over
// its cone (a spot), the sphere (a point light) or a disk beyond the scene (a directional
// light), then, up to `mp.max_events` events, exact through every surface (scene_hit:
// dielectrics choose reflection or refraction by Fresnel, mirrors and conductors reflect with
// their colour, diffuse surfaces bounce by the cosine with Russian roulette by albedo) and
// through the medium outside the dielectrics by free-flight sampling against the majorant
// (delta tracking with spectral weights, Kutz et al. 2017: a homogeneous grey medium needs no
// null events; a density grid's are its empty space). At every scattering event after the
// path's first in the medium (or after two diffuse bounces) the photon's scattered flux is
// added to the cell that holds it (64-bit fixed point: the same sums in any order). The first
// scattering event is the single scattering the other passes draw exactly (`medium_scatter`,
// the beams, `medium_bounce`), so the grid holds orders two and up.

#import shapes
#import raytrace
#import medium
#import scene
#import medium_multiple
#import photon_walk

@group(0) @binding(0) var<uniform> light: LightGpu;
@group(0) @binding(1) var<uniform> mp: MsParams;
// Per cell, r, g, b as 64-bit fixed-point words (low, high).
@group(0) @binding(2) var<storage, read_write> sums: array<atomic<u32>>;

fn deposit(x: vec3f, flux: vec3f) {
    let c = ms_cell(x) * 6u;
    let scale = ms_scale(light);
    for (var ch = 0u; ch < 3u; ch++) {
        let v = flux[ch] * scale;
        if (!(v > 0.0)) { continue; }
        let w = fixed_words(v);
        let old = atomicAdd(&sums[c + ch * 2u], w.x);
        let hi = w.y + fixed_carry(old, w.x);
        if (hi != 0u) { atomicAdd(&sums[c + ch * 2u + 1u], hi); }
    }
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u, @builtin(num_workgroups) nwg: vec3u) {
    let i = gid.y * nwg.x * 64u + gid.x;
    if (i >= mp.photons) { return; }
    walk_seed(i, mp.seed);
    let start = walk_emit(mp.disk, mp.photons);
    var o = start.o;
    var d = start.d;
    var flux = start.flux;
    let lo = mp.lo.xyz;
    let hi = mp.hi.xyz;
    let maj = mp.sigma_t.w;
    let g = mp.sigma_s.w;
    var in_medium = true;
    var scatters = 0u;
    var diffuse = 0u;
    for (var ev = 0u; ev < mp.max_events; ev++) {
        if (!any(flux > vec3f(0.0))) { return; }
        let h = scene_hit(o, d, 1e30);
        // The medium along the segment: free flights against the majorant.
        var scattered = false;
        if (in_medium && maj > 0.0) {
            let seg = box_clip(o, d, h.t, lo, hi);
            var t = seg.x;
            while (seg.y > seg.x) {
                t -= log(1.0 - rnd()) / maj;
                if (t >= seg.y) { break; }
                let x = o + d * t;
                var rho = 1.0;
                if (mp.dims.w != 0u) { rho = grid_density(density_grid, x, lo, hi); }
                let ss = rho * mp.sigma_s.rgb;
                let sn = max(vec3f(maj) - rho * mp.sigma_t.rgb, vec3f(0.0));
                let ps = (ss.r + ss.g + ss.b) / (3.0 * maj);
                let pn = (sn.r + sn.g + sn.b) / (3.0 * maj);
                let u = rnd();
                if (u < ps) {
                    flux *= ss / (maj * ps);
                    if (scatters >= 1u || diffuse >= 2u) { deposit(x, flux); }
                    scatters++;
                    // Henyey-Greenstein about the direction of travel (isotropic at g = 0).
                    var c = 1.0 - 2.0 * rnd();
                    if (abs(g) > 1e-3) {
                        let q = (1.0 - g * g) / (1.0 - g + 2.0 * g * rnd());
                        c = clamp((1.0 + g * g - q * q) / (2.0 * g), -1.0, 1.0);
                    }
                    d = ms_around(d, c, 2.0 * PI * rnd());
                    o = x;
                    scattered = true;
                    break;
                } else if (u < ps + pn) {
                    flux *= sn / (maj * pn);
                } else {
                    return;
                }
            }
        }
        if (scattered) { continue; }
        if (h.object == INVALID) { return; }
        flux *= walk_absorbed(h.t);
        if (materials[h.object].kind.x == KIND_DIFFUSE) { diffuse++; }
        if (!walk_surface(h, &o, &d, &flux, &in_medium)) { return; }
    }
}
