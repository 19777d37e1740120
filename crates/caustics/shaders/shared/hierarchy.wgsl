// Shared by the GPU-driven photon hierarchy stages (adaptive_plan, adaptive_init,
// adaptive_setup, adaptive_refine, hcm_traverse): the per-step parameters, the layout of the
// control buffer (counters, offsets, indirect arguments, statistics) and the coverage lookup.
// Stages that import it declare `lp` (LevelParams); those that look up coverage declare `cover`.

struct LevelParams {
    face: u32,
    level: u32,
    grid: u32,
    finest: u32,
    gbuffer: u32,
    flags: u32,
    cell_capacity: u32,
    photon_capacity: u32,
    tolerance: f32,
    batch_grid: u32,
    batch_leaves: u32,
    max_batches: u32,
    tile_x: u32,
    tile_y: u32,
    grid_n: u32,
    // adaptive_refine with FLAG_CHECK and FLAG_QUADS: the linearity stopping rule's tolerance
    // in caustic-map texels (0: off, the paper's rule alone).
    linearity: f32,
}

const FLAG_LAST: u32 = 1u;
const FLAG_CHECK: u32 = 2u;
const FLAG_BEGIN: u32 = 4u;
const FLAG_END: u32 = 8u;
const FLAG_NO_PLAN: u32 = 16u;
// adaptive_refine: caustic triangles (--splat triangles): trace the corners of every emitted
// cell and store its quad for splat_quads.
const FLAG_QUADS: u32 = 32u;
// adaptive_refine: trace the reflected branch at the first dielectric surface (trace_reflect).
const FLAG_REFLECT: u32 = 64u;
// adaptive_refine, maximal caustic map error: skip the check where it cannot pass
// (RenderSettings::error_skip_hopeless).
const FLAG_SKIP: u32 = 128u;
// adaptive_refine: trace the branch reflected once inside a dielectric (trace_internal_branch).
const FLAG_INTERNAL: u32 = 256u;
// adaptive_refine: the residual pass (trace_residual).
const FLAG_RESIDUAL: u32 = 512u;

// Control buffer words (u32). The indirect arguments live in a separate buffer (written by
// adaptive_setup only; a buffer cannot be indirect and writable storage in one dispatch): the
// refine step's dispatch arguments at word A_REFINE, the splat's SplatParams (groups x, y, z,
// count) at word A_SPLAT (byte 256, a valid binding offset).
const A_REFINE: u32 = 0u;
const A_SPLAT: u32 = 64u;
const C_READ_OFF: u32 = 4u;
const C_READ_COUNT: u32 = 5u;
const C_WRITE_OFF: u32 = 6u;
const C_WRITE_COUNT: u32 = 7u;
const C_PHOTONS: u32 = 8u;
// Bits: 1 cell list full, 2 photon buffer full, 4 plan count saturated, 8 more batches needed
// than were recorded.
const C_OVERFLOW: u32 = 9u;
const C_BATCH: u32 = 10u;
const C_BATCHES: u32 = 11u;
const C_LEAVES: u32 = 12u;
const C_PEAK_CELLS: u32 = 13u;
const C_PEAK_PHOTONS: u32 = 14u;
// Photons splatted over all batches (lo, hi).
const C_SPLATTED: u32 = 16u;
// Corner photons traced for caustic triangles (lo, hi).
const C_CORNERS: u32 = 18u;
// Per level k (32 each): cells kept, photons traced, photons emitted.
const C_CELLS: u32 = 32u;
const C_TRACED: u32 = 64u;
const C_EMITTED: u32 = 96u;

// log2 of a power of two.
fn log2u(x: u32) -> u32 {
    return firstTrailingBit(x);
}

// Word offset of level l of a mip chain of counts whose level 0 is g x g.
fn mip_offset(l: u32, g: u32) -> u32 {
    var off = 0u;
    var s = g;
    for (var m = 0u; m < l; m++) {
        off += s * s;
        s = s >> 1u;
    }
    return off;
}

// Caustic triangles: a photon whose quad is dropped (splat_quads) is a Gaussian as wide as its
// cell's image where points on its path around it tell that image: sigma = half the square root
// of |det J|, J the least-squares Jacobian of the landing point over the cell, from the sums
// a = sum r d^T (row-major) and m = sum d d^T (xx, xy, yy) over those points (r: a point's
// landing point minus the photon's, d: its offset in cells), J = a m^-1; at least `base` (the
// fixed sigma), at most 6 texels. Returned as f32 bits with bit 0 cleared (Photon._pad, whose
// bit 0 marks a quad), or 0 (the fixed sigma) when the points do not span two directions.
fn fallback_sigma_bits(a: vec4f, m: vec3f, base: f32) -> u32 {
    let det_m = m.x * m.z - m.y * m.y;
    if (det_m <= 1e-3) { return 0u; }
    let area = abs(a.x * a.w - a.y * a.z) / det_m;
    return bitcast<u32>(clamp(0.5 * sqrt(area), base, 6.0)) & ~1u;
}

fn pack_cell(i: u32, j: u32) -> u32 {
    return i | (j << 16u);
}

fn unpack_cell(c: u32) -> vec2u {
    return vec2u(c & 0xffffu, c >> 16u);
}

// Indirect dispatch arguments for `count` threads in workgroups of 64 (2D past 65535 groups).
fn groups_for(count: u32) -> vec3u {
    let g = (count + 63u) / 64u;
    if (g <= 65535u) { return vec3u(g, 1u, 1u); }
    return vec3u(65535u, (g + 65534u) / 65535u, 1u);
}

// Linear thread index of a (possibly 2D) dispatch of 64-wide workgroups.
fn thread_index(wg: vec3u, nwg: vec3u, lid: u32) -> u32 {
    return (wg.y * nwg.x + wg.x) * 64u + lid;
}
