// Stage: splat_lens. Thin- and thick-lens splat sizes (Wyman & Dachsbacher 2008, section 4.2):
// like photon_splat, but each photon's Gaussian has its own size: the tracer (shared/trace.wgsl,
// `lens_diameter`) stores the photon's beam diameter on the receiver in caustic-map texels in
// Photon._pad (f32 bits; 0 = unknown). sigma = max(LENS_K * diameter, LENS_FLOOR * splat
// sigma), clamped to [0.5, LENS_MAX] texels. Weights are normalised: the whole flux lands.

#import splat
#import splat_photons

// Gaussian sigma per texel of beam diameter: photons a beam diameter apart blend smoothly.
const LENS_K: f32 = 0.5;
// Smallest sigma, relative to the fixed splat's sigma (focal regions).
const LENS_FLOOR: f32 = 0.75;
const LENS_MAX: f32 = 6.0;

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) nwg: vec3u, @builtin(local_invocation_index) lid: u32) {
    let index = splat_index(wg, nwg, lid);
    if (index == INVALID) { return; }
    let ph = photons[index];
    let base = light.params.z;
    var sigma = base;
    let d = bitcast<f32>(ph._pad);
    if (d > 0.0 && d < 1e30) { sigma = clamp(max(LENS_K * d, LENS_FLOOR * base), 0.5, LENS_MAX); }
    gauss_splat(ph.face, ph.pos, ph.flux.rgb, sigma);
}
