//! Volume caustics by adaptive beam tracing (Liktor & Dachsbacher 2011): light focused by
//! specular casters into a participating medium and scattered toward the camera.
//!
//! Per spot or point light, in scenes with a medium and a specular caster (docs/beams.md,
//! "Volume caustics from beams"):
//! 1. `beam_refine`, once per level: a projected grid of `BeamSettings::grid`² cells (two
//!    triangles each) over every light face; each triangle's three edge rays are traced exactly
//!    through the casters; the triangle is discarded, split 1 → 4 into the next level's work
//!    list (atomic append, indirect dispatch) or kept as a beam (atomic append into the beam
//!    buffer; overflow counted and reported). No CPU round trip between levels. At the last
//!    level a triangle whose corners take different paths queues its parts, and `beam_shrink`
//!    (one thread per part, an indirect dispatch) finds each by bisection and keeps its beam.
//! 2. `beam_order`: the kept beams listed in hierarchy order (so the image is the same bits
//!    from run to run whatever order the atomics ran in).
//! 3. The volume caustic, per [`BeamVolume`]: `beam_hull`, `beam_raster` and `beam_resolve`
//!    (the paper's way: each beam's hull on the image drawn indirectly, a fragment per pixel it
//!    covers, blended in list order; the default where the adapter blends float32 targets), or
//!    `beam_gather` (per pixel, a loop over every beam, culled by its bounding sphere). Both add
//!    the same per-pixel, per-beam integral (`shaders/shared/beam_scatter.wgsl`): the beam's
//!    exact intersection with the camera ray and the single scattering along it, into the image
//!    and the caustic-only image (the volume caustic is caustic light). Each is the same bits
//!    every run; they differ only in the order of the sums.
//!
//! The hull is the silhouette of the beam's convex hull grown by a pixel, drawn as a triangle
//! fan, so every beam is met exactly once per pixel (a camera inside a beam included, no hull
//! faces to choose); docs/beams.md, "Volume caustics from beams", says why it replaces
//! the paper's six-triangle hull and prism.

use crate::error::Result;
use crate::gpu::types::{BEAM_FLAG_FRAGMENTS, BEAM_FLAG_SURFACE, BeamGpu};
use crate::gpu::{GpuContext, PassTimer};
use crate::passes::{DrawCtx, EyeFrame, LightFrame, layer_view};
use crate::scene::Light;
use crate::settings::{BeamVolume, RenderSettings};

mod feature;
mod gather;
mod hulls;
mod params;
mod refine;

pub(crate) use feature::Beams;
pub use gather::gather;
use gather::{record_gather_chunks, record_surface};
use hulls::{hull_buffer, record_volume_hulls};
use params::{Chunks, chunk_scale, footprint, params};
use refine::record_light_beams;

/// Statistics words of a light's beam stages (`shaders/shared/beams.wgsl`, after the append
/// counter at word 0).
const STATS_WORDS: u64 = 33;

pub use crate::output::{Beam, BeamStats};

/// A light's beam buffers: kept for the gather after the composite and for the statistics
/// read-back.
pub(crate) struct BeamFrame {
    /// The scene light's index.
    pub light: usize,
    params: wgpu::Buffer,
    stats: wgpu::Buffer,
    beams: wgpu::Buffer,
    order: wgpu::Buffer,
    capacity: u32,
    levels: u32,
    /// `beam_gather`'s footprint integral (`foot`: width threshold in pixels, lines per side).
    footprint: [f32; 4],
    /// The chunks of the ordered list and their indirect dispatch sizes (`beam_order`).
    chunks: Chunks,
    dispatch: wgpu::Buffer,
    /// The image's size (pixels).
    size: (u32, u32),
    /// The beams' hull polygons (`beam_hull`), where the hulls are drawn ([`BeamVolume::Hulls`]).
    hulls: Option<wgpu::Buffer>,
}

/// The beams of every spot and point light (`beam_refine`, `beam_order`; nothing is recorded or
/// requested when [`RenderSettings::beams_active`] is false), and with [`RenderSettings::beams_surface_active`] their surface caustic
/// (`beam_surface`) added into the eye's radiance and caustic accumulators. Recorded after the
/// shading passes and before `composite` (which then shows the surface caustic through glass and
/// in mirrors as it does the photon maps'); the volume caustic follows the composite
/// ([`record_gather`]).
pub(crate) fn record_beams(
    dc: &DrawCtx,
    eye: &EyeFrame,
    lights: &[&LightFrame],
    s: &RenderSettings,
    count_fragments: bool,
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) -> Vec<BeamFrame> {
    if !s.beams_active(dc.scene) {
        return Vec::new();
    }
    let ctx = dc.ctx;
    let b = &s.beams;
    let surface = s.beams_surface_active(dc.scene);
    let hulls = b.volume.on(ctx.device.features()) == BeamVolume::Hulls;
    let mut frames = Vec::new();
    let (rp, rn) = (layer_view(ctx, &eye.recv.pos, 0), layer_view(ctx, &eye.recv.nrm, 0));
    for (li, lf) in lights.iter().enumerate() {
        if matches!(dc.scene.lights[li], Light::Directional { .. }) {
            continue;
        }
        // (the faces the light's photons start from: a spot's spill face only receives)
        let faces = lf.emit_faces;
        let slots = b.slots_per_face() * u64::from(faces);
        // Only the directions of the camera's rays are used: a projection of moderate depth
        // range keeps them exact in f32 (the eye passes' near plane can be very close).
        let cam = &dc.scene.camera;
        let rays = (cam.view_to_clip(0.1, 100.0) * cam.world_to_view()).inverse();
        let mut bp = params(dc.scene, rays, b, s.photons.max_depth, faces, slots);
        if count_fragments {
            bp.flags |= BEAM_FLAG_FRAGMENTS;
        }
        if surface {
            bp.flags |= BEAM_FLAG_SURFACE;
        }
        let mut frame =
            record_light_beams(ctx, dc, &lf.light_buf, &bp, (footprint(b), chunk_scale(ctx, b)), enc, timer);
        frame.light = li;
        if hulls {
            frame.hulls = Some(hull_buffer(ctx, frame.capacity));
        }
        if surface {
            let views = (&wgpu::BindingResource::TextureView(&rp), &wgpu::BindingResource::TextureView(&rn));
            record_surface(ctx, dc, &frame, views, (&eye.radiance, &eye.caustic), enc, timer);
        }
        frames.push(frame);
    }
    frames
}

impl BeamFrame {
    /// What a stage over the listed beams binds: (parameters, beams, ordered list, statistics),
    /// and its indirect dispatch (`beam_hull`'s: workgroups of 64, one invocation per listed
    /// beam) as (buffer, byte offset).
    pub(crate) fn listed(&self) -> ([&wgpu::Buffer; 4], (&wgpu::Buffer, u64)) {
        ([&self.params, &self.beams, &self.order, &self.stats], (&self.dispatch, self.chunks.hull_args()))
    }
}

/// The volume caustic of the beams [`record_beams`] made (`beam_gather`, with
/// [`RenderSettings::beams_volume_active`]), added to both composited images.
/// Then, where `segs` were kept, along the segments `composite` kept of the paths beyond the specular
/// surfaces (`beam_gather` with `gather_slot`, whichever way the camera rays' volume caustic is
/// drawn), into the full image.
pub(crate) fn record_gather(
    dc: &DrawCtx,
    eye: &EyeFrame,
    frames: &[BeamFrame],
    s: &RenderSettings,
    out: &crate::passes::Composited,
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) {
    if !s.beams_volume_active(dc.scene) {
        return;
    }
    let ctx = dc.ctx;
    // The first surfaces: the eye's receivers and specular front (positions, normals).
    let eye_views = [&eye.recv.pos, &eye.front.pos, &eye.recv.nrm, &eye.front.nrm].map(|t| layer_view(ctx, t, 0));
    let views = eye_views.each_ref().map(wgpu::BindingResource::TextureView);
    let targets = gather::GatherTargets { eye_views: &views, images: (&out.full, &out.caustic), scene: &dc.geo.scene };
    let segs = &out.segments;
    for f in frames {
        if let Some(hulls) = &f.hulls {
            record_volume_hulls(ctx, f, hulls, &targets, enc, timer);
        } else {
            record_gather_chunks(ctx, f, &targets, None, enc, timer);
        }
        if segs.kept {
            for slot in 0..crate::gpu::types::EYE_SEGMENTS as u32 {
                record_gather_chunks(ctx, f, &targets, Some((segs, slot)), enc, timer);
            }
        }
    }
}

/// Read a light's beams (in rendering order) and statistics back (blocking).
pub(crate) fn read_frame(ctx: &GpuContext, f: &BeamFrame) -> Result<(BeamStats, Vec<Beam>)> {
    let words: Vec<u32> = bytemuck::cast_slice(&ctx.read_buffer(&f.stats, STATS_WORDS * 4)?).to_vec();
    let w = |i: usize| words[1 + i];
    let n = f.levels as usize + 1;
    let stats = BeamStats {
        kept_per_level: (0..n).map(|l| w(l.min(7))).collect(),
        visited_per_level: (0..n).map(|l| w(8 + l.min(7))).collect(),
        beams: w(18).min(f.capacity),
        overflow: w(16),
        inconsistent: w(17),
        grazing: w(19),
        between_casters: w(20),
        hull_fragments: w(21),
        hull_lit_fragments: w(23),
        residual: w(22),
        cut: w(24),
        dark: w(25),
    };
    let count = stats.beams as u64;
    if count == 0 {
        return Ok((stats, Vec::new()));
    }
    let order: Vec<u32> = bytemuck::cast_slice(&ctx.read_buffer(&f.order, count * 4)?).to_vec();
    let size = std::mem::size_of::<BeamGpu>() as u64;
    let all = ctx.read_buffer(&f.beams, u64::from(f.capacity.min(words[0].max(1))) * size)?;
    let recs: &[BeamGpu] = bytemuck::cast_slice(&all);
    Ok((stats, order.iter().map(|&i| Beam::from_gpu(&recs[i as usize])).collect()))
}
