//! Random numbers and sampling for the reference renderer.
//!
//! Every sample is a pure function of (seed, stream, path index, dimension): a photon path or a
//! camera sample draws the same numbers whichever thread traces it, so images do not depend on
//! the thread count. The first two dimensions of emission and of the pixel position are an
//! Owen-scrambled Sobol (0,2)-sequence over the global path index (stratified, low
//! discrepancy); the other dimensions come from a counter-based hash (splitmix64 finalizer).

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// splitmix64 finalizer: a bijective 64-bit mixer.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Hash of several words.
#[inline]
pub fn hash(words: &[u64]) -> u64 {
    let mut h = 0x9e37_79b9_7f4a_7c15u64;
    for &w in words {
        h = mix64(h ^ w.wrapping_mul(0xd6e8_feb8_6659_fd93));
    }
    h
}

/// A counter-based stream of uniform numbers for one path: `key` identifies the path.
#[derive(Clone, Copy, Debug)]
pub struct PathRng {
    key: u64,
    counter: u64,
}

impl PathRng {
    pub fn new(key: u64) -> Self {
        PathRng { key, counter: 0 }
    }
    /// Next uniform in [0, 1).
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        self.counter += 1;
        let h = mix64(self.key ^ self.counter.wrapping_mul(0x9e37_79b9_7f4a_7c15));
        (h >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
    }
    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        Vec2::new(self.next_f32(), self.next_f32())
    }
    /// An independent stream derived from this one's state (`salt` tells forks apart), which
    /// leaves this one as it was: estimates added to a path draw from a fork, so the path's own
    /// numbers, and the image without them, do not change.
    pub fn fork(&self, salt: u64) -> PathRng {
        PathRng::new(mix64(self.key ^ mix64(self.counter ^ salt.wrapping_mul(0xd6e8_feb8_6659_fd93))))
    }
}

/// Second dimension of the Sobol sequence (the first is the bit-reversed index).
#[inline]
fn sobol_dim1(mut i: u32) -> u32 {
    let mut r = 0u32;
    let mut v = 1u32 << 31;
    while i != 0 {
        if i & 1 != 0 {
            r ^= v;
        }
        i >>= 1;
        v ^= v >> 1;
    }
    r
}

/// Laine–Karras hash: an approximation of Owen's nested uniform scrambling in reversed bits.
#[inline]
fn laine_karras(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

#[inline]
fn owen(x: u32, seed: u32) -> u32 {
    laine_karras(x.reverse_bits(), seed).reverse_bits()
}

/// Point `index` of a 2D Owen-scrambled Sobol sequence; `seed` picks the scrambling. Any 2^k
/// consecutive aligned points are stratified in every 2^a × 2^b elementary interval.
pub fn sobol_2d(index: u64, seed: u64) -> Vec2 {
    // Indices beyond 2^32 start a new, independently scrambled sequence.
    let s = mix64(seed ^ (index >> 32).wrapping_mul(0x2545_f491_4f6c_dd1d));
    let i = owen(index as u32, mix64(s ^ 0x51) as u32); // shuffle the order as well
    let x = owen(i.reverse_bits(), s as u32);
    let y = owen(sobol_dim1(i), (s >> 32) as u32);
    const S: f32 = 1.0 / 4_294_967_296.0;
    Vec2::new((x >> 8) as f32 * S * 256.0, (y >> 8) as f32 * S * 256.0).min(Vec2::splat(1.0 - f32::EPSILON))
}

/// An orthonormal basis around unit `n` (Duff et al. 2017).
#[inline]
pub fn basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x), Vec3::new(b, sign + n.y * n.y * a, -n.y))
}

/// Uniform direction in the cone of half-angle with cosine `cos_max` around unit `axis`
/// (solid angle 2π(1 - cos_max)).
#[inline]
pub fn uniform_cone(u: Vec2, axis: Vec3, cos_max: f32) -> Vec3 {
    let cos_t = 1.0 - u.x * (1.0 - cos_max);
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    let (t, b) = basis(axis);
    (t * (sin_t * phi.cos()) + b * (sin_t * phi.sin()) + axis * cos_t).normalize()
}

/// Cosine-weighted direction on the hemisphere around unit `n` (pdf cos θ / π).
#[inline]
pub fn cosine_hemisphere(u: Vec2, n: Vec3) -> Vec3 {
    let d = concentric_disc(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    let (t, b) = basis(n);
    (t * d.x + b * d.y + n * z).normalize()
}

/// Shirley–Chiu concentric map of the unit square onto the unit disc (area preserving,
/// keeps strata compact).
#[inline]
pub fn concentric_disc(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) =
        if o.x.abs() > o.y.abs() { (o.x, PI / 4.0 * (o.y / o.x)) } else { (o.y, PI / 2.0 - PI / 4.0 * (o.x / o.y)) };
    Vec2::new(r * theta.cos(), r * theta.sin())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sobol_is_stratified() {
        // 256 consecutive points: exactly one per 16x16 cell.
        let mut cells = [0u32; 256];
        for i in 0..256u64 {
            let p = sobol_2d(i, 7);
            assert!(p.x >= 0.0 && p.x < 1.0 && p.y >= 0.0 && p.y < 1.0);
            cells[(p.x * 16.0) as usize * 16 + (p.y * 16.0) as usize] += 1;
        }
        assert!(cells.iter().all(|&c| c == 1), "{cells:?}");
    }

    #[test]
    fn rng_in_range() {
        let mut r = PathRng::new(3);
        let mut m = 0.0;
        for _ in 0..10000 {
            let x = r.next_f32();
            assert!((0.0..1.0).contains(&x));
            m += x as f64;
        }
        assert!((m / 10000.0 - 0.5).abs() < 0.01);
    }
}
