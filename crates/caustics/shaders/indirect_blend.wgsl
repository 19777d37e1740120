// Stage: indirect_blend. A progressive cache (`indirect.history` > 1; src/indirect/): the new
// batch's cells (`fresh`, resolved from this frame's photons into the same slots, since the
// keys persist) blended into the cache, cells = cells + alpha (fresh - cells), per slot and
// word. Flux, weight, weighted position and weighted normal are sums, so their blend keeps the
// means consistent; a slot the new batch did not reach fades.

#import indirect

@group(0) @binding(0) var<uniform> ip: IndirectParams;
@group(0) @binding(1) var<storage, read> keys: array<u32>;
@group(0) @binding(2) var<storage, read> fresh: array<vec4f>;
@group(0) @binding(3) var<storage, read_write> cells: array<vec4f>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u, @builtin(num_workgroups) nwg: vec3u) {
    let s = gid.y * nwg.x * 64u + gid.x;
    if (s >= ip.capacity || keys[s] == 0u) { return; }
    for (var k = 0u; k < 3u; k++) {
        let i = s * 3u + k;
        cells[i] = cells[i] + ip.alpha * (fresh[i] - cells[i]);
    }
}
