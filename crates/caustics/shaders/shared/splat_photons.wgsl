// Shared by the stages that splat a buffer of photons (photon_splat, splat_lens, splat_multires,
// splat_quads; `#import splat_photons`, after `#import splat`): their first four bindings and the
// photon each invocation splats.

@group(0) @binding(0) var<uniform> light: LightGpu;
@group(0) @binding(1) var<storage, read> sp: SplatParams;
@group(0) @binding(2) var<storage, read> photons: array<Photon>;
@group(0) @binding(3) var<storage, read_write> accum: array<atomic<u32>>;

// The photon that invocation lid of workgroup wg splats (a grid of nwg workgroups of 64 over the
// sp.count photons): its index, or INVALID past the count or for a photon that landed nowhere.
fn splat_index(wg: vec3u, nwg: vec3u, lid: u32) -> u32 {
    let index = (wg.y * nwg.x + wg.x) * 64u + lid;
    if (index >= sp.count || photons[index].face == INVALID) { return INVALID; }
    return index;
}
