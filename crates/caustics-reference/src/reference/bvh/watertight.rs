//! The watertight ray-triangle test (Woop, Benthin and Wald 2013): scalar, with its
//! double-precision fallback on edges, and the packet prefilter.

use super::Tri4;
use glam::Vec3;

/// Per-ray precomputation of the watertight test.
pub(super) struct WatertightRay {
    pub(super) o: Vec3,
    pub(super) k: [usize; 3],
    pub(super) s: Vec3,
}

impl WatertightRay {
    pub(super) fn new(o: Vec3, d: Vec3) -> Self {
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
    pub(super) fn hit(&self, tri: &[Vec3; 3], tmax: f32) -> Option<(f32, f32, f32)> {
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
    pub(super) fn candidates<const KX: usize, const KY: usize, const KZ: usize>(&self, pk: &Tri4, tmax: f32) -> u32 {
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
    pub(super) fn hit_k<const KX: usize, const KY: usize, const KZ: usize>(
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
