//! The passes of a GPU frame, each named (the name is both the wgpu label and the timer name),
//! which [`crate::renderer::Renderer`] records:
//!
//! 1. `eye_receivers`, `eye_specular_front`, `eye_specular_back` and the camera's second layer:
//!    camera geometry buffers ([`record_eye`]);
//! 2. per light ([`record_light`]) and face: `light_shadow` (depth of everything),
//!    `light_receivers` (position and normal of diffuse surfaces), `light_caster_front`,
//!    `light_caster_back`, and where the scene has caster meshes and two casters or more the
//!    second caster layer `light_caster_front2`, `light_caster_back2` (`raster_peel`: per texel
//!    the nearest caster of another object behind the first); then `coverage_mip` and the
//!    technique's photon stage ([`crate::techniques`]), `caustic_resolve` (flux per texel to
//!    irradiance), the temporal filter, and the shading tiles (`caustic_mask`, `shadow_tiles`:
//!    per-tile summaries of the caustic and shadow maps that `shade_receivers` skips work by);
//! 3. `shade_receivers` per light ([`record_shade`]), then `composite` (image-space refraction
//!    and reflection), in scenes with a medium `medium_scatter` per light (attenuation and
//!    single scattering along the camera rays), and `display` ([`record_composite`]).

use crate::error::Result;
use crate::gpu::pass::Pass;
use crate::gpu::pool::LayoutOf;
use crate::gpu::types::*;
use crate::gpu::{GpuContext, PassTimer};
use crate::image_io::Image;
use crate::lightspace::{CasterBox, LightView, caster_box};
use crate::output::FluxStats;
use crate::scene::{Light, Material, Scene, Tessellation};
use crate::settings::Technique;
use glam::{Mat4, Vec3};
use std::ops::Range;

use crate::settings::RenderSettings;

const POS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
use crate::settings::MAX_GBUFFER;

/// The scene's triangles, uploaded once (in the pose of the scene file), and the per-object
/// records the frame rewrites when objects move.
pub(crate) struct Geometry {
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    /// Index ranges per object.
    ranges: Vec<Range<u32>>,
    /// Per object: material and analytic shape (in the current pose).
    pub materials: wgpu::Buffer,
    /// Per object: [`ObjectTransform`] from the scene file's pose to the current one.
    pub transforms: wgpu::Buffer,
    /// The environment map (linear radiance, Rgba32Float; 1×1 black without one).
    pub environment: wgpu::Texture,
    /// The medium's density grid (R32Float, 3D; 1×1×1 holding 1 without one).
    pub density: wgpu::Texture,
    /// The exact tracer's BVH (`crate::accel`): bottom levels built once, instances rewritten
    /// when objects move ([`Geometry::write_instances`]).
    pub bvh: crate::accel::SceneBvh,
    pub bvh_nodes: wgpu::Buffer,
    pub bvh_tris: wgpu::Buffer,
    pub bvh_instances: wgpu::Buffer,
}

impl Geometry {
    /// The BVH's buffers by the names the stages give them.
    pub(crate) fn bvh_bindings(&self) -> [(&'static str, &wgpu::Buffer); 3] {
        [("bvh_nodes", &self.bvh_nodes), ("bvh_tris", &self.bvh_tris), ("bvh_instances", &self.bvh_instances)]
    }

    /// Write the BVH instances for the objects' transforms (from the scene file's pose).
    pub(crate) fn write_instances(&self, ctx: &GpuContext, transforms: &[glam::Affine3A]) {
        let inst = self.bvh.instance_records(transforms);
        ctx.queue.write_buffer(&self.bvh_instances, 0, bytemuck::cast_slice(&inst));
    }
}

#[derive(Clone, Copy, PartialEq)]
enum Subset {
    All,
    Diffuse,
    Specular,
    Casters,
    /// Specular meshes (the camera's second layer: analytic shapes are intersected exactly).
    SpecularMeshes,
}

fn in_subset(scene: &Scene, i: usize, s: Subset) -> bool {
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
fn has_specular_meshes(scene: &Scene) -> bool {
    (0..scene.objects.len()).any(|i| in_subset(scene, i, Subset::SpecularMeshes))
}

/// Upload the triangles of `scene` (the pose of its file) with identity transforms.
pub(crate) fn upload_geometry(ctx: &GpuContext, scene: &Scene, t: &Tessellation) -> Geometry {
    let mut vertices: Vec<Vertex> = Vec::new();
    let mut indices: Vec<u32> = Vec::new();
    let mut ranges = Vec::new();
    for (i, o) in scene.objects.iter().enumerate() {
        let m = o.shape.tessellate(t);
        let base = vertices.len() as u32;
        for (p, n) in m.positions.iter().zip(&m.normals) {
            vertices.push(Vertex { position: p.to_array(), normal: n.to_array(), object: i as u32 });
        }
        let start = indices.len() as u32;
        indices.extend(m.indices.iter().flat_map(|t| t.map(|x| x + base)));
        ranges.push(start..indices.len() as u32);
    }
    let storage = wgpu::BufferUsages::STORAGE;
    let identity = glam::Affine3A::IDENTITY;
    let transforms: Vec<ObjectTransform> = scene.objects.iter().map(|_| object_transform(&identity)).collect();
    let bvh = crate::accel::SceneBvh::build(scene);
    let (nodes, tris) = bvh.gpu_arrays();
    let inst = bvh.instance_records(&[]);
    Geometry {
        bvh_nodes: ctx.buffer_init("bvh_nodes", bytemuck::cast_slice(&nodes), storage),
        bvh_tris: ctx.buffer_init("bvh_tris", bytemuck::cast_slice(&tris), storage),
        bvh_instances: ctx.buffer_init("bvh_instances", bytemuck::cast_slice(&inst), storage),
        bvh,
        vertices: ctx.buffer_init("vertices", bytemuck::cast_slice(&vertices), wgpu::BufferUsages::VERTEX),
        indices: ctx.buffer_init("indices", bytemuck::cast_slice(&indices), wgpu::BufferUsages::INDEX),
        ranges,
        materials: ctx.buffer_init("materials", bytemuck::cast_slice(&material_records(scene)), storage),
        transforms: ctx.buffer_init("object_transforms", bytemuck::cast_slice(&transforms), storage),
        environment: upload_environment(ctx, scene),
        density: upload_density(ctx, scene),
    }
}

/// The GPU record of a transform (positions by the affine map, normals by its rotation).
pub(crate) fn object_transform(t: &glam::Affine3A) -> ObjectTransform {
    let m = glam::Mat3::from(t.matrix3);
    let s = m.x_axis.length();
    let rot = if s == 1.0 { m } else { m * (1.0 / s) };
    ObjectTransform { model: Mat4::from(*t).to_cols_array_2d(), normal: Mat4::from_mat3(rot).to_cols_array_2d() }
}

/// Per object: material and analytic shape of `scene` as it is now.
pub(crate) fn material_records(scene: &Scene) -> Vec<MaterialGpu> {
    let mut mats = Vec::new();
    for o in &scene.objects {
        let caster = u32::from(o.caustic_caster);
        let (kind, a, b) = match *scene.material_of(o) {
            Material::Diffuse { albedo } => (KIND_DIFFUSE, albedo.extend(0.0).to_array(), [0.0; 4]),
            Material::Dielectric { ior, ext_ior } => (KIND_DIELECTRIC, [ior, ext_ior, 0.0, 0.0], [0.0; 4]),
            Material::Mirror { reflectance } => (KIND_MIRROR, reflectance.extend(0.0).to_array(), [0.0; 4]),
            Material::Conductor { eta, k } => (KIND_CONDUCTOR, eta.extend(0.0).to_array(), k.extend(0.0).to_array()),
        };
        let (shape_kind, shape) = analytic_shape(&o.shape);
        mats.push(MaterialGpu { kind: [kind, caster, shape_kind, 0], a, b, shape });
    }
    mats
}

/// An object's analytic shape for exact intersection in the shaders: (kind, parameters).
fn analytic_shape(shape: &crate::scene::Shape) -> (u32, [[f32; 4]; 4]) {
    use crate::scene::Shape;
    match shape {
        Shape::Sphere { center, radius } => {
            (SHAPE_SPHERE, [center.extend(*radius).to_array(), [0.0; 4], [0.0; 4], [0.0; 4]])
        }
        Shape::Cylinder { base_center, axis, radius, height } => (
            SHAPE_CYLINDER,
            [base_center.extend(*radius).to_array(), axis.extend(*height).to_array(), [0.0; 4], [0.0; 4]],
        ),
        Shape::Rectangle { center, normal, u, v, size } => (
            SHAPE_RECTANGLE,
            [
                center.extend(0.0).to_array(),
                normal.extend(0.0).to_array(),
                u.extend(size.x).to_array(),
                v.extend(size.y).to_array(),
            ],
        ),
        Shape::Mesh(_) => (SHAPE_MESH, [[0.0; 4]; 4]),
    }
}

/// Raster pipelines: geometry buffers with a cull mode, and depth only. The "front" buffers of
/// specular objects are drawn two-sided: the nearest surface of a closed dielectric faces the
/// viewer anyway, and mirrors and conductors are two-sided (the inside of the mirror ring).
pub(crate) struct Raster {
    none: wgpu::RenderPipeline,
    back: wgpu::RenderPipeline,
    depth_only: wgpu::RenderPipeline,
    /// The camera's second specular layer (`raster_peel`): two-sided and back faces.
    peel: wgpu::RenderPipeline,
    peel_back: wgpu::RenderPipeline,
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

fn texture(
    ctx: &GpuContext,
    label: &str,
    size: u32,
    size_y: u32,
    layers: u32,
    format: wgpu::TextureFormat,
) -> wgpu::Texture {
    let usage =
        wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_SRC;
    ctx.texture(label, wgpu::Extent3d { width: size, height: size_y, depth_or_array_layers: layers }, format, usage)
}

pub(crate) fn layer_view(ctx: &GpuContext, t: &wgpu::Texture, layer: u32) -> wgpu::TextureView {
    ctx.view(t, Some(wgpu::TextureViewDimension::D2), layer, Some(1))
}

pub(crate) fn array_view(ctx: &GpuContext, t: &wgpu::Texture) -> wgpu::TextureView {
    ctx.view(t, Some(wgpu::TextureViewDimension::D2Array), 0, None)
}

/// A geometry buffer: position + object id, normal, depth; `layers` faces.
pub(crate) struct GBuffer {
    pub pos: wgpu::Texture,
    pub nrm: wgpu::Texture,
    pub depth: wgpu::Texture,
}

impl GBuffer {
    fn new(ctx: &GpuContext, label: &str, w: u32, h: u32, layers: u32) -> GBuffer {
        GBuffer {
            pos: texture(ctx, &format!("{label}_position"), w, h, layers, POS_FORMAT),
            nrm: texture(ctx, &format!("{label}_normal"), w, h, layers, POS_FORMAT),
            depth: texture(ctx, &format!("{label}_depth"), w, h, layers, DEPTH_FORMAT),
        }
    }
}

pub(crate) struct DrawCtx<'a> {
    pub ctx: &'a GpuContext,
    pub geo: &'a Geometry,
    pub scene: &'a Scene,
}

impl DrawCtx<'_> {
    /// Rasterize `subset` into layer `layer` of a geometry buffer (or a depth-only target).
    #[expect(clippy::too_many_arguments, reason = "a pass is described by all of these")]
    fn pass(
        &self,
        enc: &mut wgpu::CommandEncoder,
        timer: &mut PassTimer,
        name: &str,
        pipeline: &wgpu::RenderPipeline,
        gb_color: Option<(&wgpu::Texture, &wgpu::Texture)>,
        depth: &wgpu::Texture,
        layer: u32,
        world_to_clip: Mat4,
        subset: Subset,
    ) {
        self.pass_with(enc, timer, name, pipeline, gb_color, depth, layer, world_to_clip, subset, &[]);
    }

    /// A second layer behind `first` (its texture layer `layer`): `subset` rasterized again with
    /// the per-object depth peel (`raster_peel`: fragments of another object than the first
    /// layer's, behind its surface), two-sided into `front2` and back faces into `back2`, in
    /// passes named `names`. The camera's and the light's second layers.
    #[expect(clippy::too_many_arguments, reason = "a pass is described by all of these")]
    fn peel(
        &self,
        enc: &mut wgpu::CommandEncoder,
        timer: &mut PassTimer,
        raster: &Raster,
        first: &GBuffer,
        layer: u32,
        world_to_clip: Mat4,
        subset: Subset,
        [(front_name, front2), (back_name, back2)]: [(&str, &GBuffer); 2],
    ) {
        let (first_pos, first_depth) =
            (layer_view(self.ctx, &first.pos, layer), layer_view(self.ctx, &first.depth, layer));
        let extra = [
            wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&first_pos) },
            wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(&first_depth) },
        ];
        for (name, pl, gb) in [(front_name, &raster.peel, front2), (back_name, &raster.peel_back, back2)] {
            let color = Some((&gb.pos, &gb.nrm));
            self.pass_with(enc, timer, name, pl, color, &gb.depth, layer, world_to_clip, subset, &extra);
        }
    }

    /// `pass` with further bindings after the view uniform (binding 0).
    #[expect(clippy::too_many_arguments, reason = "a pass is described by all of these")]
    fn pass_with(
        &self,
        enc: &mut wgpu::CommandEncoder,
        timer: &mut PassTimer,
        name: &str,
        pipeline: &wgpu::RenderPipeline,
        gb_color: Option<(&wgpu::Texture, &wgpu::Texture)>,
        depth: &wgpu::Texture,
        layer: u32,
        world_to_clip: Mat4,
        subset: Subset,
        extra: &[wgpu::BindGroupEntry],
    ) {
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

#[expect(clippy::too_many_arguments, reason = "every field of the light's uniform")]
fn light_gpu(
    view: &LightView,
    light: &Light,
    n: u32,
    m: u32,
    g: u32,
    sigma: f32,
    scale: f64,
    caster_radius: f32,
    multi_bounce: f32,
    lens: f32,
    crop: [f32; 4],
    medium: Option<&crate::scene::Medium>,
    grid_steps: u32,
) -> LightGpu {
    let mut faces = [FaceGpu { world_to_clip: [[0.0; 4]; 4], clip_to_world: [[0.0; 4]; 4], origin: [0.0; 4] }; 6];
    for (f, face) in view.faces.iter().enumerate() {
        faces[f] = FaceGpu {
            world_to_clip: face.world_to_clip.to_cols_array_2d(),
            clip_to_world: face.world_to_clip.inverse().to_cols_array_2d(),
            origin: face.origin_or_dir.extend(if face.orthographic { 1.0 } else { 0.0 }).to_array(),
        };
    }
    let (kind, power, axis, cone, start) = match light {
        Light::Spot { direction, cone_angle, falloff_start, intensity, .. } => {
            (LIGHT_SPOT, *intensity, *direction, *cone_angle, *falloff_start)
        }
        Light::Point { intensity, .. } => {
            (LIGHT_POINT, *intensity, Vec3::Y, std::f32::consts::PI, std::f32::consts::PI)
        }
        Light::Directional { direction, irradiance } => (LIGHT_DIRECTIONAL, *irradiance, *direction, 0.0, 0.0),
    };
    LightGpu {
        faces,
        info: [view.faces.len() as u32, kind, n, m],
        power: power.extend(cone.cos()).to_array(),
        axis: axis.extend(cone).to_array(),
        params: [start, scale as f32, sigma, g as f32],
        extra: [caster_radius, view.scene_radius, view.tan_half_fov, multi_bounce],
        splat: [lens, if view.has_spill() { SPILL_FACE_PRESENT as f32 } else { 0.0 }, 0.0, 0.0],
        crop,
        // Photons carry their path's transmittance (w: 1 homogeneous, 2 a density grid marched
        // in `medium_light_steps` steps per segment, in sigma_t's w).
        medium_lo: medium
            .map_or([0.0; 4], |m| m.bounds_min.extend(if m.density.is_some() { 2.0 } else { 1.0 }).to_array()),
        medium_hi: medium.map_or([0.0; 4], |m| m.bounds_max.extend(0.0).to_array()),
        medium_sigma_t: medium.map_or([0.0; 4], |m| (m.sigma_s + m.sigma_a).extend(grid_steps as f32).to_array()),
    }
}

/// Upper bound of the flux (W, r + g + b) a light can send through its view: sets the
/// fixed-point scale so that no sum can overflow 2^53.
fn flux_bound(view: &LightView, light: &Light) -> f64 {
    match light {
        Light::Spot { intensity, cone_angle, .. } => {
            let sum = intensity.x + intensity.y + intensity.z;
            sum as f64 * std::f64::consts::TAU * (1.0 - (*cone_angle as f64).cos()).max(1e-9)
        }
        Light::Point { intensity, .. } => (intensity.x + intensity.y + intensity.z) as f64 * 4.0 * std::f64::consts::PI,
        Light::Directional { irradiance, .. } => {
            let inv = view.faces[0].world_to_clip.inverse();
            let ex = inv.transform_vector3(Vec3::new(2.0, 0.0, 0.0));
            let ey = inv.transform_vector3(Vec3::new(0.0, 2.0, 0.0));
            (irradiance.x + irradiance.y + irradiance.z) as f64 * ex.cross(ey).length() as f64
        }
    }
    .max(1e-12)
}

/// The whole face in NDC (lo.x, lo.y, hi.x, hi.y): `LightGpu.crop` of an uncropped grid.
const FULL_FACE: [f32; 4] = [-1.0, -1.0, 1.0, 1.0];

/// The NDC rectangle (lo.x, lo.y, hi.x, hi.y) over which `photon_trace` spreads the N × N grid of
/// an orthographic (directional-light) face: the casters' bounding box as the face sees it, plus
/// one cell of the cropped grid and one caster-buffer texel (G) on each side, clamped to the
/// face. The whole face when there are no casters or the box reaches behind the view. Each
/// photon's flux is E × its (smaller) cell's area, so the total follows; the shadow, receiver and
/// caustic maps stay on the whole face.
fn photon_crop(scene: &Scene, face: &crate::lightspace::LightFace, n: u32, g: u32) -> [f32; 4] {
    let CasterBox::Ndc(a, b) = caster_box(scene, face) else { return FULL_FACE };
    let margin = (b - a) / n.saturating_sub(2).max(1) as f32 + glam::Vec2::splat(2.0 / g as f32);
    let (a, b) = ((a - margin).max(glam::Vec2::splat(-1.0)), (b + margin).min(glam::Vec2::splat(1.0)));
    if b.x <= a.x || b.y <= a.y {
        return FULL_FACE;
    }
    [a.x, a.y, b.x, b.y]
}

/// An upper bound of the relevant photons (cells of the N × N grid whose caster-buffer texel
/// holds a caster) of one face: the cells within one texel of the casters' bounding box as the
/// face sees it (the whole face when the box reaches behind the light).
fn relevant_bound(scene: &Scene, face: &crate::lightspace::LightFace, n: u32, g: u32) -> u64 {
    let all = (n as u64).pow(2);
    let (a, b) = match caster_box(scene, face) {
        CasterBox::NoCasters => return 0,
        CasterBox::Behind => return all,
        CasterBox::Ndc(a, b) => (a, b),
    };
    let margin = 2.0 * (n / g) as f64 + 2.0;
    let side = |lo: f32, hi: f32| {
        let (lo, hi) = (lo.clamp(-1.0, 1.0) as f64, hi.clamp(-1.0, 1.0) as f64);
        ((hi - lo) * 0.5 * n as f64 + margin).min(n as f64)
    };
    ((side(a.x, b.x) * side(a.y, b.y)).ceil() as u64).min(all)
}

pub(crate) fn bytes_to_image(data: &[u8], w: u32, h: u32) -> Image {
    let px: &[[f32; 4]] = bytemuck::cast_slice(data);
    Image { width: w, height: h, pixels: px.iter().map(|p| [p[0], p[1], p[2]]).collect() }
}

/// What the passes of a frame share, derived from the scene and the settings.
pub(crate) struct FrameConsts {
    /// Photon grid N, caster buffer size G, caustic map size M.
    pub n: u32,
    pub g: u32,
    pub m: u32,
    /// The light's second caster layer is drawn.
    pub layer2: bool,
    /// 0: no search for a second caster; 1: analytic casters only; 2: mesh casters too.
    pub multi_bounce: f32,
    pub caster_radius: f32,
    /// The reflected branch at glass is traced.
    pub reflect_branch: bool,
    /// Trace the branch reflected once inside a dielectric (exact tracer).
    pub internal_branch: bool,
    /// Trace the residual pass (exact tracer).
    pub residual_branch: bool,
    /// The caustics of directional lights come from caustic spheres: their photon stages are
    /// skipped (set by the renderer for `Technique::CausticSpheres`).
    pub caustic_spheres: bool,
}

impl FrameConsts {
    pub fn new(scene: &Scene, s: &RenderSettings) -> FrameConsts {
        // The light's second caster layer: only for scenes with caster meshes (analytic casters
        // met after the first are intersected exactly, and scenes without meshes keep their
        // maps) and at least two casters (the peel keeps other objects only: one caster leaves
        // it empty).
        let casters: Vec<_> =
            scene.objects.iter().filter(|o| o.caustic_caster && scene.material_of(o).is_specular()).collect();
        let meshes = casters.iter().any(|o| matches!(o.shape, crate::scene::Shape::Mesh(_)));
        let layer2 = s.testing.light_second_layer && casters.len() >= 2 && meshes;
        // Whether a photon leaving a caster can meet a caster again: not for a lone convex
        // caster (a sphere), where the search would only cost time.
        let multi_bounce = if casters.len() == 1 && matches!(casters[0].shape, crate::scene::Shape::Sphere { .. }) {
            0.0
        } else if meshes {
            2.0
        } else {
            1.0
        };
        FrameConsts {
            n: s.photons.count,
            g: s.photons.count.min(MAX_GBUFFER),
            m: s.photons.caustic_map_size,
            layer2,
            multi_bounce,
            caster_radius: scene.caster_bounds().map_or(1.0, |(a, b)| (b - a).length() * 0.5),
            reflect_branch: s.photons.reflection
                && scene
                    .objects
                    .iter()
                    .any(|o| o.caustic_caster && matches!(scene.material_of(o), Material::Dielectric { .. })),
            internal_branch: s.photons.internal_reflection
                && s.photons.tracer == crate::settings::Tracer::Exact
                && scene.objects.iter().any(|o| matches!(scene.material_of(o), Material::Dielectric { .. })),
            residual_branch: s.photons.residual
                && s.photons.tracer == crate::settings::Tracer::Exact
                && scene.objects.iter().any(|o| matches!(scene.material_of(o), Material::Dielectric { .. })),
            caustic_spheres: s.photons.technique == Technique::CausticSpheres,
        }
    }
}

/// The camera's geometry buffers and the frame's radiance accumulators.
pub(crate) struct EyeFrame {
    pub recv: GBuffer,
    pub front: GBuffer,
    pub back: GBuffer,
    pub front2: GBuffer,
    pub back2: GBuffer,
    pub cam_clip: Mat4,
    /// Radiance of the diffuse surfaces, all light and caustic light only (vec4 per pixel).
    pub radiance: wgpu::Buffer,
    pub caustic: wgpu::Buffer,
}

/// The camera's passes: `eye_receivers`, `eye_specular_front`, `eye_specular_back` and the
/// second specular layer.
pub(crate) fn record_eye(
    dc: &DrawCtx,
    raster: &Raster,
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) -> EyeFrame {
    let (ctx, scene) = (dc.ctx, dc.scene);
    let cam = &scene.camera;
    let (lo, hi) = scene.bounds();
    let far = (cam.position.distance((lo + hi) * 0.5) + (hi - lo).length() * 0.5) * 1.05;
    let near = (far * 1e-4).max(1e-3);
    let cam_clip = cam.view_to_clip(near, far) * cam.world_to_view();
    let (w, h) = (cam.width, cam.height);
    let recv = GBuffer::new(ctx, "eye_receivers", w, h, 1);
    let front = GBuffer::new(ctx, "eye_specular_front", w, h, 1);
    let back = GBuffer::new(ctx, "eye_specular_back", w, h, 1);
    for (name, pl, gb, subset) in [
        ("eye_receivers", &raster.none, &recv, Subset::Diffuse),
        ("eye_specular_front", &raster.none, &front, Subset::Specular),
        ("eye_specular_back", &raster.back, &back, Subset::Specular),
    ] {
        dc.pass(enc, timer, name, pl, Some((&gb.pos, &gb.nrm)), &gb.depth, 0, cam_clip, subset);
    }
    // The second specular layer (meshes behind the first layer's object), front and back; not
    // drawn in scenes without specular meshes, where `composite` does not read it.
    let front2 = GBuffer::new(ctx, "eye_specular_front2", w, h, 1);
    let back2 = GBuffer::new(ctx, "eye_specular_back2", w, h, 1);
    if has_specular_meshes(scene) {
        dc.peel(
            enc,
            timer,
            raster,
            &front,
            0,
            cam_clip,
            Subset::SpecularMeshes,
            [("eye_specular_front2", &front2), ("eye_specular_back2", &back2)],
        );
    }
    let img_bytes = (w as u64) * (h as u64) * 16;
    let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
    EyeFrame {
        recv,
        front,
        back,
        front2,
        back2,
        cam_clip,
        radiance: ctx.buffer("radiance", img_bytes, usage),
        caustic: ctx.buffer("caustic_radiance", img_bytes, usage),
    }
}

/// A light's view, its uniform record and the fixed-point scale of its flux sums.
pub(crate) fn light_record(
    scene: &Scene,
    light: &Light,
    s: &RenderSettings,
    fc: &FrameConsts,
) -> (LightView, LightGpu, f64) {
    let view = s.light_view(scene, light);
    let scale = (1u64 << 52) as f64 / flux_bound(&view, light);
    let lens = s.photons.splat.lens_flag(s.photons.technique);
    // A directional light's view covers the whole scene: the basic technique's dense grid is
    // spread over the casters only. The hierarchical technique keeps the whole face (its tiles
    // follow a coverage mip of the full grid, and its statistics and batch plan count whole-face
    // cells); the adaptive techniques and beams trace their own grids (not photon_trace).
    // Spot and point lights keep the whole face (their views already frame the light's cone or
    // cube).
    let crop = match light {
        Light::Directional { .. } if s.photons.technique.emission() == Technique::Basic => {
            photon_crop(scene, &view.faces[0], fc.n, fc.g)
        }
        _ => FULL_FACE,
    };
    let medium = scene.medium.as_ref();
    let lg = light_gpu(
        &view,
        light,
        fc.n,
        fc.m,
        fc.g,
        s.photons.splat_sigma,
        scale,
        fc.caster_radius,
        fc.multi_bounce,
        lens,
        crop,
        medium,
        s.medium.light_steps,
    );
    (view, lg, scale)
}

/// What a light's passes made: kept (in the light's resource scope) for the frames that do not
/// redo them.
pub(crate) struct LightFrame {
    pub light_buf: wgpu::Buffer,
    pub faces: u32,
    /// The faces photons (and beams) start from: all but a spot's spill face, the last.
    pub emit_faces: u32,
    pub scale: f64,
    pub shadow: wgpu::Texture,
    pub recv: GBuffer,
    pub casters: (GBuffer, GBuffer),
    pub casters2: Option<(GBuffer, GBuffer)>,
    /// Fixed-point flux per texel (r, g, b as 64-bit words), irradiance (vec4 per texel), and
    /// the flux bookkeeping (six 64-bit sums).
    pub accum: wgpu::Buffer,
    pub irradiance: wgpu::Buffer,
    pub stats: wgpu::Buffer,
    /// The irradiance as an M × M × faces Rgba32Float texture (the renderer's output).
    pub irradiance_tex: wgpu::Texture,
    /// Per tile of the caustic map, whether it holds light (`caustic_mask`), and per tile of
    /// the shadow map its depth range (`shadow_tiles`), for `shade_receivers`.
    pub caustic_mask: wgpu::Buffer,
    pub shadow_tiles: wgpu::Buffer,
}

/// Everything one light does in a frame: the light-space buffers of every face, the technique's
/// photon stage, `caustic_resolve`, the temporal filter, and the copy of the map into a texture.
#[expect(clippy::too_many_arguments, reason = "a light's passes are described by all of these")]
pub(crate) fn record_light(
    dc: &DrawCtx,
    raster: &Raster,
    stages: &crate::techniques::Stages,
    (s, inspect): (&RenderSettings, crate::settings::Inspect),
    fc: &FrameConsts,
    (li, view, lg, scale): (usize, &LightView, &LightGpu, f64),
    temporal: Option<&mut crate::temporal::TemporalFilter>,
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) -> Result<(LightFrame, crate::techniques::Pending)> {
    let (ctx, scene) = (dc.ctx, dc.scene);
    let (n, g, m) = (fc.n, fc.g, fc.m);
    let nf = view.faces.len() as u32;
    // The faces that emit photons and have caster buffers: all but a spill face, which only
    // receives (shadow, receiver and caustic maps).
    let ne = view.emit_faces as u32;
    let light_buf = ctx.uniform("light", bytemuck::bytes_of(lg));
    let shadow = texture(ctx, "light_shadow", s.shading.shadow_map_size, s.shading.shadow_map_size, nf, DEPTH_FORMAT);
    let recv = GBuffer::new(ctx, "light_receivers", m, m, nf);
    let front = GBuffer::new(ctx, "light_caster_front", g, g, ne);
    let back = GBuffer::new(ctx, "light_caster_back", g, g, ne);
    let layer2_bufs = fc.layer2.then(|| {
        (GBuffer::new(ctx, "light_caster_front2", g, g, ne), GBuffer::new(ctx, "light_caster_back2", g, g, ne))
    });
    for (f, face) in view.faces.iter().enumerate() {
        let (f, clip) = (f as u32, face.world_to_clip);
        dc.pass(enc, timer, "light_shadow", &raster.depth_only, None, &shadow, f, clip, Subset::All);
        dc.pass(
            enc,
            timer,
            "light_receivers",
            &raster.none,
            Some((&recv.pos, &recv.nrm)),
            &recv.depth,
            f,
            clip,
            Subset::Diffuse,
        );
        if f >= ne {
            continue;
        }
        for (name, pl, gb, subset) in [
            ("light_caster_front", &raster.none, &front, Subset::Casters),
            ("light_caster_back", &raster.back, &back, Subset::Casters),
        ] {
            dc.pass(enc, timer, name, pl, Some((&gb.pos, &gb.nrm)), &gb.depth, f, clip, subset);
        }
        // The second caster layer: the casters again, with a per-object depth peel against
        // this face's first layer (two-sided front, back faces), as the camera's.
        if let Some((front2, back2)) = &layer2_bufs {
            dc.peel(
                enc,
                timer,
                raster,
                &front,
                f,
                clip,
                Subset::Casters,
                [("light_caster_front2", front2), ("light_caster_back2", back2)],
            );
        }
    }
    let texels = (m as u64) * (m as u64) * nf as u64;
    let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
    let accum = ctx.buffer("caustic_flux", texels * 24, usage);
    let irradiance = ctx.buffer("caustic_irradiance", texels * 16, usage);
    let stats = ctx.buffer("flux_stats", crate::output::FLUX_STATS_BYTES, usage);
    let splat_targets = crate::splat::SplatTargets::new(ctx, s.photons.splat, texels, nf);
    let [fpv, fnv, bpv, bnv, rpv, rnv] =
        [&front.pos, &front.nrm, &back.pos, &back.nrm, &recv.pos, &recv.nrm].map(|t| array_view(ctx, t));
    let l2v = layer2_bufs.as_ref().map(|(f2, b2)| [&f2.pos, &f2.nrm, &b2.pos, &b2.nrm].map(|t| array_view(ctx, t)));
    let layer2_views = match &l2v {
        Some(v) => [&v[0], &v[1], &v[2], &v[3]],
        None => [&fpv, &fnv, &bpv, &bnv],
    };
    let density = density_view(ctx, &dc.geo.density);
    let emit = crate::techniques::Emit {
        ctx,
        settings: s,
        inspect,
        stages,
        light_buf: &light_buf,
        front_pos: &fpv,
        front_nrm: &fnv,
        back_pos: &bpv,
        back_nrm: &bnv,
        layer2: layer2_views,
        recv_pos: &rpv,
        recv_nrm: &rnv,
        geo: dc.geo,
        density: &density,
        stats: &stats,
        accum: &accum,
        splat_targets: &splat_targets,
        n,
        g,
        bound: view.faces[..view.emit_faces].iter().map(|f| relevant_bound(scene, f, n, g)).collect(),
        reflect_branch: fc.reflect_branch,
        internal_branch: fc.internal_branch,
        residual_branch: fc.residual_branch,
        // Caustic spheres' directional lights, and spot and point lights whose surface caustic
        // comes from their beams (`SurfaceCaustics::Beams`): their maps stay zero, so the
        // shading adds no photon caustic for them.
        skip_photons: (fc.caustic_spheres && matches!(scene.lights[li], Light::Directional { .. }))
            || s.surface_caustics_from_beams(&scene.lights[li]),
    };
    let pending = crate::techniques::emit(&emit, enc, timer, ne)?;
    splat_targets.finish(ctx, s.photons.splat, &light_buf, &accum, enc, timer);
    let rp = ctx.uniform("resolve_params", bytemuck::bytes_of(&CountParams { count: texels as u32, _pad: [0; 3] }));
    Pass::new(ctx, "caustic_resolve")
        .bind("light", &light_buf)
        .bind("rp", &rp)
        .bind("accum", &accum)
        .bind("recv_pos", &rpv)
        .bind("recv_nrm", &rnv)
        .bind("irradiance", &irradiance)
        .dispatch(enc, timer, [(texels as u32).div_ceil(256), 1, 1]);
    if let Some(t) = temporal {
        t.record(ctx, enc, Some(timer), li, &irradiance, m, nf);
    }
    let (caustic_mask, shadow_tiles) =
        record_tiles(ctx, (m, s.shading.shadow_map_size, nf), &irradiance, &shadow, enc, timer);
    let irradiance_tex = ctx.texture(
        "caustic_irradiance",
        wgpu::Extent3d { width: m, height: m, depth_or_array_layers: nf },
        wgpu::TextureFormat::Rgba32Float,
        wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST | wgpu::TextureUsages::COPY_SRC,
    );
    enc.copy_buffer_to_texture(
        wgpu::TexelCopyBufferInfo {
            buffer: &irradiance,
            layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(m * 16), rows_per_image: Some(m) },
        },
        irradiance_tex.as_image_copy(),
        wgpu::Extent3d { width: m, height: m, depth_or_array_layers: nf },
    );
    let frame = LightFrame {
        light_buf,
        faces: nf,
        emit_faces: ne,
        scale,
        shadow,
        recv,
        casters: (front, back),
        casters2: layer2_bufs,
        accum,
        irradiance,
        stats,
        irradiance_tex,
        caustic_mask,
        shadow_tiles,
    };
    Ok((frame, pending))
}

/// `caustic_mask` and `shadow_tiles`: per tile of a light's finished caustic map, whether any
/// texel holds light, and per tile of its shadow map the depth range, so that `shade_receivers`
/// skips the lookups whose result they decide (made once per light's maps: a camera-only frame
/// does not redo them). `(m, shadow, faces)`: the two map sizes per face and the faces.
fn record_tiles(
    ctx: &GpuContext,
    (m, shadow_size, nf): (u32, u32, u32),
    irradiance: &wgpu::Buffer,
    shadow: &wgpu::Texture,
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) -> (wgpu::Buffer, wgpu::Buffer) {
    let ct = m.div_ceil(SHADE_TILE);
    let st = shadow_size.div_ceil(SHADE_TILE);
    let mask = ctx.buffer("caustic_mask", (ct * ct * nf) as u64 * 4, wgpu::BufferUsages::STORAGE);
    let tiles = ctx.buffer("shadow_tiles", (st * st * nf) as u64 * 8, wgpu::BufferUsages::STORAGE);
    let mp = ctx.uniform("mask_params", bytemuck::bytes_of(&TileParams { size: m, tiles: ct, faces: nf, _pad: 0 }));
    let tp = ctx
        .uniform("tile_params", bytemuck::bytes_of(&TileParams { size: shadow_size, tiles: st, faces: nf, _pad: 0 }));
    let shv = array_view(ctx, shadow);
    let mask_pass = Pass::new(ctx, "caustic_mask").bind("mp", &mp).bind("irradiance", irradiance).bind("mask", &mask);
    let tiles_pass = Pass::new(ctx, "shadow_tiles").bind("tp", &tp).bind("shadow_map", &shv).bind("tiles", &tiles);
    let (mask_pass, tiles_pass) = (mask_pass.group(), tiles_pass.group());
    mask_pass.dispatch(enc, timer, [ct.div_ceil(8), ct.div_ceil(8), nf]);
    tiles_pass.dispatch(enc, timer, [st.div_ceil(8), st.div_ceil(8), nf]);
    (mask, tiles)
}

/// The shadow maps' comparison sampler (bilinear percentage-closer lookups), shared by the
/// shading and the medium passes.
pub(crate) fn shadow_sampler(ctx: &GpuContext) -> wgpu::Sampler {
    ctx.sampler(
        "shadow",
        &wgpu::SamplerDescriptor {
            label: Some("shadow"),
            compare: Some(wgpu::CompareFunction::LessEqual),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            address_mode_u: wgpu::AddressMode::ClampToEdge,
            address_mode_v: wgpu::AddressMode::ClampToEdge,
            ..Default::default()
        },
    )
}

/// `shade_receivers`: the camera's diffuse surfaces lit by one light (added into the eye's
/// radiance accumulators).
pub(crate) fn record_shade(
    dc: &DrawCtx,
    eye: &EyeFrame,
    lf: &LightFrame,
    s: &RenderSettings,
    taps: &crate::gpu::types::EnvTapsGpu,
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) {
    let ctx = dc.ctx;
    let cam = &dc.scene.camera;
    let (w, h) = (cam.width, cam.height);
    let shadow_sampler = shadow_sampler(ctx);
    let shp = ctx.uniform(
        "shade_params",
        bytemuck::bytes_of(&ShadeParams {
            width: w,
            height: h,
            shadow_size: s.shading.shadow_map_size,
            tiles: s.testing.shading_tiles as u32,
            camera: cam.position.extend(1.0).to_array(),
            medium_lo: dc.scene.medium.as_ref().map_or([0.0; 4], |m| m.bounds_min.extend(1.0).to_array()),
            medium_hi: dc.scene.medium.as_ref().map_or([0.0; 4], |m| m.bounds_max.extend(1.0).to_array()),
            sigma_t: dc.scene.medium.as_ref().map_or([0.0; 4], |m| (m.sigma_s + m.sigma_a).extend(0.0).to_array()),
            medium_grid: match dc.scene.medium.as_ref().and_then(|m| m.density.as_ref()) {
                Some(_) => [1, s.medium.light_steps, 0, 0],
                None => [0; 4],
            },
        }),
    );
    let tapb = ctx.uniform("env_taps", bytemuck::bytes_of(taps));
    let density = density_view(ctx, &dc.geo.density);
    let (erp, ern) = (layer_view(ctx, &eye.recv.pos, 0), layer_view(ctx, &eye.recv.nrm, 0));
    let (shv, rpv) = (array_view(ctx, &lf.shadow), array_view(ctx, &lf.recv.pos));
    Pass::new(ctx, "shade_receivers")
        .bind("light", &lf.light_buf)
        .bind("sp", &shp)
        .bind("eye_pos", &erp)
        .bind("eye_nrm", &ern)
        .bind("shadow_map", &shv)
        .bind("shadow_sampler", &shadow_sampler)
        .bind("recv_pos", &rpv)
        .bind("irradiance", &lf.irradiance)
        .bind("materials", &dc.geo.materials)
        .bind("radiance", &eye.radiance)
        .bind("caustic", &eye.caustic)
        .bind("density", &density)
        .bind("taps", &tapb)
        .bind("caustic_mask", &lf.caustic_mask)
        .bind("shadow_tiles", &lf.shadow_tiles)
        .dispatch(enc, timer, [w.div_ceil(8), h.div_ceil(8), 1]);
}

/// The scene's environment map as an Rgba32Float texture (read with `textureLoad`, so no
/// filterable-float feature is needed), halved (2×2 box) while wider than the device allows; a
/// 1×1 black texture without one.
fn upload_environment(ctx: &GpuContext, scene: &Scene) -> wgpu::Texture {
    let (mut w, mut h, mut texels) = match &scene.environment {
        Some(e) => (e.width, e.height, e.texels.clone()),
        None => (1, 1, vec![glam::Vec3::ZERO]),
    };
    let max = ctx.device.limits().max_texture_dimension_2d;
    while w > max && w >= 2 && h >= 2 {
        let (w2, h2) = (w / 2, h / 2);
        let at = |x: u32, y: u32| texels[(y * w + x) as usize];
        texels = (0..w2 * h2)
            .map(|i| {
                let (x, y) = (2 * (i % w2), 2 * (i / w2));
                (at(x, y) + at(x + 1, y) + at(x, y + 1) + at(x + 1, y + 1)) * 0.25
            })
            .collect();
        (w, h) = (w2, h2);
    }
    let size = wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 };
    let texture = ctx.texture(
        "environment",
        size,
        wgpu::TextureFormat::Rgba32Float,
        wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
    );
    let rgba: Vec<[f32; 4]> = texels.iter().map(|t| t.extend(0.0).to_array()).collect();
    ctx.queue.write_texture(
        wgpu::TexelCopyTextureInfo {
            texture: &texture,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        bytemuck::cast_slice(&rgba),
        wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(w * 16), rows_per_image: Some(h) },
        size,
    );
    texture
}

/// The medium's density grid as an R32Float 3D texture, uploaded once with the geometry (read
/// with `textureLoad` and interpolated in the shader, `shared/medium.wgsl`: no filterable-float
/// feature needed, and the CPU reference's arithmetic); 1×1×1 holding 1 without a grid, so the
/// bindings are the same for every scene.
pub(crate) fn upload_density(ctx: &GpuContext, scene: &Scene) -> wgpu::Texture {
    let grid = scene.medium.as_ref().and_then(|m| m.density.as_deref());
    let (dims, data): ([u32; 3], &[f32]) = match grid {
        Some(g) => (g.dims, &g.data),
        None => ([1, 1, 1], &[1.0]),
    };
    let size = wgpu::Extent3d { width: dims[0], height: dims[1], depth_or_array_layers: dims[2] };
    let texture = ctx.texture_dim(
        "medium_density",
        wgpu::TextureDimension::D3,
        size,
        wgpu::TextureFormat::R32Float,
        wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
    );
    ctx.queue.write_texture(
        wgpu::TexelCopyTextureInfo {
            texture: &texture,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        bytemuck::cast_slice(data),
        wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(dims[0] * 4), rows_per_image: Some(dims[1]) },
        size,
    );
    texture
}

/// The density grid's 3D view.
pub(crate) fn density_view(ctx: &GpuContext, t: &wgpu::Texture) -> wgpu::TextureView {
    ctx.view(t, Some(wgpu::TextureViewDimension::D3), 0, None)
}

/// The composited images and, in a scene with a medium, the segments of the camera paths
/// beyond the first specular surface that `composite` kept for the medium's stages.
pub(crate) struct Composited {
    pub full: wgpu::Buffer,
    pub caustic: wgpu::Buffer,
    pub segments: EyeSegments,
}

/// `composite`'s list of specular pixels and their kept segments ([`EYE_SEGMENTS`] each, in
/// the list's order): a stage over them is dispatched indirectly from `args` (workgroups of 64)
/// and reads the list's length from `count[3]`. `kept`: whether `composite` kept segments
/// ([`RenderSettings::medium_segments_active`]; else `segments` is one unused slot and no stage
/// runs along them).
pub(crate) struct EyeSegments {
    pub kept: bool,
    pub list: wgpu::Buffer,
    pub count: wgpu::Buffer,
    pub args: wgpu::Buffer,
    pub segments: wgpu::Buffer,
}

impl EyeSegments {
    /// The list of specular pixels, its count and the segments, by the names the stages that
    /// read them give them.
    pub(crate) fn bindings(&self) -> [(&'static str, &wgpu::Buffer); 3] {
        [("spec_list", &self.list), ("spec_count", &self.count), ("segments", &self.segments)]
    }
}

/// `medium_scatter` (scenes with a medium; nothing is recorded or requested otherwise): two
/// dispatches per light (spot, point or directional) over the composited images. The first
/// light's attenuates both images by the transmittance along each pixel's camera ray to its
/// first surface; each adds its light's single scattering along that ray
/// (`RenderSettings::medium_steps` steps, shadowed by the light's shadow map) to the full
/// image; the second (`medium_segments`, over `composite`'s list of specular pixels) along the
/// segments the pixels' paths travel in the medium beyond their specular surfaces.
#[expect(clippy::too_many_arguments, reason = "the frame's resources")]
fn record_medium(
    dc: &DrawCtx,
    eye: &EyeFrame,
    lights: &[&LightFrame],
    s: &RenderSettings,
    images: (&wgpu::Buffer, &wgpu::Buffer),
    segs: &EyeSegments,
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) {
    let Some(m) = &dc.scene.medium else { return };
    let ctx = dc.ctx;
    let cam = &dc.scene.camera;
    let (w, h) = (cam.width, cam.height);
    let shadow_sampler = shadow_sampler(ctx);
    let g = match m.phase {
        crate::scene::Phase::Isotropic => 0.0,
        crate::scene::Phase::HenyeyGreenstein { g } => g,
    };
    let scatters = m.sigma_s.max_element() > 0.0;
    let (rv, sv) = (layer_view(ctx, &eye.recv.pos, 0), layer_view(ctx, &eye.front.pos, 0));
    let density = density_view(ctx, &dc.geo.density);
    for (li, lf) in lights.iter().enumerate() {
        let flags = u32::from(li == 0) | (u32::from(scatters) << 1);
        let params = ctx.uniform(
            "medium_params",
            bytemuck::bytes_of(&MediumParams {
                clip_to_world: eye.cam_clip.inverse().to_cols_array_2d(),
                camera: cam.position.extend(1.0).to_array(),
                lo: m.bounds_min.extend(0.0).to_array(),
                hi: m.bounds_max.extend(0.0).to_array(),
                sigma_s: m.sigma_s.extend(g).to_array(),
                sigma_t: (m.sigma_s + m.sigma_a).extend(0.0).to_array(),
                width: w,
                height: h,
                steps: s.medium.steps,
                flags,
                shadow_size: s.shading.shadow_map_size,
                grid: u32::from(m.density.is_some()),
                light_steps: s.medium.light_steps,
                _pad: 0,
            }),
        );
        let shv = array_view(ctx, &lf.shadow);
        let pass = Pass::new(ctx, "medium_scatter")
            .constants(&[("medium_segments", 0.0)])
            .bind("light", &lf.light_buf)
            .bind("mp", &params)
            .bind("recv_pos", &rv)
            .bind("spec_pos", &sv)
            .bind("shadow_map", &shv)
            .bind("shadow_sampler", &shadow_sampler)
            .bind("out_full", images.0)
            .bind("out_caustic", images.1)
            .bind("density", &density)
            .bind_all(segs.bindings())
            .group();
        pass.dispatch(enc, timer, [w.div_ceil(8), h.div_ceil(8), 1]);
        if scatters && segs.kept {
            // (one bind group for both variants)
            let segments = pass.variant("medium_scatter_segments", &[("medium_segments", 1.0)]);
            segments.dispatch_indirect(enc, timer, &segs.args, 0);
        }
    }
}

/// `composite` (image-space refraction and reflection of the camera's specular surfaces) and the
/// medium (`medium_scatter`, scenes with one): (radiance image, caustic-only image). The
/// renderer adds the volume caustics (`crate::beams`), then [`record_display`].
pub(crate) fn record_composite(
    dc: &DrawCtx,
    eye: &EyeFrame,
    lights: &[&LightFrame],
    s: &RenderSettings,
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) -> Composited {
    let ctx = dc.ctx;
    let cam = &dc.scene.camera;
    let (w, h) = (cam.width, cam.height);
    let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
    let img_bytes = (w as u64) * (h as u64) * 16;
    let out_full = ctx.buffer("image", img_bytes, usage);
    let out_caustic = ctx.buffer("caustic_image", img_bytes, usage);
    // In a storage buffer, not a uniform: see `shaders/composite.wgsl` (lavapipe's inlining).
    let layer2 = has_specular_meshes(dc.scene);
    let kept = s.medium_segments_active(dc.scene);
    let medium = dc.scene.medium.as_ref().filter(|_| kept);
    let (medium_lo, medium_hi, medium_sigma_t) = match medium {
        Some(m) => (
            m.bounds_min.extend(0.0).to_array(),
            m.bounds_max.extend(f32::from(u8::from(m.density.is_some()))).to_array(),
            (m.sigma_s + m.sigma_a).extend(s.medium.steps as f32).to_array(),
        ),
        None => ([0.0; 4], [0.0; 4], [0.0; 4]),
    };
    let cpar = ctx.buffer_init(
        "composite_params",
        bytemuck::bytes_of(&CompositeParams {
            world_to_clip: eye.cam_clip.to_cols_array_2d(),
            clip_to_world: eye.cam_clip.inverse().to_cols_array_2d(),
            camera: cam.position.extend(1.0).to_array(),
            env_rotation: match &dc.scene.environment {
                Some(e) => [e.rotate_y.cos(), e.rotate_y.sin(), 1.0, 0.0],
                None => [1.0, 0.0, 0.0, 0.0],
            },
            width: w,
            height: h,
            layer2: layer2 as u32,
            _pad: 0,
            medium_lo,
            medium_hi,
            medium_sigma_t,
        }),
        wgpu::BufferUsages::STORAGE,
    );
    // The kept segments (a scene with a medium; else one unused slot).
    let seg_slots = if medium.is_some() { (w as u64) * (h as u64) * EYE_SEGMENTS } else { 1 };
    let segments = ctx.buffer(
        "composite_segments",
        seg_slots * std::mem::size_of::<EyeSegmentGpu>() as u64,
        wgpu::BufferUsages::STORAGE,
    );
    let density = density_view(ctx, &dc.geo.density);
    // The specular pixels listed by the first pass and the indirect dispatch of the second.
    let spec_list = ctx.buffer("composite_list", (w as u64) * (h as u64) * 4, wgpu::BufferUsages::STORAGE);
    let spec_count = ctx.buffer("composite_count", 16, wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC);
    // The second pass binds the count too, so it is dispatched from a copy.
    let spec_args = ctx.buffer("composite_args", 16, wgpu::BufferUsages::INDIRECT);
    let [recv_pos, recv_nrm, spec_pos, spec_nrm, back_pos, back_nrm, spec2_pos, spec2_nrm, back2_pos, back2_nrm] = [
        &eye.recv.pos,
        &eye.recv.nrm,
        &eye.front.pos,
        &eye.front.nrm,
        &eye.back.pos,
        &eye.back.nrm,
        &eye.front2.pos,
        &eye.front2.nrm,
        &eye.back2.pos,
        &eye.back2.nrm,
    ]
    .map(|t| layer_view(ctx, t, 0));
    let env_view = ctx.view(&dc.geo.environment, Some(wgpu::TextureViewDimension::D2), 0, Some(1));
    let env = dc.scene.environment.is_some();
    let consts = |pass: u32| {
        [
            ("composite_pass", f64::from(pass)),
            ("composite_layer2", f64::from(u8::from(layer2))),
            ("composite_env", f64::from(u8::from(env))),
            ("composite_medium", f64::from(u8::from(medium.is_some()))),
        ]
    };
    let pass = Pass::new(ctx, "composite")
        .constants(&consts(0))
        .bind("cp_in", &cpar)
        .bind("recv_pos", &recv_pos)
        .bind("recv_nrm", &recv_nrm)
        .bind("spec_pos", &spec_pos)
        .bind("spec_nrm", &spec_nrm)
        .bind("back_pos", &back_pos)
        .bind("back_nrm", &back_nrm)
        .bind("spec2_pos", &spec2_pos)
        .bind("spec2_nrm", &spec2_nrm)
        .bind("back2_pos", &back2_pos)
        .bind("back2_nrm", &back2_nrm)
        .bind("materials", &dc.geo.materials)
        .bind("radiance", &eye.radiance)
        .bind("caustic_in", &eye.caustic)
        .bind("out_full", &out_full)
        .bind("out_caustic", &out_caustic)
        .bind("env_map", &env_view)
        .bind_all(dc.geo.bvh_bindings())
        .bind("spec_list", &spec_list)
        .bind("spec_count", &spec_count)
        .bind("segments", &segments)
        .bind("density", &density)
        .group();
    pass.dispatch(enc, timer, [w.div_ceil(8), h.div_ceil(8), 1]);
    enc.copy_buffer_to_buffer(&spec_count, 0, &spec_args, 0, 16);
    pass.variant("composite_specular", &consts(1)).dispatch_indirect(enc, timer, &spec_args, 0);
    let segs = EyeSegments { kept, list: spec_list, count: spec_count, args: spec_args, segments };
    record_medium(dc, eye, lights, s, (&out_full, &out_caustic), &segs, enc, timer);
    Composited { full: out_full, caustic: out_caustic, segments: segs }
}

/// `display`: the radiance image `out_full` tone-mapped into an Rgba8Unorm texture.
pub(crate) fn record_display(
    dc: &DrawCtx,
    out_full: &wgpu::Buffer,
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) -> wgpu::Texture {
    let ctx = dc.ctx;
    let (w, h) = (dc.scene.camera.width, dc.scene.camera.height);
    let display = ctx.texture(
        "display",
        wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        wgpu::TextureFormat::Rgba8Unorm,
        wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_SRC,
    );
    let dv = ctx.view(&display, Some(wgpu::TextureViewDimension::D2), 0, Some(1));
    let dp = ctx.uniform(
        "display_params",
        bytemuck::bytes_of(&DisplayParams { width: w, height: h, exposure: dc.scene.exposure, _pad: 0 }),
    );
    Pass::new(ctx, "display").bind("dp", &dp).bind("radiance", out_full).bind("display", &dv).dispatch(
        enc,
        timer,
        [w.div_ceil(8), h.div_ceil(8), 1],
    );
    display
}

/// The flux bookkeeping from a light's `flux_stats` words (fixed point, `scale` per watt).
pub(crate) fn flux_stats(words: &[u8], scale: f64) -> FluxStats {
    let sw: Vec<u32> = words.chunks_exact(4).map(|c| u32::from_le_bytes(c.try_into().unwrap())).collect();
    let v = |i: usize| ((sw[i + 1] as u64) << 32 | sw[i] as u64) as f64 / scale;
    FluxStats {
        emitted: v(0),
        landed: v(2),
        lost_no_exit: v(4),
        lost_tir: v(6),
        lost_no_receiver: v(8),
        lost_outside: v(10),
        untraced_branches: v(14),
        stack_overflows: u64::from(sw[12]),
    }
}

/// An image of a frame's intermediate buffers, for people to look at
/// ([`crate::renderer::Renderer::dump_images`]; `caustics render --dump` writes them).
#[derive(Debug, Clone)]
pub struct DumpImage {
    /// File name without extension (`light0_face0_caster_front_normal`).
    pub name: String,
    pub image: Image,
    pub kind: DumpKind,
}

/// How a [`DumpImage`] is meant to be shown.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DumpKind {
    /// Values already meant for display (normals as 0.5 + 0.5 n, normalised depths), linear.
    Display,
    /// Irradiance or radiance: shown with this exposure (and kept linear in EXR).
    Radiance { exposure: f32 },
}

/// The light-space buffers as images: normals (0.5 + 0.5 n), depths (distance from the light,
/// normalised), and the caustic maps (with the exposure that maps their 99.9th percentile to
/// white: they span orders of magnitude).
pub(crate) fn dump_images(
    ctx: &GpuContext,
    lights: &[(Vec<(&str, &GBuffer)>, u32)],
    maps: &[Vec<Image>],
) -> Result<Vec<DumpImage>> {
    let mut out = Vec::new();
    for (li, (bufs, nf)) in lights.iter().enumerate() {
        for f in 0..*nf {
            for &(name, gb) in bufs {
                // A spill face has no caster buffers (their arrays hold the emitting faces only).
                if f >= gb.pos.depth_or_array_layers() {
                    continue;
                }
                let pos = ctx.read_texture(&gb.pos, f, 16)?;
                let nrm = ctx.read_texture(&gb.nrm, f, 16)?;
                let (w, h) = (gb.pos.width(), gb.pos.height());
                let p: &[[f32; 4]] = bytemuck::cast_slice(&pos);
                let nn: &[[f32; 4]] = bytemuck::cast_slice(&nrm);
                let mut ni = Image::new(w, h);
                let mut di = Image::new(w, h);
                let valid: Vec<f32> =
                    p.iter().filter(|q| q[3] >= 0.0).map(|q| Vec3::new(q[0], q[1], q[2]).length()).collect();
                let (dmin, dmax) = valid.iter().fold((f32::MAX, f32::MIN), |(a, b), &x| (a.min(x), b.max(x)));
                for i in 0..(w * h) as usize {
                    if p[i][3] >= 0.0 {
                        ni.pixels[i] = [0.5 + 0.5 * nn[i][0], 0.5 + 0.5 * nn[i][1], 0.5 + 0.5 * nn[i][2]]
                            .map(crate::image_io::srgb_decode);
                        let d = Vec3::new(p[i][0], p[i][1], p[i][2]).length();
                        let t = 1.0 - (d - dmin) / (dmax - dmin).max(1e-6);
                        di.pixels[i] = [crate::image_io::srgb_decode(t); 3];
                    }
                }
                let stem = format!("light{li}_face{f}_{name}");
                out.push(DumpImage { name: format!("{stem}_normal"), image: ni, kind: DumpKind::Display });
                out.push(DumpImage { name: format!("{stem}_depth"), image: di, kind: DumpKind::Display });
            }
            let map = &maps[li][f as usize];
            let mut l: Vec<f32> = map.luminance().into_iter().filter(|x| *x > 0.0).collect();
            l.sort_by(f32::total_cmp);
            let p = l.get(l.len().saturating_sub(1 + l.len() / 1000)).copied().unwrap_or(1.0).max(1e-9);
            out.push(DumpImage {
                name: format!("light{li}_face{f}_caustic_map"),
                image: map.clone(),
                kind: DumpKind::Radiance { exposure: 2.0 / p },
            });
        }
    }
    Ok(out)
}
