//! A bounding volume hierarchy over triangles for the CPU reference.
//!
//! Build: `obvhs` (PLOC with reinsertion and SAH leaf collapsing), converted to our own node
//! layout; traversal is this file's own code, independent of the GPU's. The intersection is
//! watertight (Woop, Benthin and Wald 2013) with conservative box tests, so that no ray slips
//! between two triangles that share an edge. Zero-area triangles are never hit (their
//! determinant is 0).
//!
//! Why `obvhs` for the build: it is maintained, uses our `glam`, builds in a fraction of the
//! time of a top-down binned SAH at equal or better quality (PLOC + reinsertion), and exposes
//! its plain BVH2 (`nodes`, `primitive_indices`) so we can lay it out our own way. The `bvh`
//! crate (svenstaro) builds a top-down SAH BVH over `nalgebra` types (a second algebra
//! library), with a node layout and traversal of its own that we would not use. Neither offers a
//! watertight triangle test, which stays here.
//!
//! Build on one core: `obvhs` without its `parallel` feature is single threaded (the 100k
//! dragon in ~40-60 ms here, see `docs/benchmarks.md`). Should that feature be switched on in
//! the workspace (Cargo unifies features across it), the tree must still not depend on the
//! thread count (it decides which of two hits an ulp apart at a shared edge is kept, hence the
//! reference's bits): the test `tree_does_not_depend_on_the_thread_count` checks that.
//!
//! Layout: a 4-wide BVH collapsed from the BVH2 (Wald et al. 2008), child boxes stored
//! structure-of-arrays; leaves of up to 8 triangles as 4-triangle structure-of-arrays packets.
//! Traversal goes near to far over leaves and inner nodes alike. The 4-wide traversal
//! ([`Bvh::traverse_w4`]) runs a node's four box tests and a packet's four watertight tests as
//! `glam::Vec4` lane operations (SSE2 on x86-64: a vector type of the algebra crate we use
//! anyway, no unsafe code of ours), picks each axis's near plane by the sign of the direction,
//! and prefetches every child it will visit (`safe_arch`'s safe `prefetch_t0`); it performs
//! the scalar test's operations in the same order, so its results are bit for bit those of the
//! scalar code (`traverse4`, which the 8-wide layout still uses). Measured against the BVH2 layout and an
//! 8-wide one (equal to the 4-wide within noise) in `docs/benchmarks.md`, "CPU reference BVH";
//! both stay selectable ([`Bvh::build_with`]) for the benchmark, as does the former
//! hand-written binned-SAH builder ([`Bvh::build_binned_sah`]).
//!
//! Exactness: the closest hit is the one the scalar watertight test finds over the triangles
//! the traversal visits, and the box tests are conservative, so the nearest hit is never
//! missed. Where triangles meet, two hits can lie an ulp apart and which one is kept depends
//! on the order of the tests, so on the tree (as it did with the former BVH): deterministic for
//! a given mesh. (On 1M random rays at the dragon, and in reference renders of glass_bunny and
//! glass_dragon, the results are bit for bit those of the former BVH.)

use glam::{Vec3, Vec4};

/// One node: a box, and either two children (`count == 0`: the pair `start`) or a leaf of
/// `count` triangles from `start`.
#[derive(Clone, Copy, Debug)]
struct Node {
    lo: Vec3,
    start: u32,
    hi: Vec3,
    count: u32,
}

/// Two siblings in one 64-byte cache line: a traversal step reads both boxes at once.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct Pair([Node; 2]);

/// `W` children of a wide node, boxes structure-of-arrays (`b[side][axis][child]`, side 0 the
/// low bound, 1 the high one, so that a ray picks its near plane per axis by index). A child
/// slot is empty (`child == EMPTY`, box at infinity), an inner node (`child` its index) or a
/// leaf (`child` a packet reference with `LEAF` set, see `packetize`; `count` its triangles).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct NodeW<const W: usize> {
    b: [[[f32; W]; 3]; 2],
    child: [u32; W],
    count: [u32; W],
}

const EMPTY: u32 = u32::MAX;
/// Marks a wide child reference as a leaf (see `packetize`).
const LEAF: u32 = 1 << 31;
const _: () = assert!(std::mem::size_of::<NodeW<4>>() == 128 && std::mem::size_of::<NodeW<8>>() == 256);
/// Traversal stack sizes; a deeper `obvhs` tree falls back to the depth-bounded builder.
const STACK2: usize = 128;
const STACKW: usize = 256;
/// The 4-wide traversal's stack for trees whose depth allows it (`Bvh::small_stack`): a
/// safe array is zeroed on every ray, and zeroing 256 entries (2 KiB) was ~5 % of a ray's
/// instructions; 64 suffice up to depth 21 (the 100k dragon's tree has depth 11).
const STACK_SMALL: usize = 64;

enum Nodes {
    /// Binary, depth-first pairs (the former layout).
    Binary { root: Node, pairs: Vec<Pair> },
    /// 4-wide; the root is `nodes[0]`.
    Wide4(Vec<NodeW<4>>),
    /// 8-wide; the root is `nodes[0]`.
    Wide8(Vec<NodeW<8>>),
}

/// Up to four triangles of one wide leaf, structure-of-arrays (`p[vertex][axis][lane]`), so that
/// the edge tests of the four run as vector operations; `id` is the caller's index per lane.
///
/// 160 bytes, aligned to 32 so that a packet always spans exactly three cache lines.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
struct Tri4 {
    p: [[[f32; 4]; 3]; 3],
    id: [u32; 4],
}

/// A triangle BVH. Binary layouts store triangles in leaf order (`ids[i]` is the caller's index
/// of the i-th stored triangle); the wide ones store them as `packets`, each leaf's in a run.
pub struct Bvh {
    nodes: Nodes,
    tris: Vec<[Vec3; 3]>,
    ids: Vec<u32>,
    packets: Vec<Tri4>,
    /// Whether the 4-wide traversal's stack fits in `STACK_SMALL` entries.
    small_stack: bool,
    /// Depth of the wide tree (levels of inner nodes below the root; 0 for the binary ones).
    depth: usize,
}

/// A triangle hit: distance, barycentrics of vertices 1 and 2, caller's triangle index.
#[derive(Clone, Copy, Debug)]
pub struct TriHit {
    pub t: f32,
    pub b1: f32,
    pub b2: f32,
    pub id: u32,
}

/// Which node layout [`Bvh::build_with`] produces from the `obvhs` build (benchmarks only).
#[doc(hidden)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    Binary,
    Wide4,
    Wide8,
}

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
    /// Build over `tris` (world space); `tris[i]` gets id `i`.
    pub fn build(tris: Vec<[Vec3; 3]>) -> Bvh {
        Bvh::build_with(tris, Layout::Wide4)
    }

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

    /// Depth of a wide tree (0 for the binary layouts), for the benchmark.
    #[doc(hidden)]
    pub fn wide_depth(&self) -> usize {
        self.depth
    }

    pub fn node_count(&self) -> usize {
        match &self.nodes {
            Nodes::Binary { pairs, .. } => 1 + 2 * pairs.len(),
            Nodes::Wide4(nodes) => nodes.len(),
            Nodes::Wide8(nodes) => nodes.len(),
        }
    }

    /// Nearest hit with t in (0, tmax).
    pub fn intersect(&self, o: Vec3, d: Vec3, tmax: f32) -> Option<TriHit> {
        match &self.nodes {
            Nodes::Binary { root, pairs } => self.traverse2(root, pairs, o, d, tmax, false),
            Nodes::Wide4(nodes) => self.wide4(nodes, o, d, tmax, false),
            Nodes::Wide8(nodes) => self.wide(nodes, o, d, tmax, false),
        }
    }

    /// Whether anything is hit with t in (0, tmax).
    pub fn occluded(&self, o: Vec3, d: Vec3, tmax: f32) -> bool {
        match &self.nodes {
            Nodes::Binary { root, pairs } => self.traverse2(root, pairs, o, d, tmax, true).is_some(),
            Nodes::Wide4(nodes) => self.wide4(nodes, o, d, tmax, true).is_some(),
            Nodes::Wide8(nodes) => self.wide(nodes, o, d, tmax, true).is_some(),
        }
    }

    #[inline]
    fn leaf(
        &self,
        start: u32,
        count: u32,
        ray: &WatertightRay,
        tmax: &mut f32,
        best: &mut Option<TriHit>,
        any: bool,
    ) -> bool {
        for i in start..start + count {
            if let Some((t, b1, b2)) = ray.hit(&self.tris[i as usize], *tmax) {
                *tmax = t;
                *best = Some(TriHit { t, b1, b2, id: self.ids[i as usize] });
                if any {
                    return true;
                }
            }
        }
        false
    }

    /// The wide traversal, compiled once per axis permutation of the watertight test so that
    /// its component picks are constants.
    fn wide<const W: usize>(&self, nodes: &[NodeW<W>], o: Vec3, d: Vec3, tmax: f32, any: bool) -> Option<TriHit> {
        if self.packets.is_empty() {
            return None;
        }
        let ray = WatertightRay::new(o, d);
        match ray.k {
            [1, 2, 0] => self.traverse4::<W, 1, 2, 0>(nodes, &ray, d, tmax, any),
            [2, 1, 0] => self.traverse4::<W, 2, 1, 0>(nodes, &ray, d, tmax, any),
            [2, 0, 1] => self.traverse4::<W, 2, 0, 1>(nodes, &ray, d, tmax, any),
            [0, 2, 1] => self.traverse4::<W, 0, 2, 1>(nodes, &ray, d, tmax, any),
            [0, 1, 2] => self.traverse4::<W, 0, 1, 2>(nodes, &ray, d, tmax, any),
            _ => self.traverse4::<W, 1, 0, 2>(nodes, &ray, d, tmax, any),
        }
    }

    /// The triangles of the wide leaf `leaf` (a reference made by `packetize`): the vector
    /// prefilter ([`WatertightRay::candidates`]) drops the lanes that certainly miss, the scalar
    /// test decides the others in lane order, so that the result is bit for bit that of the
    /// scalar test over the leaf's triangles in order.
    #[inline(always)]
    fn leaf_k<const KX: usize, const KY: usize, const KZ: usize>(
        &self,
        leaf: u32,
        ray: &WatertightRay,
        tmax: &mut f32,
        best: &mut Option<TriHit>,
        any: bool,
    ) -> bool {
        let start = (leaf & ((1 << 27) - 1)) as usize;
        let np = ((leaf >> 27) & 15) as usize + 1;
        for pk in &self.packets[start..start + np] {
            let mut m = ray.candidates::<KX, KY, KZ>(pk, *tmax);
            while m != 0 {
                let l = m.trailing_zeros() as usize;
                m &= m - 1;
                let v = |i: usize| Vec3::new(pk.p[i][0][l], pk.p[i][1][l], pk.p[i][2][l]);
                if let Some((t, b1, b2)) = ray.hit_k::<KX, KY, KZ>(&[v(0), v(1), v(2)], *tmax) {
                    *tmax = t;
                    *best = Some(TriHit { t, b1, b2, id: pk.id[l] });
                    if any {
                        return true;
                    }
                }
            }
        }
        false
    }

    fn traverse4<const W: usize, const KX: usize, const KY: usize, const KZ: usize>(
        &self,
        nodes: &[NodeW<W>],
        ray: &WatertightRay,
        d: Vec3,
        mut tmax: f32,
        any: bool,
    ) -> Option<TriHit> {
        let inv = (Vec3::ONE / d).to_array();
        let o = ray.o.to_array();
        let mut best: Option<TriHit> = None;
        let mut stack = [(0u32, 0f32); STACKW];
        let mut sp = 0usize;
        let mut cur = 0u32;
        loop {
            if cur & LEAF != 0 {
                if self.leaf_k::<KX, KY, KZ>(cur, ray, &mut tmax, &mut best, any) {
                    return best;
                }
            } else {
                let nd = &nodes[cur as usize];
                let (tn, mut hit) = box_hit4(nd, o, inv, tmax);
                // The children hit, far to near.
                let mut kids = [(0u32, 0f32); W];
                let mut nk = 0;
                while hit != 0 {
                    let c = hit.trailing_zeros() as usize;
                    hit &= hit - 1;
                    let mut j = nk;
                    while j > 0 && kids[j - 1].1 < tn[c] {
                        kids[j] = kids[j - 1];
                        j -= 1;
                    }
                    kids[j] = (nd.child[c], tn[c]);
                    nk += 1;
                }
                // Leaves and inner nodes alike, nearest first: go on with the nearest, the
                // others onto the stack.
                if nk > 0 {
                    stack[sp..sp + nk - 1].copy_from_slice(&kids[..nk - 1]);
                    sp += nk - 1;
                    cur = kids[nk - 1].0;
                    continue;
                }
            }
            loop {
                if sp == 0 {
                    return best;
                }
                sp -= 1;
                let (c, tn) = stack[sp];
                if tn < tmax {
                    cur = c;
                    break;
                }
            }
        }
    }

    /// The 4-wide traversal (the default layout), written with `glam`'s four-lane `Vec4` (SSE2
    /// on x86-64) so that the four box tests of a node and the four triangle tests of a packet
    /// each run as one vector computation. It visits the same nodes in the same order and
    /// computes the same values as [`Bvh::traverse4`] (the generic code the 8-wide layout still
    /// uses), so the results are bit for bit the same; see [`box_hit_w4`] and
    /// [`Bvh::leaf_w4`].
    fn wide4(&self, nodes: &[NodeW<4>], o: Vec3, d: Vec3, tmax: f32, any: bool) -> Option<TriHit> {
        if self.packets.is_empty() {
            return None;
        }
        if self.small_stack {
            self.wide4_stack::<STACK_SMALL>(nodes, o, d, tmax, any)
        } else {
            self.wide4_stack::<STACKW>(nodes, o, d, tmax, any)
        }
    }

    fn wide4_stack<const S: usize>(
        &self,
        nodes: &[NodeW<4>],
        o: Vec3,
        d: Vec3,
        tmax: f32,
        any: bool,
    ) -> Option<TriHit> {
        let ray = WatertightRay::new(o, d);
        match ray.k {
            [1, 2, 0] => self.traverse_w4::<1, 2, 0, S>(nodes, &ray, d, tmax, any),
            [2, 1, 0] => self.traverse_w4::<2, 1, 0, S>(nodes, &ray, d, tmax, any),
            [2, 0, 1] => self.traverse_w4::<2, 0, 1, S>(nodes, &ray, d, tmax, any),
            [0, 2, 1] => self.traverse_w4::<0, 2, 1, S>(nodes, &ray, d, tmax, any),
            [0, 1, 2] => self.traverse_w4::<0, 1, 2, S>(nodes, &ray, d, tmax, any),
            _ => self.traverse_w4::<1, 0, 2, S>(nodes, &ray, d, tmax, any),
        }
    }

    fn traverse_w4<const KX: usize, const KY: usize, const KZ: usize, const S: usize>(
        &self,
        nodes: &[NodeW<4>],
        ray: &WatertightRay,
        d: Vec3,
        mut tmax: f32,
        any: bool,
    ) -> Option<TriHit> {
        let r = Ray4::new(ray, d);
        let mut best: Option<TriHit> = None;
        let mut stack = [(0u32, 0f32); S];
        let mut sp = 0usize;
        let mut cur = 0u32;
        loop {
            if cur & LEAF != 0 {
                if self.leaf_w4::<KX, KY, KZ>(cur, &r, ray, &mut tmax, &mut best, any) {
                    return best;
                }
            } else {
                let nd = &nodes[cur as usize];
                let (tn, hit) = box_hit_w4(nd, &r, tmax);
                if hit != 0 {
                    // Ask for every child hit now: the nearest is read next, the others (on
                    // the stack) later, by when their lines have arrived.
                    let mut m = hit;
                    while m != 0 {
                        let c = m.trailing_zeros() as usize;
                        m &= m - 1;
                        self.prefetch_w4(nodes, nd.child[c]);
                    }
                    let tn = tn.to_array();
                    let c0 = hit.trailing_zeros() as usize;
                    let rest = hit & (hit - 1);
                    if rest == 0 {
                        cur = nd.child[c0];
                        continue;
                    }
                    let c1 = rest.trailing_zeros() as usize;
                    if rest & (rest - 1) == 0 {
                        // Two children: the nearer first; on a tie the later one (as the
                        // general insertion below orders them).
                        let (near, far) = if tn[c0] < tn[c1] { (c0, c1) } else { (c1, c0) };
                        stack[sp] = (nd.child[far], tn[far]);
                        sp += 1;
                        cur = nd.child[near];
                        continue;
                    }
                    // Three or four: far to near by insertion, ties keeping the later child
                    // nearer the top; go on with the nearest, the others onto the stack.
                    let mut kids = [(0u32, 0f32); 4];
                    let mut nk = 0;
                    let mut m = hit;
                    while m != 0 {
                        let c = m.trailing_zeros() as usize;
                        m &= m - 1;
                        let mut j = nk;
                        while j > 0 && kids[j - 1].1 < tn[c] {
                            kids[j] = kids[j - 1];
                            j -= 1;
                        }
                        kids[j] = (nd.child[c], tn[c]);
                        nk += 1;
                    }
                    stack[sp..sp + nk - 1].copy_from_slice(&kids[..nk - 1]);
                    sp += nk - 1;
                    cur = kids[nk - 1].0;
                    continue;
                }
            }
            loop {
                if sp == 0 {
                    return best;
                }
                sp -= 1;
                let (c, tn) = stack[sp];
                if tn < tmax {
                    cur = c;
                    break;
                }
            }
        }
    }

    /// Software prefetch of a 4-wide child (see [`prefetch`]): an inner node's two cache lines,
    /// a leaf's first two packets (three lines each).
    #[inline(always)]
    fn prefetch_w4(&self, nodes: &[NodeW<4>], child: u32) {
        if child & LEAF != 0 {
            let start = (child & ((1 << 27) - 1)) as usize;
            let np = if (child >> 27) & 15 == 0 { 1 } else { 2 };
            for pk in self.packets.iter().skip(start).take(np) {
                prefetch(&pk.p[0]);
                prefetch(&pk.p[1][1]);
                prefetch(&pk.p[2][2]);
            }
        } else if let Some(nd) = nodes.get(child as usize) {
            prefetch(&nd.b[0]);
            prefetch(&nd.child);
        }
    }

    /// The triangles of the wide leaf `leaf` (a reference made by `packetize`), four at a time:
    /// the watertight test's single-precision arithmetic on the four lanes at once (the same
    /// operations in the same order as [`WatertightRay::hit_k`], so the same values), then the
    /// lanes that hit within the current `tmax` in lane order, each one checked again against
    /// `tmax` as an earlier lane may have shortened it. Lanes with an edge function exactly 0
    /// go to the scalar test (its double-precision fallback). The result is bit for bit that of
    /// the scalar test over the leaf's triangles in order.
    #[inline(always)]
    fn leaf_w4<const KX: usize, const KY: usize, const KZ: usize>(
        &self,
        leaf: u32,
        r: &Ray4,
        ray: &WatertightRay,
        tmax: &mut f32,
        best: &mut Option<TriHit>,
        any: bool,
    ) -> bool {
        let start = (leaf & ((1 << 27) - 1)) as usize;
        let np = ((leaf >> 27) & 15) as usize + 1;
        let zero = Vec4::ZERO;
        for pk in &self.packets[start..start + np] {
            let sheared = |i: usize| {
                let z = Vec4::from_array(pk.p[i][KZ]) - r.ok[2];
                (
                    (Vec4::from_array(pk.p[i][KX]) - r.ok[0]) - r.s[0] * z,
                    (Vec4::from_array(pk.p[i][KY]) - r.ok[1]) - r.s[1] * z,
                    r.s[2] * z,
                )
            };
            let (ax, ay, az) = sheared(0);
            let (bx, by, bz) = sheared(1);
            let (cx, cy, cz) = sheared(2);
            let u = cx * by - cy * bx;
            let v = ax * cy - ay * cx;
            let w = bx * ay - by * ax;
            let on_edge = (u.cmpeq(zero) | v.cmpeq(zero) | w.cmpeq(zero)).bitmask();
            let out = ((u.cmplt(zero) | v.cmplt(zero) | w.cmplt(zero))
                & (u.cmpgt(zero) | v.cmpgt(zero) | w.cmpgt(zero)))
            .bitmask();
            let det = u + v + w;
            let t = u * az + v * bz + w * cz;
            let td = Vec4::splat(*tmax) * det;
            let far = ((det.cmpgt(zero) & (t.cmple(zero) | t.cmpge(td)))
                | (det.cmplt(zero) & (t.cmpge(zero) | t.cmple(td))))
            .bitmask();
            let valid = (det.cmpne(zero) & det.is_finite_mask()).bitmask();
            let mut m = on_edge | (valid & !(out | far));
            if m == 0 {
                continue;
            }
            let (ta, da, va, wa) = (t.to_array(), det.to_array(), v.to_array(), w.to_array());
            while m != 0 {
                let l = m.trailing_zeros() as usize;
                m &= m - 1;
                let hit = if on_edge & (1 << l) != 0 {
                    let p = |i: usize| Vec3::new(pk.p[i][0][l], pk.p[i][1][l], pk.p[i][2][l]);
                    ray.hit_k::<KX, KY, KZ>(&[p(0), p(1), p(2)], *tmax)
                } else {
                    // The distance test of `hit_k` again with the current `tmax`.
                    let (t, det) = (ta[l], da[l]);
                    let beyond = if det > 0.0 { t >= *tmax * det } else { t <= *tmax * det };
                    if beyond {
                        None
                    } else {
                        let inv = 1.0 / det;
                        Some((t * inv, va[l] * inv, wa[l] * inv))
                    }
                };
                if let Some((t, b1, b2)) = hit {
                    *tmax = t;
                    *best = Some(TriHit { t, b1, b2, id: pk.id[l] });
                    if any {
                        return true;
                    }
                }
            }
        }
        false
    }

    fn traverse2(&self, root: &Node, pairs: &[Pair], o: Vec3, d: Vec3, mut tmax: f32, any: bool) -> Option<TriHit> {
        if self.tris.is_empty() {
            return None;
        }
        let ray = WatertightRay::new(o, d);
        let inv = Vec3::ONE / d;
        let mut best: Option<TriHit> = None;
        box_hit(root, o, inv, tmax)?;
        if root.count > 0 {
            self.leaf(root.start, root.count, &ray, &mut tmax, &mut best, any);
            return best;
        }
        let mut stack = [(0u32, 0f32); STACK2];
        let mut sp = 0usize;
        let mut cur = root.start;
        loop {
            let pair = &pairs[cur as usize].0;
            let mut inner = [(0u32, 0f32); 2];
            let mut ni = 0;
            for nd in pair {
                if let Some(tn) = box_hit(nd, o, inv, tmax) {
                    if nd.count > 0 {
                        if self.leaf(nd.start, nd.count, &ray, &mut tmax, &mut best, any) {
                            return best;
                        }
                    } else {
                        inner[ni] = (nd.start, tn);
                        ni += 1;
                    }
                }
            }
            // Leaves above may have shortened tmax.
            let mut next = None;
            for &(c, tn) in &inner[..ni] {
                if tn < tmax {
                    match next {
                        None => next = Some((c, tn)),
                        Some((c0, t0)) => {
                            let (near, far) = if tn < t0 { ((c, tn), (c0, t0)) } else { ((c0, t0), (c, tn)) };
                            stack[sp] = far;
                            sp += 1;
                            next = Some(near);
                        }
                    }
                }
            }
            if let Some((c, _)) = next {
                cur = c;
                continue;
            }
            loop {
                if sp == 0 {
                    return best;
                }
                sp -= 1;
                let (c, tn) = stack[sp];
                if tn < tmax {
                    cur = c;
                    break;
                }
            }
        }
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

/// The ray's (near, far) distances to one slab `[lo, hi]` of a box along one axis. A ray
/// parallel to the slab (`inv` infinite) that starts exactly on one of its planes gets
/// `0 · ∞ = NaN` there: it lies in the closed slab, which then does not constrain it
/// (-∞, +∞). (Before, a compare-and-select on the NaN could drop such a box: a ray grazing a
/// mesh along a box face, e.g. from a vertex's coordinate plane, could miss the mesh.)
#[inline(always)]
fn slab(lo: f32, hi: f32, o: f32, inv: f32) -> (f32, f32) {
    let t1 = (lo - o) * inv;
    let t2 = (hi - o) * inv;
    if t1.is_nan() || t2.is_nan() {
        (f32::NEG_INFINITY, f32::INFINITY)
    } else if t1 < t2 {
        (t1, t2)
    } else {
        (t2, t1)
    }
}

/// The box test of three slabs: (entry distance, whether the ray enters before `tmax`). The
/// interval is widened by 2γ₃ either way (Ize 2013) so the test is conservative for the
/// watertight triangle test: a triangle on a box face hit at t just below `tmax` is still
/// tested though the rounded entry distance may exceed t by an ulp.
#[inline(always)]
fn enter(near: [f32; 3], far: [f32; 3], tmax: f32) -> (f32, bool) {
    let m = if near[1] > near[2] { near[1] } else { near[2] };
    let t = if near[0] > m { near[0] } else { m } * 0.999_999_6;
    let tn = if t > 0.0 { t } else { 0.0 };
    let m = if far[1] < far[2] { far[1] } else { far[2] };
    let tf = if far[0] < m { far[0] } else { m } * 1.000_000_4;
    (tn, tn <= tf && tn < tmax)
}

/// Entry distance of the ray into the node's box, if it enters before `tmax`.
#[inline]
fn box_hit(n: &Node, o: Vec3, inv: Vec3, tmax: f32) -> Option<f32> {
    let (nx, fx) = slab(n.lo.x, n.hi.x, o.x, inv.x);
    let (ny, fy) = slab(n.lo.y, n.hi.y, o.y, inv.y);
    let (nz, fz) = slab(n.lo.z, n.hi.z, o.z, inv.z);
    let (tn, hit) = enter([nx, ny, nz], [fx, fy, fz], tmax);
    hit.then_some(tn)
}

/// [`box_hit`] for the children of a wide node at once (the same arithmetic lane by lane,
/// written as plain array code so that it compiles to vector instructions); bit `c` of the mask
/// is set when child `c` is hit. Empty slots (box at infinity) never hit.
#[inline(always)]
fn box_hit4<const W: usize>(n: &NodeW<W>, o: [f32; 3], inv: [f32; 3], tmax: f32) -> ([f32; W], u32) {
    let mut near = [[0f32; W]; 3];
    let mut far = [[0f32; W]; 3];
    for a in 0..3 {
        for c in 0..W {
            (near[a][c], far[a][c]) = slab(n.b[0][a][c], n.b[1][a][c], o[a], inv[a]);
        }
    }
    let mut tn = [0f32; W];
    let mut mask = 0;
    for c in 0..W {
        let hit;
        (tn[c], hit) = enter([near[0][c], near[1][c], near[2][c]], [far[0][c], far[1][c], far[2][c]], tmax);
        mask |= (hit as u32) << c;
    }
    (tn, mask)
}

/// Asks the CPU to bring the cache line holding `x` into its caches ahead of use (SSE's
/// `prefetcht0` through `safe_arch`; our crate forbids `unsafe`). A hint only: it changes no
/// result. Elsewhere than x86 it does nothing.
#[inline(always)]
fn prefetch<T>(x: &T) {
    #[cfg(all(any(target_arch = "x86", target_arch = "x86_64"), target_feature = "sse"))]
    safe_arch::prefetch_t0(x);
    #[cfg(not(all(any(target_arch = "x86", target_arch = "x86_64"), target_feature = "sse")))]
    let _ = x;
}

/// Lane by lane `if x > m { x } else { m }`: a NaN `x` keeps `m`. On x86 that is exactly
/// SSE's `maxps(x, m)` (the second operand when either is NaN), which `glam`'s `max` is there
/// (or, with `glam`'s `scalar-math`, `f32::max`, which also returns the operand that is not
/// NaN; `m` never is). Elsewhere (NEON's max propagates NaN) the compare and select.
#[inline(always)]
fn max_keep(x: Vec4, m: Vec4) -> Vec4 {
    #[cfg(all(any(target_arch = "x86", target_arch = "x86_64"), target_feature = "sse"))]
    return x.max(m);
    #[cfg(not(all(any(target_arch = "x86", target_arch = "x86_64"), target_feature = "sse")))]
    return Vec4::select(x.cmpgt(m), x, m);
}

/// Lane by lane `if x < m { x } else { m }` (SSE's `minps(x, m)` on x86), see [`max_keep`].
#[inline(always)]
fn min_keep(x: Vec4, m: Vec4) -> Vec4 {
    #[cfg(all(any(target_arch = "x86", target_arch = "x86_64"), target_feature = "sse"))]
    return x.min(m);
    #[cfg(not(all(any(target_arch = "x86", target_arch = "x86_64"), target_feature = "sse")))]
    return Vec4::select(x.cmplt(m), x, m);
}

/// Per-ray constants of the 4-wide traversal, each splat across the four lanes.
struct Ray4 {
    /// Origin and inverse direction for the box test.
    o: [Vec4; 3],
    inv: [Vec4; 3],
    /// Per axis, the side (`NodeW::b`) of the near plane: 0 (low) unless the direction is
    /// negative, and of the far one.
    near: [usize; 3],
    /// The watertight test's origin components in its axis order (`k`) and its shear.
    ok: [Vec4; 3],
    s: [Vec4; 3],
}

impl Ray4 {
    fn new(ray: &WatertightRay, d: Vec3) -> Ray4 {
        let inv = Vec3::ONE / d;
        let o = ray.o;
        let [kx, ky, kz] = ray.k;
        Ray4 {
            o: [Vec4::splat(o.x), Vec4::splat(o.y), Vec4::splat(o.z)],
            inv: [Vec4::splat(inv.x), Vec4::splat(inv.y), Vec4::splat(inv.z)],
            near: [
                inv.x.is_sign_negative() as usize,
                inv.y.is_sign_negative() as usize,
                inv.z.is_sign_negative() as usize,
            ],
            ok: [Vec4::splat(o[kx]), Vec4::splat(o[ky]), Vec4::splat(o[kz])],
            s: [Vec4::splat(ray.s.x), Vec4::splat(ray.s.y), Vec4::splat(ray.s.z)],
        }
    }
}

/// [`box_hit4`] for a 4-wide node in `Vec4` lanes, the same values without its min/max
/// selects: by the sign of the direction, the near plane's distance `(b - o) · inv` is the
/// smaller of the two (a product with a positive, resp. negative, factor is monotone in `b`,
/// rounding included). A NaN distance (a ray parallel to a slab, starting on its plane) leaves
/// the running maximum (resp. minimum) as it is, which is [`slab`]'s "this axis does not
/// constrain". Folding 0 into the entry maximum before the 2γ₃ widening gives the same entry
/// distance as [`enter`]'s clamp after it (the widening is monotone and keeps 0 at 0).
#[inline(always)]
fn box_hit_w4(n: &NodeW<4>, r: &Ray4, tmax: f32) -> (Vec4, u32) {
    let mut tn = Vec4::ZERO;
    let mut tf = Vec4::INFINITY;
    for a in 0..3 {
        let near = r.near[a] & 1;
        let t_near = (Vec4::from_array(n.b[near][a]) - r.o[a]) * r.inv[a];
        let t_far = (Vec4::from_array(n.b[near ^ 1][a]) - r.o[a]) * r.inv[a];
        // `select(x > m, x, m)`: a NaN `x` keeps `m`.
        tn = max_keep(t_near, tn);
        tf = min_keep(t_far, tf);
    }
    let tn = tn * Vec4::splat(0.999_999_6);
    let tf = tf * Vec4::splat(1.000_000_4);
    (tn, (tn.cmple(tf) & tn.cmplt(Vec4::splat(tmax))).bitmask())
}

impl Bvh {
    /// The former hand-written builder: top-down binned SAH, 16 bins, binary layout. Kept for
    /// the benchmark's comparison (the retired `bvh_bench` example: docs/benchmarks.md, "Retired measurement programs").
    #[doc(hidden)]
    pub fn build_binned_sah(tris: Vec<[Vec3; 3]>) -> Bvh {
        let n = tris.len();
        let mut boxes = Vec::with_capacity(n);
        let mut cents = Vec::with_capacity(n);
        for t in &tris {
            let mut b = Aabb::EMPTY;
            for p in t {
                b.grow(*p);
            }
            boxes.push(b);
            cents.push((b.lo + b.hi) * 0.5);
        }
        let mut order: Vec<u32> = (0..n as u32).collect();
        let mut pairs = Vec::with_capacity(n / MAX_LEAF + 1);
        let root = if n > 0 {
            build_rec(&mut pairs, &mut order, 0, &boxes, &cents, 0)
        } else {
            Node { lo: Vec3::ZERO, hi: Vec3::ZERO, start: 0, count: 0 }
        };
        let stored = order.iter().map(|&i| tris[i as usize]).collect();
        Bvh {
            nodes: Nodes::Binary { root, pairs },
            tris: stored,
            ids: order,
            packets: Vec::new(),
            small_stack: false,
            depth: 0,
        }
    }
}

const BINS: usize = 16;
const MAX_LEAF: usize = 4;
const TRAVERSAL_COST: f32 = 1.0;
const INTERSECT_COST: f32 = 1.0;

#[derive(Clone, Copy)]
struct Aabb {
    lo: Vec3,
    hi: Vec3,
}

impl Aabb {
    const EMPTY: Aabb = Aabb { lo: Vec3::splat(f32::INFINITY), hi: Vec3::splat(f32::NEG_INFINITY) };
    fn grow(&mut self, p: Vec3) {
        self.lo = self.lo.min(p);
        self.hi = self.hi.max(p);
    }
    fn merge(&mut self, b: &Aabb) {
        self.lo = self.lo.min(b.lo);
        self.hi = self.hi.max(b.hi);
    }
    fn area(&self) -> f32 {
        let e = self.hi - self.lo;
        if e.x < 0.0 { 0.0 } else { 2.0 * (e.x * e.y + e.y * e.z + e.z * e.x) }
    }
}

fn build_rec(
    pairs: &mut Vec<Pair>,
    order: &mut [u32],
    offset: usize,
    boxes: &[Aabb],
    cents: &[Vec3],
    depth: u32,
) -> Node {
    let mut bb = Aabb::EMPTY;
    let mut cb = Aabb::EMPTY;
    for &i in order.iter() {
        bb.merge(&boxes[i as usize]);
        cb.grow(cents[i as usize]);
    }
    let leaf = Node { lo: bb.lo, hi: bb.hi, start: offset as u32, count: order.len() as u32 };
    let n = order.len();
    if n <= 1 {
        return leaf;
    }
    // Binned SAH over the centroid box, all three axes.
    let ext = cb.hi - cb.lo;
    let mut best = (f32::INFINITY, 0usize, 0usize); // cost, axis, split bin
    for axis in 0..3 {
        if ext[axis] <= 0.0 {
            continue;
        }
        let scale = BINS as f32 / ext[axis];
        let mut bin_box = [Aabb::EMPTY; BINS];
        let mut bin_n = [0u32; BINS];
        for &i in order.iter() {
            let b = (((cents[i as usize][axis] - cb.lo[axis]) * scale) as usize).min(BINS - 1);
            bin_n[b] += 1;
            bin_box[b].merge(&boxes[i as usize]);
        }
        let mut right_area = [0f32; BINS];
        let mut right_n = [0u32; BINS];
        let mut acc = Aabb::EMPTY;
        let mut cnt = 0;
        for b in (1..BINS).rev() {
            acc.merge(&bin_box[b]);
            cnt += bin_n[b];
            right_area[b] = acc.area();
            right_n[b] = cnt;
        }
        let mut acc = Aabb::EMPTY;
        let mut cnt = 0;
        for b in 0..BINS - 1 {
            acc.merge(&bin_box[b]);
            cnt += bin_n[b];
            if cnt == 0 || right_n[b + 1] == 0 {
                continue;
            }
            let cost = acc.area() * cnt as f32 + right_area[b + 1] * right_n[b + 1] as f32;
            if cost < best.0 {
                best = (cost, axis, b + 1);
            }
        }
    }
    let leaf_cost = INTERSECT_COST * n as f32;
    let split_cost = TRAVERSAL_COST + INTERSECT_COST * best.0 / bb.area().max(1e-30);
    // Below depth 80 split in the middle of the list, so the depth (and the traversal stack,
    // 128 entries) stays bounded whatever the input.
    let mid = if depth < 80 && best.0.is_finite() && (split_cost < leaf_cost || n > MAX_LEAF) {
        let axis = best.1;
        let scale = BINS as f32 / ext[axis];
        let lo = cb.lo[axis];
        partition(order, |i| ((((cents[i as usize][axis] - lo) * scale) as usize).min(BINS - 1)) < best.2)
    } else if n > MAX_LEAF {
        // All centroids coincide (or SAH failed): split in the middle of the list.
        n / 2
    } else {
        return leaf;
    };
    let me = pairs.len();
    pairs.push(Pair([leaf; 2]));
    let (left, right) = order.split_at_mut(mid);
    let l = build_rec(pairs, left, offset, boxes, cents, depth + 1);
    let r = build_rec(pairs, right, offset + mid, boxes, cents, depth + 1);
    pairs[me] = Pair([l, r]);
    Node { lo: bb.lo, hi: bb.hi, start: me as u32, count: 0 }
}

fn partition(v: &mut [u32], pred: impl Fn(u32) -> bool) -> usize {
    let mut i = 0;
    for j in 0..v.len() {
        if pred(v[j]) {
            v.swap(i, j);
            i += 1;
        }
    }
    i
}

/// Per-ray precomputation of the watertight test.
struct WatertightRay {
    o: Vec3,
    k: [usize; 3],
    s: Vec3,
}

impl WatertightRay {
    fn new(o: Vec3, d: Vec3) -> Self {
        let a = d.abs();
        let kz = if a.x > a.y {
            if a.x > a.z { 0 } else { 2 }
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let s = Vec3::new(d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]);
        WatertightRay { o, k: [kx, ky, kz], s }
    }

    /// (t, b1, b2) for a hit with t in (0, tmax).
    #[inline]
    fn hit(&self, tri: &[Vec3; 3], tmax: f32) -> Option<(f32, f32, f32)> {
        match self.k {
            [1, 2, 0] => self.hit_k::<1, 2, 0>(tri, tmax),
            [2, 1, 0] => self.hit_k::<2, 1, 0>(tri, tmax),
            [2, 0, 1] => self.hit_k::<2, 0, 1>(tri, tmax),
            [0, 2, 1] => self.hit_k::<0, 2, 1>(tri, tmax),
            [0, 1, 2] => self.hit_k::<0, 1, 2>(tri, tmax),
            _ => self.hit_k::<1, 0, 2>(tri, tmax),
        }
    }

    /// Bit `l` set unless lane `l` of the packet certainly misses within (0, tmax): the same
    /// single-precision arithmetic as [`WatertightRay::hit_k`], lane by lane; lanes whose
    /// edge functions are not all decided in single precision (one is 0), or whose distance test
    /// is not decided, stay candidates.
    #[inline(always)]
    fn candidates<const KX: usize, const KY: usize, const KZ: usize>(&self, pk: &Tri4, tmax: f32) -> u32 {
        let o = self.o.to_array();
        let mut mask = 0;
        for l in 0..4 {
            let a = [pk.p[0][KX][l] - o[KX], pk.p[0][KY][l] - o[KY], pk.p[0][KZ][l] - o[KZ]];
            let b = [pk.p[1][KX][l] - o[KX], pk.p[1][KY][l] - o[KY], pk.p[1][KZ][l] - o[KZ]];
            let c = [pk.p[2][KX][l] - o[KX], pk.p[2][KY][l] - o[KY], pk.p[2][KZ][l] - o[KZ]];
            let ax = a[0] - self.s.x * a[2];
            let ay = a[1] - self.s.y * a[2];
            let bx = b[0] - self.s.x * b[2];
            let by = b[1] - self.s.y * b[2];
            let cx = c[0] - self.s.x * c[2];
            let cy = c[1] - self.s.y * c[2];
            let u = cx * by - cy * bx;
            let v = ax * cy - ay * cx;
            let w = bx * ay - by * ax;
            let zero = u == 0.0 || v == 0.0 || w == 0.0;
            let out = (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0);
            let det = u + v + w;
            let t = u * (self.s.z * a[2]) + v * (self.s.z * b[2]) + w * (self.s.z * c[2]);
            let far = (det > 0.0 && (t <= 0.0 || t >= tmax * det)) || (det < 0.0 && (t >= 0.0 || t <= tmax * det));
            mask |= ((zero || !(out || far)) as u32) << l;
        }
        mask
    }

    /// [`WatertightRay::hit`] with the ray's axis permutation `k` as constants.
    #[inline(always)]
    fn hit_k<const KX: usize, const KY: usize, const KZ: usize>(
        &self,
        tri: &[Vec3; 3],
        tmax: f32,
    ) -> Option<(f32, f32, f32)> {
        debug_assert_eq!(self.k, [KX, KY, KZ]);
        let (kx, ky, kz) = (KX, KY, KZ);
        let a = (tri[0] - self.o).to_array();
        let b = (tri[1] - self.o).to_array();
        let c = (tri[2] - self.o).to_array();
        let ax = a[kx] - self.s.x * a[kz];
        let ay = a[ky] - self.s.y * a[kz];
        let bx = b[kx] - self.s.x * b[kz];
        let by = b[ky] - self.s.y * b[kz];
        let cx = c[kx] - self.s.x * c[kz];
        let cy = c[ky] - self.s.y * c[kz];
        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        if u == 0.0 || v == 0.0 || w == 0.0 {
            // Exactly on an edge in single precision: decide in double precision.
            u = (cx as f64 * by as f64 - cy as f64 * bx as f64) as f32;
            v = (ax as f64 * cy as f64 - ay as f64 * cx as f64) as f32;
            w = (bx as f64 * ay as f64 - by as f64 * ax as f64) as f32;
        }
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let az = self.s.z * a[kz];
        let bz = self.s.z * b[kz];
        let cz = self.s.z * c[kz];
        let t = u * az + v * bz + w * cz;
        if det > 0.0 {
            if t <= 0.0 || t >= tmax * det {
                return None;
            }
        } else if t >= 0.0 || t <= tmax * det {
            return None;
        }
        let inv = 1.0 / det;
        Some((t * inv, v * inv, w * inv))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shared_edge_is_watertight() {
        // Two triangles forming a square; rays through the diagonal must hit exactly one.
        let tris = vec![
            [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0)],
            [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 0.0)],
        ];
        let bvh = Bvh::build(tris);
        for i in 0..1000 {
            let x = i as f32 / 1000.0 * 0.98 + 0.01;
            let o = Vec3::new(x, x, 1.0);
            assert!(bvh.intersect(o, Vec3::new(0.0, 0.0, -1.0), f32::INFINITY).is_some(), "{x}");
        }
    }

    #[test]
    fn degenerate_triangle_is_never_hit() {
        let tris = vec![[Vec3::ZERO, Vec3::X, Vec3::X * 2.0]];
        let bvh = Bvh::build(tris);
        assert!(bvh.intersect(Vec3::new(0.5, 1.0, 0.0), Vec3::NEG_Y, 10.0).is_none());
        assert!(bvh.intersect(Vec3::new(0.5, 0.0, 1.0), Vec3::NEG_Z, 10.0).is_none());
    }

    #[test]
    fn many_triangles_match_brute_force() {
        let mut tris = Vec::new();
        let mut s = 1u64;
        let mut r = || {
            s = super::super::sampling::mix64(s);
            (s >> 40) as f32 / (1u64 << 24) as f32
        };
        for _ in 0..2000 {
            let c = Vec3::new(r(), r(), r()) * 10.0;
            tris.push([c, c + Vec3::new(r(), r(), r()) - 0.5, c + Vec3::new(r(), r(), r()) - 0.5]);
        }
        let bvh = Bvh::build(tris.clone());
        for _ in 0..500 {
            let o = Vec3::new(r(), r(), r()) * 12.0 - 1.0;
            let d = (Vec3::new(r(), r(), r()) - 0.5).normalize();
            let h = bvh.intersect(o, d, f32::INFINITY).map(|h| h.t);
            let ray = WatertightRay::new(o, d);
            let mut best = f32::INFINITY;
            for t in &tris {
                if let Some((t, _, _)) = ray.hit(t, best) {
                    best = t;
                }
            }
            assert_eq!(h.unwrap_or(f32::INFINITY), best);
        }
    }

    /// A closed sphere-like mesh (a cube's faces as `n`×`n` grids pushed onto the unit sphere,
    /// vertices shared through their grid coordinates so that neighbours share edges exactly),
    /// plus degenerate triangles (a repeated vertex, three collinear points) on its surface.
    fn closed_mesh(n: i32) -> (Vec<[Vec3; 3]>, Vec<Vec3>, Vec<[Vec3; 2]>) {
        let vert =
            |x: i32, y: i32, z: i32| (Vec3::new(x as f32, y as f32, z as f32) / n as f32 * 2.0 - 1.0).normalize() * 1.3;
        let mut tris = Vec::new();
        let mut verts = Vec::new();
        let mut edges = Vec::new();
        for axis in 0..3 {
            for side in [0, n] {
                let at = |u: i32, v: i32| {
                    let mut c = [0; 3];
                    c[axis] = side;
                    c[(axis + 1) % 3] = u;
                    c[(axis + 2) % 3] = v;
                    vert(c[0], c[1], c[2])
                };
                for u in 0..n {
                    for v in 0..n {
                        let (a, b, c, d) = (at(u, v), at(u + 1, v), at(u + 1, v + 1), at(u, v + 1));
                        let (t1, t2) = if side == 0 { ([a, c, b], [a, d, c]) } else { ([a, b, c], [a, c, d]) };
                        tris.push(t1);
                        tris.push(t2);
                        verts.push(a);
                        edges.push([a, c]);
                        edges.push([a, b]);
                        edges.push([a, d]);
                    }
                }
            }
        }
        let k = tris.len();
        for i in (0..k).step_by(7) {
            let [a, b, _] = tris[i];
            tris.push([a, a, b]);
            tris.push([a, (a + b) * 0.5, b]);
        }
        (tris, verts, edges)
    }

    /// The nearest of all the hits. Where triangles meet, several hit within an ulp or two of
    /// each other, and which of them a closest-hit search keeps depends on the order it tests
    /// them in (the test compares t·det with tmax·det before dividing): a BVH may return any
    /// hit within `NEAR_TIE_ULPS` of this one.
    fn nearest(tris: &[[Vec3; 3]], o: Vec3, d: Vec3) -> Option<f32> {
        let ray = WatertightRay::new(o, d);
        tris.iter().filter_map(|t| ray.hit(t, f32::INFINITY)).map(|h| h.0).min_by(f32::total_cmp)
    }

    const NEAR_TIE_ULPS: u32 = 2;

    fn assert_nearest(got: Option<TriHit>, want: Option<f32>, what: &str) {
        match (got, want) {
            (None, None) => {}
            (Some(h), Some(w)) => assert!(
                h.t >= w && h.t.to_bits() - w.to_bits() <= NEAR_TIE_ULPS,
                "{what}: got t = {}, the nearest hit is at {w}",
                h.t
            ),
            _ => panic!("{what}: got {got:?}, want {want:?}"),
        }
    }

    fn brute(tris: &[[Vec3; 3]], o: Vec3, d: Vec3, tmax: f32) -> Option<(f32, u32)> {
        let ray = WatertightRay::new(o, d);
        let mut best = None;
        let mut tm = tmax;
        for (i, t) in tris.iter().enumerate() {
            if let Some((t, _, _)) = ray.hit(t, tm) {
                tm = t;
                best = Some((t, i as u32));
            }
        }
        best
    }

    #[test]
    fn every_layout_matches_brute_force_and_is_watertight_on_a_closed_mesh() {
        let (tris, verts, edges) = closed_mesh(8);
        let mut s = 7u64;
        let mut r = || {
            s = super::super::sampling::mix64(s);
            (s >> 40) as f32 / (1u64 << 24) as f32
        };
        let bvhs = [
            ("default", Bvh::build(tris.clone())),
            ("binary", Bvh::build_with(tris.clone(), Layout::Binary)),
            ("wide4", Bvh::build_with(tris.clone(), Layout::Wide4)),
            ("wide4, deep-tree stack", {
                let mut b = Bvh::build_with(tris.clone(), Layout::Wide4);
                assert!(b.small_stack);
                b.small_stack = false;
                b
            }),
            ("wide8", Bvh::build_with(tris.clone(), Layout::Wide8)),
            ("binned SAH", Bvh::build_binned_sah(tris.clone())),
        ];
        let mut targets: Vec<Vec3> = verts.clone();
        for (k, e) in edges.iter().enumerate() {
            // Points on shared edges: the midpoint and a point a random way along.
            targets.push((e[0] + e[1]) * 0.5);
            if k % 3 == 0 {
                targets.push(e[0].lerp(e[1], r()));
            }
        }
        for (n, &p) in targets.iter().enumerate() {
            // From outside, from inside (the centre and an off-centre point) towards p.
            let outside = Vec3::new(r() - 0.5, r() - 0.5, r() - 0.5).normalize() * 4.0;
            let inside = Vec3::new(r() - 0.5, r() - 0.5, r() - 0.5) * 0.6;
            // A point computed on an edge may round to just outside the (convex) mesh, which a
            // ray from outside may then rightly miss: from outside, aim just inside.
            for (o, p) in [(outside, p * (1.0 - 1e-6)), (Vec3::ZERO, p), (inside, p)] {
                let to = p - o;
                let d = to.normalize();
                let want = nearest(&tris, o, d);
                for (name, bvh) in &bvhs {
                    let got = bvh.intersect(o, d, f32::INFINITY);
                    assert_nearest(got, want, &format!("{name}, target {n}, from {o}"));
                    // Watertight: aimed at a surface point, a ray hits at or before it.
                    let h = got.unwrap_or_else(|| panic!("{name}: ray from {o} to {p} slipped through"));
                    assert!(h.t <= to.length() * 1.0001, "{name}: {} > {}", h.t, to.length());
                    // The reported triangle is hit at that distance, with those barycentrics.
                    let (t, b1, b2) = WatertightRay::new(o, d).hit(&tris[h.id as usize], f32::INFINITY).unwrap();
                    assert_eq!((t, b1, b2), (h.t, h.b1, h.b2), "{name}");
                    for tmax in if n % 4 == 0 { vec![h.t, h.t * 1.001, h.t * 0.999] } else { vec![] } {
                        let occ = brute(&tris, o, d, tmax).is_some();
                        assert_eq!(bvh.occluded(o, d, tmax), occ, "{name}, tmax {tmax}");
                    }
                }
            }
        }
        // Random rays, most of them missing or grazing.
        for _ in 0..2000 {
            let o = Vec3::new(r(), r(), r()) * 6.0 - 3.0;
            let d = (Vec3::new(r(), r(), r()) - 0.5).normalize();
            let want = nearest(&tris, o, d);
            for (name, bvh) in &bvhs {
                assert_nearest(bvh.intersect(o, d, f32::INFINITY), want, name);
                assert_eq!(bvh.occluded(o, d, 2.0), brute(&tris, o, d, 2.0).is_some(), "{name}");
            }
        }
        // Axis-aligned rays (zero direction components) through vertices and edges.
        for &p in targets.iter().step_by(5) {
            for d in [Vec3::X, Vec3::NEG_Y, Vec3::Z] {
                let o = p - d * 3.0;
                let want = nearest(&tris, o, d);
                for (name, bvh) in &bvhs {
                    assert_nearest(bvh.intersect(o, d, f32::INFINITY), want, name);
                }
            }
        }
    }

    /// Everything a traversal reads, as bits.
    fn fingerprint(b: &Bvh) -> Vec<u32> {
        let mut v: Vec<u32> = b.ids.clone();
        for t in &b.tris {
            v.extend(t.iter().flat_map(|p| p.to_array()).map(f32::to_bits));
        }
        for pk in &b.packets {
            v.extend(pk.id);
            v.extend(pk.p.iter().flatten().flatten().map(|x| x.to_bits()));
        }
        let mut wide = |lo: &[[f32; 8]], hi: &[[f32; 8]], child: &[u32]| {
            v.extend(lo.iter().chain(hi).flatten().map(|x| x.to_bits()));
            v.extend(child);
        };
        match &b.nodes {
            Nodes::Binary { root, pairs } => {
                for n in std::iter::once(root).chain(pairs.iter().flat_map(|p| &p.0)) {
                    wide(&[], &[], &[n.start, n.count, n.lo.x.to_bits(), n.hi.z.to_bits()]);
                }
            }
            Nodes::Wide4(nodes) => {
                for n in nodes {
                    let pad = |a: &[[f32; 4]; 3]| a.map(|r| [r[0], r[1], r[2], r[3], 0.0, 0.0, 0.0, 0.0]);
                    wide(&pad(&n.b[0]), &pad(&n.b[1]), &n.child);
                }
            }
            Nodes::Wide8(nodes) => {
                for n in nodes {
                    wide(&n.b[0], &n.b[1], &n.child);
                }
            }
        }
        v
    }

    #[test]
    fn tree_does_not_depend_on_the_thread_count() {
        let (tris, _, _) = closed_mesh(24);
        let build = |threads: usize, layout: Layout| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| fingerprint(&Bvh::build_with(tris.clone(), layout)))
        };
        for layout in [Layout::Binary, Layout::Wide4, Layout::Wide8] {
            let one = build(1, layout);
            for threads in [2, 3, 8] {
                assert!(build(threads, layout) == one, "{layout:?}: {threads} threads build another tree");
            }
        }
    }

    #[test]
    fn tiny_inputs() {
        for n in 0..10 {
            let tris: Vec<[Vec3; 3]> = (0..n)
                .map(|i| {
                    [Vec3::new(i as f32, 0.0, 0.0), Vec3::new(i as f32 + 1.0, 0.0, 0.0), Vec3::new(i as f32, 1.0, 0.0)]
                })
                .collect();
            for layout in [Layout::Binary, Layout::Wide4, Layout::Wide8] {
                let bvh = Bvh::build_with(tris.clone(), layout);
                for i in 0..n {
                    let h = bvh.intersect(Vec3::new(i as f32 + 0.25, 0.25, 1.0), Vec3::NEG_Z, f32::INFINITY);
                    assert_eq!(h.map(|h| (h.id, h.t)), Some((i as u32, 1.0)), "{layout:?} {n} {i}");
                }
                assert!(bvh.intersect(Vec3::new(-0.5, 0.25, 1.0), Vec3::NEG_Z, f32::INFINITY).is_none());
            }
        }
    }
}
