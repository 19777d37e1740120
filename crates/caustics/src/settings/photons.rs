//! The `photons` section: the photon grid, how photons are emitted, traced and splatted, and
//! the caustic maps they land in.

use serde::{Deserialize, Serialize};

/// The photon caustic maps: how many photons, emitted how ([`Emission`]), traced how
/// ([`Tracer`]), splatted how ([`SplatMode`]), into caustic maps of what size.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PhotonSettings {
    /// Photon grid size N per light-view face: N × N photons (the equivalent, finest grid of
    /// the adaptive techniques), 16 to 8192 (adaptive: a power of two up to 65536).
    pub count: u32,
    /// How photons are emitted (the photon maps' technique).
    pub emission: Emission,
    /// How photons are traced from the first caster to the receiver.
    pub tracer: Tracer,
    /// Exact tracer: specular interactions a photon path may have before it is given up (its
    /// flux is then booked as lost), 1 to 64.
    pub max_depth: u32,
    /// How photons are splatted into the caustic map (`crate::splat`).
    pub splat: SplatMode,
    /// Gaussian splat standard deviation, in caustic-map texels (fixed splats; the fallback and
    /// smallest sizes of the other modes scale with it), in (0.1, 16].
    pub splat_sigma: f32,
    /// Caustic map (and receiver map) size M per face: a multiple of 16 from 16 to 2048.
    pub caustic_map_size: u32,
    /// Memory for photon storage (bytes): the grid (basic), the tiles (hierarchical) or the
    /// hierarchy (adaptive) is processed in batches that fit.
    pub memory: u64,
    /// Also trace the light reflected at the first dielectric surface (a second photon per cell,
    /// weighted by Fresnel reflectance; the first carries the transmitted light): basic, a
    /// second pass over the grid; hierarchical and adaptive, a second traversal.
    pub reflection: bool,
    /// Exact tracer: also trace the light reflected once inside a dielectric at its first exit
    /// (a third photon per cell, weighted by that Fresnel reflectance; the others carry the
    /// transmitted part). The light reflected inside more than once is booked as untraced
    /// (`FluxStats::untraced_branches`).
    pub internal_reflection: bool,
    /// Exact tracer: also trace the residual pass: every Fresnel choice made at random with its
    /// probability (as the CPU reference does), keeping the paths the other passes do not
    /// follow (light reflected inside glass more than once, reflections at later interfaces).
    /// Unbiased, so the caustic's energy matches the reference; noisy where those paths carry
    /// much (complex meshes), and one more pass over the grid.
    pub residual: bool,
}

impl Default for PhotonSettings {
    fn default() -> Self {
        PhotonSettings {
            count: 1024,
            emission: Emission::Basic,
            tracer: Tracer::default(),
            max_depth: 16,
            splat: SplatMode::default(),
            splat_sigma: 1.0,
            caustic_map_size: 1024,
            memory: 64 << 20,
            reflection: true,
            internal_reflection: true,
            residual: true,
        }
    }
}

impl PhotonSettings {
    /// Check the ranges that do not depend on the device: (field path, message) on error.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        let max_n = self.emission.max_photons();
        if !(16..=max_n).contains(&self.count) {
            return Err((
                "photons.count",
                format!("the {} photon grid must be 16 to {max_n} per side (got {})", self.emission, self.count),
            ));
        }
        if !(1..=64).contains(&self.max_depth) {
            return Err(("photons.max_depth", format!("must be 1 to 64 interactions (got {})", self.max_depth)));
        }
        if !(self.splat_sigma > 0.1 && self.splat_sigma <= 16.0) {
            return Err(("photons.splat_sigma", format!("must lie in (0.1, 16] texels (got {})", self.splat_sigma)));
        }
        if self.memory < 64 * 32 {
            return Err(("photons.memory", "must be at least 2 KiB".into()));
        }
        Ok(())
    }
}

/// How photons are emitted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Emission {
    /// Basic caustic maps: a dense N × N photon grid per light-view face.
    #[default]
    Basic,
    /// Hierarchical caustic maps: the dense grid, then a top-down traversal of a mip hierarchy
    /// of valid photons that skips irrelevant regions.
    Hierarchical,
    /// Adaptive caustic maps, maximal traversal level: every relevant cluster is refined down
    /// to the finest grid N (equivalent to a dense N × N grid).
    AdaptiveLevel,
    /// Adaptive caustic maps, maximal caustic map error: a cluster whose photons land in one
    /// caustic-map texel (or within the tolerance) is emitted as one photon; the finest grid N
    /// caps the refinement.
    AdaptiveError,
}

impl Emission {
    /// Every variant.
    pub const ALL: [Emission; 4] =
        [Emission::Basic, Emission::Hierarchical, Emission::AdaptiveLevel, Emission::AdaptiveError];

    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Emission::Basic => "basic",
            Emission::Hierarchical => "hierarchical",
            Emission::AdaptiveLevel => "adaptive-level",
            Emission::AdaptiveError => "adaptive-error",
        }
    }

    /// One line on what it does (the command line's help).
    pub fn describe(self) -> &'static str {
        match self {
            Emission::Basic => "Basic caustic maps: a dense N x N photon grid per light-view face",
            Emission::Hierarchical => {
                "Hierarchical caustic maps: the dense grid, traversed top-down through a mip hierarchy"
            }
            Emission::AdaptiveLevel => {
                "Adaptive caustic maps, maximal traversal level (equivalent to a dense N x N grid)"
            }
            Emission::AdaptiveError => "Adaptive caustic maps, maximal caustic map error (finest grid N)",
        }
    }

    /// The variant named `s` on the command line (surrounding whitespace ignored).
    pub fn parse(s: &str) -> Option<Emission> {
        Emission::ALL.into_iter().find(|t| t.name() == s.trim())
    }

    /// Whether it is one of the adaptive caustic maps (maximal level or maximal error).
    pub fn is_adaptive(self) -> bool {
        matches!(self, Emission::AdaptiveLevel | Emission::AdaptiveError)
    }

    /// The largest finest grid N this technique supports.
    pub fn max_photons(self) -> u32 {
        if self.is_adaptive() { 65536 } else { 8192 }
    }
}

impl std::fmt::Display for Emission {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// How photons find their way from the first caster to the receiver.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Tracer {
    /// Exact paths through the scene: meshes by a BVH, analytic shapes in closed form, every
    /// interface with Fresnel, total internal reflection, up to `max_depth` interactions
    /// (`shaders/shared/raytrace.wgsl`, `src/accel.rs`).
    #[default]
    Exact,
    /// The papers' image-space tracer: the light's caster front/back buffers (and their second
    /// layer), marched; the receiver found in the receiver map.
    ImageSpace,
}

impl Tracer {
    /// Every variant.
    pub const ALL: [Tracer; 2] = [Tracer::Exact, Tracer::ImageSpace];

    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Tracer::Exact => "exact",
            Tracer::ImageSpace => "image-space",
        }
    }

    /// One line on what it does (the command line's help).
    pub fn describe(self) -> &'static str {
        match self {
            Tracer::Exact => "Exact photon paths through a BVH of the scene (the default)",
            Tracer::ImageSpace => "The papers' image-space tracer through the light's caster buffers (for comparison)",
        }
    }

    /// The variant named `s` on the command line (surrounding whitespace ignored).
    pub fn parse(s: &str) -> Option<Tracer> {
        Tracer::ALL.into_iter().find(|t| t.name() == s.trim())
    }
}

impl std::fmt::Display for Tracer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// How photons are splatted into the caustic map.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SplatMode {
    /// A Gaussian of fixed width ([`PhotonSettings::splat_sigma`] texels).
    Fixed,
    /// Adaptive multi-resolution splatting: radii 1.5, 3.5, 5.5, 7.5 × `splat_sigma` texels.
    #[serde(rename = "multires")]
    MultiRes,
    /// Splat sizes from the thin-lens equations.
    ThinLens,
    /// Splat sizes from the thick-lens equations (principal planes, thickness).
    ThickLens,
    /// Splat sizes from ray differentials (Igehy 1999) carried through every interaction: the
    /// exact first-order image of the photon's cell on the receiver (beyond the papers).
    Differential,
    /// Caustic triangles: from the dense photon grid (basic technique) or from the cell quads of
    /// the adaptive hierarchy (adaptive techniques) or dual quads (hierarchical technique).
    #[default]
    Triangles,
}

impl SplatMode {
    /// Every variant.
    pub const ALL: [SplatMode; 6] = [
        SplatMode::Fixed,
        SplatMode::MultiRes,
        SplatMode::ThinLens,
        SplatMode::ThickLens,
        SplatMode::Differential,
        SplatMode::Triangles,
    ];

    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            SplatMode::Fixed => "fixed",
            SplatMode::MultiRes => "multires",
            SplatMode::ThinLens => "thin-lens",
            SplatMode::ThickLens => "thick-lens",
            SplatMode::Differential => "differential",
            SplatMode::Triangles => "triangles",
        }
    }

    /// One line on what it does (the command line's help).
    pub fn describe(self) -> &'static str {
        match self {
            SplatMode::Fixed => "A Gaussian of fixed width (photons.splat_sigma texels)",
            SplatMode::MultiRes => "Adaptive multi-resolution splatting (Wyman & Dachsbacher 2008, section 4.1)",
            SplatMode::ThinLens => "Splat sizes from the thin-lens equations (Wyman & Dachsbacher 2008, section 4.2)",
            SplatMode::ThickLens => "Splat sizes from the thick-lens equations",
            SplatMode::Differential => {
                "Splat sizes from ray differentials carried through every interaction (exact first-order beam size)"
            }
            SplatMode::Triangles => {
                "Caustic triangles: flux spread over the area between adjacent photons (the default)"
            }
        }
    }

    /// The variant named `s` on the command line (surrounding whitespace ignored).
    pub fn parse(s: &str) -> Option<SplatMode> {
        SplatMode::ALL.into_iter().find(|m| m.name() == s.trim())
    }

    /// What the tracer writes into `light.splat.x`: 1 thin-lens, 2 thick-lens beam diameters.
    /// Triangles write none (0): the hierarchical and adaptive techniques use `Photon._pad` to
    /// mark photons that carry a quad (`splat_quads`).
    /// Caustic triangles from the dense grid (basic technique) take ray-differential beam sizes
    /// too: their continuity test and their Gaussian fallback use them.
    pub fn lens_flag(self, technique: Emission) -> f32 {
        match self {
            SplatMode::ThinLens => 1.0,
            SplatMode::ThickLens => 2.0,
            SplatMode::Differential => 3.0,
            SplatMode::Triangles if technique == Emission::Basic => 3.0,
            _ => 0.0,
        }
    }

    /// The splat stage that takes a photon buffer: for triangles, `splat_quads` (quads, or
    /// Gaussians where a photon has none) with the hierarchical and adaptive techniques (the
    /// basic one draws `caustic_triangles` instead).
    pub fn stage(self, technique: Emission) -> &'static str {
        match self {
            SplatMode::Fixed => "photon_splat",
            SplatMode::MultiRes => "splat_multires",
            SplatMode::Triangles if technique != Emission::Basic => "splat_quads",
            SplatMode::ThinLens | SplatMode::ThickLens | SplatMode::Differential | SplatMode::Triangles => "splat_lens",
        }
    }

    /// The photon hierarchy stores a quad per photon for `splat_quads`: the adaptive techniques
    /// trace each cell's corners, the hierarchical one takes its dual quad from the dense tile.
    pub fn cell_quads(self, technique: Emission) -> bool {
        self == SplatMode::Triangles && technique != Emission::Basic
    }
}

impl std::fmt::Display for SplatMode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}
