// Stage: photon_trace. Basic caustic maps (Wyman & Nichols 2009, section 2; Shah et al. 2007):
// one photon per cell of a dense N x N grid over one face of the light view. Each photon reads
// the caster front/back geometry buffers (light space) at its cell, refracts at the front and
// back surface (image-space two-interface approximation, refined by re-projecting the exit point
// into the back-surface buffer), or reflects once off a mirror or conductor, then finds the
// receiver it hits by an iterative search in the receiver position map (light space).
// Flux: I(w) * dw of the photon's cell (spot, point) or E * cell area (directional), times the
// Fresnel transmittance at each interface (reflectance for mirrors and conductors).
// Total internal reflection at the back surface ends the photon; its flux is counted as lost.
// The grid spans light.crop in NDC: a directional light's view covers the whole scene, so the
// basic technique spreads its grid over the casters' box only (passes::photon_crop); the other
// techniques and lights use the whole face.
// Output: one Photon per grid cell of the batch (face = INVALID when it carries no caustic).
// A batch is a range of the row-major grid (tile = 0), or a tile x tile square whose top-left
// cell has row-major index batch_offset (hierarchical caustic maps), stored row-major.

#import shapes
#import raytrace
#import medium
#import trace
#import scene

struct TraceParams {
    face: u32,
    batch_offset: u32,
    batch_count: u32,
    tile: u32,
}


@group(0) @binding(0) var<uniform> light: LightGpu;
@group(0) @binding(1) var<uniform> tp: TraceParams;
@group(0) @binding(2) var front_pos: texture_2d_array<f32>;
@group(0) @binding(3) var front_nrm: texture_2d_array<f32>;
@group(0) @binding(4) var back_pos: texture_2d_array<f32>;
@group(0) @binding(5) var back_nrm: texture_2d_array<f32>;
@group(0) @binding(6) var recv_pos: texture_2d_array<f32>;
@group(0) @binding(7) var recv_nrm: texture_2d_array<f32>;
@group(0) @binding(8) var<storage, read_write> photons: array<Photon>;
// Fixed-point flux totals (lo, hi word pairs, r + g + b): 0 emitted onto casters, 2 landed in
// the map, 4 lost for want of a back surface, 6 lost to total internal reflection, 8 lost for
// want of a receiver, 10 landed outside the map.
@group(0) @binding(9) var<storage, read_write> stats: array<atomic<u32>>;
// The light's second caster layer (front, back), or the first where the scene needs none.
@group(0) @binding(10) var front_pos2: texture_2d_array<f32>;
@group(0) @binding(11) var front_nrm2: texture_2d_array<f32>;
@group(0) @binding(12) var back_pos2: texture_2d_array<f32>;
@group(0) @binding(13) var back_nrm2: texture_2d_array<f32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    if (gid.x >= tp.batch_count) { return; }
    let index = tp.batch_offset + gid.x;
    let n_grid = light.info.z;
    var i = index % n_grid;
    var j = index / n_grid;
    if (tp.tile > 0u) {
        i = tp.batch_offset % n_grid + gid.x % tp.tile;
        j = tp.batch_offset / n_grid + gid.x / tp.tile;
    }
    // The grid spans light.crop (the whole face, or a directional light's casters under the
    // basic technique); with the whole face this is exactly -1 + (i + 1/2) 2/N, 1 - (j + 1/2) 2/N.
    let lo = light.crop.xy;
    let hi = light.crop.zw;
    let cell = (hi - lo) / f32(n_grid);
    let ndc = vec2f(lo.x + (f32(i) + 0.5) * cell.x, hi.y - (f32(j) + 0.5) * cell.y);
    // The high bit of `face` selects the reflected branch at the first dielectric surface.
    trace_reflect = (tp.face >> 31u) == 1u;
    // Bit 30: the branch reflected once inside a dielectric (exact tracer).
    trace_internal_branch = ((tp.face >> 30u) & 1u) == 1u;
    // Bit 29: the residual pass (exact tracer).
    trace_residual = ((tp.face >> 29u) & 1u) == 1u;
    photons[gid.x] = trace_photon(tp.face & 0x1fffffffu, ndc, cell);
}
