//! The `adaptive` section: the photon hierarchy of the adaptive (and hierarchical) techniques.

use serde::{Deserialize, Serialize};

/// The hierarchy of adaptive caustic maps (Wyman & Nichols 2009; `docs/adaptive.md`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AdaptiveSettings {
    /// Adaptive and hierarchical techniques: the coarse grid the hierarchy starts from (a power
    /// of two, 4 to 4096).
    pub base_grid: u32,
    /// Maximal caustic map error: a cluster converges when its photons land in one caustic-map
    /// texel (0) or within this many texels (> 0).
    pub error_tolerance: f32,
    /// Maximal caustic map error: convergence is checked for clusters whose photons lie on a grid
    /// of at least this size (Wyman & Nichols check from the 512² level on).
    pub check_grid: u32,
    /// Maximal caustic map error with caustic triangles: an optional second stopping rule (0:
    /// off, the default: the paper's rule alone). A cluster also converges when its cell quad
    /// maps linearly enough: its corner lattice and children's photons land within this many
    /// caustic-map texels of the bilinear interpolation of its corners (`docs/adaptive.md`).
    pub quad_linearity: f32,
}

impl Default for AdaptiveSettings {
    fn default() -> Self {
        AdaptiveSettings { base_grid: 64, error_tolerance: 0.0, check_grid: 512, quad_linearity: 0.0 }
    }
}

impl AdaptiveSettings {
    /// Check the ranges: (field path, message) on error.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        if !(self.quad_linearity >= 0.0 && self.quad_linearity <= 1e6) {
            return Err(("adaptive.quad_linearity", format!("must be 0 or more texels (got {})", self.quad_linearity)));
        }
        if !(self.error_tolerance >= 0.0 && self.error_tolerance <= 1e6) {
            return Err((
                "adaptive.error_tolerance",
                format!("must be 0 or more texels (got {})", self.error_tolerance),
            ));
        }
        Ok(())
    }
}
