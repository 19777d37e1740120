// Stage: beam_surface_raster. The surface caustic from beams drawn as the beams' hulls (Liktor &
// Dachsbacher 2011, section 5.3: the same fragment shader tests the camera's surface point in
// the beam), as beam_raster draws the volume caustic: one instance per listed beam, a fan over
// its hull (shared/beam_fan.wgsl). Each fragment adds what beam_surface adds for that pixel and
// beam (shared/beam_receive.wgsl, `surface_beam`), as radiance, by the blend into a float image
// in list order (beam_resolve adds it to the eye's radiance and caustic accumulators before the
// composite). The hull holds every point the beam can light (beam_hull grows it to the heights
// `beam_irradiance` accepts), grown by the pixel's square, which holds the footprint's points.

#import beams
#import medium
#import beam_medium
#import beam_receive
#import beam_fan
#import scene

@group(0) @binding(0) var<storage, read> bp: BeamParams;
@group(0) @binding(1) var recv_pos: texture_2d<f32>;
@group(0) @binding(2) var recv_nrm: texture_2d<f32>;
@group(0) @binding(3) var<storage, read> beams: array<BeamGpu>;
@group(0) @binding(4) var<storage, read> hulls: array<BeamHull>;
// The beam statistics: the fragments shaded are counted (as beam_raster's).
@group(0) @binding(5) var<storage, read_write> stats: array<atomic<u32>>;

@fragment
fn fs_main(in: HullVertex) -> @location(0) vec4f {
    let px = vec2u(in.pos.xy);
    // (the fragments counted in one-shot renders, as beam_raster's)
    let count = (bp.flags & BEAM_FLAG_FRAGMENTS) != 0u;
    if (count) { atomicAdd(&stats[1u + BS_FRAGMENTS], 1u); }
    var sp = surface_pixel(px);
    if (!sp.lit) { return vec4f(0.0); }
    var acc = vec3f(0.0);
    var splat = vec3f(0.0);
    surface_beam(in.beam, px, &sp, &acc, &splat);
    if (count && (any(acc != vec3f(0.0)) || any(splat != vec3f(0.0)))) { atomicAdd(&stats[1u + BS_LIT], 1u); }
    return vec4f(surface_radiance(&sp, acc, splat), 0.0);
}
