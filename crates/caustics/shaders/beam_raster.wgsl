// Stage: beam_raster. The volume caustic drawn as the beams' hulls (Liktor & Dachsbacher 2011,
// section 5): one instance per entry of the ordered list (an indirect draw, its instance count
// written by beam_order), a triangle fan over the hull beam_hull made (shared/beam_fan.wgsl). Each fragment is one
// pixel and one beam: the beam's single scattering toward the camera in that pixel
// (shared/beam_scatter.wgsl, `beam_pixel`, exactly what beam_gather adds for the pair), added
// by the blend into a float image (beam_resolve adds it to the frame). The fan covers each
// pixel once, so each beam counts once per pixel, and blending follows the draw's primitive
// order (instances in list order), so the image is the same bits every run. The intersection is
// exact along every ray, clipped at the pixel's first surface: no soft clipping is needed.

#import beams
#import medium
#import beam_medium
#import beam_scatter
#import beam_fan
#import scene

@group(0) @binding(0) var<storage, read> bp: BeamParams;
@group(0) @binding(1) var recv_pos: texture_2d<f32>;
@group(0) @binding(2) var spec_pos: texture_2d<f32>;
@group(0) @binding(3) var<storage, read> beams: array<BeamGpu>;
@group(0) @binding(4) var<storage, read> hulls: array<BeamHull>;
// The footprint integral's width threshold and lines (as beam_gather's).
@group(0) @binding(5) var<storage, read> foot: vec4f;
// The beam statistics (shared/beams.wgsl): the fragments shaded are counted for `caustics
// bench` (one atomic per fragment; the hulls' fill is what they cost), and those that added
// light, in one-shot renders (BEAM_FLAG_FRAGMENTS).
@group(0) @binding(6) var<storage, read_write> stats: array<atomic<u32>>;
// The eye's receiver and specular normals (the first surface's tangent plane in each pixel).
@group(0) @binding(7) var recv_nrm: texture_2d<f32>;
@group(0) @binding(8) var spec_nrm: texture_2d<f32>;

@fragment
fn fs_main(in: HullVertex) -> @location(0) vec4f {
    let px = vec2u(in.pos.xy);
    var acc = vec3f(0.0);
    beam_pixel(in.beam, px, pixel_view(px), in.heights, &acc);
    if ((bp.flags & BEAM_FLAG_FRAGMENTS) != 0u) {
        atomicAdd(&stats[1u + BS_FRAGMENTS], 1u);
        if (any(acc != vec3f(0.0))) { atomicAdd(&stats[1u + BS_LIT], 1u); }
    }
    return vec4f(acc, 0.0);
}
