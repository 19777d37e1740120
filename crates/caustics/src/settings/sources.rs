//! The `sources` section: where each kind of light's caustics come from, three independent
//! choices (how the photon maps emit their photons is `photons.emission`). The command line's
//! `--technique NAME` is a shorthand that sets them ([`Technique`]).

use serde::{Deserialize, Serialize};

/// Where the caustics of each kind of light come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SourceSettings {
    /// Spot and point lights' caustic on diffuse surfaces.
    pub local: LocalSource,
    /// Directional lights' caustic on diffuse surfaces (the scene's and the environment's).
    pub distant: DistantSource,
    /// Spot and point lights' volume caustic in a scattering medium.
    pub volume: VolumeSource,
}

/// The caustic on surfaces of spot and point lights.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LocalSource {
    /// The lights' photon caustic maps (`shade_receivers`), emitted as `photons.emission` says.
    #[default]
    Photons,
    /// The beams of adaptive beam tracing (Liktor & Dachsbacher 2011, section 5.3): per camera
    /// pixel, the irradiance of the beams that end on its surface point (`beam_surface`), with
    /// or without a medium; the lights' photon stages are skipped (nothing counted twice).
    Beams,
}

/// The caustic on surfaces of directional lights.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DistantSource {
    /// The lights' photon caustic maps.
    #[default]
    Photons,
    /// Caustic spheres (Tandianus et al. 2010, `crate::caustic_spheres`): tables precomputed per
    /// caustic object (`Renderer::set_caustic_spheres`), looked up by one eye-space pass
    /// (`sphere_gather`) for every directional light; their photon stages are skipped. In a
    /// medium, the tables' volume caustic too (`sphere_volume`).
    Spheres,
}

/// The volume caustic of spot and point lights in a scattering medium.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum VolumeSource {
    /// Adaptive beam tracing's beams (`crate::beams`, `beam_gather`), set in the `beams` section.
    #[default]
    Beams,
    /// None: the medium's direct light only.
    None,
}

/// The command line's `--technique NAME`: a shorthand for the choices it sets
/// ([`Technique::apply`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Technique {
    /// An emission technique for every light's photon maps.
    Photons(super::Emission),
    /// Caustic spheres for directional lights; basic photon maps for the others.
    CausticSpheres,
    /// Beams for spot and point lights' surface caustic; basic photon maps for directional lights.
    Beams,
}

impl Technique {
    /// Every variant.
    pub const ALL: [Technique; 6] = [
        Technique::Photons(super::Emission::Basic),
        Technique::Photons(super::Emission::Hierarchical),
        Technique::Photons(super::Emission::AdaptiveLevel),
        Technique::Photons(super::Emission::AdaptiveError),
        Technique::CausticSpheres,
        Technique::Beams,
    ];

    /// Set what this shorthand names (the other choices are left as they are).
    pub fn apply(self, s: &mut super::RenderSettings) {
        match self {
            Technique::Photons(e) => s.photons.emission = e,
            Technique::CausticSpheres => s.sources.distant = DistantSource::Spheres,
            Technique::Beams => s.sources.local = LocalSource::Beams,
        }
    }

    /// The emission technique of the photon maps this shorthand draws (basic for the lights
    /// that caustic spheres and beams leave to photon maps).
    pub fn emission(self) -> super::Emission {
        match self {
            Technique::Photons(e) => e,
            _ => super::Emission::Basic,
        }
    }

    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Technique::Photons(e) => e.name(),
            Technique::CausticSpheres => "caustic-spheres",
            Technique::Beams => "beams",
        }
    }

    /// One line on what it does (the command line's help).
    pub fn describe(self) -> &'static str {
        match self {
            Technique::Photons(e) => e.describe(),
            Technique::CausticSpheres => {
                "Caustic spheres for directional lights: precomputed tables, one eye-space pass (sources.distant=spheres)"
            }
            Technique::Beams => {
                "Adaptive beam tracing (Liktor & Dachsbacher 2011) for the caustics of spot and point lights on surfaces, no photon maps (sources.local=beams)"
            }
        }
    }

    /// The variant named `s` on the command line (surrounding whitespace ignored).
    pub fn parse(s: &str) -> Option<Technique> {
        Technique::ALL.into_iter().find(|t| t.name() == s.trim())
    }
}

impl std::fmt::Display for Technique {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// `ALL`, `name` (the JSON and command-line name) and `describe` (one line of help) of a choice.
macro_rules! named {
    ($t:ident { $($v:ident => $name:literal, $help:literal;)* }) => {
        impl $t {
            /// Every variant.
            pub const ALL: [$t; [$($name),*].len()] = [$($t::$v),*];

            /// The JSON and command-line name.
            pub fn name(self) -> &'static str {
                match self { $($t::$v => $name,)* }
            }

            /// One line on what it does (the command line's and the viewer's help).
            pub fn describe(self) -> &'static str {
                match self { $($t::$v => $help,)* }
            }
        }
    };
}

named!(LocalSource {
    Photons => "photons", "The lights' photon caustic maps (the default)";
    Beams => "beams", "Adaptive beam tracing's beams where they end on surfaces (no photon maps)";
});
named!(DistantSource {
    Photons => "photons", "The lights' photon caustic maps (the default)";
    Spheres => "spheres", "Caustic spheres: the objects' precomputed tables, one eye-space pass";
});
named!(VolumeSource {
    Beams => "beams", "Adaptive beam tracing's beams (the default)";
    None => "none", "No volume caustic: the medium's direct light only";
});
