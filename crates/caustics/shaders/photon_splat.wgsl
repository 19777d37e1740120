// Stage: photon_splat. Splats each photon's flux into the caustic map with a Gaussian kernel of
// sigma texels (WebGPU has no point sizes: compute atomics). The kernel's weights are normalised
// over the texels inside the map, so a photon's whole flux lands in the map.
// Accumulation is in 64-bit fixed point (two u32 words, carry propagated), so the sum does not
// depend on the order photons arrive in: bit-identical maps run to run.
// Layout of `accum`: per face, per texel, per channel (r, g, b): (lo, hi).
// The photon count is read from a storage buffer whose first three words are the (indirect)
// dispatch arguments: the adaptive techniques write count and arguments on the GPU.

#import splat
#import splat_photons

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) nwg: vec3u, @builtin(local_invocation_index) lid: u32) {
    let index = splat_index(wg, nwg, lid);
    if (index == INVALID) { return; }
    let ph = photons[index];
    gauss_splat(ph.face, ph.pos, ph.flux.rgb, light.params.z);
}
