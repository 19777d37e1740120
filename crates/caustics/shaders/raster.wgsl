// Stage: raster. Rasterizes scene triangles into geometry buffers, for the light views (receiver
// maps, caster front/back buffers, shadow maps) and for the camera.
// Inputs: vertex buffer (position, normal, object id), a view uniform.
// Outputs: target 0 = (world position, object id), target 1 = (shading normal, 0); depth.

#import raster_common

@fragment
fn fs_main(v: VsOut) -> FsOut {
    return gbuffer_out(v);
}
