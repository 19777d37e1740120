//! The scalar traversals: the binary layout's and the generic wide one (the 8-wide layout's),
//! with the scalar watertight test per triangle.

use super::boxes::{box_hit, box_hit4};
use super::watertight::WatertightRay;
use super::{Bvh, LEAF, Node, NodeW, Pair, STACK2, STACKW, TriHit};
use glam::Vec3;

impl Bvh {
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
    pub(super) fn wide<const W: usize>(
        &self,
        nodes: &[NodeW<W>],
        o: Vec3,
        d: Vec3,
        tmax: f32,
        any: bool,
    ) -> Option<TriHit> {
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

    pub(super) fn traverse2(
        &self,
        root: &Node,
        pairs: &[Pair],
        o: Vec3,
        d: Vec3,
        mut tmax: f32,
        any: bool,
    ) -> Option<TriHit> {
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
