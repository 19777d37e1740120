//! The default build: `obvhs`'s BVH2 converted to our binary or wide node layout, and the wide
//! leaves' triangles packed into 4-lane packets.

use super::{Bvh, EMPTY, LEAF, Layout, Node, NodeW, Nodes, Pair, STACK_SMALL, STACK2, STACKW, Tri4};
use glam::Vec3;

/// Most triangles per leaf of the `obvhs` build (two packets), and the relative cost of a
/// traversal step in its SAH leaf collapse (decides below that). Measured on the 100k dragon:
/// (8, 8) traces faster than (4, 3), obvhs's default, and builds as fast.
const OBVHS_MAX_LEAF: u32 = 8;
const OBVHS_COLLAPSE_COST: f32 = 8.0;

fn obvhs_params() -> obvhs::BvhBuildParams {
    // `medium_build` without spatial pre-splits (a triangle must be in exactly one leaf so
    // that stored order and ids stay one-to-one), with our leaf size.
    obvhs::BvhBuildParams {
        pre_split: false,
        max_prims_per_leaf: OBVHS_MAX_LEAF,
        collapse_traversal_cost: OBVHS_COLLAPSE_COST,
        ..obvhs::BvhBuildParams::medium_build()
    }
}

impl Bvh {
    #[doc(hidden)]
    pub fn build_with(tris: Vec<[Vec3; 3]>, layout: Layout) -> Bvh {
        if tris.is_empty() {
            return Bvh::build_binned_sah(tris);
        }
        let aabbs: Vec<obvhs::aabb::Aabb> = tris
            .iter()
            .map(|t| {
                let lo = t[0].min(t[1]).min(t[2]);
                let hi = t[0].max(t[1]).max(t[2]);
                obvhs::aabb::Aabb::new(lo.into(), hi.into())
            })
            .collect();
        let b2 = obvhs::bvh2::builder::build_bvh2(&aabbs, obvhs_params(), &mut std::time::Duration::default());
        let mut stored = Vec::with_capacity(tris.len());
        let mut ids = Vec::with_capacity(tris.len());
        let mut emit_leaf = |n: &obvhs::bvh2::node::Bvh2Node| {
            let start = stored.len() as u32;
            for k in n.first_index..n.first_index + n.prim_count {
                let id = b2.primitive_indices[k as usize];
                stored.push(tris[id as usize]);
                ids.push(id);
            }
            start
        };
        let mut small_stack = false;
        let mut wide_depth = 0;
        let nodes = match layout {
            Layout::Binary => {
                let mut pairs = Vec::with_capacity(b2.nodes.len() / 2);
                let mut depth = 0;
                let root = to_binary(&b2, 0, 0, &mut depth, &mut pairs, &mut emit_leaf);
                if depth >= STACK2 {
                    return Bvh::build_binned_sah(tris);
                }
                Nodes::Binary { root, pairs }
            }
            Layout::Wide4 => {
                let mut nodes = Vec::with_capacity(b2.nodes.len() / 3 + 1);
                let mut depth = 0;
                to_wide(&b2, 0, 0, &mut depth, &mut nodes, &mut emit_leaf);
                // Each level pushes at most W - 1 entries.
                if 3 * depth >= STACKW {
                    return Bvh::build_binned_sah(tris);
                }
                small_stack = 3 * depth < STACK_SMALL;
                wide_depth = depth;
                Nodes::Wide4(nodes)
            }
            Layout::Wide8 => {
                let mut nodes = Vec::with_capacity(b2.nodes.len() / 7 + 1);
                let mut depth = 0;
                to_wide(&b2, 0, 0, &mut depth, &mut nodes, &mut emit_leaf);
                if 7 * depth >= STACKW {
                    return Bvh::build_binned_sah(tris);
                }
                wide_depth = depth;
                Nodes::Wide8(nodes)
            }
        };
        debug_assert_eq!(stored.len(), tris.len());
        let mut bvh = Bvh { nodes, tris: stored, ids, packets: Vec::new(), small_stack, depth: wide_depth };
        match &mut bvh.nodes {
            Nodes::Binary { .. } => {}
            Nodes::Wide4(nodes) => match packetize(nodes, &bvh.tris, &bvh.ids) {
                Some(p) => bvh.packets = p,
                None => return Bvh::build_binned_sah(tris),
            },
            Nodes::Wide8(nodes) => match packetize(nodes, &bvh.tris, &bvh.ids) {
                Some(p) => bvh.packets = p,
                None => return Bvh::build_binned_sah(tris),
            },
        }
        if !bvh.packets.is_empty() {
            bvh.tris = Vec::new();
            bvh.ids = Vec::new();
        }
        bvh
    }
}

fn node_box(n: &obvhs::bvh2::node::Bvh2Node) -> (Vec3, Vec3) {
    let b = n.aabb();
    (Vec3::from(b.min), Vec3::from(b.max))
}

/// The `obvhs` BVH2 subtree at `i` as a binary node; inner nodes go to `pairs` depth first.
fn to_binary(
    b2: &obvhs::bvh2::Bvh2,
    i: usize,
    depth: usize,
    max_depth: &mut usize,
    pairs: &mut Vec<Pair>,
    emit_leaf: &mut impl FnMut(&obvhs::bvh2::node::Bvh2Node) -> u32,
) -> Node {
    let n = &b2.nodes[i];
    *max_depth = (*max_depth).max(depth);
    let (lo, hi) = node_box(n);
    if n.is_leaf() {
        return Node { lo, hi, start: emit_leaf(n), count: n.prim_count };
    }
    let me = pairs.len();
    let placeholder = Node { lo, hi, start: 0, count: 0 };
    pairs.push(Pair([placeholder; 2]));
    let l = to_binary(b2, n.first_index as usize, depth + 1, max_depth, pairs, emit_leaf);
    let r = to_binary(b2, n.first_index as usize + 1, depth + 1, max_depth, pairs, emit_leaf);
    pairs[me] = Pair([l, r]);
    Node { lo, hi, start: me as u32, count: 0 }
}

/// The `obvhs` BVH2 subtree at `i` as 4-wide nodes, depth first; returns the node index. Each
/// wide node takes the BVH2 node's children and opens the inner child of largest area until it
/// has four (Wald et al. 2008's collapse).
fn to_wide<const W: usize>(
    b2: &obvhs::bvh2::Bvh2,
    i: usize,
    depth: usize,
    max_depth: &mut usize,
    nodes: &mut Vec<NodeW<W>>,
    emit_leaf: &mut impl FnMut(&obvhs::bvh2::node::Bvh2Node) -> u32,
) -> u32 {
    let n = &b2.nodes[i];
    *max_depth = (*max_depth).max(depth);
    let mut kids: Vec<usize> =
        if n.is_leaf() { vec![i] } else { vec![n.first_index as usize, n.first_index as usize + 1] };
    while kids.len() < W {
        let open = kids
            .iter()
            .enumerate()
            .filter(|(_, k)| !b2.nodes[**k].is_leaf())
            .max_by(|a, b| b2.nodes[*a.1].aabb().half_area().total_cmp(&b2.nodes[*b.1].aabb().half_area()))
            .map(|(j, _)| j);
        let Some(j) = open else { break };
        let f = b2.nodes[kids[j]].first_index as usize;
        kids[j] = f;
        kids.insert(j + 1, f + 1);
    }
    let me = nodes.len();
    nodes.push(NodeW {
        // An empty slot's box is the point (∞, ∞, ∞): on every axis both slab distances are
        // ±∞, so either the far distance is -∞ or the near one is +∞, never < tmax.
        b: [[[f32::INFINITY; W]; 3]; 2],
        child: [EMPTY; W],
        count: [0; W],
    });
    for (c, &k) in kids.iter().enumerate() {
        let kn = &b2.nodes[k];
        let (lo, hi) = node_box(kn);
        let (child, count) = if kn.is_leaf() {
            (emit_leaf(kn), kn.prim_count)
        } else {
            (to_wide(b2, k, depth + 1, max_depth, nodes, emit_leaf), 0)
        };
        let nd = &mut nodes[me];
        for a in 0..3 {
            nd.b[0][a][c] = lo[a];
            nd.b[1][a][c] = hi[a];
        }
        nd.child[c] = child;
        nd.count[c] = count;
    }
    me as u32
}

/// Replaces the wide leaves' triangle ranges (into `tris`) by packet references: `LEAF`, the
/// number of packets less one in bits 27..31, the first packet below. `None` when a leaf or
/// the mesh is too large for that.
fn packetize<const W: usize>(nodes: &mut [NodeW<W>], tris: &[[Vec3; 3]], ids: &[u32]) -> Option<Vec<Tri4>> {
    let mut packets = Vec::with_capacity(tris.len() / 3 + 1);
    for nd in nodes.iter_mut() {
        for c in 0..W {
            if nd.child[c] == EMPTY || nd.count[c] == 0 {
                continue;
            }
            let (start, count) = (nd.child[c] as usize, nd.count[c] as usize);
            let np = count.div_ceil(4);
            if np > 16 || packets.len() >= 1 << 27 {
                return None;
            }
            nd.child[c] = LEAF | ((np as u32 - 1) << 27) | packets.len() as u32;
            for chunk in (start..start + count).collect::<Vec<_>>().chunks(4) {
                // Unused lanes repeat the last triangle: a second test of a triangle cannot
                // change the result (its distance is not below the one it set).
                let mut pk = Tri4 { p: [[[0.0; 4]; 3]; 3], id: [ids[chunk[0]]; 4] };
                for l in 0..4 {
                    let i = chunk[l.min(chunk.len() - 1)];
                    for (v, p) in tris[i].iter().enumerate() {
                        for a in 0..3 {
                            pk.p[v][a][l] = p[a];
                        }
                    }
                    pk.id[l] = ids[i];
                }
                packets.push(pk);
            }
        }
    }
    Some(packets)
}
