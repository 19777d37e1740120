//! What a one-shot render returns: the images, maps and bookkeeping of a frame.

use crate::image_io::Image;
use crate::techniques::TechniqueStats;

/// Flux bookkeeping of one light (watts, summed over r, g and b).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FluxStats {
    /// Flux of the photons that hit a caster.
    pub emitted: f64,
    /// Flux that landed in the caustic map.
    pub landed: f64,
    /// Flux lost for want of a back surface in the caster buffers.
    pub lost_no_exit: f64,
    /// Flux lost to total internal reflection (the basic technique follows one refraction path).
    pub lost_tir: f64,
    /// Flux whose receiver the iterative search did not find.
    pub lost_no_receiver: f64,
    /// Flux that landed outside the caustic map.
    pub lost_outside: f64,
    /// Exact tracer: flux of the Fresnel branches after the first surface that no photon
    /// follows (light reflected inside a dielectric that leaves it later; the image-space tracer
    /// drops the same light without booking it). emitted = landed + lost + untraced, for the
    /// transmitted pass.
    pub untraced_branches: f64,
    /// Photon rays of the exact tracer that would have overflowed the BVH traversal stack
    /// (they may have missed a surface; reported as an overflow).
    pub stack_overflows: u64,
}

/// Bytes of a light's flux bookkeeping buffer: six fixed-point (lo, hi) pairs, the stack
/// overflow count, a spare word, the untraced branches' (lo, hi) pair.
pub const FLUX_STATS_BYTES: u64 = 64;

/// What a GPU render produces.
#[derive(Debug, Clone)]
pub struct GpuRender {
    /// Full image, linear radiance W/(m² sr).
    pub image: Image,
    /// Caustic light only, on the diffuse surfaces the camera sees directly.
    pub caustic: Image,
    /// Per light, per face: caustic irradiance maps (W/m²), M × M.
    pub caustic_maps: Vec<Vec<Image>>,
    /// Per light, per face: the raw fixed-point flux per texel (r, g, b), for determinism checks.
    pub caustic_flux_bits: Vec<Vec<u64>>,
    pub flux: Vec<FluxStats>,
    /// GPU milliseconds per named pass (empty without timestamp queries).
    pub timings: Vec<(String, f64)>,
    /// Host wall-clock milliseconds from the frame's submission to the GPU's completion of it:
    /// all of the frame's GPU work, without recording, pipeline builds or read-back. Where pass
    /// timestamps are not to be trusted (on lavapipe the basic technique's `photon_splat`
    /// escapes its own: `docs/benchmarks.md`) this is the measure to compare.
    pub frame_wall_ms: f64,
    /// Photons traced (all lights, faces and batches).
    pub photons_traced: u64,
    /// Batches the photon grid was split into (all lights and faces).
    pub batches: u32,
    /// What the photon emission technique did (photons traced, splatted, relevant, coverage,
    /// per level, memory, batches).
    pub technique: TechniqueStats,
    pub adapter: String,
    /// Per light with beams (volume caustics, `crate::beams`): the statistics and the beams
    /// rendered, in rendering order.
    pub beams: Vec<(crate::beams::BeamStats, Vec<crate::beams::Beam>)>,
}
