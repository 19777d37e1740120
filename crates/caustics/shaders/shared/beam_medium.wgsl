// Shared WGSL (`#import beam_medium`, after `#import medium` and `#import beams`): the medium
// along the beams' light paths and the camera rays. A stage importing it declares
// `density_grid` (the scene's density grid, `passes::upload_density`). With a density grid
// (BEAM_FLAG_GRID) a segment's optical depth in density units is the midpoint rule of
// `grid_optical_depth` in BEAM_GRID_STEPS steps and the scattering coefficient at a point is
// the density there times sigma_s; a homogeneous medium keeps the exact in-box length and a
// density of 1, so its images are the same bits as before.

// Steps of the midpoint rule per segment (as RenderSettings::medium_light_steps' default).
const BEAM_GRID_STEPS: u32 = 16u;

fn beam_has_grid() -> bool {
    return (bp.flags & BEAM_FLAG_GRID) != 0u;
}

// Optical depth (density units; the medium's length for a homogeneous one) of segment a -> b.
fn beam_depth(a: vec3f, b: vec3f) -> f32 {
    if (beam_has_grid()) {
        return grid_optical_depth(density_grid, a, b, bp.lo.xyz, bp.hi.xyz, BEAM_GRID_STEPS);
    }
    return box_length(a, b, bp.lo.xyz, bp.hi.xyz);
}

// The density at x (1 for a homogeneous medium).
fn beam_density(x: vec3f) -> f32 {
    if (beam_has_grid()) {
        return grid_density(density_grid, x, bp.lo.xyz, bp.hi.xyz);
    }
    return 1.0;
}
