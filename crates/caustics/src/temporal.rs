//! Temporal filter of caustic maps for animations (issue 5, item 6; `docs/splatting.md`,
//! "Temporal filter").
//!
//! A [`TemporalFilter`] lives across the frames of an animation. It keeps, per light and face,
//! the previous frame's raw caustic map and the filtered history on the GPU, and blends each new
//! map into the history with an exponential weight `alpha` (the new frame's weight), except where
//! the photon map changed:
//!
//! - **rejection**: where the 3 × 3 box sum of the new raw map differs from the previous raw
//!   map's by more than `threshold` × the larger of the two (luminance r + g + b), the texel takes
//!   the new map. Photon jitter that only moves flux between neighbouring texels does not change
//!   the 3 × 3 sum; a caustic that moved, appeared or vanished does;
//! - **clamp**: elsewhere the history is clamped per channel to the min/max of the new map's 3 × 3
//!   neighbourhood before blending (the standard TAA clamp), so a ghost cannot outlive one frame
//!   even where the rejection test does not fire;
//! - **local flux balance** (`flux_radius` r, 3 by default): the blend's change of the new map,
//!   D = blend − new, is split into what it adds (D > 0) and what it removes (D < 0) over the
//!   (2r + 1)² texels around each texel, and the side in excess is scaled down so that the two
//!   balance: the blend only moves flux between nearby texels (smoothing how photon jitter
//!   spreads it), a moving caustic neither dims nor brightens by lagging (without it the glass
//!   sphere's focal caustic, drifting about 0.4 texel a frame, lost up to 20 % of the map's
//!   flux), and history that the new frame does not balance anywhere nearby (a ghost) is removed.
//!   Texels the blend did not change are not touched.
//!
//! The blend is `h + alpha (new - h)`: where the history equals the new map the result is the
//! new map bit for bit (D = 0 everywhere, so the balance changes nothing), so a static scene
//! (deterministic maps) is filtered to exactly its input from the first frame on, and its flux
//! is preserved. The first frame, a change of map size or face count, and [`TemporalFilter::reset`] start from the
//! new map. Deterministic: same inputs, same outputs (fixed summation order, no float atomics).
//!
//! How to use it, from an engine's frame loop:
//!
//! ```no_run
//! # fn f(ctx: &caustics::gpu::GpuContext, scenes: &[caustics::Scene]) -> caustics::Result<()> {
//! use caustics::temporal::{TemporalFilter, TemporalSettings};
//! let settings = caustics::render::RenderSettings::default();
//! let mut filter = TemporalFilter::new(TemporalSettings::default());
//! for scene in scenes {
//!     // Instead of `caustics::render::render`: the same frame, with the caustic maps filtered
//!     // on the GPU between the resolve and shading passes (no CPU round trip). The image, the
//!     // caustic image and `caustic_maps` are filtered; `caustic_flux_bits` and `flux` are raw.
//!     let out = filter.render(ctx, scene, &settings)?;
//! #   let _ = out;
//! }
//! # Ok(()) }
//! ```
//!
//! A caller with its own caustic-map buffers (M × M × faces `vec4<f32>` texels, face-major,
//! usage `STORAGE | COPY_SRC | COPY_DST`) records the filter into its own command encoder with
//! [`TemporalFilter::record`]; the buffer is replaced by the filtered maps in place.
//!
//! Limits: the history is kept in light-space texels without reprojection, so what moves in a
//! light's map is either rejected (shown raw) or, below the threshold, blended with a lag of about
//! (1 − alpha) / alpha frames (a sharp caustic drifting under a texel a frame is smeared by a
//! texel or two along its motion; its flux is kept). The filter reduces flicker where the map is
//! locally stable; measured numbers are in `docs/splatting.md`.

use crate::error::Result;
use crate::gpu::pass::Pass;
use crate::gpu::types::TemporalParams;
use crate::gpu::uniform;
use crate::gpu::{GpuContext, PassTimer};
use crate::image_io::Image;

/// Parameters of the temporal filter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TemporalSettings {
    /// Weight of the new frame in the exponential blend, in (0, 1]; 1 turns the filter off.
    pub alpha: f32,
    /// Relative change of a texel's 3 × 3 flux sum (new raw map against the previous raw map)
    /// above which the history is rejected.
    pub threshold: f32,
    /// Reject a texel's history also when the photon map changed around one of its 8 neighbours
    /// (fewer lag artefacts at moving edges, less flicker reduction).
    pub dilate: bool,
    /// Balance the blend's flux changes over (2r + 1)² texels, r = `flux_radius` (0: off, at
    /// most 8; see the module documentation).
    pub flux_radius: u32,
}

impl Default for TemporalSettings {
    fn default() -> Self {
        TemporalSettings { alpha: 0.2, threshold: 0.25, dilate: false, flux_radius: 3 }
    }
}

impl TemporalSettings {
    /// `alpha` in (0, 1], `threshold` ≥ 0 (infinity: never reject), `flux_radius` ≤
    /// [`MAX_FLUX_RADIUS`].
    pub fn validate(&self) -> Result<()> {
        let err = |field: &str, message: String| Err(crate::Error::input("<temporal settings>", field, message));
        if !(self.alpha > 0.0 && self.alpha <= 1.0) {
            return err("alpha", format!("must lie in (0, 1] (got {})", self.alpha));
        }
        if self.threshold.is_nan() || self.threshold < 0.0 {
            return err("threshold", format!("must be 0 or more (got {})", self.threshold));
        }
        if self.flux_radius > MAX_FLUX_RADIUS {
            return err("flux_radius", format!("must be at most {MAX_FLUX_RADIUS} (got {})", self.flux_radius));
        }
        Ok(())
    }
}

/// The largest `flux_radius`.
pub const MAX_FLUX_RADIUS: u32 = 8;

/// GPU state of one light's maps.
pub(crate) struct LightHistory {
    size: u32,
    faces: u32,
    /// The previous frame's raw maps.
    previous: wgpu::Buffer,
    /// The filtered maps (the output of the last frame).
    history: wgpu::Buffer,
    /// The blend before the local flux correction.
    scratch: wgpu::Buffer,
    /// Texels rejected, texels blended (last frame).
    counters: wgpu::Buffer,
    has_history: bool,
}

/// Per-texel statistics of the last filtered frame of one light.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TemporalStats {
    /// Texels that took the new map (history rejected, or no history).
    pub rejected: u64,
    /// Texels blended with the (clamped) history.
    pub blended: u64,
}

/// The temporal filter's state across frames: see the module documentation.
pub struct TemporalFilter {
    /// How it filters.
    pub settings: TemporalSettings,
    pub(crate) lights: Vec<Option<LightHistory>>,
}

/// One light's caustic maps as the filter reads and writes them: `size` × `size` × `faces`
/// texels of `vec4<f32>` (rgb irradiance, face-major, rows top-down), as the renderer resolves
/// them, in a buffer with usage `STORAGE | COPY_SRC | COPY_DST`.
#[derive(Clone, Copy)]
pub struct CausticMaps<'a> {
    /// The maps.
    pub buffer: &'a wgpu::Buffer,
    /// Texels per side of a face (M).
    pub size: u32,
    /// Faces of the light's view.
    pub faces: u32,
}

impl TemporalFilter {
    /// A filter with no history: its first frame is output unfiltered.
    pub fn new(settings: TemporalSettings) -> TemporalFilter {
        TemporalFilter { settings, lights: Vec::new() }
    }

    /// Forget the history: the next frame is output unfiltered (a cut, a teleport).
    pub fn reset(&mut self) {
        for l in self.lights.iter_mut().flatten() {
            l.has_history = false;
        }
    }

    /// Record the filter of one light's caustic maps into `encoder` (after the commands run,
    /// `maps.buffer` holds the filtered maps). `light` indexes the history (one per light of the
    /// scene). Settings out of range (see [`TemporalSettings::validate`]) are clamped.
    pub fn record(
        &mut self,
        ctx: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        timer: Option<&mut PassTimer>,
        light: usize,
        maps: CausticMaps,
    ) {
        let CausticMaps { buffer: maps, size, faces } = maps;
        if self.lights.len() <= light {
            self.lights.resize_with(light + 1, || None);
        }
        let slot = &mut self.lights[light];
        if slot.as_ref().is_none_or(|l| l.size != size || l.faces != faces) {
            let bytes = size as u64 * size as u64 * faces as u64 * 16;
            let buffer = |label: &str, bytes: u64| {
                ctx.kept_buffer(
                    label,
                    bytes,
                    wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                )
            };
            *slot = Some(LightHistory {
                size,
                faces,
                previous: buffer("temporal_previous", bytes),
                history: buffer("temporal_history", bytes),
                scratch: buffer("temporal_scratch", bytes),
                counters: buffer("temporal_counters", 8),
                has_history: false,
            });
        }
        let Some(l) = slot.as_mut() else { return };
        let flags = u32::from(self.settings.dilate) | self.settings.flux_radius.min(MAX_FLUX_RADIUS) << 1;
        let mut untimed = PassTimer::disabled();
        let timer = timer.unwrap_or(&mut untimed);
        encoder.clear_buffer(&l.counters, 0, None);
        for stage in 0..2 {
            let params = TemporalParams {
                size,
                faces,
                has_history: u32::from(l.has_history),
                stage,
                alpha: if self.settings.alpha > 0.0 { self.settings.alpha.min(1.0) } else { 1.0 },
                threshold: self.settings.threshold.max(0.0),
                flags,
                _pad: 0,
            };
            let pbuf = uniform(ctx, "temporal_params", bytemuck::bytes_of(&params));
            Pass::new(ctx, "temporal_filter")
                .bind("tp", &pbuf)
                .bind("current", maps)
                .bind("previous", &l.previous)
                .bind("history", &l.history)
                .bind("scratch", &l.scratch)
                .bind("counters", &l.counters)
                .dispatch(encoder, timer, [size.div_ceil(8), size.div_ceil(8), faces]);
        }
        let bytes = size as u64 * size as u64 * faces as u64 * 16;
        encoder.copy_buffer_to_buffer(maps, 0, &l.previous, 0, bytes);
        encoder.copy_buffer_to_buffer(&l.history, 0, maps, 0, bytes);
        l.has_history = true;
    }

    /// The last frame's raw (unfiltered) maps, per light and face (a readback, for tests and
    /// measurements).
    pub fn raw_maps(&self, ctx: &GpuContext) -> Result<Vec<Vec<Image>>> {
        self.read(ctx, |l| &l.previous)
    }

    /// The last frame's filtered maps, per light and face (a readback).
    pub fn filtered_maps(&self, ctx: &GpuContext) -> Result<Vec<Vec<Image>>> {
        self.read(ctx, |l| &l.history)
    }

    /// Texels rejected and blended in the last frame, per light (a readback).
    pub fn stats(&self, ctx: &GpuContext) -> Result<Vec<TemporalStats>> {
        let mut out = Vec::new();
        for l in &self.lights {
            out.push(match l {
                Some(l) => {
                    let c = ctx.read_buffer(&l.counters, 8)?;
                    let w: &[u32] = bytemuck::cast_slice(&c);
                    TemporalStats { rejected: w[0] as u64, blended: w[1] as u64 }
                }
                None => TemporalStats::default(),
            });
        }
        Ok(out)
    }

    fn read(&self, ctx: &GpuContext, which: impl Fn(&LightHistory) -> &wgpu::Buffer) -> Result<Vec<Vec<Image>>> {
        let mut out = Vec::new();
        for l in &self.lights {
            let Some(l) = l else {
                out.push(Vec::new());
                continue;
            };
            let texels = l.size as usize * l.size as usize;
            let data = ctx.read_buffer(which(l), texels as u64 * l.faces as u64 * 16)?;
            let px: &[[f32; 4]] = bytemuck::cast_slice(&data);
            out.push(
                px.chunks_exact(texels)
                    .map(|c| Image {
                        width: l.size,
                        height: l.size,
                        pixels: c.iter().map(|p| [p[0], p[1], p[2]]).collect(),
                    })
                    .collect(),
            );
        }
        Ok(out)
    }
}
