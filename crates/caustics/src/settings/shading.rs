//! The `shading` section: shadow maps, spot lights' spill faces, the tessellation of analytic
//! shapes for rasterization.

use super::RenderSettings;
use crate::lightspace::{LightView, MAX_SPOT_FRUSTUM_DEG, bounds_beyond_spot, casters_in_view};
use crate::scene::{Light, Scene, Tessellation};
use serde::{Deserialize, Serialize};

/// How receivers are shaded and lights' views laid out.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ShadingSettings {
    /// Shadow map size per face (texels), 16 to the adapter's texture limit.
    pub shadow_map_size: u32,
    /// Spill faces of spot lights (`crate::lightspace::spill_face`): a second, wider face that
    /// receives the caustic light glass bends outside the spot's own view.
    pub spill_faces: SpillFaces,
    /// Segments of tessellated spheres and cylinders (rasterization only; the photons meet the
    /// exact shapes), 8 to 8192.
    pub tessellation: Tessellation,
}

impl Default for ShadingSettings {
    fn default() -> Self {
        ShadingSettings { shadow_map_size: 2048, spill_faces: SpillFaces::Auto, tessellation: Tessellation::default() }
    }
}

impl ShadingSettings {
    /// Check the ranges that do not depend on the device: (field path, message) on error.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        let t = &self.tessellation;
        if !(8..=8192).contains(&t.sphere_segments) {
            return Err((
                "shading.tessellation.sphere_segments",
                format!("must be 8 to 8192 segments (got {})", t.sphere_segments),
            ));
        }
        if !(8..=8192).contains(&t.cylinder_segments) {
            return Err((
                "shading.tessellation.cylinder_segments",
                format!("must be 8 to 8192 segments (got {})", t.cylinder_segments),
            ));
        }
        if self.shadow_map_size < 16 {
            return Err((
                "shading.shadow_map_size",
                format!("must be at least 16 texels (got {})", self.shadow_map_size),
            ));
        }
        Ok(())
    }
}

/// The largest caustic map for which [`SpillFaces::Auto`] adds spill faces (each adds a layer
/// to every per-face map of its light).
pub const MAX_AUTO_SPILL_MAP: u32 = 1024;

impl RenderSettings {
    /// Whether the GPU gives `light` a spill face under these settings: a spot light of up to
    /// 75° whose surface caustic is not drawn by the beams (then it has no photon map; the
    /// beams' stages run over the emitting faces, `LightView::emit_faces`), and for
    /// [`SpillFaces::Auto`] only where a specular caster is in the spot's view, the scene's
    /// bounds reach beyond it and the caustic map is at most [`MAX_AUTO_SPILL_MAP`]².
    pub fn uses_spill_face(&self, scene: &Scene, light: &Light) -> bool {
        let spot = matches!(light, Light::Spot { cone_angle, .. } if cone_angle.to_degrees() <= MAX_SPOT_FRUSTUM_DEG);
        if !spot || self.surface_caustics_from_beams(light) {
            return false;
        }
        match self.shading.spill_faces {
            SpillFaces::Off => false,
            SpillFaces::On => true,
            SpillFaces::Auto => {
                self.photons.caustic_map_size <= MAX_AUTO_SPILL_MAP
                    && bounds_beyond_spot(scene, light)
                    && casters_in_view(scene, &LightView::new(scene, light).faces[0])
            }
        }
    }

    /// The light view the GPU uses for `light`: [`LightView::with_spill`] where
    /// [`RenderSettings::uses_spill_face`], else [`LightView::new`].
    pub fn light_view(&self, scene: &Scene, light: &Light) -> LightView {
        if self.uses_spill_face(scene, light) {
            LightView::with_spill(scene, light)
        } else {
            LightView::new(scene, light)
        }
    }
}

/// Whether spot lights get a spill face ([`ShadingSettings::spill_faces`]; the rule is
/// `RenderSettings::uses_spill_face`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SpillFaces {
    /// Where a specular caster is in the spot's view and the scene's bounds reach beyond it,
    /// with caustic maps up to 1024² (memory); never for lights whose caustics come from beams.
    #[default]
    Auto,
    /// Never (the spot's own face only).
    Off,
    /// Every spot light of up to 75° not handled by beams.
    On,
}

impl SpillFaces {
    /// Every variant.
    pub const ALL: [SpillFaces; 3] = [SpillFaces::Auto, SpillFaces::Off, SpillFaces::On];

    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            SpillFaces::Auto => "auto",
            SpillFaces::Off => "off",
            SpillFaces::On => "on",
        }
    }

    /// The variant named `s` on the command line (surrounding whitespace ignored).
    pub fn parse(s: &str) -> Option<SpillFaces> {
        SpillFaces::ALL.into_iter().find(|m| m.name() == s.trim())
    }
}

impl std::fmt::Display for SpillFaces {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}
