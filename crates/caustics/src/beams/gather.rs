//! The per-pixel beam stages: `beam_gather` over the ordered list's chunks (the volume caustic),
//! `beam_surface` (the surface caustic without hulls), and the standalone [`gather`] for tests
//! and tools.

use crate::error::{Error, Result};
use crate::gpu::pass::{Pass, SharedGroup};
use crate::gpu::types::{BEAM_FLAG_FRAGMENTS, BeamGpu};
use crate::gpu::{GpuContext, PassTimer};
use crate::image_io::Image;
use crate::passes::DrawCtx;
use crate::scene::Scene;
use crate::settings::{BeamSettings, BeamVolume};

use super::hulls::{HullsOf, draw_hulls, hull_buffer, record_hull_polygons, record_volume_hulls};
use super::params::{ChunkRecords, Chunks, KINDS, chunk_scale, footprint, params};
use super::refine::record_order;
use super::{Beam, BeamFrame, STATS_WORDS};

/// The surface caustic of one light's beams, added into the eye's diffuse radiance and caustic
/// accumulators: their hulls drawn (`beam_surface_raster`) where the frame has them, else
/// `beam_surface`, one dispatch per chunk of the ordered list (as the gather: a fixed order, and
/// short loops).
pub(super) fn record_surface(
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
        let resources = [
            f.params.as_entire_binding(),
            eye_views.0.clone(),
            eye_views.1.clone(),
            f.beams.as_entire_binding(),
            hulls.as_entire_binding(),
            f.stats.as_entire_binding(),
        ];
        draw_hulls(ctx, f, "beam_surface_raster", (&resources, &dc.geo.scene), accum, enc, timer);
        return;
    }
    let records = ChunkRecords::new(ctx, "beam_surface_chunks", f.chunks.surface_n, f.chunks.surface);
    for c in 0..f.chunks.surface_n {
        Pass::new(ctx, "beam_surface")
            .bind("bp", &f.params)
            .bind("recv_pos", eye_views.0.clone())
            .bind("recv_nrm", eye_views.1.clone())
            .bind("beams", &f.beams)
            .bind("order", &f.order)
            .bind("stats", &f.stats)
            .bind("radiance", accum.0)
            .bind("caustic", accum.1)
            .bind("chunk", records.binding(c))
            .shared(&dc.geo.scene)
            .dispatch_indirect(enc, timer, &f.dispatch, 12 * u64::from(f.chunks.gather_n + c));
    }
}
/// What the volume caustic's draws read and write: the camera's first surfaces (receiver and
/// specular positions, then normals), the scene group, and the two images they add into.
#[derive(Clone, Copy)]
pub(super) struct GatherTargets<'a> {
    pub eye_views: &'a [wgpu::BindingResource<'a>; 4],
    pub images: (&'a wgpu::Buffer, &'a wgpu::Buffer),
    pub scene: &'a SharedGroup,
}

/// `beam_gather` over light `f`'s chunks: along the camera rays, or (`segs`: the segments and a
/// slot) along the kept segments in that slot.
pub(super) fn record_gather_chunks(
    ctx: &GpuContext,
    f: &BeamFrame,
    targets: &GatherTargets,
    segs: Option<(&crate::passes::EyeSegments, u32)>,
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) {
    let GatherTargets { eye_views, images, scene } = *targets;
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
            .shared(scene)
            .bind("recv_nrm", eye_views[2].clone())
            .bind("spec_nrm", eye_views[3].clone())
            .bind_all(seg_bindings)
            .dispatch_indirect(enc, timer, dispatch, 12 * u64::from(c));
    }
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
    // (the density grid of the scene; no surfaces to hit)
    let scene_group = crate::geometry::scene_group_of(&ctx, scene, None);
    // (positions and normals: the normals are never read where no surface is)
    let tv: [wgpu::BindingResource; 4] = std::array::from_fn(|_| wgpu::BindingResource::TextureView(&nv));
    let mut timer = PassTimer::disabled();
    let foot = footprint(b);
    // (one beam per slot here)
    let chunks = Chunks::new(&bp, &foot, (1, chunk_scale(&ctx, b)));
    let dispatch = chunks.dispatch_buffer(&ctx);
    record_order(&ctx, (&params, bp.slots), (&slot_buf, &order, &stats), (&chunks, &dispatch), &mut enc, &mut timer);
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
        let targets = GatherTargets { eye_views: &tv, images: (&full, &caustic), scene: &scene_group };
        record_volume_hulls(&ctx, &f, &hulls, &targets, &mut enc, &mut timer);
    } else {
        let targets = GatherTargets { eye_views: &tv, images: (&full, &caustic), scene: &scene_group };
        record_gather_chunks(&ctx, &f, &targets, None, &mut enc, &mut timer);
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
