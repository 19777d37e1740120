// Stage: hcm_traverse. One level of the top-down traversal of hierarchical caustic maps
// (Wyman 2008, as the baseline of Wyman & Nichols 2009): a dense tile of photons was traced
// (photon_trace) and a mip chain of valid-photon counts built over it (coverage_mip, source 1).
// Each thread takes one cell (of the grid lp.grid over the tile) that holds valid photons and
// keeps its children that hold some: appended to the cell list, or, at the finest level
// (FLAG_LAST), the photon itself is copied to the compact photon buffer that is splatted.

#import hierarchy
#import coverage

@group(0) @binding(0) var<uniform> lp: LevelParams;
@group(0) @binding(1) var<storage, read> cover: array<u32>;
@group(0) @binding(2) var<storage, read_write> cells: array<u32>;
@group(0) @binding(3) var<storage, read> tile: array<Photon>;
@group(0) @binding(4) var<storage, read_write> photons: array<Photon>;
@group(0) @binding(5) var<storage, read_write> ctrl: array<atomic<u32>>;

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) nwg: vec3u, @builtin(local_invocation_index) lid: u32) {
    let t = thread_index(wg, nwg, lid);
    if (t >= atomicLoad(&ctrl[C_READ_COUNT])) { return; }
    let parent = unpack_cell(cells[atomicLoad(&ctrl[C_READ_OFF]) + t]);
    let s = 2u * lp.grid;
    for (var q = 0u; q < 4u; q++) {
        let c = 2u * parent + vec2u(q & 1u, q >> 1u);
        if (covered_count(c.x, c.y, s) == 0u) { continue; }
        if ((lp.flags & FLAG_LAST) != 0u) {
            let k = atomicAdd(&ctrl[C_PHOTONS], 1u);
            atomicAdd(&ctrl[C_EMITTED + lp.level + 1u], 1u);
            if (k >= lp.photon_capacity) { atomicOr(&ctrl[C_OVERFLOW], 2u); continue; }
            photons[k] = tile[c.y * lp.finest + c.x];
        } else {
            let k = atomicAdd(&ctrl[C_WRITE_COUNT], 1u);
            if (k >= lp.cell_capacity) { atomicOr(&ctrl[C_OVERFLOW], 1u); continue; }
            cells[atomicLoad(&ctrl[C_WRITE_OFF]) + k] = pack_cell(c.x, c.y);
        }
    }
}
