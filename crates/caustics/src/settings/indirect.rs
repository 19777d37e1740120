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
    /// Batches of `photons` the cache averages over, 1 to 64. 1 (the default) rebuilds the cache
    /// from one batch whenever a light or an object changes. N > 1 refines it progressively:
    /// every frame traces a fresh batch (new random numbers) and blends it into the cache with
    /// weight max(1/n, 1/N) for its n-th batch (the first N averaged evenly, then an exponential
    /// average: noise variance 1/(2N − 1) of one batch's), for 6N frames after the last change
    /// of a light or an object, then stops (camera-only frames cost the gather alone). A change
    /// keeps the cache and blends the new light in: the old light fades as (1 − 1/N)^k after k
    /// frames (to 1/e after about N frames, to 0.25 % when refining stops), without the jump
    /// of a rebuild from one noisy batch.
    pub history: u32,
}

/// Photons per light per frame when interreflection is switched on without a count (the
/// viewer's checkbox): 2^16, refined progressively over [`VIEWER_HISTORY`] batches (settled, the
/// noise of about 2^20 photons; a quarter of the cost of the 2^18 the tests build at once while
/// a light is dragged).
pub const VIEWER_PHOTONS: u32 = 1 << 16;

/// The viewer's `history`: a dragged light's bounced light follows within about 8 frames.
pub const VIEWER_HISTORY: u32 = 8;

impl Default for IndirectSettings {
    fn default() -> Self {
        IndirectSettings { photons: 0, grid: 48, capacity: 1 << 17, bounces: 16, history: 1 }
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
        if !(1..=64).contains(&self.history) {
            return Err(("indirect.history", format!("must be 1 to 64 (got {})", self.history)));
        }
        Ok(())
    }

    /// Frames a progressive cache (`history` > 1) keeps refining after the last change.
    pub fn refine_frames(&self) -> u32 {
        if self.history > 1 { 6 * self.history } else { 0 }
    }
}
