//! Homogeneous participating media: transmittance, free-flight sampling, phase functions.
//!
//! The medium fills its axis-aligned box except the inside of dielectric objects; outside the
//! box is vacuum. A ray segment lies inside a dielectric exactly when it ends on a dielectric's
//! back face (dielectrics are closed and not nested), so the tracers need no state for it.
//!
//! Free flight: a segment [0, t_max] of a ray (clipped to the box) is sampled with the
//! *scattering* coefficients, one channel chosen uniformly and the density averaged over the
//! three channels (spectral MIS, the "one-sample balance heuristic"): collision at t with
//! density p(t) = mean_c σs_c e^{−σs_c t}, or no collision with probability
//! P = mean_c e^{−σs_c t_max}. The weights are then
//! `T_c(t) σs_c / p(t)` at a collision and `T_c(t_max) / P` past the segment, with
//! `T_c(t) = e^{−σt_c t}`: absorption enters as an analytic weight (an absorbing-only medium
//! is rendered without noise), and every weight is at most 3.
//!
//! **Heterogeneous media** (a density grid, `caustics::scene::DensityGrid`: σs(x) = ρ(x) σs,
//! σa(x) = ρ(x) σa, ρ trilinear): free flight by *delta tracking* and transmittance by *ratio
//! tracking*, both with the majorant μ̄ = max ρ · max_c σt_c, one for the three channels.
//! Tentative collisions are drawn from μ̄ e^{−μ̄ s}; at one at x, a real scattering is chosen with
//! probability P_s = mean_c σs_c(x) / μ̄ (weight σs(x) / (μ̄ P_s)), else the collision is null
//! (weight (μ̄ − σt(x)) / (μ̄ (1 − P_s)), per channel: absorption and the other channels'
//! differences as weights, "weighted delta tracking"); past the segment the weight is the
//! product of the null weights. Ratio tracking multiplies (1 − σt(x_i)/μ̄) over the tentative
//! collisions before the segment's end. Both are unbiased for any μ̄ ≥ max σt; the homogeneous
//! medium keeps the analytic code above (no random number drawn for its transmittance), so its
//! images are bit for bit those of before.

use super::sampling::PathRng;
use caustics::scene::{DensityGrid, Medium, Phase};
use glam::Vec3;
use std::f32::consts::PI;
use std::sync::Arc;

/// What happened along a segment.
pub enum Flight {
    /// No collision before the segment's end: multiply the throughput by `weight`.
    Pass { weight: Vec3 },
    /// A scattering collision at distance `t` along the ray; multiply by `weight`.
    Scatter { t: f32, weight: Vec3 },
}

#[derive(Clone, Debug)]
pub struct Media {
    pub sigma_s: Vec3,
    pub sigma_t: Vec3,
    pub phase: Phase,
    lo: Vec3,
    hi: Vec3,
    /// The density grid of a heterogeneous medium (`None`: homogeneous).
    grid: Option<Arc<DensityGrid>>,
    /// μ̄ = max ρ · max_c σt_c (heterogeneous media only).
    majorant: f32,
}

impl Media {
    pub fn new(m: &Medium) -> Self {
        let sigma_t = m.sigma_s + m.sigma_a;
        Media {
            sigma_s: m.sigma_s,
            sigma_t,
            phase: m.phase,
            lo: m.bounds_min,
            hi: m.bounds_max,
            grid: m.density.clone(),
            majorant: m.max_density() * sigma_t.max_element(),
        }
    }

    /// Whether the medium has a density grid.
    pub fn heterogeneous(&self) -> bool {
        self.grid.is_some()
    }

    /// The density at `x` (1 without a grid).
    #[inline]
    pub fn density(&self, x: Vec3) -> f32 {
        match &self.grid {
            None => 1.0,
            Some(g) => g.lookup((x - self.lo) / (self.hi - self.lo)),
        }
    }

    /// The part [t0, t1] of the ray o + t d, 0 ≤ t ≤ t_max, inside the box (None if empty).
    pub fn clip(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, f32)> {
        let (mut t0, mut t1) = (0.0f32, t_max);
        for k in 0..3 {
            let inv = 1.0 / d[k];
            let (mut a, mut b) = ((self.lo[k] - o[k]) * inv, (self.hi[k] - o[k]) * inv);
            if a > b {
                std::mem::swap(&mut a, &mut b);
            }
            if a.is_nan() || b.is_nan() {
                // d[k] == 0 and o on a slab plane: inside if within the slab.
                if o[k] < self.lo[k] || o[k] > self.hi[k] {
                    return None;
                }
                continue;
            }
            t0 = t0.max(a);
            t1 = t1.min(b);
        }
        (t0 < t1).then_some((t0, t1))
    }

    /// Length of the ray segment [0, t_max] inside the box.
    pub fn length_in(&self, o: Vec3, d: Vec3, t_max: f32) -> f32 {
        self.clip(o, d, t_max).map_or(0.0, |(a, b)| b - a)
    }

    /// Transmittance along the segment [0, t_max] (which must not lie inside a dielectric):
    /// exact for a homogeneous medium (no random number drawn), an unbiased ratio-tracking
    /// estimate for a heterogeneous one.
    pub fn transmittance(&self, o: Vec3, d: Vec3, t_max: f32, rng: &mut PathRng) -> Vec3 {
        if self.grid.is_some() {
            return self.ratio_tracking(o, d, t_max, rng);
        }
        let l = self.length_in(o, d, t_max);
        if l > 0.0 { (-self.sigma_t * l).exp() } else { Vec3::ONE }
    }

    /// Ratio tracking (module documentation) along [0, t_max] clipped to the box.
    fn ratio_tracking(&self, o: Vec3, d: Vec3, t_max: f32, rng: &mut PathRng) -> Vec3 {
        let Some((t0, t1)) = self.clip(o, d, t_max) else { return Vec3::ONE };
        let mu = self.majorant;
        if mu <= 0.0 {
            return Vec3::ONE;
        }
        let mut tr = Vec3::ONE;
        let mut t = t0;
        loop {
            t -= (1.0 - rng.next_f32()).ln() / mu;
            if t >= t1 {
                return tr;
            }
            let st = self.sigma_t * self.density(o + d * t);
            tr *= (Vec3::ONE - st / mu).max(Vec3::ZERO);
            if tr.max_element() <= 0.0 {
                return Vec3::ZERO;
            }
        }
    }

    /// Weighted delta tracking (module documentation) along [t0, t1].
    fn delta_tracking(&self, o: Vec3, d: Vec3, t0: f32, t1: f32, rng: &mut PathRng) -> Flight {
        let mu = self.majorant;
        let mean_ss = self.sigma_s.element_sum() / 3.0;
        if mu <= 0.0 || mean_ss <= 0.0 {
            // Nothing scatters: only the transmittance remains.
            return Flight::Pass { weight: self.ratio_tracking(o, d, t1, rng) };
        }
        let mut w = Vec3::ONE;
        let mut t = t0;
        loop {
            let u = rng.next_2d();
            t -= (1.0 - u.x).ln() / mu;
            if t >= t1 {
                return Flight::Pass { weight: w };
            }
            let rho = self.density(o + d * t);
            // P_s = mean σs(x) / μ̄; the scattering weight σs(x) / (μ̄ P_s) = σs / mean σs.
            let ps = (rho * mean_ss / mu).min(1.0);
            if u.y < ps {
                return Flight::Scatter { t, weight: w * self.sigma_s / mean_ss };
            }
            w *= (Vec3::splat(mu) - self.sigma_t * rho).max(Vec3::ZERO) / (mu * (1.0 - ps));
            if w.max_element() <= 0.0 {
                return Flight::Pass { weight: Vec3::ZERO };
            }
        }
    }

    /// Sample a collision along the segment [0, t_max] of the ray (outside dielectrics).
    pub fn sample(&self, o: Vec3, d: Vec3, t_max: f32, rng: &mut PathRng) -> Flight {
        let Some((t0, t1)) = self.clip(o, d, t_max) else { return Flight::Pass { weight: Vec3::ONE } };
        if self.grid.is_some() {
            return self.delta_tracking(o, d, t0, t1, rng);
        }
        let len = t1 - t0;
        let ss = self.sigma_s;
        if ss.max_element() <= 0.0 {
            return Flight::Pass { weight: (-self.sigma_t * len).exp() };
        }
        let u = rng.next_2d();
        let c = ((u.x * 3.0) as usize).min(2);
        let s = if ss[c] > 0.0 { -(1.0 - u.y).ln() / ss[c] } else { f32::INFINITY };
        if s < len {
            let p = (ss * (-ss * s).exp()).element_sum() / 3.0;
            let w = (-self.sigma_t * s).exp() * ss / p;
            Flight::Scatter { t: t0 + s, weight: w }
        } else {
            let p = (-ss * len).exp().element_sum() / 3.0;
            Flight::Pass { weight: (-self.sigma_t * len).exp() / p }
        }
    }

    /// Phase function value (1/sr) for travel direction `wi` turning into `wo` (both unit,
    /// both in the direction of travel).
    pub fn phase(&self, wi: Vec3, wo: Vec3) -> f32 {
        match self.phase {
            Phase::Isotropic => 0.25 / PI,
            Phase::HenyeyGreenstein { g } => {
                let c = wi.dot(wo).clamp(-1.0, 1.0);
                let den = (1.0 + g * g - 2.0 * g * c).max(1e-12);
                (1.0 - g * g) / (4.0 * PI * den * den.sqrt())
            }
        }
    }

    /// Sample a new travel direction from the phase function (exactly: weight 1).
    pub fn sample_phase(&self, wi: Vec3, rng: &mut PathRng) -> Vec3 {
        let u = rng.next_2d();
        let cos = match self.phase {
            Phase::HenyeyGreenstein { g } if g.abs() > 1e-3 => {
                let q = (1.0 - g * g) / (1.0 - g + 2.0 * g * u.x);
                ((1.0 + g * g - q * q) / (2.0 * g)).clamp(-1.0, 1.0)
            }
            _ => 1.0 - 2.0 * u.x,
        };
        let sin = (1.0 - cos * cos).max(0.0).sqrt();
        let phi = 2.0 * PI * u.y;
        let (t, b) = wi.any_orthonormal_pair();
        (t * (sin * phi.cos()) + b * (sin * phi.sin()) + wi * cos).normalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn media(g: Option<f32>) -> Media {
        Media::new(&Medium {
            sigma_s: Vec3::new(0.5, 1.0, 2.0),
            sigma_a: Vec3::new(0.1, 0.0, 0.3),
            phase: g.map_or(Phase::Isotropic, |g| Phase::HenyeyGreenstein { g }),
            bounds_min: Vec3::splat(-1.0),
            bounds_max: Vec3::splat(1.0),
            density: None,
        })
    }

    #[test]
    fn clipping_to_the_box() {
        let m = media(None);
        let (a, b) = m.clip(Vec3::new(-3.0, 0.0, 0.0), Vec3::X, 10.0).unwrap();
        assert!((a - 2.0).abs() < 1e-6 && (b - 4.0).abs() < 1e-6);
        assert!(m.clip(Vec3::new(-3.0, 2.0, 0.0), Vec3::X, 10.0).is_none());
        assert!((m.length_in(Vec3::ZERO, Vec3::Y, 0.5) - 0.5).abs() < 1e-6);
        assert!((m.length_in(Vec3::ZERO, Vec3::Y, f32::INFINITY) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn phase_functions_integrate_to_one_and_sampling_matches() {
        for g in [None, Some(0.6), Some(-0.3)] {
            let m = media(g);
            let wi = Vec3::new(0.3, -0.8, 0.52).normalize();
            // ∫ p dω by a fine midpoint rule in cos θ about wi.
            let n = 20000;
            let (t, _) = wi.any_orthonormal_pair();
            let mut s = 0.0f64;
            for i in 0..n {
                let c = -1.0 + (i as f32 + 0.5) * 2.0 / n as f32;
                let wo = wi * c + t * (1.0 - c * c).sqrt();
                s += m.phase(wi, wo) as f64 * 2.0 * std::f64::consts::PI * 2.0 / n as f64;
            }
            assert!((s - 1.0).abs() < 1e-3, "{g:?}: {s}");
            // Mean cosine of sampled directions is g.
            let mut rng = PathRng::new(7);
            let k = 200_000;
            let mean: f64 = (0..k).map(|_| m.sample_phase(wi, &mut rng).dot(wi) as f64).sum::<f64>() / k as f64;
            assert!((mean - g.unwrap_or(0.0) as f64).abs() < 0.01, "{g:?}: {mean}");
        }
    }

    #[test]
    fn free_flight_is_unbiased() {
        // E[weight at collision · f(t)] + E[pass weight] equals the analytic integral for
        // f = 1: ∫_0^L T σs dt + T(L) = σs/σt (1 − e^{−σt L}) + e^{−σt L}.
        let m = media(None);
        let (o, d, len) = (Vec3::new(-1.0, 0.0, 0.0), Vec3::X, 1.5);
        let mut rng = PathRng::new(3);
        let k = 400_000;
        let mut acc = glam::DVec3::ZERO;
        for _ in 0..k {
            acc += match m.sample(o, d, len, &mut rng) {
                Flight::Pass { weight } | Flight::Scatter { weight, .. } => weight.as_dvec3(),
            };
        }
        acc /= k as f64;
        for c in 0..3 {
            let (ss, st) = (m.sigma_s[c] as f64, m.sigma_t[c] as f64);
            let e = ss / st * (1.0 - (-st * len as f64).exp()) + (-st * len as f64).exp();
            assert!((acc[c] / e - 1.0).abs() < 0.01, "channel {c}: {} vs {e}", acc[c]);
        }
    }
}
