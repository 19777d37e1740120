//! The raster pipelines and [`DrawCtx`]'s draw helpers: which objects a pass draws, into which
//! geometry buffer layer.

use super::{DEPTH_FORMAT, DrawCtx, GBuffer, POS_FORMAT, layer_view};
use crate::gpu::pool::LayoutOf;
use crate::gpu::types::*;
use crate::gpu::{GpuContext, PassTimer};
use crate::scene::Scene;
use glam::Mat4;

#[derive(Clone, Copy, PartialEq)]
pub(super) enum Subset {
    All,
    Diffuse,
    Specular,
    Casters,
    /// Specular meshes (the camera's second layer: analytic shapes are intersected exactly).
    SpecularMeshes,
}

pub(super) fn in_subset(scene: &Scene, i: usize, s: Subset) -> bool {
    let o = &scene.objects[i];
    let spec = scene.material_of(o).is_specular();
    match s {
        Subset::All => true,
        Subset::Diffuse => !spec,
        Subset::Specular => spec,
        Subset::Casters => spec && o.caustic_caster,
        Subset::SpecularMeshes => spec && matches!(o.shape, crate::scene::Shape::Mesh(_)),
    }
}

/// Whether the camera's second specular layer can hold anything (it holds specular meshes only).
pub(super) fn has_specular_meshes(scene: &Scene) -> bool {
    (0..scene.objects.len()).any(|i| in_subset(scene, i, Subset::SpecularMeshes))
}

/// Raster pipelines: geometry buffers with a cull mode, and depth only. The "front" buffers of
/// specular objects are drawn two-sided: the nearest surface of a closed dielectric faces the
/// viewer anyway, and mirrors and conductors are two-sided (the inside of the mirror ring).
pub(crate) struct Raster {
    pub(super) none: wgpu::RenderPipeline,
    pub(super) back: wgpu::RenderPipeline,
    pub(super) depth_only: wgpu::RenderPipeline,
    /// The camera's second specular layer (`raster_peel`): two-sided and back faces.
    pub(super) peel: wgpu::RenderPipeline,
    pub(super) peel_back: wgpu::RenderPipeline,
}

fn vertex_layout() -> wgpu::VertexBufferLayout<'static> {
    const ATTRS: [wgpu::VertexAttribute; 3] = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Uint32];
    wgpu::VertexBufferLayout {
        array_stride: std::mem::size_of::<Vertex>() as u64,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &ATTRS,
    }
}

/// The raster pipelines, built on the context's first frame and reused after.
pub(crate) fn raster_pipelines(ctx: &GpuContext) -> Raster {
    let mut built = None;
    let mut get = |i: usize, label: &str| {
        ctx.render_pipeline(label, || built.get_or_insert_with(|| build_raster_pipelines(ctx))[i].clone())
    };
    Raster {
        none: get(0, "raster_two_sided"),
        back: get(1, "raster_back_faces"),
        depth_only: get(2, "raster_depth"),
        peel: get(3, "raster_peel_two_sided"),
        peel_back: get(4, "raster_peel_back_faces"),
    }
}

fn build_raster_pipelines(ctx: &GpuContext) -> [wgpu::RenderPipeline; 5] {
    let view_entry = wgpu::BindGroupLayoutEntry {
        binding: 0,
        visibility: wgpu::ShaderStages::VERTEX,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    };
    let texture_entry = |binding: u32, sample_type: wgpu::TextureSampleType| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Texture {
            sample_type,
            view_dimension: wgpu::TextureViewDimension::D2,
            multisampled: false,
        },
        count: None,
    };
    let layout = |label: &str, entries: &[wgpu::BindGroupLayoutEntry]| {
        let bgl = ctx.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some(label), entries });
        ctx.device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(label),
            bind_group_layouts: &[Some(&bgl)],
            immediate_size: 0,
        })
    };
    // The objects' transforms, read by the vertex shader.
    let transforms_entry = wgpu::BindGroupLayoutEntry {
        binding: 3,
        visibility: wgpu::ShaderStages::VERTEX,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: true },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    };
    let raster = (ctx.shader("raster"), layout("raster", &[view_entry, transforms_entry]));
    let peel = (
        ctx.shader("raster_peel"),
        layout(
            "raster_peel",
            &[
                view_entry,
                texture_entry(1, wgpu::TextureSampleType::Float { filterable: false }),
                texture_entry(2, wgpu::TextureSampleType::Depth),
                transforms_entry,
            ],
        ),
    );
    let make = |(module, layout): &(wgpu::ShaderModule, wgpu::PipelineLayout),
                cull: Option<wgpu::Face>,
                color: bool,
                label: &str| {
        let targets = [
            Some(wgpu::ColorTargetState { format: POS_FORMAT, blend: None, write_mask: wgpu::ColorWrites::ALL }),
            Some(wgpu::ColorTargetState { format: POS_FORMAT, blend: None, write_mask: wgpu::ColorWrites::ALL }),
        ];
        ctx.device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(label),
            layout: Some(layout),
            vertex: wgpu::VertexState {
                module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[Some(vertex_layout())],
            },
            primitive: wgpu::PrimitiveState { cull_mode: cull, ..Default::default() },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Less),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: color.then(|| wgpu::FragmentState {
                module,
                entry_point: Some("fs_main"),
                compilation_options: Default::default(),
                targets: &targets,
            }),
            multiview_mask: None,
            cache: None,
        })
    };
    [
        make(&raster, None, true, "raster_two_sided"),
        make(&raster, Some(wgpu::Face::Front), true, "raster_back_faces"),
        make(&raster, None, false, "raster_depth"),
        make(&peel, None, true, "raster_peel_two_sided"),
        make(&peel, Some(wgpu::Face::Front), true, "raster_peel_back_faces"),
    ]
}

/// What a raster pass draws: `subset` of the scene seen through `world_to_clip`, into texture
/// layer `layer` of its target.
#[derive(Clone, Copy)]
pub(super) struct Draw {
    pub world_to_clip: Mat4,
    pub layer: u32,
    pub subset: Subset,
}

/// A raster pass: its name (label and timer entry), pipeline, and target: a geometry buffer,
/// or a depth texture alone.
pub(super) struct RasterPass<'a> {
    pub name: &'a str,
    pub pipeline: &'a wgpu::RenderPipeline,
    pub color: Option<(&'a wgpu::Texture, &'a wgpu::Texture)>,
    pub depth: &'a wgpu::Texture,
}

impl<'a> RasterPass<'a> {
    /// A pass into a geometry buffer (position, normal, depth).
    pub fn gbuffer(name: &'a str, pipeline: &'a wgpu::RenderPipeline, gb: &'a GBuffer) -> RasterPass<'a> {
        RasterPass { name, pipeline, color: Some((&gb.pos, &gb.nrm)), depth: &gb.depth }
    }
}

impl DrawCtx<'_> {
    /// Rasterize `draw` in pass `p`.
    pub(super) fn pass(&self, enc: &mut wgpu::CommandEncoder, timer: &mut PassTimer, p: RasterPass, draw: Draw) {
        self.pass_with(enc, timer, p, draw, &[]);
    }

    /// A second layer behind `first` (its texture layer `draw.layer`): `draw.subset` rasterized
    /// again with the per-object depth peel (`raster_peel`: fragments of another object than the
    /// first layer's, behind its surface), two-sided into `front2` and back faces into `back2`,
    /// in passes named `names`. The camera's and the light's second layers.
    pub(super) fn peel(
        &self,
        enc: &mut wgpu::CommandEncoder,
        timer: &mut PassTimer,
        raster: &Raster,
        first: &GBuffer,
        draw: Draw,
        [(front_name, front2), (back_name, back2)]: [(&str, &GBuffer); 2],
    ) {
        let layer = draw.layer;
        let (first_pos, first_depth) =
            (layer_view(self.ctx, &first.pos, layer), layer_view(self.ctx, &first.depth, layer));
        let extra = [
            wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&first_pos) },
            wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(&first_depth) },
        ];
        for (name, pl, gb) in [(front_name, &raster.peel, front2), (back_name, &raster.peel_back, back2)] {
            self.pass_with(enc, timer, RasterPass::gbuffer(name, pl, gb), draw, &extra);
        }
    }

    /// `pass` with further bindings after the view uniform (binding 0).
    fn pass_with(
        &self,
        enc: &mut wgpu::CommandEncoder,
        timer: &mut PassTimer,
        p: RasterPass,
        draw: Draw,
        extra: &[wgpu::BindGroupEntry],
    ) {
        let RasterPass { name, pipeline, color: gb_color, depth } = p;
        let Draw { world_to_clip, layer, subset } = draw;
        let ctx = self.ctx;
        let ubuf =
            ctx.uniform(name, bytemuck::bytes_of(&RasterView { world_to_clip: world_to_clip.to_cols_array_2d() }));
        let own = [
            wgpu::BindGroupEntry { binding: 0, resource: ubuf.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 3, resource: self.geo.transforms.as_entire_binding() },
        ];
        let bg = ctx.bind_group(name, LayoutOf::Render(pipeline.clone()), &[&own[..], extra].concat());
        let views = gb_color.map(|(p, n)| (layer_view(ctx, p, layer), layer_view(ctx, n, layer)));
        let clear_pos = wgpu::Color { r: 0.0, g: 0.0, b: 0.0, a: -1.0 };
        let attachments: Vec<Option<wgpu::RenderPassColorAttachment>> = match &views {
            Some((p, n)) => vec![
                Some(wgpu::RenderPassColorAttachment {
                    view: p,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations { load: wgpu::LoadOp::Clear(clear_pos), store: wgpu::StoreOp::Store },
                }),
                Some(wgpu::RenderPassColorAttachment {
                    view: n,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                        store: wgpu::StoreOp::Store,
                    },
                }),
            ],
            None => vec![],
        };
        let dview = layer_view(ctx, depth, layer);
        let mut rp = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some(name),
            color_attachments: &attachments,
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &dview,
                depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Store }),
                stencil_ops: None,
            }),
            timestamp_writes: timer.render(name),
            occlusion_query_set: None,
            multiview_mask: None,
        });
        rp.set_pipeline(pipeline);
        rp.set_bind_group(0, &bg, &[]);
        rp.set_vertex_buffer(0, self.geo.vertices.slice(..));
        rp.set_index_buffer(self.geo.indices.slice(..), wgpu::IndexFormat::Uint32);
        for (i, r) in self.geo.ranges.iter().enumerate() {
            if in_subset(self.scene, i, subset) && !r.is_empty() {
                rp.draw_indexed(r.clone(), 0, 0..1);
            }
        }
    }
}
