//! The `medium` section: the ray marches of scenes with a participating medium.

use serde::{Deserialize, Serialize};

/// Scenes with a participating medium: the camera ray march of the lights' single scattering,
/// the transmittance toward the lights, the light the surfaces reflect into the medium.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MediumSettings {
    /// Steps of the camera ray march that adds the lights' single scattering (`medium_scatter`,
    /// docs/media.md), 1 to 4096.
    pub steps: u32,
    /// Heterogeneous media (a density grid): steps of each ray march for the transmittance
    /// toward a light (per camera-ray step in `medium_scatter`, per surface point in
    /// `shade_receivers`), 1 to 1024. Homogeneous media use the closed form.
    pub light_steps: u32,
    /// The light diffuse surfaces reflect into the medium (light → floor → fog → camera, and the
    /// caustic's: light → glass → floor → fog → camera) comes from virtual point lights, one per
    /// block of each light face's receiver map: this many blocks per side
    /// (`medium_bounce_lights`, docs/media.md "Light between surfaces and the medium"), 0 to
    /// 64; 0 leaves that light out.
    pub bounce_grid: u32,
    /// Steps of the camera ray march that gathers the virtual point lights (`medium_bounce`),
    /// 1 to 4096.
    pub bounce_steps: u32,
    /// The medium along the camera paths beyond their first specular surface (through glass, in
    /// mirrors): `composite` attenuates what they see, and the medium's passes add the light
    /// scattered along them (`EyeSegment`, docs/media.md "The medium beyond the first
    /// specular surface"). Default on; off, glass shows what lies behind it as if the medium
    /// ended at its surface (cheaper).
    pub beyond_specular: bool,
    /// Multiple scattering (light scattered twice or more in the medium, docs/media.md
    /// "Multiple scattering"): photons per light on random walks through the medium and the
    /// scene, whose second and later scattering events fill a grid the camera and the surfaces
    /// read (`medium_ms_*`, src/medium_multiple/), 0 to 16777216; 0 leaves multiple scattering
    /// out (single scattering only, as before it existed).
    pub multiple_photons: u32,
    /// Cells of that grid along the medium box's longest side (the others in proportion), 2 to
    /// 128.
    pub multiple_grid: u32,
}

impl Default for MediumSettings {
    fn default() -> Self {
        MediumSettings {
            steps: 64,
            light_steps: 16,
            bounce_grid: 16,
            bounce_steps: 8,
            beyond_specular: true,
            multiple_photons: 262_144,
            multiple_grid: 32,
        }
    }
}

impl MediumSettings {
    /// Check the ranges: (field path, message) on error.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        if !(1..=4096).contains(&self.steps) {
            return Err(("medium.steps", format!("must be 1 to 4096 (got {})", self.steps)));
        }
        if !(1..=1024).contains(&self.light_steps) {
            return Err(("medium.light_steps", format!("must be 1 to 1024 (got {})", self.light_steps)));
        }
        if self.bounce_grid > 64 {
            return Err(("medium.bounce_grid", format!("must be 0 to 64 (got {})", self.bounce_grid)));
        }
        if !(1..=4096).contains(&self.bounce_steps) {
            return Err(("medium.bounce_steps", format!("must be 1 to 4096 (got {})", self.bounce_steps)));
        }
        if self.multiple_photons > 1 << 24 {
            return Err(("medium.multiple_photons", format!("must be 0 to 16777216 (got {})", self.multiple_photons)));
        }
        if !(2..=128).contains(&self.multiple_grid) {
            return Err(("medium.multiple_grid", format!("must be 2 to 128 (got {})", self.multiple_grid)));
        }
        Ok(())
    }
}
