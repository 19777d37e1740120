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

mod binned_sah;
mod boxes;
mod build;
#[cfg(test)]
mod tests;
mod traverse;
mod watertight;
mod wide4;

use glam::Vec3;

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

impl Bvh {
    /// Build over `tris` (world space); `tris[i]` gets id `i`.
    pub fn build(tris: Vec<[Vec3; 3]>) -> Bvh {
        Bvh::build_with(tris, Layout::Wide4)
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
}
