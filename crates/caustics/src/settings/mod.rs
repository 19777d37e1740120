//! What a frame is asked to do: the settings of a GPU render, in sections (`photons`,
//! `adaptive`, `shading`, `medium`, `environment`, `beams`, `indirect`), each with its defaults and its own
//! validation, errors named by field path (`beams.grid`). Every section reads and writes as JSON
//! (serde), so the settings of an image can be stored with it and read back
//! ([`RenderSettings::to_json`], [`RenderSettings::from_json`], [`RenderSettings::set`]).
//! Every other module reads them; this one depends on none of them.

pub mod adaptive;
pub mod beams;
pub mod environment;
pub mod indirect;
pub mod medium;
pub mod photons;
pub mod shading;
pub mod sources;
#[doc(hidden)]
pub mod testing;

pub use adaptive::AdaptiveSettings;
pub use beams::{BeamSettings, BeamVolume};
pub use environment::{DEFAULT_ENV_LIGHTS, DEFAULT_ENV_TAPS, EnvironmentSettings};
pub use indirect::IndirectSettings;
pub use medium::MediumSettings;
pub use photons::{Emission, PhotonSettings, SplatMode, Tracer};
pub use shading::{ShadingSettings, SpillFaces};
pub use sources::{DistantSource, LocalSource, SourceSettings, Technique, VolumeSource};
#[doc(hidden)]
pub use testing::TestingSettings;

use serde::{Deserialize, Serialize};

/// The largest caster geometry buffer; denser photon grids interpolate between its texels.
pub(crate) const MAX_GBUFFER: u32 = 2048;

/// Settings of a GPU render, in sections. `Default` is the renderer's defaults; a JSON object
/// with any subset of the sections and their keys reads as those over the defaults
/// ([`RenderSettings::from_json`]).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RenderSettings {
    /// Where each kind of light's caustics come from: photon maps, beams, caustic spheres.
    pub sources: SourceSettings,
    /// The photon caustic maps: the grid, the emission technique, the tracer, the splats.
    pub photons: PhotonSettings,
    /// The photon hierarchy of the adaptive and hierarchical techniques.
    pub adaptive: AdaptiveSettings,
    /// Shadow maps, spill faces, tessellation.
    pub shading: ShadingSettings,
    /// The ray marches of a participating medium.
    pub medium: MediumSettings,
    /// The directional lights an environment light is segmented into.
    pub environment: EnvironmentSettings,
    /// Volume caustics by adaptive beam tracing in scenes with a medium (`crate::beams`).
    pub beams: BeamSettings,
    /// Diffuse interreflection from a world-space cache fed by photons (`crate::indirect`).
    pub indirect: IndirectSettings,
    /// Knobs for tests and comparisons ([`TestingSettings`]).
    #[doc(hidden)]
    pub testing: TestingSettings,
}

impl RenderSettings {
    /// Check every section's ranges (those that need no device): the first error as
    /// (field path, message). [`RenderSettings::validate`] adds the adapter's limits.
    pub fn validate_sections(&self) -> Result<(), (&'static str, String)> {
        self.shading.validate()?;
        self.photons.validate()?;
        self.adaptive.validate()?;
        if self.adaptive.quad_linearity > 0.0
            && !(self.photons.emission == Emission::AdaptiveError && self.photons.splat == SplatMode::Triangles)
        {
            return Err((
                "adaptive.quad_linearity",
                "needs photons.emission adaptive-error with photons.splat triangles (it stops on cell quads)"
                    .to_string(),
            ));
        }
        self.medium.validate()?;
        self.environment.validate()?;
        self.beams.validate()?;
        self.indirect.validate()?;
        Ok(())
    }

    /// The settings as JSON, every section and key written out.
    pub fn to_json(&self) -> serde_json::Value {
        json_value(self)
    }

    /// Settings from JSON text: any subset of the sections and keys, over the defaults. Errors
    /// name the key path (`beams.grid`) and `file`.
    pub fn from_json(file: &str, text: &str) -> crate::Result<RenderSettings> {
        let de = &mut serde_json::Deserializer::from_str(text);
        serde_path_to_error::deserialize(de).map_err(|e| {
            let path = e.path().to_string();
            let inner = e.into_inner();
            let line = Some((inner.line(), inner.column()));
            crate::Error::Input {
                file: file.into(),
                field: if path == "." { String::new() } else { path },
                line,
                message: inner.to_string(),
            }
        })
    }

    /// Set one key by its path (`beams.grid`, `photons.emission`) to a JSON value. An unknown
    /// key is an error that lists the keys its section knows; a value of the wrong type is an
    /// error naming the path.
    pub fn set(&mut self, path: &str, value: serde_json::Value) -> crate::Result<()> {
        let bad = |m: String| crate::Error::input("<settings>", path, m);
        let mut root = self.to_json();
        let mut node = &mut root;
        let keys: Vec<&str> = path.split('.').collect();
        for (i, key) in keys.iter().enumerate() {
            let serde_json::Value::Object(map) = node else {
                return Err(bad(format!("`{}` is not a section", keys[..i].join("."))));
            };
            if !map.contains_key(*key) {
                let known: Vec<&str> = map.keys().map(String::as_str).filter(|k| *k != "testing" || i > 0).collect();
                let within = if i == 0 { "the settings".to_string() } else { format!("`{}`", keys[..i].join(".")) };
                return Err(bad(format!("no key `{key}` in {within}; known keys: {}", known.join(", "))));
            }
            node = map.get_mut(*key).expect("checked");
        }
        if node.is_object() && !value.is_object() {
            return Err(bad("is a section; set one of its keys".into()));
        }
        *node = value;
        *self = serde_json::from_value(root).map_err(|e| bad(e.to_string()))?;
        Ok(())
    }
}

/// `value` as JSON with its `f32`s written as `f32`s (`0.2`, not `0.20000000298023224`):
/// `serde_json::to_value` widens them to `f64`, so the text is made first (the shortest decimal
/// of each `f32`) and read back.
pub fn json_value<T: Serialize>(value: &T) -> serde_json::Value {
    let text = serde_json::to_string(value).expect("settings serialize");
    serde_json::from_str(&text).expect("settings read back")
}

impl RenderSettings {
    /// Whether `light`'s caustic on surfaces comes from its beams (and its photon stage is
    /// skipped): [`LocalSource::Beams`] and a spot or point light.
    pub fn surface_caustics_from_beams(&self, light: &crate::scene::Light) -> bool {
        self.sources.local == LocalSource::Beams && !matches!(light, crate::scene::Light::Directional { .. })
    }

    /// Whether `composite` keeps the camera paths' segments in the medium beyond the first
    /// specular surface ([`MediumSettings::beyond_specular`] and a medium).
    pub fn medium_segments_active(&self, scene: &crate::scene::Scene) -> bool {
        self.medium.beyond_specular && scene.medium.is_some()
    }

    /// Whether the volume caustic is gathered (`beam_gather`): a medium that scatters, a
    /// specular caster, and [`VolumeSource::Beams`].
    pub fn beams_volume_active(&self, scene: &crate::scene::Scene) -> bool {
        self.sources.volume == VolumeSource::Beams
            && scene.medium.as_ref().is_some_and(|m| m.sigma_s.max_element() > 0.0)
            && scene.objects.iter().any(|o| scene.material_of(o).is_specular())
    }

    /// Whether the caustic on surfaces comes from the beams (`beam_surface`):
    /// [`LocalSource::Beams`] and a specular caster (with or without a medium;
    /// `sources.volume` switches the volume caustic only).
    pub fn beams_surface_active(&self, scene: &crate::scene::Scene) -> bool {
        self.sources.local == LocalSource::Beams && scene.objects.iter().any(|o| scene.material_of(o).is_specular())
    }

    /// Whether the directional lights' caustics come from caustic spheres (their photon stages
    /// skipped).
    pub fn caustic_spheres(&self) -> bool {
        self.sources.distant == DistantSource::Spheres
    }

    /// Whether the beam stages (`crate::beams`) run for this scene: the volume caustic, the
    /// surface caustic or both.
    pub fn beams_active(&self, scene: &crate::scene::Scene) -> bool {
        self.beams_volume_active(scene) || self.beams_surface_active(scene)
    }

    /// The warning for a scene with absorbing dielectrics whose caustics (some of them) come
    /// from beams or caustic spheres, which draw the glass clear; `None` when none applies.
    pub fn absorption_warning(&self, scene: &crate::scene::Scene) -> Option<String> {
        let absorbing = scene.objects.iter().any(|o| scene.material_of(o).absorption().max_element() > 0.0);
        if !absorbing {
            return None;
        }
        let spheres = self.caustic_spheres()
            && (scene.environment.is_some()
                || scene.lights.iter().any(|l| matches!(l, crate::scene::Light::Directional { .. })));
        let what = match (self.beams_active(scene), spheres) {
            (false, false) => return None,
            (true, false) => "beams",
            (false, true) => "caustic spheres",
            (true, true) => "beams and caustic spheres",
        };
        Some(format!(
            "{}: absorption is ignored by beams/caustic spheres: the caustics from {what} are drawn as through clear glass",
            scene.source
        ))
    }
}

/// What a frame also copies out for inspection (tests and tools that look inside the photon
/// stage; not part of rendering): set with `Renderer::set_inspect` or
/// `render::render_inspect`, read in [`crate::techniques::TechniqueStats`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Inspect {
    /// Keep the coverage masks (caster front-buffer texels per face,
    /// `TechniqueStats::coverage_masks`), for tests that model the traversal on the CPU.
    pub coverage: bool,
    /// Basic technique with a photon-buffer splat (not `triangles`): keep every traced photon
    /// (`TechniqueStats::photons`; memory grows with the grid).
    pub photons: bool,
}
