//! The `beams` section: volume (and surface) caustics by adaptive beam tracing.
//! (Where the surface caustic of spot and point lights comes from is `sources.local`.)

use serde::{Deserialize, Serialize};

/// How the volume caustic's beams reach the pixels ([`BeamSettings::volume`]). Both add the same
/// light per pixel and beam (`shaders/shared/beam_scatter.wgsl`); only the order of the sums
/// differs, and each is the same bits from run to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
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
    /// Every variant.
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

    /// The variant named `s` on the command line (surrounding whitespace ignored).
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
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BeamSettings {
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
    /// Surface caustics from beams ([`LocalSource::Beams`](super::LocalSource::Beams)): points per pixel side on the
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
    /// cutoff"). Beams whose ends light a surface ([`LocalSource::Beams`](super::LocalSource::Beams)) are not cut.
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
