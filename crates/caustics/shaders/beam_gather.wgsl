// Stage: beam_gather. The volume caustic gathered per pixel: one thread per pixel loops over
// the ordered beam list (beam_order), a chunk of it per dispatch, and adds each beam's single
// scattering toward the camera (shared/beam_scatter.wgsl, `beam_pixel`). Every beam is met once
// per pixel ray, so a camera inside a beam counts it once too, and the sum is in the list's
// order (the same bits every run). The cost is a test per pixel and beam (the bounding sphere
// against the pixel's cone); beam_hull and beam_raster (the paper's hulls) spend work only on
// the pixels a beam can reach.
// With `gather_slot` k >= 0 (one dispatch per chunk and slot, so that no two invocations add to
// one pixel at once, with the chunk's dispatch size; invocation i takes the i-th pixel of
// `composite`'s list of specular pixels) each
// invocation gathers along its pixel's kept segment k beyond the specular surface
// (`EyeSegment`, shared/medium.wgsl), weighted by the path's weight, into the full and the
// caustic-only image (light -> specular -> medium -> specular -> camera is caustic light: the CPU
// reference renders it with photon beams, caustics_reference::reference::photon_beams). The
// hulls draw only the camera rays; these segments are gathered either way.

#import beams
#import medium
#import beam_medium
#import beam_scatter
#import scene

// Constants from storage, not uniforms: this stage is bound once per chunk, and lavapipe
// compiles a variant per bind of a shader whose loops read uniforms (ChunkRecords, beams.rs).
@group(0) @binding(0) var<storage, read> bp: BeamParams;
@group(0) @binding(1) var recv_pos: texture_2d<f32>;
@group(0) @binding(2) var spec_pos: texture_2d<f32>;
@group(0) @binding(3) var<storage, read> beams: array<BeamGpu>;
@group(0) @binding(4) var<storage, read> order: array<u32>;
@group(0) @binding(5) var<storage, read> stats: array<u32>;
@group(0) @binding(6) var<storage, read_write> out_full: array<vec4f>;
@group(0) @binding(7) var<storage, read_write> out_caustic: array<vec4f>;
// The chunk of the ordered list this dispatch gathers: beams offset .. offset + base_count.
// One dispatch per chunk, in order: lavapipe was measured to stop a pixel's loop after about
// 65536 loop iterations in all (some 950 beams), so a pixel never loops over all beams at once.
@group(0) @binding(8) var<storage, read> chunk: BeamLevel;
// The footprint integral: x = the width (pixels) under which a beam's section is integrated
// over the pixel's footprint instead of sampled by its rays (0: never), y = lines per side of
// the section (1 to 4).
@group(0) @binding(9) var<storage, read> foot: vec4f;
// The eye's receiver and specular normals (the first surface's tangent plane in each pixel).
@group(0) @binding(10) var recv_nrm: texture_2d<f32>;
@group(0) @binding(11) var spec_nrm: texture_2d<f32>;
// `composite`'s list of specular pixels, its length (count[3]) and the segments it kept.
@group(0) @binding(12) var<storage, read> spec_list: array<u32>;
@group(0) @binding(13) var<storage, read> spec_count: array<u32, 4>;
@group(0) @binding(14) var<storage, read> segments: array<EyeSegment>;
override gather_slot: i32 = -1;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3u, @builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) nwg: vec3u, @builtin(local_invocation_index) li: u32) {
    if (gather_slot >= 0) {
        // (the chunk's dispatch over the image's pixels, as the camera rays': enough
        // invocations for every listed pixel; the rest return)
        along_segment((wg.y * nwg.x + wg.x) * 64u + li);
        return;
    }
    if (gid.x >= bp.width || gid.y >= bp.height) { return; }
    let idx = gid.y * bp.width + gid.x;
    let view = pixel_view(gid.xy);
    let count = min(stats[1u + BS_ORDERED], bp.capacity);
    if (chunk.offset >= count) { return; }
    var acc = vec3f(0.0);
    let end = min(count, chunk.offset + chunk.base_count);
    for (var k = chunk.offset; k < end; k++) {
        beam_pixel(order[k], gid.xy, view, vec2f(0.0, 3.0e38), &acc);
    }
    if (all(acc == vec3f(0.0))) { return; }
    out_full[idx] += vec4f(acc, 0.0);
    out_caustic[idx] += vec4f(acc, 0.0);
}

// Listed specular pixel i's kept segment `gather_slot`, against this chunk's beams.
fn along_segment(i: u32) {
    if (i >= spec_count[3]) { return; }
    let e = segments[i * EYE_SEGMENTS + u32(gather_slot)];
    if (!(e.o.w > 0.0)) { return; }
    let o = e.o.xyz;
    let d = segment_dir(e);
    let seg = box_clip(o, d, e.o.w, bp.lo.xyz, bp.hi.xyz);
    if (seg.y <= seg.x) { return; }
    let count = min(stats[1u + BS_ORDERED], bp.capacity);
    if (chunk.offset >= count) { return; }
    var acc = vec3f(0.0);
    let end = min(count, chunk.offset + chunk.base_count);
    for (var k = chunk.offset; k < end; k++) {
        beam_segment(order[k], o, d, seg, &acc);
    }
    if (all(acc == vec3f(0.0))) { return; }
    let idx = spec_list[i];
    out_full[idx] += vec4f(e.w * acc, 0.0);
    out_caustic[idx] += vec4f(e.w * acc, 0.0);
}
