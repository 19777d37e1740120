// Stage: splat_quads. Caustic triangles from the adaptive photon hierarchy (adaptive-level,
// adaptive-error with --splat triangles): every emitted photon stands for one cell of its grid
// (or a merged cluster: one cell of the coarser grid) and carries that cell's flux. When
// adaptive_refine found the cell's four corner photons valid, on the photon's face, on the
// photon's path (same signature) and no quad edge longer than the discontinuity limit, it set
// Photon._pad bit 0 and stored the corners' landing points in `corners` (two vec4f a photon:
// (top-left, top-right), (bottom-left, bottom-right)); the cell's flux is then spread uniformly
// over the quad the corners span (two triangles split along the top-left/bottom-right diagonal,
// exact clipped area per texel, shared/triangles.wgsl). Folds keep their flux over their
// unsigned area. Otherwise (a silhouette, total internal reflection, another path or face inside
// the cell) the photon is a normalised Gaussian of the fixed splat's sigma, as with fixed
// splats: light is never smeared across a discontinuity; where adaptive_refine dropped a quad on
// one path for the length of an edge (light spreading thin), of the sigma it stored in _pad
// (f32 bits, bit 0 clear), as wide as the cell's image, so that thin light stays smooth. Either way the photon's whole flux
// lands once. The photon count and indirect arguments come from `sp` (written on the GPU).

#import splat
#import splat_photons
#import triangles

@group(0) @binding(4) var<storage, read> corners: array<vec4f>;

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) nwg: vec3u, @builtin(local_invocation_index) lid: u32) {
    let index = splat_index(wg, nwg, lid);
    if (index == INVALID) { return; }
    let ph = photons[index];
    if ((ph._pad & 1u) != 0u) {
        let top = corners[2u * index];
        let bottom = corners[2u * index + 1u];
        let half = 0.5 * ph.flux.rgb;
        triangle(ph.face, top.xy, top.zw, bottom.zw, half);
        triangle(ph.face, top.xy, bottom.zw, bottom.xy, half);
        return;
    }
    var sigma = light.params.z;
    if (ph._pad != 0u) { sigma = bitcast<f32>(ph._pad); }
    gauss_splat(ph.face, ph.pos, ph.flux.rgb, sigma);
}
