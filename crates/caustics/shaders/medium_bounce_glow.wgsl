// Stage: medium_bounce_glow. The light one light's lit surfaces reflect into the medium and the
// medium scatters (the fog's glow over a lit floor), gathered into point emitters ("glow
// VPLs") for `medium_bounce_surfaces`, which lights the diffuse surfaces the camera sees with
// it (light -> floor -> fog -> floor -> camera: the glow lights the floor back, most visibly in
// shadows).
//
// Each of the light's surface VPLs (`medium_bounce_lights`: flux F, a Lambertian emitter) sends
// F / GLOW_DIRS along each of GLOW_DIRS fixed directions, cosine-distributed over the
// hemisphere of its normal (stratified: GLOW_RINGS rings of equal probability, GLOW_DIRS /
// GLOW_RINGS azimuths each). Each direction's ray is cut into GLOW_STEPS equal steps from the
// VPL to where it leaves the medium's box (at most GLOW_REACH mean free paths of the medium's
// mean sigma_t: the light beyond is under e^-GLOW_REACH); a step's midpoint x scatters
//   flux = sigma_s(x) * (F / GLOW_DIRS) * T(VPL -> x) * ds,
// leaving by the phase function about the direction. Samples are binned into point emitters
// (shared/medium_emit.wgsl: the VPL grid's blocks and 16 slices; half the blocks and 8 slices
// left the lit-floor test's floor 1 % darker).
// Not modelled: visibility along the directions (an object above the floor does not stop its
// glow), light reflected more than once.
// `emit_pass` 0, per VPL and direction: the samples' range of distances; 1: the sums; 2, per
// bin: the emitters.

#import medium
#import medium_bounce
#import medium_emit
#import scene

@group(0) @binding(0) var<uniform> light: LightGpu;
@group(0) @binding(1) var<uniform> ep: EmitParams;
@group(0) @binding(2) var<storage, read> surface: array<Vpl>;
// Per bin EMIT_WORDS words; then the range's two words.
@group(0) @binding(3) var<storage, read_write> sums: array<atomic<u32>>;
@group(0) @binding(4) var<storage, read_write> vpls: array<Vpl>;

override emit_pass: u32 = 0u;

const GLOW_RINGS: u32 = 4u;
const GLOW_DIRS: u32 = 32u;
const GLOW_STEPS: u32 = 8u;
const GLOW_REACH: f32 = 6.0;

// Direction k of the cosine-distributed set about the unit normal n.
fn glow_dir(n: vec3f, k: u32) -> vec3f {
    let per_ring = GLOW_DIRS / GLOW_RINGS;
    let ring = k / per_ring;
    let a = k % per_ring;
    // (the rings' azimuths offset by half a step each: no two rings line up)
    let u1 = (f32(ring) + 0.5) / f32(GLOW_RINGS);
    let phi = 2.0 * PI * (f32(a) + 0.5 * f32(ring & 1u) + 0.25) / f32(per_ring);
    let r = sqrt(u1);
    let local = vec3f(r * cos(phi), r * sin(phi), sqrt(max(1.0 - u1, 0.0)));
    // An orthonormal frame about n (Duff et al. 2017).
    let s = select(-1.0, 1.0, n.z >= 0.0);
    let aa = -1.0 / (s + n.z);
    let bb = n.x * n.y * aa;
    let t = vec3f(1.0 + s * n.x * n.x * aa, s * bb, -s * n.x);
    let b = vec3f(bb, s + n.y * n.y * aa, -n.y);
    return normalize(local.x * t + local.y * b + local.z * n);
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    if (emit_pass == 2u) {
        emit_resolve(gid.x);
        return;
    }
    let j = gid.x / GLOW_DIRS;
    if (j >= ep.vpl_count) { return; }
    let v = surface[ep.vpl_offset + j];
    let f = v.full.rgb / f32(GLOW_DIRS);
    if (all(f <= vec3f(0.0))) { return; }
    let lo = ep.lo.xyz;
    let hi = ep.hi.xyz;
    let o = v.pos.xyz;
    let d = glow_dir(normalize(v.nrm.xyz), gid.x % GLOW_DIRS);
    let sig_mean = (ep.sigma_t.r + ep.sigma_t.g + ep.sigma_t.b) / 3.0;
    var reach = 1e30;
    if (sig_mean > 0.0) { reach = GLOW_REACH / sig_mean; }
    let seg = box_clip(o, d, reach, lo, hi);
    if (seg.y <= seg.x) { return; }
    let ds = (seg.y - seg.x) / f32(GLOW_STEPS);
    // (the optical depth from the VPL to the current step's start, density units)
    var tau = 0.0;
    if (ep.heterogeneous != 0u && seg.x > 0.0) { tau = grid_optical_depth(density_grid, o, o + d * seg.x, lo, hi, GLOW_STEPS); }
    for (var i = 0u; i < GLOW_STEPS; i++) {
        let t = seg.x + (f32(i) + 0.5) * ds;
        let x = o + d * t;
        var rho = 1.0;
        var tau_here = t - seg.x;
        if (ep.heterogeneous != 0u) {
            rho = grid_density(density_grid, x, lo, hi);
            tau_here = tau + 0.5 * rho * ds;
            tau += rho * ds;
        }
        if (emit_pass == 0u) {
            emit_range(x);
            continue;
        }
        emit_deposit(x, ep.sigma_s.rgb * rho * f * exp(-ep.sigma_t.rgb * tau_here) * ds, d);
    }
}
