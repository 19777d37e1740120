// Stage: bvh_refit. One level of a deformed mesh's bottom-level BVH refit in place (src/accel.rs,
// `SceneBvh::refit`; src/geometry.rs, `Geometry::record_refits`): the topology is kept, each node
// of the level gets the box of what it holds. A leaf: the minimum and maximum of its triangles'
// vertices (the triangles were rewritten in leaf order before the frame); an inner node: the
// union of its children, `a` and `a + 1`, of a lower level (dispatched before, in the same
// compute pass). Minima and maxima are exact: the boxes are the CPU refit's, bit for bit.

// The level's nodes (global indices into `nodes`), bound as this level's part of the mesh's list.
@group(0) @binding(0) var<storage, read> level: array<u32>;
@group(0) @binding(1) var<storage, read> tris: array<BvhTri>;
@group(0) @binding(2) var<storage, read_write> nodes: array<BvhNode>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let k = gid.x + gid.y * groups.x * 64u;
    if (k >= arrayLength(&level)) { return; }
    let i = level[k];
    if (i >= arrayLength(&nodes)) { return; }
    let n = nodes[i];
    // f32::MAX and f32::MIN, as the CPU starts from.
    var lo = vec3f(bitcast<f32>(0x7f7fffffu));
    var hi = vec3f(bitcast<f32>(0xff7fffffu));
    if (n.count == 0u) {
        if (n.a + 1u >= arrayLength(&nodes)) { return; }
        let a = nodes[n.a];
        let b = nodes[n.a + 1u];
        lo = min(a.lo, b.lo);
        hi = max(a.hi, b.hi);
    } else {
        let end = min(n.a + n.count, arrayLength(&tris));
        for (var t = n.a; t < end; t++) {
            let tri = tris[t];
            lo = min(lo, tri.p0.xyz);
            hi = max(hi, tri.p0.xyz);
            lo = min(lo, tri.p1.xyz);
            hi = max(hi, tri.p1.xyz);
            lo = min(lo, tri.p2.xyz);
            hi = max(hi, tri.p2.xyz);
        }
    }
    nodes[i].lo = lo;
    nodes[i].hi = hi;
}
