//! The `testing` section: knobs kept for tests and comparisons only. Hidden from the
//! documentation; every default is what renders best.

use serde::{Deserialize, Serialize};

/// Switches that exist to check or time a part of the renderer against its alternative. The
/// defaults are the renderer; each off (or on) reproduces an older way for comparison.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TestingSettings {
    /// Exact tracer: take each photon's first caster surface from the light's caster front
    /// buffer (the papers' deferred emission: a texel's tangent plane) instead of tracing the
    /// BVH from the light; the rest of the path is exact. Off by default (the comparison is in
    /// `docs/benchmarks.md`).
    pub first_hit_from_buffer: bool,
    /// Maximal caustic map error: skip the convergence check on levels where the spread of a
    /// cluster's children predicts that it cannot pass (`docs/adaptive.md`); the check would
    /// only trace photons to refine them. On by default; off gives the paper's traversal.
    pub error_skip_hopeless: bool,
    /// Rasterize the light's second caster layer (`light_caster_front2`, `light_caster_back2`:
    /// per texel, the nearest caster of another object behind the first layer's) when the scene
    /// has caster meshes and two casters or more, so that photons find and traverse a mesh
    /// hidden from the light behind another caster. Off: only the first layer (the renderer
    /// before it; for comparisons).
    pub light_second_layer: bool,
    /// `shade_receivers` skips the caustic lookups where the light's caustic map is zero and
    /// the shadow lookups where its shadow map is all in front or all behind, as per-tile
    /// summaries made with the light's maps say (`caustic_mask`, `shadow_tiles`). The image is
    /// the same bit for bit; off only to check that (tests) or to time the difference.
    pub shading_tiles: bool,
}

impl Default for TestingSettings {
    fn default() -> Self {
        TestingSettings {
            first_hit_from_buffer: false,
            error_skip_hopeless: true,
            light_second_layer: true,
            shading_tiles: true,
        }
    }
}
