// Stage: raster_peel. A second layer of geometry buffers (multi-layer deferred refraction,
// Wyman & Nichols 2009 section 3.1): like raster, but a fragment is kept only if it lies behind
// the first layer's surface at its pixel and belongs to another object (one depth peel per
// object); two-sided for the front buffer and back faces only for the back buffer. The camera's
// second specular layer (`eye_specular_front2/back2`: the specular meshes; analytic shapes are
// intersected exactly in `composite`) and the light's second caster layer per light-view face
// (`light_caster_front2/back2`: all casters, against that face's `light_caster_front`).

#import raster_common

@group(0) @binding(1) var first_pos: texture_2d<f32>;
@group(0) @binding(2) var first_depth: texture_depth_2d;

@fragment
fn fs_main(v: VsOut) -> FsOut {
    let px = vec2i(floor(v.clip.xy));
    let first = textureLoad(first_pos, px, 0);
    if (first.w >= 0.0 && (u32(first.w) == v.object || v.clip.z <= textureLoad(first_depth, px, 0))) {
        discard;
    }
    return gbuffer_out(v);
}
