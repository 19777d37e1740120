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

use crate::error::{Error, Result};
use crate::gpu::pass::Pass;
use crate::gpu::types::{
    BEAM_FLAG_CHAINS, BEAM_FLAG_FRAGMENTS, BEAM_FLAG_GRID, BEAM_FLAG_REFLECTION, BEAM_FLAG_SURFACE, BEAM_HULL_PARTS,
    BEAM_KINDS, BEAM_ORDER_RUN, BEAM_PARTS, BeamGpu, BeamHull, BeamLevel, BeamParams, BeamPart, BeamTri,
};
use crate::gpu::{GpuContext, PassTimer};
use crate::image_io::Image;
use crate::passes::{DrawCtx, EyeFrame, LightFrame, density_view, layer_view, upload_density};
use crate::scene::{Light, Phase, Scene, Shape};
use crate::settings::{BeamSettings, BeamVolume, RenderSettings};
use glam::{Mat4, Vec3};

/// Statistics words of a light's beam stages (`shaders/shared/beams.wgsl`, after the append
/// counter at word 0).
const STATS_WORDS: u64 = 33;

/// The entry of `beam_refine`'s indirect arguments (16 bytes each, one per level before it) that
/// holds `beam_shrink`'s dispatch size and the parts queued (`PARTS_ARGS` in
/// shaders/shared/beams.wgsl).
const PARTS_ARGS: u64 = 7;

/// The most parts `beam_shrink` takes (one dispatch of 65535 workgroups of 64).
const PARTS_MAX: u64 = 65535 * 64;

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

/// The chunks of the ordered list that `beam_gather` and `beam_surface` dispatch over, one
/// dispatch each, recorded for the most beams the hierarchy can keep (no read-back of the
/// count); `beam_order` writes each chunk's indirect dispatch size, none for a chunk past the
/// beams it listed. (Adaptive 16² + 3's hierarchy has 43520 slots: 1024 gather chunks recorded
/// for its 10⁴ beams; on lavapipe the empty dispatches were not measurably slower, the
/// gather's work per beam dominates: docs/benchmarks.md, "Beams: reflected branches shrunk,
/// the target met".)
#[derive(Clone, Copy, Debug)]
struct Chunks {
    /// Beams per gather chunk, and gather chunks.
    gather: u32,
    gather_n: u32,
    /// Beams per surface chunk, and surface chunks (their dispatch sizes follow the gather's).
    surface: u32,
    surface_n: u32,
}

impl Chunks {
    /// Chunks for the beams `bp` can hold, at most `kinds` per slot ([`kinds`]), `scale` times
    /// the sizes lavapipe's loop limit allows ([`chunk_scale`]).
    fn new(bp: &BeamParams, foot: &[f32; 4], (kinds, scale): (u64, u32)) -> Chunks {
        let (pixel_samples, surface_samples, flags) = (bp.pixel_samples, bp.surface_samples, bp.flags);
        let most = most_beams(bp.capacity, bp.slots, kinds);
        // With a density grid every point of a beam marches the grid toward its base and the
        // camera (2 x BEAM_GRID_STEPS lookups): a beam costs a pixel that many times more.
        let grid = if flags & BEAM_FLAG_GRID != 0 { GRID_COST } else { 1 };
        // A beam costs a pixel its rays and, where it is thin, its footprint's lines (counted as
        // one ray more: a beam's thin part is short, and `many_overlapping_beams_sum_like_one`
        // checks thousands of thin beams in one pixel; chunks of fewer beams multiply the
        // dispatches and binds).
        let rays = pixel_samples.max(1) * pixel_samples.max(1) + u32::from(foot[0] > 0.0);
        let gather = (GATHER_CHUNK * scale / rays / grid).max(1);
        // (a small beam's exact clip is some 40 loop iterations: counted as 16 points at least)
        let points = surface_samples.clamp(1, 8).pow(2);
        let surface = (SURFACE_CHUNK * scale / points.max(16) / grid).max(1);
        Chunks { gather, gather_n: most.div_ceil(gather), surface, surface_n: most.div_ceil(surface) }
    }

    /// `beam_order`'s uniform (`ch` in beam_order.wgsl).
    fn gpu(&self) -> BeamLevel {
        BeamLevel { level: self.gather, offset: self.gather_n, next_offset: self.surface, base_count: self.surface_n }
    }

    /// The indirect arguments' buffer (beam_order writes them): 3 words per chunk, then
    /// `beam_hull`'s dispatch (3 words) and `beam_raster`'s draw (4 words).
    fn dispatch_buffer(&self, ctx: &GpuContext) -> wgpu::Buffer {
        crate::gpu::storage(ctx, "beam_chunk_dispatch", self.hull_args() + 28, wgpu::BufferUsages::INDIRECT)
    }

    /// Byte offset of `beam_hull`'s indirect dispatch size (`beam_raster`'s draw follows it).
    fn hull_args(&self) -> u64 {
        12 * u64::from(self.gather_n + self.surface_n)
    }
}

/// The footprint uniform of `beam_gather` (`foot` in beam_gather.wgsl).
fn footprint(b: &BeamSettings) -> [f32; 4] {
    [b.footprint, b.footprint_lines as f32, 0.0, 0.0]
}

fn params(scene: &Scene, clip_to_world: Mat4, b: &BeamSettings, max_depth: u32, faces: u32, slots: u64) -> BeamParams {
    let m = scene.medium.as_ref();
    let g = m.map_or(0.0, |m| match m.phase {
        Phase::Isotropic => 0.0,
        Phase::HenyeyGreenstein { g } => g,
    });
    let cam = &scene.camera;
    BeamParams {
        clip_to_world: clip_to_world.to_cols_array_2d(),
        world_to_clip: clip_to_world.inverse().to_cols_array_2d(),
        camera: cam.position.extend(1.0).to_array(),
        lo: m.map_or([0.0; 4], |m| m.bounds_min.extend(0.0).to_array()),
        hi: m.map_or([0.0; 4], |m| m.bounds_max.extend(0.0).to_array()),
        sigma_s: m.map_or(Vec3::ZERO, |m| m.sigma_s).extend(g).to_array(),
        sigma_t: m.map_or(Vec3::ZERO, |m| m.sigma_s + m.sigma_a).extend(0.0).to_array(),
        grid: b.grid,
        levels: b.levels,
        faces,
        max_depth,
        normal_cos: b.normal_threshold_deg.to_radians().cos(),
        depth_rel: b.depth_threshold,
        energy: b.energy_threshold,
        camera_size: b.camera_threshold,
        surface_samples: b.surface_samples,
        capacity: b.capacity,
        slots: slots as u32,
        samples: b.samples,
        width: cam.width,
        height: cam.height,
        flags: if b.reflection { BEAM_FLAG_REFLECTION } else { 0 }
            | if m.is_some_and(|m| m.density.is_some()) { BEAM_FLAG_GRID } else { 0 }
            | if chains(scene) { BEAM_FLAG_CHAINS } else { 0 },
        pixel_samples: b.pixel_samples,
        linearity: b.linearity_threshold,
        residual: if b.reflection { b.residual } else { 0.0 },
        cut: m.map_or(0.0, |m| cut_factor(m, b.cutoff)),
        _pad: 0,
    }
}

/// The energy cutoff's factor (`BeamParams::cut`, `cut_tail` in shaders/shared/beam_trace.wgsl),
/// in m/W: the largest scattering coefficient the medium has (σs's largest channel, times the
/// density grid's largest value where it has one) times the phase function's largest value,
/// over the cutoff radiance; 0 without a cutoff.
fn cut_factor(m: &crate::scene::Medium, cutoff: f32) -> f32 {
    if cutoff <= 0.0 {
        return 0.0;
    }
    let g = match m.phase {
        Phase::Isotropic => 0.0f32,
        Phase::HenyeyGreenstein { g } => g.abs(),
    };
    // (Henyey-Greenstein's largest value, at 0° for g > 0: (1 + g) / (4π (1 - g)²))
    let phase = (1.0 + g) / (4.0 * std::f32::consts::PI * (1.0 - g) * (1.0 - g));
    let density = m.density.as_ref().map_or(1.0, |d| d.max);
    m.sigma_s.max_element() * density * phase / cutoff
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
#[expect(clippy::too_many_arguments, reason = "the frame's resources")]
pub(crate) fn record_gather(
    dc: &DrawCtx,
    eye: &EyeFrame,
    frames: &[BeamFrame],
    s: &RenderSettings,
    images: (&wgpu::Buffer, &wgpu::Buffer),
    segs: &crate::passes::EyeSegments,
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
    let density = density_view(ctx, &dc.geo.density);
    for f in frames {
        if let Some(hulls) = &f.hulls {
            record_volume_hulls(ctx, f, hulls, &views, images, &density, enc, timer);
        } else {
            record_gather_chunks(ctx, f, &views, images, &density, None, enc, timer);
        }
        if segs.kept {
            for slot in 0..crate::gpu::types::EYE_SEGMENTS as u32 {
                record_gather_chunks(ctx, f, &views, images, &density, Some((segs, slot)), enc, timer);
            }
        }
    }
}

/// `beam_refine` (every level) and `beam_order` for one light.
fn record_light_beams(
    ctx: &GpuContext,
    dc: &DrawCtx,
    light_buf: &wgpu::Buffer,
    bp: &BeamParams,
    (footprint, scale): ([f32; 4], u32),
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) -> BeamFrame {
    let storage = wgpu::BufferUsages::empty();
    let levels = bp.levels;
    let per_level = |l: u32| (2 * u64::from(bp.grid).pow(2) * u64::from(bp.faces)) << (2 * l);
    let offset = |l: u32| (0..l).map(per_level).sum::<u64>();
    let slots = u64::from(bp.slots);
    let params = ctx.constants("beam_params", bytemuck::bytes_of(bp));
    let work = crate::gpu::storage(ctx, "beam_work", slots * std::mem::size_of::<BeamTri>() as u64, storage);
    let args = crate::gpu::storage(ctx, "beam_args", 16 * 8, storage);
    // The next level's dispatch size, copied out of `args` (a buffer a dispatch writes cannot be
    // its own indirect argument).
    let indirect = crate::gpu::storage(ctx, "beam_indirect", 16 * 8, wgpu::BufferUsages::INDIRECT);
    let slot_buf = crate::gpu::storage(ctx, "beam_slots", KINDS * slots * 4, storage);
    let cap = u64::from(bp.capacity);
    let beams = crate::gpu::storage(ctx, "beams", cap * std::mem::size_of::<BeamGpu>() as u64, storage);
    let order = crate::gpu::storage(ctx, "beam_order", cap * 4, storage);
    let stats = crate::gpu::storage(ctx, "beam_stats", STATS_WORDS * 4, storage);
    // The parts of the silhouette triangles (`beam_shrink`): at most one beam each, so no more
    // than the beam buffer holds (more are counted as an overflow).
    let parts =
        crate::gpu::storage(ctx, "beam_parts", cap.min(PARTS_MAX) * std::mem::size_of::<BeamPart>() as u64, storage);
    let geo = dc.geo;
    let density = density_view(ctx, &geo.density);
    for l in 0..=levels {
        let lv = BeamLevel {
            level: l,
            offset: offset(l) as u32,
            next_offset: offset(l + 1) as u32,
            base_count: per_level(0) as u32,
        };
        let lvb = ctx.uniform("beam_level", bytemuck::bytes_of(&lv));
        let refine = Pass::new(ctx, "beam_refine")
            .bind("light", light_buf)
            .bind("bp", &params)
            .bind("lv", &lvb)
            .bind("materials", &geo.materials)
            .bind_all(geo.bvh_bindings())
            .bind("work", &work)
            .bind("args", &args)
            .bind("slots", &slot_buf)
            .bind("beams", &beams)
            .bind("stats", &stats)
            .bind("density_grid", &density)
            .bind("parts", &parts);
        if l == 0 {
            let groups = (per_level(0) as u32).div_ceil(64);
            refine.dispatch(enc, timer, [groups.min(65535), groups.div_ceil(65535), 1]);
        } else {
            refine.dispatch_indirect(enc, timer, &indirect, 16 * u64::from(l));
        }
        if l < levels {
            let at = 16 * u64::from(l + 1);
            enc.copy_buffer_to_buffer(&args, at, &indirect, at, 16);
        }
    }
    // `beam_shrink`: the beams of the silhouette triangles' parts `beam_refine` queued, one
    // thread each (indirect dispatch over their count, in `args`' entry [`PARTS_ARGS`]).
    let at = 16 * PARTS_ARGS;
    enc.copy_buffer_to_buffer(&args, at, &indirect, at, 16);
    Pass::new(ctx, "beam_shrink")
        .bind("light", light_buf)
        .bind("bp", &params)
        .bind("materials", &geo.materials)
        .bind_all(geo.bvh_bindings())
        .bind("parts", &parts)
        .bind("args", &args)
        .bind("slots", &slot_buf)
        .bind("beams", &beams)
        .bind("stats", &stats)
        .bind("density_grid", &density)
        .dispatch_indirect(enc, timer, &indirect, at);
    let chunks = Chunks::new(bp, &footprint, (kinds(bp), scale));
    let dispatch = chunks.dispatch_buffer(ctx);
    record_order(ctx, (&params, bp.slots), (&slot_buf, &order, &stats), (&chunks, &dispatch), enc, timer);
    let size = (bp.width, bp.height);
    BeamFrame {
        light: 0,
        params,
        stats,
        beams,
        order,
        capacity: bp.capacity,
        levels,
        footprint,
        chunks,
        dispatch,
        size,
        hulls: None,
    }
}

/// `beam_order_runs` (count), `beam_order` (the runs' places, the dispatch sizes) and
/// `beam_order_runs` (write): the kept beams listed in hierarchy order.
fn record_order(
    ctx: &GpuContext,
    (params, slots_n): (&wgpu::Buffer, u32),
    (slots, order, stats): (&wgpu::Buffer, &wgpu::Buffer, &wgpu::Buffer),
    (chunks, dispatch): (&Chunks, &wgpu::Buffer),
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) {
    let n_runs = (u64::from(BEAM_KINDS) * u64::from(slots_n)).div_ceil(u64::from(BEAM_ORDER_RUN)).max(1);
    let runs = crate::gpu::storage(ctx, "beam_order_runs", 4 * n_runs, wgpu::BufferUsages::empty());
    let groups = n_runs.div_ceil(64) as u32;
    // Each dispatch labelled and timed as `beam_order` (the list's three dispatches are one pass
    // to `bench`).
    let groups = [groups.min(65535), groups.div_ceil(65535), 1];
    let runs_pass = |write: bool| {
        Pass::new(ctx, "beam_order_runs")
            .constants(&[("order_write", f64::from(u8::from(write)))])
            .label("beam_order")
            .bind("bp", params)
            .bind("slots", slots)
            .bind("runs", &runs)
            .bind("order", order)
    };
    runs_pass(false).dispatch(enc, timer, groups);
    let cu = ctx.uniform("beam_order_chunks", bytemuck::bytes_of(&chunks.gpu()));
    Pass::new(ctx, "beam_order")
        .bind("bp", params)
        .bind("runs", &runs)
        .bind("stats", stats)
        .bind("ch", &cu)
        .bind("dispatch", dispatch)
        .dispatch(enc, timer, [1, 1, 1]);
    runs_pass(true).dispatch(enc, timer, groups);
}

/// The most beams a light's ordered list can hold: `capacity`, and at most `kinds` per slot of
/// the hierarchy.
fn most_beams(capacity: u32, slots: u32, kinds: u64) -> u32 {
    u64::from(capacity).min(kinds * u64::from(slots)).max(1) as u32
}

/// Whether light can cross `scene`'s medium from one specular surface to another: unless it
/// has at most one specular object, a sphere or a rectangle (which light leaving it never meets
/// again). Then the beams' second layer and the branches reflected at a second dielectric exist
/// ([`BEAM_FLAG_CHAINS`]).
fn chains(scene: &Scene) -> bool {
    let mut specular = scene.objects.iter().filter(|o| scene.materials[o.material].is_specular());
    match (specular.next(), specular.next()) {
        (None, _) => false,
        (Some(o), None) => !matches!(o.shape, Shape::Sphere { .. } | Shape::Rectangle { .. }),
        _ => true,
    }
}

/// The beams a slot of the hierarchy can hold under beam parameters `bp`: [`KINDS`], or without
/// [`BEAM_FLAG_CHAINS`] ([`chains`]) the parts of the last segments of the first three branches
/// and, where it is on, the residual branch alone. Only the number of gather and surface chunks
/// recorded depends on it (those past the beams kept are empty dispatches).
fn kinds(bp: &BeamParams) -> u64 {
    if bp.flags & BEAM_FLAG_CHAINS != 0 { KINDS } else { (3 + u64::from(bp.residual > 0.0)) * u64::from(BEAM_PARTS) }
}

/// The surface caustic of one light's beams, added into the eye's diffuse radiance and caustic
/// accumulators: their hulls drawn (`beam_surface_raster`) where the frame has them, else
/// `beam_surface`, one dispatch per chunk of the ordered list (as the gather: a fixed order, and
/// short loops).
fn record_surface(
    ctx: &GpuContext,
    dc: &DrawCtx,
    f: &BeamFrame,
    eye_views: (&wgpu::BindingResource, &wgpu::BindingResource),
    accum: (&wgpu::Buffer, &wgpu::Buffer),
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) {
    if let Some(hulls) = &f.hulls {
        record_hull_polygons(ctx, f, hulls, HullsOf::Ends, enc, timer);
        let density = density_view(ctx, &dc.geo.density);
        let resources = [
            f.params.as_entire_binding(),
            eye_views.0.clone(),
            eye_views.1.clone(),
            f.beams.as_entire_binding(),
            hulls.as_entire_binding(),
            dc.geo.materials.as_entire_binding(),
            wgpu::BindingResource::TextureView(&density),
            f.stats.as_entire_binding(),
        ];
        draw_hulls(ctx, f, "beam_surface_raster", &resources, accum, enc, timer);
        return;
    }
    let density = density_view(ctx, &dc.geo.density);
    let records = ChunkRecords::new(ctx, "beam_surface_chunks", f.chunks.surface_n, f.chunks.surface);
    for c in 0..f.chunks.surface_n {
        Pass::new(ctx, "beam_surface")
            .bind("bp", &f.params)
            .bind("recv_pos", eye_views.0.clone())
            .bind("recv_nrm", eye_views.1.clone())
            .bind("beams", &f.beams)
            .bind("order", &f.order)
            .bind("stats", &f.stats)
            .bind("materials", &dc.geo.materials)
            .bind("radiance", accum.0)
            .bind("caustic", accum.1)
            .bind("chunk", records.binding(c))
            .bind("density_grid", &density)
            .dispatch_indirect(enc, timer, &f.dispatch, 12 * u64::from(f.chunks.gather_n + c));
    }
}

/// The hull polygons of `capacity` beams (`BEAM_HULL_PARTS` each), written by
/// [`record_hull_polygons`].
fn hull_buffer(ctx: &GpuContext, capacity: u32) -> wgpu::Buffer {
    let size = u64::from(capacity) * u64::from(BEAM_HULL_PARTS) * std::mem::size_of::<BeamHull>() as u64;
    crate::gpu::storage(ctx, "beam_hulls", size, wgpu::BufferUsages::empty())
}

/// What a hull polygon bounds: the whole beam (the volume caustic) or its end (the points the
/// surface caustic lights).
#[derive(Clone, Copy)]
enum HullsOf {
    Beams = 0,
    Ends = 1,
}

/// `beam_hull`: each ordered beam's hull polygon on the image into `hulls` (an indirect
/// dispatch, a thread per listed beam), for the hull draws of the surface (`HullsOf::Ends`) and
/// volume caustics (`HullsOf::Beams`); run before each draw, which then reads them.
fn record_hull_polygons(
    ctx: &GpuContext,
    f: &BeamFrame,
    hulls: &wgpu::Buffer,
    of: HullsOf,
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) {
    let mode = ctx.constants("beam_hull_mode", bytemuck::cast_slice(&[of as u32, 0, 0, 0]));
    Pass::new(ctx, "beam_hull")
        .bind("bp", &f.params)
        .bind("beams", &f.beams)
        .bind("order", &f.order)
        .bind("stats", &f.stats)
        .bind("hulls", hulls)
        .bind("mode", &mode)
        .dispatch_indirect(enc, timer, &f.dispatch, f.chunks.hull_args());
}

/// The hulls of one light's beams drawn by render stage `stage` (`beam_raster`: the volume
/// caustic; `beam_surface_raster`: the surface caustic) with group 0 `resources`, indirectly
/// (instance k the list's k-th beam; `beam_order` wrote the count), blended into a float image in
/// list order, then `beam_resolve`: that image added to both `images`.
fn draw_hulls(
    ctx: &GpuContext,
    f: &BeamFrame,
    stage: &str,
    resources: &[wgpu::BindingResource],
    images: (&wgpu::Buffer, &wgpu::Buffer),
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) {
    let (w, h) = f.size;
    let extent = wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 };
    let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
    let target = ctx.texture(stage, extent, HULL_FORMAT, usage);
    let target_view = ctx.view(&target, None, 0, None);
    let rpl = raster_pipeline(ctx, stage);
    let entries: Vec<wgpu::BindGroupEntry> = resources
        .iter()
        .enumerate()
        .map(|(i, r)| wgpu::BindGroupEntry { binding: i as u32, resource: r.clone() })
        .collect();
    let rbg = ctx.bind_group(stage, crate::gpu::pool::LayoutOf::Render(rpl.clone()), &entries);
    {
        let mut rp = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some(stage),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &target_view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: timer.render(stage),
            occlusion_query_set: None,
            multiview_mask: None,
        });
        rp.set_pipeline(&rpl);
        rp.set_bind_group(0, &rbg, &[]);
        rp.draw_indirect(&f.dispatch, f.chunks.hull_args() + 12);
    }
    Pass::new(ctx, "beam_resolve")
        .bind("volume", &target_view)
        .bind("out_full", images.0)
        .bind("out_caustic", images.1)
        .dispatch(enc, timer, [w.div_ceil(8), h.div_ceil(8), 1]);
}

/// The volume caustic of one light's beams drawn as their hulls (`beam_hull` into `hulls`, then
/// `beam_raster`), added to both frame images.
#[expect(clippy::too_many_arguments, reason = "the volume draw's resources")]
fn record_volume_hulls(
    ctx: &GpuContext,
    f: &BeamFrame,
    hulls: &wgpu::Buffer,
    eye_views: &[wgpu::BindingResource; 4],
    images: (&wgpu::Buffer, &wgpu::Buffer),
    density: &wgpu::TextureView,
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) {
    record_hull_polygons(ctx, f, hulls, HullsOf::Beams, enc, timer);
    let foot = ctx.constants("beam_footprint", bytemuck::cast_slice(&f.footprint));
    let resources = [
        f.params.as_entire_binding(),
        eye_views[0].clone(),
        eye_views[1].clone(),
        f.beams.as_entire_binding(),
        hulls.as_entire_binding(),
        foot.as_entire_binding(),
        wgpu::BindingResource::TextureView(density),
        f.stats.as_entire_binding(),
        eye_views[2].clone(),
        eye_views[3].clone(),
    ];
    draw_hulls(ctx, f, "beam_raster", &resources, images, enc, timer);
}

/// The hull draws' image: float32, so that the blend adds as the gather's sums do.
const HULL_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;

/// A hull draw's pipeline (render stage `stage`): no vertex buffers (the vertex shader reads the
/// hulls), no depth (the fragment clips at the pixel's first surface itself), additive blending.
fn raster_pipeline(ctx: &GpuContext, stage: &str) -> wgpu::RenderPipeline {
    ctx.render_pipeline(stage, || {
        let module = ctx.shader(stage);
        let layout = ctx.render_stage_layout(stage);
        let add = wgpu::BlendComponent {
            src_factor: wgpu::BlendFactor::One,
            dst_factor: wgpu::BlendFactor::One,
            operation: wgpu::BlendOperation::Add,
        };
        ctx.device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(stage),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: None,
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_main"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: HULL_FORMAT,
                    blend: Some(wgpu::BlendState { color: add, alpha: add }),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        })
    })
}

/// `beam_gather` over light `f`'s chunks: along the camera rays, or (`segs`: the segments and a
/// slot) along the kept segments in that slot.
#[expect(clippy::too_many_arguments, reason = "the gathering stage's resources")]
fn record_gather_chunks(
    ctx: &GpuContext,
    f: &BeamFrame,
    eye_views: &[wgpu::BindingResource; 4],
    images: (&wgpu::Buffer, &wgpu::Buffer),
    density: &wgpu::TextureView,
    segs: Option<(&crate::passes::EyeSegments, u32)>,
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) {
    let (params, beams, order, stats) = (&f.params, &f.beams, &f.order, &f.stats);
    let (chunks, dispatch, foot) = (&f.chunks, &f.dispatch, f.footprint);
    let slot = segs.map_or(-1.0, |(_, k)| f64::from(k));
    let (label, seg_bindings) = match segs {
        Some((sg, _)) => ("beam_gather_segments", sg.bindings()),
        // (the stage reads none of them along the camera rays)
        None => ("beam_gather", [("spec_list", order), ("spec_count", stats), ("segments", order)]),
    };
    let foot_buf = ctx.constants("beam_footprint", bytemuck::cast_slice(&foot));
    // One dispatch per chunk of the ordered list (see beam_gather.wgsl and `Chunks`), its size
    // written by beam_order (none past the beams listed).
    let records = ChunkRecords::new(ctx, "beam_gather_chunks", chunks.gather_n, chunks.gather);
    for c in 0..chunks.gather_n {
        Pass::new(ctx, "beam_gather")
            .constants(&[("gather_slot", slot)])
            .label(label)
            .bind("bp", params)
            .bind("recv_pos", eye_views[0].clone())
            .bind("spec_pos", eye_views[1].clone())
            .bind("beams", beams)
            .bind("order", order)
            .bind("stats", stats)
            .bind("out_full", images.0)
            .bind("out_caustic", images.1)
            .bind("chunk", records.binding(c))
            .bind("foot", &foot_buf)
            .bind("density_grid", density)
            .bind("recv_nrm", eye_views[2].clone())
            .bind("spec_nrm", eye_views[3].clone())
            .bind_all(seg_bindings)
            .dispatch_indirect(enc, timer, dispatch, 12 * u64::from(c));
    }
}

/// The chunk records of one chunked stage (`chunk` in beam_gather.wgsl and beam_surface.wgsl),
/// all in one buffer of constants, one record per storage-offset alignment: each chunk's bind
/// group binds its own record.
///
/// Read from storage, not a uniform per chunk: lavapipe (Mesa 22.3) specializes a shader on the
/// uniform values its loops read, compiling and keeping a new variant at every bind of a chunk
/// (some 0.5 MB each, kept until the device is dropped: docs/beams.md, "Beams: memory").
struct ChunkRecords {
    buffer: wgpu::Buffer,
    stride: u64,
}

impl ChunkRecords {
    fn new(ctx: &GpuContext, label: &str, n: u32, chunk: u32) -> ChunkRecords {
        let size = std::mem::size_of::<BeamLevel>();
        let stride = u64::from(ctx.device.limits().min_storage_buffer_offset_alignment).max(size as u64);
        let mut bytes = vec![0u8; stride as usize * n.max(1) as usize];
        for c in 0..n {
            let at = stride as usize * c as usize;
            let record = BeamLevel { level: c, offset: c * chunk, next_offset: 0, base_count: chunk };
            bytes[at..at + size].copy_from_slice(bytemuck::bytes_of(&record));
        }
        ChunkRecords { buffer: ctx.constants(label, &bytes), stride }
    }

    /// Chunk `c`'s record.
    fn binding(&self, c: u32) -> wgpu::BindingResource<'_> {
        wgpu::BindingResource::Buffer(wgpu::BufferBinding {
            buffer: &self.buffer,
            offset: self.stride * u64::from(c),
            size: wgpu::BufferSize::new(std::mem::size_of::<BeamLevel>() as u64),
        })
    }
}

/// How many times larger than lavapipe allows the chunks of `beam_gather` and `beam_surface`
/// are: [`BeamSettings::chunk_scale`], or where that is 0 (automatic), 1 on a CPU adapter
/// (lavapipe's shaders end an invocation's loops after some 65536 iterations in all, which sizes
/// [`GATHER_CHUNK`] and [`SURFACE_CHUNK`]) and [`GPU_CHUNK_SCALE`] on a GPU, where every chunk is
/// a dispatch and a barrier and no loop limit applies. (Not yet measured on a GPU.)
fn chunk_scale(ctx: &GpuContext, b: &BeamSettings) -> u32 {
    match b.chunk_scale {
        0 if ctx.info.device_type == wgpu::DeviceType::Cpu => 1,
        0 => GPU_CHUNK_SCALE,
        n => n,
    }
}

/// [`chunk_scale`] on GPUs: 16 (a chunk of the default gather is then 2048 beams instead of 128,
/// so the default 16² + 3 hierarchy's 10⁴ beams take 5 dispatches instead of 78, and its worst
/// case, the capacity of 131 072 beams, 64 recorded dispatches instead of 1024).
const GPU_CHUNK_SCALE: u32 = 16;

/// Beams per slot of the hierarchy ([`BEAM_KINDS`]): six branches (transmitted, reflected at
/// the first surface, reflected once inside, the same two at a second dielectric, the residual
/// branch) times two
/// layers (the path's last segment, and the one between its last two specular objects) times
/// four parts (a last-level triangle whose corners take different paths: one beam per path,
/// and one for its orphans, the light on paths none of its corners takes).
const KINDS: u64 = BEAM_KINDS as u64;

/// Beams one `beam_gather` dispatch loops over per camera ray (beam_gather.wgsl says why).
const GATHER_CHUNK: u32 = 256;

/// Beam × surface point tests one `beam_surface` dispatch makes per pixel at most (a chunk is
/// this over the points per pixel): a point test is a few dozen operations, so chunks are
/// larger than the gather's, and a pixel's loops stay far below lavapipe's limit of about
/// 65536 iterations per invocation.
const SURFACE_CHUNK: u32 = 4096;

/// How many times more a beam costs a pixel's loops in a medium with a density grid (its
/// points march the grid: `Chunks::new`), so chunks are that much smaller.
const GRID_COST: u32 = 2;

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

/// The radiance `beams` scatter toward `scene`'s camera in its medium, alone (no surfaces: the
/// camera rays end at the medium's box): the given beams gathered per pixel or drawn as hulls
/// (`BeamSettings::volume`), for tests and tools. Blocking.
pub fn gather(ctx: &GpuContext, scene: &Scene, beams: &[Beam], b: &BeamSettings) -> Result<Image> {
    let field = |f: &'static str, m: String| Error::input("<beams>", f, m);
    b.validate().map_err(|(f, m)| field(f, m))?;
    if let Some(why) = b.volume.unsupported(ctx) {
        return Err(field("volume", why));
    }
    if scene.medium.is_none() {
        return Err(field("medium", "the scene has no medium".into()));
    }
    if beams.len() > b.capacity as usize {
        return Err(field("beams", format!("{} beams, capacity {}", beams.len(), b.capacity)));
    }
    let ctx = ctx.with_own_pool();
    let cam = &scene.camera;
    let (w, h) = (cam.width, cam.height);
    let clip = cam.view_to_clip(0.01, 100.0) * cam.world_to_view();
    let mut bp = params(scene, clip.inverse(), b, 0, 1, 1);
    bp.flags |= BEAM_FLAG_FRAGMENTS;
    bp.slots = beams.len().max(1) as u32;
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    ctx.begin_scope("beam_gather", &mut enc);
    let usage = wgpu::BufferUsages::STORAGE;
    let params = ctx.constants("beam_params", bytemuck::bytes_of(&bp));
    let recs: Vec<BeamGpu> = beams.iter().map(Beam::to_gpu).collect();
    let beam_buf = if recs.is_empty() {
        crate::gpu::storage(&ctx, "beams", 128, wgpu::BufferUsages::empty())
    } else {
        ctx.buffer_init("beams", bytemuck::cast_slice(&recs), usage)
    };
    let b3 = KINDS as u32;
    let slots: Vec<u32> = (0..b3 * beams.len() as u32).map(|i| if i % b3 == 0 { i / b3 + 1 } else { 0 }).collect();
    let slot_buf = ctx.buffer_init(
        "beam_slots",
        bytemuck::cast_slice(&slots.iter().copied().chain([0]).collect::<Vec<_>>()),
        usage,
    );
    let order = crate::gpu::storage(&ctx, "beam_order", 4 * beams.len().max(1) as u64, wgpu::BufferUsages::empty());
    let stats = crate::gpu::storage(&ctx, "beam_stats", STATS_WORDS * 4, wgpu::BufferUsages::empty());
    let img_bytes = u64::from(w) * u64::from(h) * 16;
    let full = crate::gpu::storage(&ctx, "image", img_bytes, wgpu::BufferUsages::empty());
    let caustic = crate::gpu::storage(&ctx, "caustic_image", img_bytes, wgpu::BufferUsages::empty());
    // No surfaces: every pixel's position buffer says "nothing" (w = -1).
    let none = ctx.texture(
        "beam_no_surface",
        wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        wgpu::TextureFormat::Rgba32Float,
        wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
    );
    let texels: Vec<f32> = (0..w * h).flat_map(|_| [0.0, 0.0, 0.0, -1.0]).collect();
    ctx.queue.write_texture(
        none.as_image_copy(),
        bytemuck::cast_slice(&texels),
        wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(w * 16), rows_per_image: Some(h) },
        wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
    );
    let nv = ctx.view(&none, Some(wgpu::TextureViewDimension::D2), 0, Some(1));
    let density = upload_density(&ctx, scene);
    // (positions and normals: the normals are never read where no surface is)
    let tv: [wgpu::BindingResource; 4] = std::array::from_fn(|_| wgpu::BindingResource::TextureView(&nv));
    let mut timer = PassTimer::disabled();
    let foot = footprint(b);
    // (one beam per slot here)
    let chunks = Chunks::new(&bp, &foot, (1, chunk_scale(&ctx, b)));
    let dispatch = chunks.dispatch_buffer(&ctx);
    record_order(&ctx, (&params, bp.slots), (&slot_buf, &order, &stats), (&chunks, &dispatch), &mut enc, &mut timer);
    let dv = density_view(&ctx, &density);
    let f = BeamFrame {
        light: 0,
        params,
        stats,
        beams: beam_buf,
        order,
        capacity: bp.capacity,
        levels: 0,
        footprint: foot,
        chunks,
        dispatch,
        size: (w, h),
        hulls: None,
    };
    if b.volume.on(ctx.device.features()) == BeamVolume::Hulls {
        let hulls = hull_buffer(&ctx, f.capacity);
        record_volume_hulls(&ctx, &f, &hulls, &tv, (&full, &caustic), &dv, &mut enc, &mut timer);
    } else {
        record_gather_chunks(&ctx, &f, &tv, (&full, &caustic), &dv, None, &mut enc, &mut timer);
    }
    ctx.end_scope();
    ctx.queue.submit([enc.finish()]);
    let data = ctx.read_buffer(&full, img_bytes)?;
    let px: &[f32] = bytemuck::cast_slice(&data);
    let mut img = Image::new(w, h);
    for y in 0..h {
        for x in 0..w {
            let i = ((y * w + x) * 4) as usize;
            img.set(x, y, [px[i], px[i + 1], px[i + 2]]);
        }
    }
    Ok(img)
}
