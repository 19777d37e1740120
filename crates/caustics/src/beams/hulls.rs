//! The hull draws: each beam's hull polygon on the image (`beam_hull`), drawn by `beam_raster`
//! (volume caustic) or `beam_surface_raster` (surface caustic), and their pipelines.

use crate::gpu::pass::{Pass, SharedGroup};
use crate::gpu::types::{BEAM_HULL_PARTS, BeamHull};
use crate::gpu::{GpuContext, PassTimer};

use super::BeamFrame;

/// The hull polygons of `capacity` beams (`BEAM_HULL_PARTS` each), written by
/// [`record_hull_polygons`].
pub(super) fn hull_buffer(ctx: &GpuContext, capacity: u32) -> wgpu::Buffer {
    let size = u64::from(capacity) * u64::from(BEAM_HULL_PARTS) * std::mem::size_of::<BeamHull>() as u64;
    crate::gpu::storage(ctx, "beam_hulls", size, wgpu::BufferUsages::empty())
}

/// What a hull polygon bounds: the whole beam (the volume caustic) or its end (the points the
/// surface caustic lights).
#[derive(Clone, Copy)]
pub(super) enum HullsOf {
    Beams = 0,
    Ends = 1,
}

/// `beam_hull`: each ordered beam's hull polygon on the image into `hulls` (an indirect
/// dispatch, a thread per listed beam), for the hull draws of the surface (`HullsOf::Ends`) and
/// volume caustics (`HullsOf::Beams`); run before each draw, which then reads them.
pub(super) fn record_hull_polygons(
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
/// caustic; `beam_surface_raster`: the surface caustic) with group 0 `resources` and the scene
/// group, indirectly (instance k the list's k-th beam; `beam_order` wrote the count), blended into a float image in
/// list order, then `beam_resolve`: that image added to both `images`.
pub(super) fn draw_hulls(
    ctx: &GpuContext,
    f: &BeamFrame,
    stage: &str,
    (resources, scene): (&[wgpu::BindingResource], &SharedGroup),
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
        rp.set_bind_group(scene.index, &scene.group, &[]);
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
pub(super) fn record_volume_hulls(
    ctx: &GpuContext,
    f: &BeamFrame,
    hulls: &wgpu::Buffer,
    targets: &super::gather::GatherTargets,
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) {
    let super::gather::GatherTargets { eye_views, images, scene } = *targets;
    record_hull_polygons(ctx, f, hulls, HullsOf::Beams, enc, timer);
    let foot = ctx.constants("beam_footprint", bytemuck::cast_slice(&f.footprint));
    let resources = [
        f.params.as_entire_binding(),
        eye_views[0].clone(),
        eye_views[1].clone(),
        f.beams.as_entire_binding(),
        hulls.as_entire_binding(),
        foot.as_entire_binding(),
        f.stats.as_entire_binding(),
        eye_views[2].clone(),
        eye_views[3].clone(),
    ];
    draw_hulls(ctx, f, "beam_raster", (&resources, scene), images, enc, timer);
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
