// Stage: beam_surface. Surface caustics from beams, one thread per pixel over the ordered beam
// list (beam_order), in chunks as beam_gather, so the sum runs in a fixed order (the same bits
// from run to run) and no invocation loops long enough to meet lavapipe's loop limit. Each
// beam's light on the pixel's surface point is shared/beam_receive.wgsl's `surface_beam` (the
// method is described there); beam_surface_raster adds the same per pixel and beam from the
// beams' hulls.

#import beams
#import medium
#import beam_medium
#import beam_receive
#import scene

// Constants from storage, not uniforms: this stage is bound once per chunk, and lavapipe
// compiles a variant per bind of a shader whose loops read uniforms (ChunkRecords, beams.rs).
@group(0) @binding(0) var<storage, read> bp: BeamParams;
@group(0) @binding(1) var recv_pos: texture_2d<f32>;
@group(0) @binding(2) var recv_nrm: texture_2d<f32>;
@group(0) @binding(3) var<storage, read> beams: array<BeamGpu>;
@group(0) @binding(4) var<storage, read> order: array<u32>;
@group(0) @binding(5) var<storage, read> stats: array<u32>;
@group(0) @binding(6) var<storage, read_write> radiance: array<vec4f>;
@group(0) @binding(7) var<storage, read_write> caustic: array<vec4f>;
// The chunk of the ordered list this dispatch tests: beams offset .. offset + base_count.
@group(0) @binding(8) var<storage, read> chunk: BeamLevel;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    if (gid.x >= bp.width || gid.y >= bp.height) { return; }
    let count = min(stats[1u + BS_ORDERED], bp.capacity);
    if (chunk.offset >= count) { return; }
    var sp = surface_pixel(gid.xy);
    if (!sp.lit) { return; }
    var acc = vec3f(0.0);
    var splat = vec3f(0.0);
    let end = min(count, chunk.offset + chunk.base_count);
    for (var k = chunk.offset; k < end; k++) {
        surface_beam(order[k], gid.xy, &sp, &acc, &splat);
    }
    if (all(acc == vec3f(0.0)) && all(splat == vec3f(0.0))) { return; }
    let l = surface_radiance(&sp, acc, splat);
    let idx = gid.y * bp.width + gid.x;
    radiance[idx] += vec4f(l, 0.0);
    caustic[idx] += vec4f(l, 0.0);
}
