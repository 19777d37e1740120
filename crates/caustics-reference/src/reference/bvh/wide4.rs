//! The hand-written 4-wide traversal (the default layout) in `glam::Vec4` lanes: per-ray
//! constants, node order, software prefetch and the four-triangle packet test.

use super::boxes::box_hit_w4;
use super::watertight::WatertightRay;
use super::{Bvh, LEAF, NodeW, STACK_SMALL, STACKW, TriHit};
use glam::{Vec3, Vec4};

impl Bvh {
    /// The 4-wide traversal (the default layout), written with `glam`'s four-lane `Vec4` (SSE2
    /// on x86-64) so that the four box tests of a node and the four triangle tests of a packet
    /// each run as one vector computation. It visits the same nodes in the same order and
    /// computes the same values as [`Bvh::traverse4`] (the generic code the 8-wide layout still
    /// uses), so the results are bit for bit the same; see [`box_hit_w4`] and
    /// [`Bvh::leaf_w4`].
    pub(super) fn wide4(&self, nodes: &[NodeW<4>], o: Vec3, d: Vec3, tmax: f32, any: bool) -> Option<TriHit> {
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

/// Per-ray constants of the 4-wide traversal, each splat across the four lanes.
pub(super) struct Ray4 {
    /// Origin and inverse direction for the box test.
    pub(super) o: [Vec4; 3],
    pub(super) inv: [Vec4; 3],
    /// Per axis, the side (`NodeW::b`) of the near plane: 0 (low) unless the direction is
    /// negative, and of the far one.
    pub(super) near: [usize; 3],
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
