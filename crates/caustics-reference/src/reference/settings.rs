//! What the reference is asked for and what it returns: [`ReferenceSettings`] (and their
//! limits), [`ReferenceOutput`] and [`ReferenceStats`].

use super::{CausticPaths, DiffuseOrders};
use caustics::error::{Error, Result};
use caustics::image_io::Image;

/// The most photons per light the reference accepts (2^40).
pub const MAX_PHOTONS: u64 = 1 << 40;

/// How much work the reference does.
#[derive(Debug, Clone, PartialEq)]
pub struct ReferenceSettings {
    /// Photons emitted per light (toward the specular objects; see [`emit`](super::emit)).
    pub photons_per_light: u64,
    /// Camera paths per pixel for the non-caustic image.
    pub camera_spp: u32,
    /// Most interactions per path (specular and diffuse surfaces, medium scatterings).
    pub max_depth: u32,
    /// Seed of every random number.
    pub seed: u64,
    /// Texels per side of each light-space caustic map face.
    pub caustic_map_size: u32,
    /// Participating medium: single scattering only (every path from a light to the camera
    /// scatters in the medium at most once, with any number of surface bounces before and
    /// after) instead of multiple scattering.
    pub medium_single_scattering_only: bool,
    /// Which caustic paths the camera image `caustic` (and so `image`) holds: all of them
    /// (the default), or only light → specular chain → the first diffuse surface → camera,
    /// the part the GPU's caustic maps render, or the rest (for measurements). The caustic
    /// maps and the `nocaustic` image do not depend on it. See [`CausticPaths`].
    pub caustic_paths: CausticPaths,
    /// Which diffuse bounce orders of the light the camera images (`caustic`, `nocaustic` and
    /// so `image`) hold: every order (the default), or a range, such as order 1 alone (direct
    /// light and the caustics on their first diffuse surface) or 2 and up (light that bounced
    /// off a diffuse surface before the one the camera sees). The order of a path is its number
    /// of diffuse surface vertices; see [`DiffuseOrders`]. The caustic maps do not depend on
    /// it; the random choices do not either, so disjoint ranges add up to `all` path by path.
    pub diffuse_orders: DiffuseOrders,
    /// Give spot lights (cone up to 75°) a spill face in their caustic maps
    /// (`LightView::with_spill`), as the GPU does where `RenderSettings::uses_spill_face`; off
    /// by default, so every map keeps one face per spot light. The camera images do not depend
    /// on it.
    pub spill_faces: bool,
    /// Caustic photons reflect partially at dielectric interfaces (the default). Off, every
    /// dielectric interface transmits them with weight 1 − F, reflecting only totally: the light
    /// the GPU's transmitted branches carry (the beams' and photon maps' first branch; with
    /// `--no-glass-reflection` on the GPU the like-for-like comparison of docs/benchmarks.md).
    /// The camera paths (the `nocaustic` image) do not depend on it.
    pub partial_reflections: bool,
    /// Scenes with a medium and specular objects: photons per light traced as photon beams
    /// ([`photon_beams`](super::photon_beams)) for the caustic light the camera sees in the medium through specular
    /// surfaces (light → specular → medium → specular → camera); 0 leaves those paths out.
    pub medium_beam_photons: u64,
    /// The photon beams' kernel radius (m); 0: half a pixel's footprint at the specular objects
    /// ([`photon_beams::auto_radius`](super::photon_beams::auto_radius)).
    pub medium_beam_radius: f32,
    /// Scenes with specular objects: photons per light whose first diffuse hits are kept
    /// ([`view_photons`](super::view_photons)) for the caustic the camera sees on surfaces through specular surfaces
    /// (light → glass → floor → glass → camera); 0 leaves that light out.
    pub specular_view_photons: u64,
    /// Their kernel radius (m); 0: a pixel's footprint at the specular objects.
    pub specular_view_radius: f32,
    /// For the tests of the photon beams and the deposits: the camera sees the caustic light
    /// directly through them too, instead of through the photons' camera connections from
    /// medium scattering points and first diffuse hits (both estimate the same light).
    #[doc(hidden)]
    pub gather_direct: bool,
}

/// The most photon beams per light the reference accepts (memory: about 100 bytes a beam).
pub const MAX_BEAM_PHOTONS: u64 = 1 << 24;

impl Default for ReferenceSettings {
    fn default() -> Self {
        ReferenceSettings {
            photons_per_light: 4_000_000,
            camera_spp: 16,
            max_depth: 16,
            seed: 0,
            caustic_map_size: 512,
            medium_single_scattering_only: false,
            caustic_paths: CausticPaths::All,
            diffuse_orders: DiffuseOrders::ALL,
            spill_faces: false,
            partial_reflections: true,
            medium_beam_photons: 1 << 18,
            medium_beam_radius: 0.0,
            specular_view_photons: 1 << 18,
            specular_view_radius: 0.0,
            gather_direct: false,
        }
    }
}

impl ReferenceSettings {
    /// Check the settings; errors name the command-line option.
    pub fn validate(&self) -> Result<()> {
        let e = |field: &str, m: String| Err(Error::input("<command line>", field, m));
        if self.photons_per_light == 0 || self.photons_per_light > MAX_PHOTONS {
            return e("--photons", format!("must be between 1 and 2^40 per light (got {})", self.photons_per_light));
        }
        if self.camera_spp == 0 || self.camera_spp > 1 << 20 {
            return e("cpu.spp", format!("must be between 1 and 1048576 (got {})", self.camera_spp));
        }
        if self.max_depth == 0 || self.max_depth > 1024 {
            return e("cpu.max_depth", format!("must be between 1 and 1024 (got {})", self.max_depth));
        }
        if !self.diffuse_orders.is_valid() {
            return e(
                "cpu.diffuse_orders",
                format!("the lowest order must not exceed the highest (got {})", self.diffuse_orders),
            );
        }
        if self.medium_beam_photons > MAX_BEAM_PHOTONS {
            return e(
                "--medium-beams",
                format!("must be between 0 and 2^24 per light (got {})", self.medium_beam_photons),
            );
        }
        if self.specular_view_photons > MAX_BEAM_PHOTONS {
            return e(
                "--specular-view-photons",
                format!("must be between 0 and 2^24 per light (got {})", self.specular_view_photons),
            );
        }
        if !(self.specular_view_radius >= 0.0 && self.specular_view_radius.is_finite()) {
            return e(
                "--specular-view-radius",
                format!("must be 0 (automatic) or a positive length in metres (got {})", self.specular_view_radius),
            );
        }
        if !(self.medium_beam_radius >= 0.0 && self.medium_beam_radius.is_finite()) {
            return e(
                "--medium-beam-radius",
                format!("must be 0 (automatic) or a positive length in metres (got {})", self.medium_beam_radius),
            );
        }
        if self.caustic_map_size == 0 || self.caustic_map_size > 16384 {
            return e(
                "--caustic-map-size",
                format!("must be between 1 and 16384 texels (got {})", self.caustic_map_size),
            );
        }
        Ok(())
    }
}

/// Work done and speed.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReferenceStats {
    /// Photon paths traced (all lights).
    pub photon_paths: u64,
    /// Camera paths traced.
    pub camera_paths: u64,
    /// Rays cast (closest-hit and shadow/visibility rays) in photon and camera passes.
    pub rays: u64,
    /// Rays of the photon pass alone.
    pub photon_rays: u64,
    pub threads: usize,
    pub triangles: usize,
    pub bvh_seconds: f64,
    pub photon_seconds: f64,
    pub camera_seconds: f64,
    /// Wall-clock seconds, everything included.
    pub seconds: f64,
    /// Rays per second over the photon and camera passes.
    pub rays_per_second: f64,
    /// Photon paths per second in the photon pass.
    pub photon_paths_per_second: f64,
    /// Photon beams kept for the medium seen through specular surfaces and their kernel radius
    /// (m) (0, 0: none).
    pub medium_beams: u64,
    pub medium_beam_radius: f32,
    /// Deposits kept for the surfaces seen through specular surfaces and their kernel radius
    /// (m) (0, 0: none).
    pub view_deposits: u64,
    pub view_radius: f32,
    /// Seconds the beams' and the deposits' own photons took to trace and index.
    pub gather_photon_seconds: f64,
}

impl std::fmt::Display for ReferenceStats {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let t = self.threads.max(1) as f64;
        write!(
            f,
            "CPU reference: {} photon paths in {:.2} s ({:.2} M paths/s, {:.2} M/s per thread), {} camera paths in {:.2} s; \
             {} rays ({:.2} M rays/s, {:.2} M/s per thread); {} threads, {} triangles (BVH {:.3} s); {:.2} s in all",
            self.photon_paths,
            self.photon_seconds,
            self.photon_paths_per_second / 1e6,
            self.photon_paths_per_second / 1e6 / t,
            self.camera_paths,
            self.camera_seconds,
            self.rays,
            self.rays_per_second / 1e6,
            self.rays_per_second / 1e6 / t,
            self.threads,
            self.triangles,
            self.bvh_seconds,
            self.seconds
        )?;
        if self.medium_beams > 0 {
            write!(f, "; {} photon beams (radius {:.4} m)", self.medium_beams, self.medium_beam_radius)?;
        }
        if self.view_deposits > 0 {
            write!(
                f,
                "; {} deposits for the surfaces seen through glass (radius {:.4} m)",
                self.view_deposits, self.view_radius
            )?;
        }
        if self.medium_beams > 0 || self.view_deposits > 0 {
            write!(f, " in {:.2} s", self.gather_photon_seconds)?;
        }
        Ok(())
    }
}

/// A complete reference rendering.
#[derive(Debug, Clone)]
pub struct ReferenceOutput {
    /// `caustic + nocaustic`, radiance W/(m² sr) (the whole rendering with the default
    /// [`CausticPaths::All`]).
    pub image: Image,
    /// Caustic light only (light tracing), W/(m² sr): the path classes of
    /// [`ReferenceSettings::caustic_paths`] (all of them by default).
    pub caustic: Image,
    /// Everything else (camera paths), W/(m² sr).
    pub nocaustic: Image,
    /// Per pixel and channel: the estimated variance of `caustic`'s value (the variance of the
    /// mean over [`CAUSTIC_BATCHES`] independent batches of photons), (W/(m² sr))²; where the
    /// camera sees caustic light through glass (gathered from the deposits and photon beams),
    /// plus the camera samples' variance of that part, not the noise of the deposits and beams
    /// themselves.
    pub caustic_variance: Image,
    /// Per pixel and channel: the estimated variance of `nocaustic`'s value (sample variance
    /// of the camera paths / spp; an over-estimate, since the paths are stratified).
    pub nocaustic_variance: Image,
    /// Per light, per light-view face: N×N caustic irradiance (W/m²).
    pub caustic_maps: Vec<Vec<Image>>,
    pub stats: ReferenceStats,
}

/// The photons of each light are traced in this many batches (consecutive index ranges); the
/// spread between batches gives the caustic variance estimate.
pub const CAUSTIC_BATCHES: u64 = 16;
