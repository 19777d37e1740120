//! An environment region's caustic spread over the region's solid angle (issue 15).
//!
//! The environment lights the GPU frame as D directional lights, one per region of the median
//! cut (`crate::scene::environment_lights`). One direction per region makes each broad
//! region's caustic one sharp pattern where the truth is that pattern blurred over the
//! region's directions. Measured (`docs/benchmarks.md`, "Environment caustics spread over
//! their regions"): on `sky.exr` this takes the caustic's HDR-FLIP at D = 24 from 0.278 to
//! 0.223; most of what remains, and most of the error on `studio.exr`, is the GPU's caustic of
//! a single directional light, not the environment's approximation.
//!
//! **What we do.** Each region is cut again by the same median cut into up to K sub-regions
//! ([`crate::scene::environment_lights::subdivide`], `RenderSettings::env_taps`), each with its
//! own `L·Ω`-weighted centre ω_k and total `Σ L Ω` (the taps). The region's light still traces
//! one caustic map, from its centre ω_c. At a shaded point p, `shade_receivers` sums over the
//! taps the caustic sub-direction k would give there, read from that one map by turning the
//! scene about the casters' centre c: for a caster symmetric about c (a sphere) the caustic of
//! direction ω_k is exactly the caustic of ω_c turned by the rotation R_k taking ω_c to ω_k, so
//! E_k(p) = E_c(c + R_kᵀ (p − c)). That point lies off the receiver; we follow the ray from c
//! through it to the receiver's tangent plane at p (f = c + s R_kᵀ (p − c),
//! s = n·(p − c) / n·(R_kᵀ (p − c))), read the map there and scale by s³: the caustic light
//! leaves the caster as from a source at c, so its irradiance on the plane goes as cos/r²,
//! and cos_p/r_p² over cos_f/r_f² is s · s² (cos_p/cos_f = s, r_f = s r_p): the Jacobian of
//! the map p → f, so the turned caustic keeps its flux. Tap k is weighted by its sub-region's total over the
//! light's `facing` irradiance (per channel): the flux a sphere of constant cross-section
//! intercepts from the sub-region, against what the map was traced with. So the weights sum to
//! total/facing ≥ 1 (the light's `facing` loses the region's spread; a sphere does not).
//!
//! **Why this and not K directional lights per region.** K traced lights cost K times the
//! light passes (shadow map, light-space buffers, photon tracing: nearly all of a frame's
//! 14–16 s of GPU passes on lavapipe at D = 24, where all the shading takes under 50 ms);
//! the taps cost K bilinear lookups per pixel and light in `shade_receivers` (the taps also
//! stand in for the 3×3 pixel-footprint box filter: tap k reads at the k-th point of an R2
//! sequence over the footprint). The price: the turn is exact for a sphere only; for other
//! casters it is the approximation that the caustic turns with the light about the casters'
//! centre, good for small turns (fine regions) and compact casters.
//!
//! A region that cannot be cut (one texel, a black region, the merged region of D < 6) gets no
//! taps, and its light renders exactly as a plain directional light (`tests/gpu/environment.rs`).

use crate::gpu::types::{EnvTapsGpu, MAX_ENV_TAPS};
use crate::scene::Environment;
use crate::scene::environment_lights::{EnvironmentLight, subdivide};
use glam::{Mat3, Quat, Vec3};

/// The sub-directions of one region, in the map's own frame: (unit direction toward the
/// sub-region's centre, weight = its total `Σ L Ω` over the region's `facing`, per channel).
/// Empty when the region is not cut (fewer than two sub-regions).
pub type RegionTaps = Vec<(Vec3, Vec3)>;

/// The taps of every region of `regions` (those of `segment_map`, map frame), up to `k` each
/// (`k` ≤ [`MAX_ENV_TAPS`]; 0 or 1: none).
pub fn region_taps(env: &Environment, regions: &[EnvironmentLight], k: usize) -> Vec<RegionTaps> {
    let k = k.min(MAX_ENV_TAPS);
    regions
        .iter()
        .map(|r| {
            if k < 2 || r.facing.max_element() <= 0.0 {
                return Vec::new();
            }
            let subs = subdivide(env, r, k);
            if subs.len() < 2 {
                return Vec::new();
            }
            let ratio = |t: f32, f: f32| if f > 0.0 { t / f } else { 0.0 };
            subs.iter()
                .map(|s| {
                    let w = Vec3::new(
                        ratio(s.irradiance.x, r.facing.x),
                        ratio(s.irradiance.y, r.facing.y),
                        ratio(s.irradiance.z, r.facing.z),
                    );
                    (s.centre, w)
                })
                .collect()
        })
        .collect()
}

/// The `shade_receivers` record of one light: `taps` of a region whose centre is `centre`
/// (both in the map's own frame), turned into the world by `rotation` (the environment's
/// map-to-world rotation), about `pivot` (world). Count 0 for no taps.
pub fn record(taps: &RegionTaps, centre: Vec3, rotation: Mat3, pivot: Vec3) -> EnvTapsGpu {
    let mut g = EnvTapsGpu::zeroed_record();
    g.centre = pivot.extend(1.0).to_array();
    let c = (rotation * centre).normalize();
    for (slot, (dir, w)) in g.taps.iter_mut().zip(taps.iter().take(MAX_ENV_TAPS)) {
        let d = (rotation * *dir).normalize();
        // R takes c to d; the shader applies Rᵀ, whose rows are R's columns.
        let r = Mat3::from_quat(Quat::from_rotation_arc(c, d));
        slot.rows = [r.x_axis.extend(0.0).to_array(), r.y_axis.extend(0.0).to_array(), r.z_axis.extend(0.0).to_array()];
        slot.weight = w.extend(0.0).to_array();
    }
    g.info[0] = taps.len().min(MAX_ENV_TAPS) as u32;
    g
}

impl EnvTapsGpu {
    /// No taps: the light's own caustic map.
    pub fn zeroed_record() -> EnvTapsGpu {
        bytemuck::Zeroable::zeroed()
    }
}
