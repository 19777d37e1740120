//! Photon emission from spot, point, directional and environment lights.
//!
//! An [`Emitter`] samples directions (spot, point) or positions (directional) uniformly over a
//! domain that contains every direction that matters, and gives each photon the flux that makes
//! the estimator exact: `I(ω) · Ω / N` for a spot or point light sampled uniformly over a cone
//! of solid angle Ω, `E · A / N` for a directional light sampled uniformly over a disc of area A
//! perpendicular to it. With stratified (Sobol) samples the sum over N photons converges to the
//! light's flux into the domain.
//!
//! [`Emitter::full`] covers all the light's emission (used by the sampling tests);
//! [`Emitter::toward`] covers only the directions that can reach a given sphere (the bounding
//! sphere of the specular objects, for caustic photons) or the spot cone, whichever is smaller.
//! Directions outside it cannot produce a caustic, so skipping them keeps the caustic estimate
//! unbiased.
//!
//! [`Emitter::environment`] draws a direction from the environment's importance-sampling
//! distribution (density `p(ω)` per solid angle), then a point uniform on a disc of area A
//! perpendicular to it (the target sphere's cross-section, as a directional light's), and gives
//! the photon `L(ω) · A / (p(ω) N)`.

use super::sampling::{basis, concentric_disc, uniform_cone};
use caustics::scene::{Environment, Light, SpotProfile};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;
use std::sync::Arc;

#[derive(Clone, Debug)]
enum Domain {
    /// Uniform over a cone: `cos_max`, solid angle.
    Cone { origin: Vec3, axis: Vec3, cos_max: f32, solid_angle: f32 },
    /// Uniform over a disc perpendicular to `dir`, starting `back` behind the disc's plane.
    Disc { center: Vec3, u: Vec3, v: Vec3, radius: f32, dir: Vec3, back: f32, area: f32 },
    /// A direction from the environment's distribution, then uniform over a disc of `radius`
    /// around `center` perpendicular to it, starting `back` before the disc's plane.
    Environment { env: Arc<Environment>, center: Vec3, radius: f32, back: f32, area: f32 },
}

/// Samples photons from one light.
#[derive(Clone, Debug)]
pub struct Emitter {
    light: Light,
    domain: Domain,
}

/// Placeholder light of an environment emitter (whose radiance is in its domain).
const NO_LIGHT: Light = Light::Directional { direction: Vec3::NEG_Y, irradiance: Vec3::ZERO };

/// One emitted photon: origin, unit direction, and flux × N (W; divide by the photon count).
#[derive(Clone, Copy, Debug)]
pub struct Emitted {
    pub origin: Vec3,
    pub dir: Vec3,
    pub flux_n: Vec3,
}

impl Emitter {
    /// All the light's emission. `scene_center`/`scene_radius` bound the scene (directional
    /// lights cover that sphere's cross-section).
    pub fn full(light: &Light, scene_center: Vec3, scene_radius: f32) -> Emitter {
        let domain = match light {
            Light::Spot { position, direction, cone_angle, .. } => {
                let cos_max = cone_angle.cos();
                Domain::Cone { origin: *position, axis: *direction, cos_max, solid_angle: 2.0 * PI * (1.0 - cos_max) }
            }
            Light::Point { position, .. } => {
                Domain::Cone { origin: *position, axis: Vec3::Y, cos_max: -1.0, solid_angle: 4.0 * PI }
            }
            Light::Directional { direction, .. } => {
                disc(*direction, scene_center, scene_radius, scene_center, scene_radius)
            }
        };
        Emitter { light: light.clone(), domain }
    }

    /// Only the emission that can reach the sphere (`target_center`, `target_radius`), inside a
    /// scene bounded by (`scene_center`, `scene_radius`).
    pub fn toward(
        light: &Light,
        target_center: Vec3,
        target_radius: f32,
        scene_center: Vec3,
        scene_radius: f32,
    ) -> Emitter {
        let full = Emitter::full(light, scene_center, scene_radius);
        let domain = match light {
            Light::Spot { position, .. } | Light::Point { position, .. } => {
                let to = target_center - *position;
                let d = to.length();
                if d <= target_radius * 1.0001 {
                    return full;
                }
                let sin_a = target_radius / d;
                // A slightly widened cone: float rounding must not cut off grazing directions.
                let cos_max = ((1.0 - sin_a * sin_a).max(0.0).sqrt() - 1e-6).max(-1.0);
                let solid_angle = 2.0 * PI * (1.0 - cos_max);
                match full.domain {
                    Domain::Cone { solid_angle: full_sa, .. } if full_sa <= solid_angle => return full,
                    _ => {}
                }
                Domain::Cone { origin: *position, axis: to / d, cos_max, solid_angle }
            }
            Light::Directional { direction, .. } => {
                disc(*direction, target_center, target_radius * 1.0001, scene_center, scene_radius)
            }
        };
        Emitter { light: light.clone(), domain }
    }

    /// The environment's emission that can reach the sphere (`target_center`,
    /// `target_radius`), inside a scene bounded by (`scene_center`, `scene_radius`).
    pub fn environment(
        env: Arc<Environment>,
        target_center: Vec3,
        target_radius: f32,
        scene_center: Vec3,
        scene_radius: f32,
    ) -> Emitter {
        let radius = target_radius * 1.0001;
        let back = scene_radius + (target_center - scene_center).length() + radius + 1e-3 * (1.0 + scene_radius);
        Emitter {
            light: NO_LIGHT,
            domain: Domain::Environment { env, center: target_center, radius, back, area: PI * radius * radius },
        }
    }

    /// Whether [`Self::sample_with`] asks for its second 2D sample.
    pub fn needs_aux(&self) -> bool {
        matches!(self.domain, Domain::Environment { .. })
    }

    /// Photon for the 2D sample `u`; `None` where the light emits nothing (outside a spot cone).
    #[inline]
    pub fn sample(&self, u: Vec2) -> Option<Emitted> {
        self.sample_with(u, || Vec2::splat(0.5))
    }

    /// Photon for the 2D sample `u` and, for an environment (the position on the disc; the
    /// direction comes from `u`), the 2D sample `aux` returns (called only then).
    #[inline]
    pub fn sample_with(&self, u: Vec2, aux: impl FnOnce() -> Vec2) -> Option<Emitted> {
        match &self.domain {
            Domain::Environment { env, center, radius, back, area } => {
                let s = env.sample(u)?;
                if s.pdf.is_nan() || s.pdf <= 0.0 || s.radiance.max_element() <= 0.0 {
                    return None;
                }
                let (du, dv) = basis(s.dir);
                let p = concentric_disc(aux()) * *radius;
                let origin = *center + du * p.x + dv * p.y + s.dir * *back;
                Some(Emitted { origin, dir: -s.dir, flux_n: s.radiance * (*area / s.pdf) })
            }
            Domain::Cone { origin, axis, cos_max, solid_angle } => {
                let dir = uniform_cone(u, *axis, *cos_max);
                let i = self.light.intensity_toward(dir);
                (i.max_element() > 0.0).then_some(Emitted { origin: *origin, dir, flux_n: i * *solid_angle })
            }
            Domain::Disc { center, u: du, v: dv, radius, dir, back, area } => {
                let p = concentric_disc(u) * *radius;
                let origin = *center + *du * p.x + *dv * p.y - *dir * *back;
                let e = match &self.light {
                    Light::Directional { irradiance, .. } => *irradiance,
                    _ => Vec3::ZERO,
                };
                Some(Emitted { origin, dir: *dir, flux_n: e * *area })
            }
        }
    }

    /// The total flux (W) into the sampling domain, where known in closed form: directional
    /// lights and point lights exactly; spot lights by numerical integration of the profile.
    pub fn domain_flux(&self) -> Vec3 {
        match (&self.domain, &self.light) {
            (Domain::Disc { area, .. }, Light::Directional { irradiance, .. }) => *irradiance * *area,
            (Domain::Cone { solid_angle, .. }, Light::Point { intensity, .. }) => *intensity * *solid_angle,
            (Domain::Cone { .. }, Light::Spot { intensity, cone_angle, falloff_start, profile, .. })
                if *profile == SpotProfile::Gltf =>
            {
                // glTF's curve is t² with t linear in c = cos θ from the outer cone's cosine over
                // a width w (dΩ = 2π dc): ∫ I f 2π dc = 2π I ((1 − (c_o + w)) + w/3).
                let (inner, outer) = (*falloff_start as f64, *cone_angle as f64);
                let w = (inner.cos() - outer.cos()).max(0.001);
                let s = (1.0 - (outer.cos() + w)).max(0.0) + w / 3.0;
                *intensity * (2.0 * std::f64::consts::PI * s) as f32
            }
            (Domain::Cone { .. }, Light::Spot { intensity, cone_angle, falloff_start, .. }) => {
                // ∫ I f(θ) 2π sin θ dθ over the whole cone (valid for `full` emitters).
                let n = 100_000;
                let mut s = 0.0f64;
                for k in 0..n {
                    let th = (k as f64 + 0.5) / n as f64 * *cone_angle as f64;
                    let f = if th <= *falloff_start as f64 {
                        1.0
                    } else {
                        (*cone_angle as f64 - th) / (*cone_angle as f64 - *falloff_start as f64)
                    };
                    s += f * th.sin();
                }
                *intensity * (s * 2.0 * std::f64::consts::PI * *cone_angle as f64 / n as f64) as f32
            }
            _ => Vec3::ZERO,
        }
    }
}

fn disc(direction: Vec3, center: Vec3, radius: f32, scene_center: Vec3, scene_radius: f32) -> Domain {
    let dir = direction.normalize();
    let (u, v) = basis(dir);
    // Start far enough back that every scene point lies ahead of the disc.
    let back = scene_radius + (center - scene_center).length() + radius + 1e-3 * (1.0 + scene_radius);
    Domain::Disc { center, u, v, radius, dir, back, area: PI * radius * radius }
}
