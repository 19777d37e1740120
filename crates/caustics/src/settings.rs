//! What a frame is asked to do: the settings of a GPU render, the photon emission technique and
//! the splat mode. Every other module reads them; this one depends on none of them.

use crate::scene::Tessellation;

/// The largest caster geometry buffer; denser photon grids interpolate between its texels.
pub(crate) const MAX_GBUFFER: u32 = 2048;

/// How photons are emitted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub enum Technique {
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
    /// Caustic spheres (Tandianus et al. 2010, `crate::caustic_spheres`): the caustics of
    /// directional lights (the scene's and the environment's) come from tables precomputed per
    /// caustic object (`Renderer::set_caustic_spheres`), looked up by one eye-space pass
    /// (`sphere_gather`) for all of them; their light passes trace no photons. Spot and point
    /// lights, which the tables do not describe, get basic caustic maps
    /// ([`Technique::emission`]).
    CausticSpheres,
}

impl Technique {
    pub const ALL: [Technique; 5] = [
        Technique::Basic,
        Technique::Hierarchical,
        Technique::AdaptiveLevel,
        Technique::AdaptiveError,
        Technique::CausticSpheres,
    ];

    /// The photon emission technique of the lights' caustic maps: itself, or for caustic
    /// spheres the basic one (the spot and point lights' caustic maps).
    pub fn emission(self) -> Technique {
        match self {
            Technique::CausticSpheres => Technique::Basic,
            t => t,
        }
    }

    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Technique::Basic => "basic",
            Technique::Hierarchical => "hierarchical",
            Technique::AdaptiveLevel => "adaptive-level",
            Technique::AdaptiveError => "adaptive-error",
            Technique::CausticSpheres => "caustic-spheres",
        }
    }

    /// One line on what it does (the command line's help).
    pub fn describe(self) -> &'static str {
        match self {
            Technique::Basic => "Basic caustic maps: a dense N x N photon grid per light-view face",
            Technique::Hierarchical => {
                "Hierarchical caustic maps: the dense grid, traversed top-down through a mip hierarchy"
            }
            Technique::AdaptiveLevel => {
                "Adaptive caustic maps, maximal traversal level (equivalent to a dense N x N grid)"
            }
            Technique::AdaptiveError => "Adaptive caustic maps, maximal caustic map error (finest grid N)",
            Technique::CausticSpheres => {
                "Caustic spheres: directional lights from precomputed tables, one eye-space pass (others: basic)"
            }
        }
    }

    pub fn parse(s: &str) -> Option<Technique> {
        Technique::ALL.into_iter().find(|t| t.name() == s.trim())
    }

    pub fn is_adaptive(self) -> bool {
        matches!(self, Technique::AdaptiveLevel | Technique::AdaptiveError)
    }

    /// The largest finest grid N this technique supports.
    pub fn max_photons(self) -> u32 {
        if self.is_adaptive() { 65536 } else { 8192 }
    }
}

impl std::fmt::Display for Technique {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// How photons find their way from the first caster to the receiver.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
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
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub enum SplatMode {
    /// A Gaussian of fixed width (`splat_sigma` texels).
    Fixed,
    /// Adaptive multi-resolution splatting: radii 1.5, 3.5, 5.5, 7.5 × `splat_sigma` texels.
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
            SplatMode::Fixed => "A Gaussian of fixed width (--splat-sigma texels)",
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

    pub fn parse(s: &str) -> Option<SplatMode> {
        SplatMode::ALL.into_iter().find(|m| m.name() == s.trim())
    }

    /// What the tracer writes into `light.splat.x`: 1 thin-lens, 2 thick-lens beam diameters.
    /// Triangles write none (0): the hierarchical and adaptive techniques use `Photon._pad` to
    /// mark photons that carry a quad (`splat_quads`).
    /// Caustic triangles from the dense grid (basic technique) take ray-differential beam sizes
    /// too: their continuity test and their Gaussian fallback use them.
    pub fn lens_flag(self, technique: Technique) -> f32 {
        match self {
            SplatMode::ThinLens => 1.0,
            SplatMode::ThickLens => 2.0,
            SplatMode::Differential => 3.0,
            SplatMode::Triangles if technique == Technique::Basic => 3.0,
            _ => 0.0,
        }
    }

    /// The splat stage that takes a photon buffer: for triangles, `splat_quads` (quads, or
    /// Gaussians where a photon has none) with the hierarchical and adaptive techniques (the
    /// basic one draws `caustic_triangles` instead).
    pub fn stage(self, technique: Technique) -> &'static str {
        match self {
            SplatMode::Fixed => "photon_splat",
            SplatMode::MultiRes => "splat_multires",
            SplatMode::Triangles if technique != Technique::Basic => "splat_quads",
            SplatMode::ThinLens | SplatMode::ThickLens | SplatMode::Differential | SplatMode::Triangles => "splat_lens",
        }
    }

    /// The photon hierarchy stores a quad per photon for `splat_quads`: the adaptive techniques
    /// trace each cell's corners, the hierarchical one takes its dual quad from the dense tile.
    pub fn cell_quads(self, technique: Technique) -> bool {
        self == SplatMode::Triangles && technique != Technique::Basic
    }
}

impl std::fmt::Display for SplatMode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Settings of a GPU render.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderSettings {
    /// Photon grid size N per light-view face: N × N photons (the equivalent, finest grid of
    /// the adaptive techniques).
    pub photons: u32,
    /// How photons are emitted.
    pub technique: Technique,
    /// How photons are traced from the first caster to the receiver.
    pub tracer: Tracer,
    /// Exact tracer: specular interactions a photon path may have before it is given up (its
    /// flux is then booked as lost).
    pub max_depth: u32,
    /// Exact tracer: take each photon's first caster surface from the light's caster front
    /// buffer (the papers' deferred emission: a texel's tangent plane) instead of tracing the
    /// BVH from the light; the rest of the path is exact. Off by default (the comparison is in
    /// `docs/benchmarks.md`).
    pub first_hit_from_buffer: bool,
    /// Adaptive techniques: the coarse grid the hierarchy starts from (a power of two).
    pub base_grid: u32,
    /// Maximal caustic map error: a cluster converges when its photons land in one caustic-map
    /// texel (0) or within this many texels (> 0).
    pub max_error_tolerance: f32,
    /// Maximal caustic map error: convergence is checked for clusters whose photons lie on a grid
    /// of at least this size (Wyman & Nichols check from the 512² level on).
    pub error_check_grid: u32,
    /// Maximal caustic map error with caustic triangles: an optional second stopping rule (0:
    /// off, the default: the paper's rule alone). A cluster also converges when its cell quad
    /// maps linearly enough: its corner lattice and children's photons land within this many
    /// caustic-map texels of the bilinear interpolation of its corners (`docs/adaptive.md`).
    pub quad_linearity: f32,
    /// Maximal caustic map error: skip the convergence check on levels where the spread of a
    /// cluster's children predicts that it cannot pass (`docs/adaptive.md`); the check would
    /// only trace photons to refine them. On by default; off gives the paper's traversal.
    pub error_skip_hopeless: bool,
    /// Caustic map (and receiver map) size M per face.
    pub caustic_map_size: u32,
    /// Shadow map size per face.
    pub shadow_map_size: u32,
    /// Gaussian splat standard deviation, in caustic-map texels (fixed splats; the fallback and
    /// smallest sizes of the other modes scale with it).
    pub splat_sigma: f32,
    /// How photons are splatted into the caustic map (`crate::splat`).
    pub splat: SplatMode,
    /// Also trace the light reflected at the first dielectric surface (a second photon per cell,
    /// weighted by Fresnel reflectance; the first carries the transmitted light): basic, a
    /// second pass over the grid; hierarchical and adaptive, a second traversal.
    pub dielectric_reflection: bool,
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
    pub residual_branches: bool,
    /// Rasterize the light's second caster layer (`light_caster_front2`, `light_caster_back2`:
    /// per texel, the nearest caster of another object behind the first layer's) when the scene
    /// has caster meshes and two casters or more, so that photons find and traverse a mesh
    /// hidden from the light behind another caster. Off: only the first layer (the renderer
    /// before it; for comparisons).
    pub light_second_layer: bool,
    /// Memory for photon storage (bytes): the grid (basic), the tiles (hierarchical) or the
    /// hierarchy (adaptive) is processed in batches that fit.
    pub photon_memory: u64,
    pub tessellation: Tessellation,
    /// Scenes with a participating medium: steps of the camera ray march that adds the lights'
    /// single scattering (`medium_scatter`, docs/media.md), 1 to 4096.
    pub medium_steps: u32,
    /// Heterogeneous media (a density grid): steps of each ray march for the transmittance
    /// toward a light (per camera-ray step in `medium_scatter`, per surface point in
    /// `shade_receivers`), 1 to 1024. Homogeneous media use the closed form.
    pub medium_light_steps: u32,
    /// Scenes with a medium: the light diffuse surfaces reflect into it (light → floor → fog
    /// → camera, and the caustic's: light → glass → floor → fog → camera) comes from virtual
    /// point lights, one per block of each light face's receiver map: this many blocks per side
    /// (`medium_bounce_lights`, docs/media.md "Light between surfaces and the medium"), 0 to
    /// 64; 0 leaves that light out.
    pub medium_bounce_grid: u32,
    /// Steps of the camera ray march that gathers the virtual point lights (`medium_bounce`),
    /// 1 to 4096.
    pub medium_bounce_steps: u32,
    /// Scenes with a medium: the medium along the camera paths beyond their first specular
    /// surface (through glass, in mirrors): `composite` attenuates what they see, and the
    /// medium's passes add the light scattered along them (`EyeSegment`, docs/media.md
    /// "The medium beyond the first specular surface"). Default on; off, glass shows what lies
    /// behind it as if the medium ended at its surface (cheaper).
    pub medium_beyond_specular: bool,
    /// Scenes with an environment light: the directional lights it is segmented into (the
    /// cube-map median cut, `scene::environment_lights`), 1 to 256; they light diffuse surfaces
    /// with shadow maps and cast caustics like the scene's own directional lights.
    pub env_lights: u32,
    /// How the median cut picks the region to split (`SplitRule`, default: by flux-weighted
    /// angular radius; `Total` is the paper's rule), for comparisons.
    pub env_split: crate::scene::environment_lights::SplitRule,
    /// Sub-directions each environment region's caustic is spread over (`crate::env_taps`),
    /// 0 to 32; 0 or 1: none (each region's caustic from its one direction, as the paper).
    pub env_taps: u32,
    /// Volume caustics by adaptive beam tracing in scenes with a medium (`crate::beams`).
    pub beams: BeamSettings,
    /// Where the caustic on diffuse surfaces of spot and point lights comes from: the photon
    /// caustic maps (default) or the beams (`crate::beams`, `beam_surface`; the lights' photon
    /// stages are then skipped, so neither is counted twice). Directional lights always use
    /// their caustic maps (beams are built for spot and point lights only).
    pub surface_caustics: SurfaceCaustics,
    /// `shade_receivers` skips the caustic lookups where the light's caustic map is zero and
    /// the shadow lookups where its shadow map is all in front or all behind, as per-tile
    /// summaries made with the light's maps say (`caustic_mask`, `shadow_tiles`). The image is
    /// the same bit for bit; off only to check that (tests) or to time the difference.
    pub shading_tiles: bool,
    /// Spill faces of spot lights (`crate::lightspace::spill_face`): a second, wider face that
    /// receives the caustic light glass bends outside the spot's own view.
    pub spill_faces: SpillFaces,
}

/// Whether spot lights get a spill face ([`RenderSettings::spill_faces`]; the rule is
/// `RenderSettings::uses_spill_face`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
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
    pub const ALL: [SpillFaces; 3] = [SpillFaces::Auto, SpillFaces::Off, SpillFaces::On];

    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            SpillFaces::Auto => "auto",
            SpillFaces::Off => "off",
            SpillFaces::On => "on",
        }
    }

    pub fn parse(s: &str) -> Option<SpillFaces> {
        SpillFaces::ALL.into_iter().find(|m| m.name() == s.trim())
    }
}

impl std::fmt::Display for SpillFaces {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The source of the caustic on diffuse surfaces ([`RenderSettings::surface_caustics`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub enum SurfaceCaustics {
    /// The lights' photon caustic maps (`shade_receivers`).
    #[default]
    Photons,
    /// The beams of adaptive beam tracing (Liktor & Dachsbacher 2011, section 5.3): per
    /// camera pixel, the irradiance of the beams that end on its surface point
    /// (`beam_surface`), for spot and point lights, with or without a medium.
    Beams,
}

impl SurfaceCaustics {
    pub const ALL: [SurfaceCaustics; 2] = [SurfaceCaustics::Photons, SurfaceCaustics::Beams];

    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            SurfaceCaustics::Photons => "photons",
            SurfaceCaustics::Beams => "beams",
        }
    }

    /// One line on what it does (the command line's help).
    pub fn describe(self) -> &'static str {
        match self {
            SurfaceCaustics::Photons => "The lights' photon caustic maps (the default)",
            SurfaceCaustics::Beams => {
                "Spot and point lights: the light of adaptive beam tracing's beams where they end on surfaces, drawn as their hulls or gathered per pixel as --beam-volume says (no photon maps)"
            }
        }
    }

    pub fn parse(s: &str) -> Option<SurfaceCaustics> {
        SurfaceCaustics::ALL.into_iter().find(|m| m.name() == s.trim())
    }
}

impl std::fmt::Display for SurfaceCaustics {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl RenderSettings {
    /// Whether `light`'s caustic on surfaces comes from its beams (and its photon stage is
    /// skipped): [`SurfaceCaustics::Beams`] and a spot or point light.
    pub fn surface_caustics_from_beams(&self, light: &crate::scene::Light) -> bool {
        self.surface_caustics == SurfaceCaustics::Beams && !matches!(light, crate::scene::Light::Directional { .. })
    }

    /// Whether the volume caustic is gathered (`beam_gather`): a medium that scatters, a
    /// specular caster, and the beams enabled.
    /// Whether `composite` keeps the camera paths' segments in the medium beyond the first
    /// specular surface ([`Self::medium_beyond_specular`] and a medium).
    pub fn medium_segments_active(&self, scene: &crate::scene::Scene) -> bool {
        self.medium_beyond_specular && scene.medium.is_some()
    }

    pub fn beams_volume_active(&self, scene: &crate::scene::Scene) -> bool {
        self.beams.enabled
            && scene.medium.as_ref().is_some_and(|m| m.sigma_s.max_element() > 0.0)
            && scene.objects.iter().any(|o| scene.material_of(o).is_specular())
    }

    /// Whether the caustic on surfaces comes from the beams (`beam_surface`):
    /// [`SurfaceCaustics::Beams`] and a specular caster (with or without a medium;
    /// `BeamSettings::enabled` switches the volume caustic only).
    pub fn beams_surface_active(&self, scene: &crate::scene::Scene) -> bool {
        self.surface_caustics == SurfaceCaustics::Beams
            && scene.objects.iter().any(|o| scene.material_of(o).is_specular())
    }

    /// Whether the beam stages (`crate::beams`) run for this scene: the volume caustic, the
    /// surface caustic or both.
    pub fn beams_active(&self, scene: &crate::scene::Scene) -> bool {
        self.beams_volume_active(scene) || self.beams_surface_active(scene)
    }
}

/// How the volume caustic's beams reach the pixels ([`BeamSettings::volume`]). Both add the same
/// light per pixel and beam (`shaders/shared/beam_scatter.wgsl`); only the order of the sums
/// differs, and each is the same bits from run to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub enum BeamVolume {
    /// Hulls where the device blends float32 targets, else the gather.
    #[default]
    Auto,
    /// Per pixel, a loop over every beam, culled by its bounding sphere (`beam_gather`): the
    /// work grows with pixels times beams.
    Gather,
    /// The paper's way: each beam's hull drawn indirectly (`beam_hull`, `beam_raster`), so a
    /// beam costs only the pixels its hull covers. Needs float32 blending
    /// (`wgpu::Features::FLOAT32_BLENDABLE`).
    Hulls,
}

impl BeamVolume {
    pub const ALL: [BeamVolume; 3] = [BeamVolume::Auto, BeamVolume::Gather, BeamVolume::Hulls];

    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            BeamVolume::Auto => "auto",
            BeamVolume::Gather => "gather",
            BeamVolume::Hulls => "hulls",
        }
    }

    /// One line on what it does (the command line's help).
    pub fn describe(self) -> &'static str {
        match self {
            BeamVolume::Auto => "Hulls where the adapter blends float32 targets, else the gather (the default)",
            BeamVolume::Gather => "Per pixel, a loop over every beam",
            BeamVolume::Hulls => "Each beam's hull drawn indirectly: work only where a beam can reach",
        }
    }

    pub fn parse(s: &str) -> Option<BeamVolume> {
        BeamVolume::ALL.into_iter().find(|m| m.name() == s.trim())
    }

    /// Why this way cannot run on `ctx`'s device (hulls without float32 blending), if it cannot.
    pub fn unsupported(self, ctx: &crate::gpu::GpuContext) -> Option<String> {
        (self == BeamVolume::Hulls && !ctx.device.features().contains(wgpu::Features::FLOAT32_BLENDABLE))
            .then(|| format!("hulls need float32 blending, which {} does not offer (use gather)", ctx.info.name))
    }

    /// The way used on a device with `features`: [`BeamVolume::Auto`] resolved.
    pub fn on(self, features: wgpu::Features) -> BeamVolume {
        match self {
            BeamVolume::Auto if features.contains(wgpu::Features::FLOAT32_BLENDABLE) => BeamVolume::Hulls,
            BeamVolume::Auto => BeamVolume::Gather,
            v => v,
        }
    }
}

impl std::fmt::Display for BeamVolume {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Volume caustics by adaptive beam tracing (Liktor & Dachsbacher 2011; `crate::beams`,
/// docs/beams.md "Volume caustics from beams"). Used in scenes with a participating
/// medium and a specular caster, for every spot and point light.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeamSettings {
    /// Render the volume caustic (on by default; off: the medium's direct light only).
    pub enabled: bool,
    /// Cells per side of the projected grid over each light face (two beams per cell), 1 to 1024.
    pub grid: u32,
    /// Refinement levels (each splits a triangle 1 -> 4), 0 (a regular grid) to 6.
    pub levels: u32,
    /// Split where the edges' normals at the first specular surface differ by more than this
    /// angle (degrees).
    pub normal_threshold_deg: f32,
    /// Split where the edges' distances from the light to the first surface differ by more
    /// than this fraction of their mean.
    pub depth_threshold: f32,
    /// Split where the beam's flux, relative to the flux of the light face at the light's peak
    /// intensity, times its convergence (base area over its smallest cross-section before the
    /// receiver, at least 1), exceeds this.
    pub energy_threshold: f32,
    /// Split where the beam's width over its distance from the camera exceeds this (radians).
    pub camera_threshold: f32,
    /// Split where a beam misplaces more than this fraction of the triangle's light: the exactly
    /// traced edge of the triangle's centroid against the beam's line of barycentrics (1/3, 1/3,
    /// 1/3), at the beam's start and farthest end, over the beam's width, times the share of the
    /// light toward the triangle the beam carries (ours, not the paper's: its criteria see the
    /// corners only, and where refraction or reflection bends fast, near a silhouette, a coarse
    /// beam puts its light off its true place). 0 turns it off.
    pub linearity_threshold: f32,
    /// Beams held per light (more are dropped and reported as an overflow).
    pub capacity: u32,
    /// Midpoint-rule points per piece of a camera ray inside a beam.
    pub samples: u32,
    /// Camera rays per pixel side (the box pixel filter: n² stratified rays per pixel), 1 to 8.
    /// Default 1 (the pixel centre; n rays cost n² times the gather).
    pub pixel_samples: u32,
    /// Surface caustics from beams ([`SurfaceCaustics::Beams`]): points per pixel side on the
    /// surface's tangent plane (the box pixel filter: n² stratified points, each tested in the
    /// beams), 1 to 8. Default 4 (a point test is cheap; the caustic's focal lines are thinner
    /// than a pixel).
    pub surface_samples: u32,
    /// Also the beams of light reflected at the first dielectric surface, and of light
    /// reflected once inside it (refracted in, reflected, refracted out).
    pub reflection: bool,
    /// With `reflection`, the residual branch: the light reflected partially at an interface the
    /// reflected branches do not follow (the fifth interaction or later, or two partial
    /// reflections or more: on a mesh caster whose light enters and leaves it several times,
    /// some 8 % of the in-medium light). Its Fresnel choices are drawn at random, the same for a
    /// whole triangle of the grid: at each dielectric interface it reflects with probability
    /// p = max(F, this) (weight F / p, else transmits with (1 − F) / (1 − p)), and the
    /// triangle's beam is kept only where the path so drawn is not another branch's. Unbiased;
    /// deterministic (the draws are keyed by the triangle). 0 turns it off; below 1.
    pub residual: f32,
    /// The paper's energy cutoff (section 4.3: a divergent beam is extruded only as far as its
    /// light is not negligible), as a radiance in W/(m² sr): a beam that diverges beyond its
    /// last focus ends where the light of the rest of it, seen along its length (the most a
    /// camera ray through it can collect: σs · the phase function's largest value · flux ·
    /// ∫ dl / A, bounded by the section's growth, transmittance left out), is this. The bound is
    /// per beam: a pixel that sees many beams' tails loses up to this for each, and the light
    /// of a faint glow made of many beams goes first (docs/benchmarks.md, "Beams: the energy
    /// cutoff"). Beams whose ends light a surface ([`SurfaceCaustics::Beams`]) are not cut.
    /// Shorter hulls cost fewer fragments. 0 (the default) draws every beam to its end.
    pub cutoff: f32,
    /// The footprint integral of the volume caustic (`beam_gather`): where a beam's
    /// cross-section, seen from the camera, is narrower than this many pixels (near a focus, the
    /// caustic's singular lines), its light is integrated over each pixel's footprint in beam
    /// space instead of sampled by the pixel's rays. 0 turns it off (rays only), at most 64.
    pub footprint: f32,
    /// Lines per side of a thin section in the footprint integral (lines² lines of constant
    /// barycentrics, each clipped exactly to the pixel), 1 to 4.
    pub footprint_lines: u32,
    /// Beams per dispatch of the gather and of the surface caustic, as a multiple of what
    /// lavapipe allows (its shaders end an invocation's loops after some 65536 iterations in
    /// all): 0 (default) chooses, 1 on CPU adapters and 16 on GPUs; at most 1024. Larger chunks
    /// mean fewer dispatches and barriers; the image changes only in the order of its sums.
    pub chunk_scale: u32,
    /// How the volume caustic is drawn: a per-pixel gather or the beams' hulls.
    pub volume: BeamVolume,
}

impl Default for BeamSettings {
    fn default() -> Self {
        BeamSettings {
            enabled: true,
            grid: 16,
            levels: 3,
            normal_threshold_deg: 25.0,
            depth_threshold: 0.1,
            energy_threshold: 0.05,
            camera_threshold: 0.2,
            linearity_threshold: 0.05,
            capacity: 1 << 17,
            samples: 4,
            pixel_samples: 1,
            surface_samples: 4,
            reflection: true,
            residual: 0.3,
            cutoff: 0.0,
            footprint: 2.0,
            footprint_lines: 2,
            chunk_scale: 0,
            volume: BeamVolume::Auto,
        }
    }
}

impl BeamSettings {
    /// A regular grid of `grid` cells per side (no refinement).
    pub fn regular(grid: u32) -> BeamSettings {
        BeamSettings { grid, levels: 0, ..Default::default() }
    }

    /// Check the beam settings: (field, message) on error.
    pub fn validate(&self) -> std::result::Result<(), (&'static str, String)> {
        let b = self;
        if !(1..=1024).contains(&b.grid) {
            return Err(("beams.grid", format!("must be 1 to 1024 cells (got {})", b.grid)));
        }
        if b.levels > 6 {
            return Err(("beams.levels", format!("must be 0 to 6 (got {})", b.levels)));
        }
        if b.slots_per_face() * 6 > 4_000_000 {
            return Err((
                "beams.grid",
                format!(
                    "a grid of {} with {} levels has {} triangle slots per face; at most 666666 (6 faces)",
                    b.grid,
                    b.levels,
                    b.slots_per_face()
                ),
            ));
        }
        if !(b.cutoff >= 0.0 && b.cutoff.is_finite()) {
            return Err(("beams.cutoff", format!("must be a radiance of at least 0 W/(m² sr) (got {})", b.cutoff)));
        }
        if !(b.residual >= 0.0 && b.residual < 1.0) {
            return Err(("beams.residual", format!("must be at least 0 and below 1 (got {})", b.residual)));
        }
        if !(b.normal_threshold_deg >= 0.0 && b.normal_threshold_deg <= 180.0) {
            return Err(("beams.normal_threshold_deg", format!("must be 0 to 180 (got {})", b.normal_threshold_deg)));
        }
        for (name, v) in [
            ("beams.depth_threshold", b.depth_threshold),
            ("beams.energy_threshold", b.energy_threshold),
            ("beams.camera_threshold", b.camera_threshold),
        ] {
            if !(v > 0.0 && v.is_finite()) {
                return Err((name, format!("must be a positive number (got {v})")));
            }
        }
        if !(b.linearity_threshold >= 0.0 && b.linearity_threshold.is_finite()) {
            return Err((
                "beams.linearity_threshold",
                format!("must be 0 (off) or a positive number (got {})", b.linearity_threshold),
            ));
        }
        if !(1..=1 << 22).contains(&b.capacity) {
            return Err(("beams.capacity", format!("must be 1 to 4194304 beams (got {})", b.capacity)));
        }
        if !(1..=8).contains(&b.pixel_samples) {
            return Err(("beams.pixel_samples", format!("must be 1 to 8 (got {})", b.pixel_samples)));
        }
        if !(1..=8).contains(&b.surface_samples) {
            return Err(("beams.surface_samples", format!("must be 1 to 8 (got {})", b.surface_samples)));
        }
        if !(1..=64).contains(&b.samples) {
            return Err(("beams.samples", format!("must be 1 to 64 (got {})", b.samples)));
        }
        if !(b.footprint >= 0.0 && b.footprint <= 64.0) {
            return Err(("beams.footprint", format!("must be 0 (off) to 64 pixels (got {})", b.footprint)));
        }
        if !(1..=4).contains(&b.footprint_lines) {
            return Err(("beams.footprint_lines", format!("must be 1 to 4 (got {})", b.footprint_lines)));
        }
        if b.chunk_scale > 1024 {
            return Err(("beams.chunk_scale", format!("must be 0 (automatic) to 1024 (got {})", b.chunk_scale)));
        }
        Ok(())
    }

    /// Slots of the refinement hierarchy per light face and branch: 2 grid^2 (4^(levels+1) - 1) / 3.
    pub fn slots_per_face(&self) -> u64 {
        2 * u64::from(self.grid).pow(2) * ((1u64 << (2 * (self.levels + 1))) - 1) / 3
    }
}

/// The default of [`RenderSettings::env_taps`] (`docs/benchmarks.md`, "Environment caustics
/// spread over their regions").
pub const DEFAULT_ENV_TAPS: u32 = 16;

/// The default of [`RenderSettings::env_lights`]: the paper's 24 (Tandianus et al. 2010).
pub const DEFAULT_ENV_LIGHTS: u32 = 24;

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            photons: 1024,
            technique: Technique::Basic,
            tracer: Tracer::default(),
            max_depth: 16,
            first_hit_from_buffer: false,
            base_grid: 64,
            max_error_tolerance: 0.0,
            error_check_grid: 512,
            quad_linearity: 0.0,
            error_skip_hopeless: true,
            caustic_map_size: 1024,
            shadow_map_size: 2048,
            splat_sigma: 1.0,
            splat: SplatMode::default(),
            dielectric_reflection: true,
            internal_reflection: true,
            residual_branches: true,
            light_second_layer: true,
            photon_memory: 64 << 20,
            tessellation: Tessellation::default(),
            medium_steps: 64,
            medium_light_steps: 16,
            medium_bounce_grid: 16,
            medium_bounce_steps: 8,
            medium_beyond_specular: true,
            env_lights: DEFAULT_ENV_LIGHTS,
            env_split: Default::default(),
            env_taps: DEFAULT_ENV_TAPS,
            beams: BeamSettings::default(),
            surface_caustics: SurfaceCaustics::default(),
            shading_tiles: true,
            spill_faces: SpillFaces::Auto,
        }
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
