// Coverage lookup (imported after `hierarchy`): the number of covered level-0 texels (caster
// front buffer texels with a caster, or valid photons of a hierarchical tile) under cell (i, j)
// of an s x s grid over the face. Exact for a photon grid: a photon of an N x N grid (N >= G)
// reads level-0 texel (i, j) * G / N, so a cell covers exactly the texels its photons read.
fn covered_count(i: u32, j: u32, s: u32) -> u32 {
    let g = lp.gbuffer;
    if (s >= g) {
        let sh = log2u(s / g);
        return cover[(j >> sh) * g + (i >> sh)];
    }
    let l = log2u(g / s);
    return cover[mip_offset(l, g) + j * s + i];
}
