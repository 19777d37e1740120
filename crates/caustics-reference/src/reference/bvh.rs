//! A bounding volume hierarchy over triangles: binned SAH build, depth-first node layout
//! (left child follows its parent), watertight ray-triangle intersection (Woop, Benthin and
//! Wald 2013) with conservative box tests, so that no ray slips between two triangles that
//! share an edge. Zero-area triangles are never hit (their determinant is 0).
//!
//! Written here rather than taken from a crate: the reference must share nothing with the GPU
//! path and be easy to audit; the crates we looked at (`bvh`, `obvhs`) either pull in a second
//! linear-algebra library or do not offer a watertight triangle test, and this is ~300 lines.

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

/// A triangle BVH. Triangles are stored in leaf order; `ids[i]` is the caller's index of the
/// i-th stored triangle.
pub struct Bvh {
    root: Node,
    pairs: Vec<Pair>,
    tris: Vec<[Vec3; 3]>,
    ids: Vec<u32>,
}

/// A triangle hit: distance, barycentrics of vertices 1 and 2, caller's triangle index.
#[derive(Clone, Copy, Debug)]
pub struct TriHit {
    pub t: f32,
    pub b1: f32,
    pub b2: f32,
    pub id: u32,
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

impl Bvh {
    /// Build over `tris` (world space); `tris[i]` gets id `i`.
    pub fn build(tris: Vec<[Vec3; 3]>) -> Bvh {
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
        Bvh { root, pairs, tris: stored, ids: order }
    }

    pub fn node_count(&self) -> usize {
        1 + 2 * self.pairs.len()
    }

    /// Nearest hit with t in (0, tmax).
    pub fn intersect(&self, o: Vec3, d: Vec3, tmax: f32) -> Option<TriHit> {
        self.traverse(o, d, tmax, false)
    }

    /// Whether anything is hit with t in (0, tmax).
    pub fn occluded(&self, o: Vec3, d: Vec3, tmax: f32) -> bool {
        self.traverse(o, d, tmax, true).is_some()
    }

    #[inline]
    fn leaf(&self, nd: &Node, ray: &WatertightRay, tmax: &mut f32, best: &mut Option<TriHit>, any: bool) -> bool {
        for i in nd.start..nd.start + nd.count {
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

    fn traverse(&self, o: Vec3, d: Vec3, mut tmax: f32, any: bool) -> Option<TriHit> {
        if self.tris.is_empty() {
            return None;
        }
        let ray = WatertightRay::new(o, d);
        let inv = Vec3::ONE / d;
        let mut best: Option<TriHit> = None;
        box_hit(&self.root, o, inv, tmax)?;
        if self.root.count > 0 {
            self.leaf(&self.root, &ray, &mut tmax, &mut best, any);
            return best;
        }
        let mut stack = [(0u32, 0f32); 128];
        let mut sp = 0usize;
        let mut cur = self.root.start;
        loop {
            let pair = &self.pairs[cur as usize].0;
            let mut inner = [(0u32, 0f32); 2];
            let mut ni = 0;
            for nd in pair {
                if let Some(tn) = box_hit(nd, o, inv, tmax) {
                    if nd.count > 0 {
                        if self.leaf(nd, &ray, &mut tmax, &mut best, any) {
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

/// Entry distance of the ray into the node's box, if it enters before `tmax`. The far distance
/// is widened by 2γ₃ (Ize 2013) so the test is conservative for the watertight triangle test.
#[inline]
fn box_hit(n: &Node, o: Vec3, inv: Vec3, tmax: f32) -> Option<f32> {
    let t1 = (n.lo - o) * inv;
    let t2 = (n.hi - o) * inv;
    let tn = t1.min(t2).max_element().max(0.0);
    let tf = t1.max(t2).min_element() * 1.000_000_4;
    (tn <= tf && tn < tmax).then_some(tn)
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
        let [kx, ky, kz] = self.k;
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
}
