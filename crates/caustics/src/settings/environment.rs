//! The `environment` section: how an environment light is segmented into directional lights.

use crate::scene::environment_lights::SplitRule;
use serde::{Deserialize, Serialize};

/// The default of [`EnvironmentSettings::taps`] (`docs/benchmarks.md`, "Environment caustics
/// spread over their regions").
pub const DEFAULT_ENV_TAPS: u32 = 16;

/// The default of [`EnvironmentSettings::lights`]: the paper's 24 (Tandianus et al. 2010).
pub const DEFAULT_ENV_LIGHTS: u32 = 24;

/// Scenes with an environment light.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EnvironmentSettings {
    /// The directional lights the environment is segmented into (the cube-map median cut,
    /// `scene::environment_lights`), 1 to 256; they light diffuse surfaces with shadow maps and
    /// cast caustics like the scene's own directional lights.
    pub lights: u32,
    /// How the median cut picks the region to split (`SplitRule`, default: by flux-weighted
    /// angular radius; `total` is the paper's rule), for comparisons.
    pub split: SplitRule,
    /// Sub-directions each environment region's caustic is spread over (`crate::env_taps`),
    /// 0 to 32; 0 or 1: none (each region's caustic from its one direction, as the paper).
    pub taps: u32,
}

impl Default for EnvironmentSettings {
    fn default() -> Self {
        EnvironmentSettings { lights: DEFAULT_ENV_LIGHTS, split: SplitRule::default(), taps: DEFAULT_ENV_TAPS }
    }
}

impl EnvironmentSettings {
    /// Check the ranges: (field path, message) on error.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        if !(1..=256).contains(&self.lights) {
            return Err(("environment.lights", format!("must be 1 to 256 directional lights (got {})", self.lights)));
        }
        if self.taps as usize > crate::gpu::types::MAX_ENV_TAPS {
            let max = crate::gpu::types::MAX_ENV_TAPS;
            return Err((
                "environment.taps",
                format!("must be 0 to {max} sub-directions per region (got {})", self.taps),
            ));
        }
        Ok(())
    }
}
