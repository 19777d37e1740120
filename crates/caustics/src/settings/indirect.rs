//! The `indirect` section: diffuse interreflection (light that reaches a diffuse surface after
//! bouncing off another), from a world-space cache fed by photons (src/indirect/,
//! docs/indirect.md).

use serde::{Deserialize, Serialize};

/// Diffuse interreflection: photons per light that keep going after their first diffuse hit,
/// the cache they fill and the bounces they make.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IndirectSettings {
    /// Photons per light on random walks whose second and later diffuse hits fill the cache
    /// (`indirect_trace`), 0 to 16777216; 0 (the default) leaves interreflection out: every
    /// surface shows only the light that reached it first (direct and caustic), bit for bit as
    /// before the cache existed.
    pub photons: u32,
    /// Cells of the cache along the scene's longest side (a cell's side is the scene's longest
    /// side over this; the gather's kernel radius two cells), 4 to 500.
    pub grid: u32,
    /// Entries of the cache's hash table, a power of two from 1024 to 4194304; a frame whose
    /// surfaces need more cells loses the deposits that find no slot and reports them.
    pub capacity: u32,
    /// Diffuse bounces per photon at most (orders 2 to `bounces` + 1 of the light), 1 to 64;
    /// Russian roulette by albedo ends most paths sooner.
    pub bounces: u32,
}

/// Photons per light when interreflection is switched on without a count (the viewer's
/// checkbox): 2^18, the count the tests measure (a closed room within 3 % of the reference's
/// energy at 8 × 8 HDR-FLIP 0.09).
pub const VIEWER_PHOTONS: u32 = 1 << 18;

impl Default for IndirectSettings {
    fn default() -> Self {
        IndirectSettings { photons: 0, grid: 48, capacity: 1 << 17, bounces: 16 }
    }
}

impl IndirectSettings {
    /// Whether the frame draws interreflection.
    pub fn active(&self) -> bool {
        self.photons > 0
    }

    /// Check the ranges: (field path, message) on error.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        if self.photons > 1 << 24 {
            return Err(("indirect.photons", format!("must be 0 to 16777216 (got {})", self.photons)));
        }
        if !(4..=500).contains(&self.grid) {
            return Err(("indirect.grid", format!("must be 4 to 500 (got {})", self.grid)));
        }
        if !self.capacity.is_power_of_two() || !(1024..=1 << 22).contains(&self.capacity) {
            return Err((
                "indirect.capacity",
                format!("must be a power of two from 1024 to 4194304 (got {})", self.capacity),
            ));
        }
        if !(1..=64).contains(&self.bounces) {
            return Err(("indirect.bounces", format!("must be 1 to 64 (got {})", self.bounces)));
        }
        Ok(())
    }
}
