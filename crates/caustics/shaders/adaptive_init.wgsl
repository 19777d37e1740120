// Stage: adaptive_init. Starts one batch of the photon hierarchy: appends the covered cells of
// the S x S start grid that the plan gave to the current batch (ctrl[C_BATCH]) to the cell list.
// With FLAG_NO_PLAN (hierarchical caustic maps) every covered cell of the grid is appended.

#import hierarchy
#import coverage

@group(0) @binding(0) var<uniform> lp: LevelParams;
@group(0) @binding(1) var<storage, read> cover: array<u32>;
@group(0) @binding(2) var<storage, read> plan: array<u32>;
@group(0) @binding(3) var<storage, read_write> cells: array<u32>;
@group(0) @binding(4) var<storage, read_write> ctrl: array<atomic<u32>>;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    let s = lp.batch_grid;
    if (gid.x >= s || gid.y >= s) { return; }
    if (covered_count(gid.x, gid.y, s) == 0u) { return; }
    if ((lp.flags & FLAG_NO_PLAN) == 0u && plan[gid.y * s + gid.x] != atomicLoad(&ctrl[C_BATCH])) { return; }
    let k = atomicAdd(&ctrl[C_WRITE_COUNT], 1u);
    if (k >= lp.cell_capacity) { atomicOr(&ctrl[C_OVERFLOW], 1u); return; }
    cells[atomicLoad(&ctrl[C_WRITE_OFF]) + k] = pack_cell(gid.x, gid.y);
}
