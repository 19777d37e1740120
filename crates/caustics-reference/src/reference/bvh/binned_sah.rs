//! The former hand-written builder (top-down binned SAH, binary layout), kept for the
//! benchmark's comparison.

use super::{Bvh, Node, Nodes, Pair};
use glam::Vec3;

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
