//! The GPU renderer: caustic maps (the photon emission technique is pluggable, see
//! [`crate::techniques`]) and the final image. One function chains the passes; each pass is
//! named, and the name is both the wgpu label and the timer name:
//!
//! 1. `eye_receivers`, `eye_specular_front`, `eye_specular_back`: camera geometry buffers;
//! 2. per light and face: `light_shadow` (depth of everything), `light_receivers` (position and
//!    normal of diffuse surfaces), `light_caster_front`, `light_caster_back`, and where the scene
//!    has caster meshes and two casters or more the second caster layer `light_caster_front2`,
//!    `light_caster_back2` (`raster_peel`: per texel the nearest caster of another object
//!    behind the first);
//! 3. per light and face: `coverage_mip`, then the technique's passes: basic per photon batch
//!    `photon_trace`, `photon_splat` (64-bit fixed-point atomics); hierarchical per tile
//!    `photon_trace`, `hcm_mip`, `hcm_traverse`, `photon_splat`; adaptive `adaptive_plan`, then
//!    per batch `adaptive_traverse` (all levels, indirect dispatches) and `photon_splat`;
//! 4. `caustic_resolve`: flux per texel to irradiance;
//! 5. `shade_receivers` per light, then `composite` (image-space refraction and reflection).

use crate::error::{Error, Result};
use crate::gpu::types::*;
use crate::gpu::{GpuContext, PassTimer};
use crate::image_io::Image;
use crate::lightspace::LightView;
use crate::scene::{Light, Material, Scene, Tessellation};
pub use crate::splat::SplatMode;
pub use crate::techniques::{LevelStats, Technique, TechniqueStats};
use glam::{Mat4, Vec3};
use std::ops::Range;
use std::path::Path;
use wgpu::util::DeviceExt;

/// Settings of a GPU render.
#[derive(Debug, Clone)]
pub struct RenderSettings {
    /// Photon grid size N per light-view face: N × N photons (the equivalent, finest grid of
    /// the adaptive techniques).
    pub photons: u32,
    /// How photons are emitted.
    pub technique: Technique,
    /// Adaptive techniques: the coarse grid the hierarchy starts from (a power of two).
    pub base_grid: u32,
    /// Maximal caustic map error: a cluster converges when its photons land in one caustic-map
    /// texel (0) or within this many texels (> 0).
    pub max_error_tolerance: f32,
    /// Maximal caustic map error: convergence is checked for clusters whose photons lie on a grid
    /// of at least this size (Wyman & Nichols check from the 512² level on).
    pub error_check_grid: u32,
    /// Maximal caustic map error with caustic triangles: an optional second stopping rule (0:
    /// off, the default: the paper's rule alone). A cluster also converges when its cell quad
    /// maps linearly enough: its corner lattice and children's photons land within this many
    /// caustic-map texels of the bilinear interpolation of its corners (`docs/adaptive.md`).
    pub quad_linearity: f32,
    /// Maximal caustic map error: skip the convergence check on levels where the spread of a
    /// cluster's children predicts that it cannot pass (`docs/adaptive.md`); the check would
    /// only trace photons to refine them. On by default; off gives the paper's traversal.
    pub error_skip_hopeless: bool,
    /// Keep the coverage masks (caster front-buffer texels per face) in the statistics, for
    /// tests that model the traversal on the CPU.
    pub keep_coverage: bool,
    /// Basic technique with a photon-buffer splat (not `triangles`): keep every traced photon
    /// (`TechniqueStats::photons`), for tests and tools that inspect photons (memory grows with
    /// the grid).
    pub keep_photons: bool,
    /// Caustic map (and receiver map) size M per face.
    pub caustic_map_size: u32,
    /// Shadow map size per face.
    pub shadow_map_size: u32,
    /// Gaussian splat standard deviation, in caustic-map texels (fixed splats; the fallback and
    /// smallest sizes of the other modes scale with it).
    pub splat_sigma: f32,
    /// How photons are splatted into the caustic map (`crate::splat`).
    pub splat: SplatMode,
    /// Also trace the light reflected at the first dielectric surface (a second photon per cell,
    /// weighted by Fresnel reflectance; the first carries the transmitted light): basic, a
    /// second pass over the grid; hierarchical and adaptive, a second traversal.
    pub dielectric_reflection: bool,
    /// Rasterize the light's second caster layer (`light_caster_front2`, `light_caster_back2`:
    /// per texel, the nearest caster of another object behind the first layer's) when the scene
    /// has caster meshes and two casters or more, so that photons find and traverse a mesh
    /// hidden from the light behind another caster. Off: only the first layer (the renderer
    /// before it; for comparisons).
    pub light_second_layer: bool,
    /// Memory for photon storage (bytes): the grid (basic), the tiles (hierarchical) or the
    /// hierarchy (adaptive) is processed in batches that fit.
    pub photon_memory: u64,
    pub tessellation: Tessellation,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            photons: 1024,
            technique: Technique::Basic,
            base_grid: 64,
            max_error_tolerance: 0.0,
            error_check_grid: 512,
            quad_linearity: 0.0,
            error_skip_hopeless: true,
            keep_coverage: false,
            keep_photons: false,
            caustic_map_size: 1024,
            shadow_map_size: 2048,
            splat_sigma: 1.0,
            splat: SplatMode::default(),
            dielectric_reflection: true,
            light_second_layer: true,
            photon_memory: 64 << 20,
            tessellation: Tessellation::default(),
        }
    }
}

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
}

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
}

const POS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// The largest caster geometry buffer; denser photon grids interpolate between its texels.
pub(crate) const MAX_GBUFFER: u32 = 2048;

struct Geometry {
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    /// Index ranges per object.
    ranges: Vec<Range<u32>>,
    materials: wgpu::Buffer,
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

fn upload_geometry(ctx: &GpuContext, scene: &Scene, t: &Tessellation) -> Geometry {
    let mut vertices: Vec<Vertex> = Vec::new();
    let mut indices: Vec<u32> = Vec::new();
    let mut ranges = Vec::new();
    let mut mats = Vec::new();
    for (i, o) in scene.objects.iter().enumerate() {
        let m = o.shape.tessellate(t);
        let base = vertices.len() as u32;
        for (p, n) in m.positions.iter().zip(&m.normals) {
            vertices.push(Vertex { position: p.to_array(), normal: n.to_array(), object: i as u32 });
        }
        let start = indices.len() as u32;
        indices.extend(m.indices.iter().flat_map(|t| t.map(|x| x + base)));
        ranges.push(start..indices.len() as u32);
        let caster = u32::from(o.caustic_caster);
        let (kind, a, b) = match *scene.material_of(o) {
            Material::Diffuse { albedo } => (0, albedo.extend(0.0).to_array(), [0.0; 4]),
            Material::Dielectric { ior, ext_ior } => (1, [ior, ext_ior, 0.0, 0.0], [0.0; 4]),
            Material::Mirror { reflectance } => (2, reflectance.extend(0.0).to_array(), [0.0; 4]),
            Material::Conductor { eta, k } => (3, eta.extend(0.0).to_array(), k.extend(0.0).to_array()),
        };
        let (shape_kind, shape) = analytic_shape(&o.shape);
        mats.push(MaterialGpu { kind: [kind, caster, shape_kind, 0], a, b, shape });
    }
    let d = &ctx.device;
    Geometry {
        vertices: d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("vertices"),
            contents: bytemuck::cast_slice(&vertices),
            usage: wgpu::BufferUsages::VERTEX,
        }),
        indices: d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("indices"),
            contents: bytemuck::cast_slice(&indices),
            usage: wgpu::BufferUsages::INDEX,
        }),
        ranges,
        materials: d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("materials"),
            contents: bytemuck::cast_slice(&mats),
            usage: wgpu::BufferUsages::STORAGE,
        }),
    }
}

/// An object's analytic shape for exact intersection in the shaders: (kind, parameters).
fn analytic_shape(shape: &crate::scene::Shape) -> (u32, [[f32; 4]; 4]) {
    use crate::scene::Shape;
    match shape {
        Shape::Sphere { center, radius } => (1, [center.extend(*radius).to_array(), [0.0; 4], [0.0; 4], [0.0; 4]]),
        Shape::Cylinder { base_center, axis, radius, height } => {
            (2, [base_center.extend(*radius).to_array(), axis.extend(*height).to_array(), [0.0; 4], [0.0; 4]])
        }
        Shape::Rectangle { center, normal, u, v, size } => (
            3,
            [
                center.extend(0.0).to_array(),
                normal.extend(0.0).to_array(),
                u.extend(size.x).to_array(),
                v.extend(size.y).to_array(),
            ],
        ),
        Shape::Mesh(_) => (0, [[0.0; 4]; 4]),
    }
}

/// Raster pipelines: geometry buffers with a cull mode, and depth only. The "front" buffers of
/// specular objects are drawn two-sided: the nearest surface of a closed dielectric faces the
/// viewer anyway, and mirrors and conductors are two-sided (the inside of the mirror ring).
struct Raster {
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
fn raster_pipelines(ctx: &GpuContext) -> Raster {
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
    let raster = (ctx.shader("raster"), layout("raster", &[view_entry]));
    let peel = (
        ctx.shader("raster_peel"),
        layout(
            "raster_peel",
            &[
                view_entry,
                texture_entry(1, wgpu::TextureSampleType::Float { filterable: false }),
                texture_entry(2, wgpu::TextureSampleType::Depth),
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
    ctx.device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width: size, height: size_y, depth_or_array_layers: layers },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    })
}

fn layer_view(t: &wgpu::Texture, layer: u32) -> wgpu::TextureView {
    t.create_view(&wgpu::TextureViewDescriptor {
        dimension: Some(wgpu::TextureViewDimension::D2),
        base_array_layer: layer,
        array_layer_count: Some(1),
        ..Default::default()
    })
}

fn array_view(t: &wgpu::Texture) -> wgpu::TextureView {
    t.create_view(&wgpu::TextureViewDescriptor {
        dimension: Some(wgpu::TextureViewDimension::D2Array),
        ..Default::default()
    })
}

/// A geometry buffer: position + object id, normal, depth; `layers` faces.
struct GBuffer {
    pos: wgpu::Texture,
    nrm: wgpu::Texture,
    depth: wgpu::Texture,
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

struct DrawCtx<'a> {
    ctx: &'a GpuContext,
    geo: &'a Geometry,
    scene: &'a Scene,
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
        let (first_pos, first_depth) = (layer_view(&first.pos, layer), layer_view(&first.depth, layer));
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
        let ubuf = self.ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(name),
            contents: bytemuck::bytes_of(&RasterView { world_to_clip: world_to_clip.to_cols_array_2d() }),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let bg = self.ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(name),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[&[wgpu::BindGroupEntry { binding: 0, resource: ubuf.as_entire_binding() }], extra].concat(),
        });
        let views = gb_color.map(|(p, n)| (layer_view(p, layer), layer_view(n, layer)));
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
        let dview = layer_view(depth, layer);
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
            (0, *intensity, *direction, *cone_angle, *falloff_start)
        }
        Light::Point { intensity, .. } => (1, *intensity, Vec3::Y, std::f32::consts::PI, std::f32::consts::PI),
        Light::Directional { direction, irradiance } => (2, *irradiance, *direction, 0.0, 0.0),
    };
    LightGpu {
        faces,
        info: [view.faces.len() as u32, kind, n, m],
        power: power.extend(cone.cos()).to_array(),
        axis: axis.extend(cone).to_array(),
        params: [start, scale as f32, sigma, g as f32],
        extra: [caster_radius, view.scene_radius, view.tan_half_fov, multi_bounce],
        splat: [lens, 0.0, 0.0, 0.0],
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

/// An upper bound of the relevant photons (cells of the N × N grid whose caster-buffer texel
/// holds a caster) of one face: the cells within one texel of the casters' bounding box as the
/// face sees it (the whole face when the box reaches behind the light).
fn relevant_bound(scene: &Scene, face: &crate::lightspace::LightFace, n: u32, g: u32) -> u64 {
    let all = (n as u64).pow(2);
    let Some((lo, hi)) = scene.caster_bounds() else { return 0 };
    let (mut a, mut b) = (glam::Vec2::splat(f32::MAX), glam::Vec2::splat(f32::MIN));
    for k in 0..8 {
        let p = Vec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        );
        let c = face.world_to_clip * p.extend(1.0);
        if c.w <= 1e-6 {
            return all;
        }
        let q = glam::Vec2::new(c.x / c.w, c.y / c.w);
        a = a.min(q);
        b = b.max(q);
    }
    let margin = 2.0 * (n / g) as f64 + 2.0;
    let side = |lo: f32, hi: f32| {
        let (lo, hi) = (lo.clamp(-1.0, 1.0) as f64, hi.clamp(-1.0, 1.0) as f64);
        ((hi - lo) * 0.5 * n as f64 + margin).min(n as f64)
    };
    ((side(a.x, b.x) * side(a.y, b.y)).ceil() as u64).min(all)
}

fn bytes_to_image(data: &[u8], w: u32, h: u32) -> Image {
    let px: &[[f32; 4]] = bytemuck::cast_slice(data);
    Image { width: w, height: h, pixels: px.iter().map(|p| [p[0], p[1], p[2]]).collect() }
}

impl RenderSettings {
    /// The largest caustic map (power of two, at most `preferred`) whose accumulation buffer
    /// fits this adapter's storage-binding limit for every light of `scene` (a point light's
    /// cube has six faces).
    pub fn fitting_caustic_map_size(ctx: &GpuContext, scene: &Scene, preferred: u32) -> u32 {
        let max_bind = ctx.device.limits().max_storage_buffer_binding_size;
        let faces = scene.lights.iter().map(|l| LightView::new(scene, l).faces.len() as u64).max().unwrap_or(1);
        let mut m = preferred.next_power_of_two().min(2048);
        while m > 16 && (m as u64).pow(2) * faces * 24 > max_bind {
            m /= 2;
        }
        m
    }

    /// Check the settings against the adapter's limits; errors name the command-line option.
    pub fn validate(&self, ctx: &GpuContext, scene: &Scene) -> Result<()> {
        let cl = |f: &str, m: String| Err(Error::input("<command line>", f, m));
        let t = &self.tessellation;
        if !(8..=8192).contains(&t.sphere_segments) || !(8..=8192).contains(&t.cylinder_segments) {
            return cl("--tessellation", format!("must be 8 to 8192 segments (got {})", t.sphere_segments));
        }
        let max_n = self.technique.max_photons();
        if !(16..=max_n).contains(&self.photons) {
            return cl(
                "--photons",
                format!("the {} photon grid must be 16 to {max_n} per side (got {})", self.technique, self.photons),
            );
        }
        if !(self.quad_linearity >= 0.0 && self.quad_linearity <= 1e6) {
            return cl("--quad-linearity", format!("must be 0 or more texels (got {})", self.quad_linearity));
        }
        if self.quad_linearity > 0.0
            && !(self.technique == Technique::AdaptiveError && self.splat == SplatMode::Triangles)
        {
            return cl(
                "--quad-linearity",
                "needs --technique adaptive-error with --splat triangles (it stops on cell quads)".to_string(),
            );
        }
        if !(self.max_error_tolerance >= 0.0 && self.max_error_tolerance <= 1e6) {
            return cl("--max-error-tolerance", format!("must be 0 or more texels (got {})", self.max_error_tolerance));
        }
        let max_tex = ctx.device.limits().max_texture_dimension_2d;
        if !(16..=2048).contains(&self.caustic_map_size) || self.caustic_map_size > max_tex {
            return cl(
                "--caustic-map",
                format!("must be 16 to {} texels (got {})", max_tex.min(2048), self.caustic_map_size),
            );
        }
        if !(16..=max_tex).contains(&self.shadow_map_size) {
            return cl("--shadow-map", format!("must be 16 to {max_tex} texels (got {})", self.shadow_map_size));
        }
        if !(self.splat_sigma > 0.1 && self.splat_sigma <= 16.0) {
            return cl("--splat-sigma", format!("must lie in (0.1, 16] texels (got {})", self.splat_sigma));
        }
        let c = &scene.camera;
        if c.width > max_tex || c.height > max_tex {
            return cl("--size", format!("{}x{} exceeds this adapter's texture limit {max_tex}", c.width, c.height));
        }
        let max_bind = ctx.device.limits().max_storage_buffer_binding_size;
        let faces = scene.lights.iter().map(|l| LightView::new(scene, l).faces.len() as u64).max().unwrap_or(1);
        let accum = (self.caustic_map_size as u64).pow(2) * faces * 24;
        if accum > max_bind {
            return cl(
                "--caustic-map",
                format!(
                    "a {0}x{0} caustic map with {faces} face(s) needs {1} MiB, over this adapter's {2} MiB storage-binding limit",
                    self.caustic_map_size,
                    accum >> 20,
                    max_bind >> 20
                ),
            );
        }
        if self.photon_memory < 64 * 32 {
            return cl("--photon-memory", "must be at least 2 KiB".into());
        }
        if self.technique == Technique::Basic && self.photon_memory > max_bind {
            return cl("--photon-memory", format!("must be between 2 KiB and {} MiB", max_bind >> 20));
        }
        match self.technique {
            Technique::Basic => {}
            Technique::Hierarchical => {
                crate::techniques::hierarchical::HierarchicalPlan::new(self, max_bind)?;
            }
            Technique::AdaptiveLevel | Technique::AdaptiveError => {
                crate::techniques::adaptive::AdaptivePlan::new(self, max_bind)?;
            }
        }
        if (c.width as u64 * c.height as u64 * 16) > max_bind {
            return cl("--size", "the image exceeds this adapter's storage-binding limit".into());
        }
        Ok(())
    }
}

/// Render `scene` on the GPU with basic caustic maps. `dump` writes the intermediate buffers.
pub fn render(ctx: &GpuContext, scene: &Scene, s: &RenderSettings, dump: Option<&Path>) -> Result<GpuRender> {
    render_with(ctx, scene, s, dump, None)
}

/// [`render`], with the caustic maps passed through a temporal filter before shading
/// ([`crate::temporal::TemporalFilter::render`]).
pub(crate) fn render_with(
    ctx: &GpuContext,
    scene: &Scene,
    s: &RenderSettings,
    dump: Option<&Path>,
    temporal: Option<&mut crate::temporal::TemporalFilter>,
) -> Result<GpuRender> {
    s.validate(ctx, scene)?;
    let val_scope = ctx.device.push_error_scope(wgpu::ErrorFilter::Validation);
    let oom_scope = ctx.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
    let out = render_inner(ctx, scene, s, dump, temporal);
    let oom = pollster::block_on(oom_scope.pop());
    let val = pollster::block_on(val_scope.pop());
    if let Some(e) = oom {
        return Err(Error::Device(format!("out of GPU memory: {e}")));
    }
    if let Some(e) = val {
        return Err(Error::Device(format!("{e}")));
    }
    out
}

fn render_inner(
    ctx: &GpuContext,
    scene: &Scene,
    s: &RenderSettings,
    dump: Option<&Path>,
    mut temporal: Option<&mut crate::temporal::TemporalFilter>,
) -> Result<GpuRender> {
    let dev = &ctx.device;
    let geo = upload_geometry(ctx, scene, &s.tessellation);
    let raster = raster_pipelines(ctx);
    // The light's second caster layer: only for scenes with caster meshes (analytic casters
    // met after the first are intersected exactly, and scenes without meshes keep their maps)
    // and at least two casters (the peel keeps other objects only: one caster leaves it empty).
    let specular_casters: Vec<_> =
        scene.objects.iter().filter(|o| o.caustic_caster && scene.material_of(o).is_specular()).collect();
    let layer2 = s.light_second_layer
        && specular_casters.len() >= 2
        && specular_casters.iter().any(|o| matches!(o.shape, crate::scene::Shape::Mesh(_)));
    let pipelines = crate::techniques::Pipelines::new(ctx, s.technique, s.splat, layer2);
    let resolve_pl = ctx.compute_pipeline("caustic_resolve");
    let shade_pl = ctx.compute_pipeline("shade_receivers");
    let composite_pl = ctx.compute_pipeline("composite");
    let dc = DrawCtx { ctx, geo: &geo, scene };
    let mut timer = PassTimer::new(ctx, 2048);
    let mut enc = dev.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame") });

    // 1. Camera geometry buffers.
    let cam = &scene.camera;
    let (lo, hi) = scene.bounds();
    let far = (cam.position.distance((lo + hi) * 0.5) + (hi - lo).length() * 0.5) * 1.05;
    let near = (far * 1e-4).max(1e-3);
    let cam_clip = cam.view_to_clip(near, far) * cam.world_to_view();
    let (w, h) = (cam.width, cam.height);
    let eye_recv = GBuffer::new(ctx, "eye_receivers", w, h, 1);
    let eye_front = GBuffer::new(ctx, "eye_specular_front", w, h, 1);
    let eye_back = GBuffer::new(ctx, "eye_specular_back", w, h, 1);
    dc.pass(
        &mut enc,
        &mut timer,
        "eye_receivers",
        &raster.none,
        Some((&eye_recv.pos, &eye_recv.nrm)),
        &eye_recv.depth,
        0,
        cam_clip,
        Subset::Diffuse,
    );
    dc.pass(
        &mut enc,
        &mut timer,
        "eye_specular_front",
        &raster.none,
        Some((&eye_front.pos, &eye_front.nrm)),
        &eye_front.depth,
        0,
        cam_clip,
        Subset::Specular,
    );
    dc.pass(
        &mut enc,
        &mut timer,
        "eye_specular_back",
        &raster.back,
        Some((&eye_back.pos, &eye_back.nrm)),
        &eye_back.depth,
        0,
        cam_clip,
        Subset::Specular,
    );
    // The second specular layer (meshes behind the first layer's object), front and back.
    let eye_front2 = GBuffer::new(ctx, "eye_specular_front2", w, h, 1);
    let eye_back2 = GBuffer::new(ctx, "eye_specular_back2", w, h, 1);
    dc.peel(
        &mut enc,
        &mut timer,
        &raster,
        &eye_front,
        0,
        cam_clip,
        Subset::SpecularMeshes,
        [("eye_specular_front2", &eye_front2), ("eye_specular_back2", &eye_back2)],
    );

    let img_bytes = (w as u64) * (h as u64) * 16;
    let storage = |label: &str, size: u64| {
        dev.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    };
    let uniform = |label: &str, bytes: &[u8]| {
        dev.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: bytes,
            usage: wgpu::BufferUsages::UNIFORM,
        })
    };
    let radiance = storage("radiance", img_bytes);
    let caustic_rad = storage("caustic_radiance", img_bytes);
    let shadow_sampler = dev.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("shadow"),
        compare: Some(wgpu::CompareFunction::LessEqual),
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        address_mode_u: wgpu::AddressMode::ClampToEdge,
        address_mode_v: wgpu::AddressMode::ClampToEdge,
        ..Default::default()
    });

    let m = s.caustic_map_size;
    let n = s.photons;
    let g = n.min(MAX_GBUFFER);
    let caster_radius = scene.caster_bounds().map_or(1.0, |(a, b)| (b - a).length() * 0.5);
    // Whether a photon leaving a caster can meet a caster again: not for a lone convex caster (a
    // sphere), where the search would only cost time.
    let casters: Vec<_> =
        scene.objects.iter().filter(|o| o.caustic_caster && scene.material_of(o).is_specular()).collect();
    // 0: no search; 1: analytic casters only, intersected exactly; 2: mesh casters too, found
    // by marching through the light's caster buffer.
    let multi_bounce = if casters.len() == 1 && matches!(casters[0].shape, crate::scene::Shape::Sphere { .. }) {
        0.0
    } else if casters.iter().any(|o| matches!(o.shape, crate::scene::Shape::Mesh(_))) {
        2.0
    } else {
        1.0
    };

    struct PerLight {
        accum: wgpu::Buffer,
        irradiance: wgpu::Buffer,
        stats: wgpu::Buffer,
        faces: u32,
        scale: f64,
        recv: GBuffer,
        casters: (GBuffer, GBuffer),
        casters2: Option<(GBuffer, GBuffer)>,
    }
    let mut per_light = Vec::new();
    let mut pendings = Vec::new();
    for (li, light) in scene.lights.iter().enumerate() {
        let view = LightView::new(scene, light);
        let nf = view.faces.len() as u32;
        let scale = (1u64 << 52) as f64 / flux_bound(&view, light);
        let lens = s.splat.lens_flag(s.technique);
        let lg = light_gpu(&view, light, n, m, g, s.splat_sigma, scale, caster_radius, multi_bounce, lens);
        let light_buf = uniform("light", bytemuck::bytes_of(&lg));
        let shadow = texture(ctx, "light_shadow", s.shadow_map_size, s.shadow_map_size, nf, DEPTH_FORMAT);
        let recv = GBuffer::new(ctx, "light_receivers", m, m, nf);
        let front = GBuffer::new(ctx, "light_caster_front", g, g, nf);
        let back = GBuffer::new(ctx, "light_caster_back", g, g, nf);
        let layer2_bufs = layer2.then(|| {
            (GBuffer::new(ctx, "light_caster_front2", g, g, nf), GBuffer::new(ctx, "light_caster_back2", g, g, nf))
        });
        for (f, face) in view.faces.iter().enumerate() {
            let f = f as u32;
            dc.pass(
                &mut enc,
                &mut timer,
                "light_shadow",
                &raster.depth_only,
                None,
                &shadow,
                f,
                face.world_to_clip,
                Subset::All,
            );
            dc.pass(
                &mut enc,
                &mut timer,
                "light_receivers",
                &raster.none,
                Some((&recv.pos, &recv.nrm)),
                &recv.depth,
                f,
                face.world_to_clip,
                Subset::Diffuse,
            );
            dc.pass(
                &mut enc,
                &mut timer,
                "light_caster_front",
                &raster.none,
                Some((&front.pos, &front.nrm)),
                &front.depth,
                f,
                face.world_to_clip,
                Subset::Casters,
            );
            dc.pass(
                &mut enc,
                &mut timer,
                "light_caster_back",
                &raster.back,
                Some((&back.pos, &back.nrm)),
                &back.depth,
                f,
                face.world_to_clip,
                Subset::Casters,
            );
            // The second caster layer: the casters again, with a per-object depth peel against
            // this face's first layer (two-sided front, back faces), as the camera's.
            if let Some((front2, back2)) = &layer2_bufs {
                dc.peel(
                    &mut enc,
                    &mut timer,
                    &raster,
                    &front,
                    f,
                    face.world_to_clip,
                    Subset::Casters,
                    [("light_caster_front2", front2), ("light_caster_back2", back2)],
                );
            }
        }
        let texels = (m as u64) * (m as u64) * nf as u64;
        let accum = storage("caustic_flux", texels * 24);
        let irradiance = storage("caustic_irradiance", texels * 16);
        let stats = storage("flux_stats", 48);
        let splat_targets = crate::splat::SplatTargets::new(ctx, s.splat, texels, nf);
        let (fpv, fnv, bpv, bnv, rpv, rnv) = (
            array_view(&front.pos),
            array_view(&front.nrm),
            array_view(&back.pos),
            array_view(&back.nrm),
            array_view(&recv.pos),
            array_view(&recv.nrm),
        );
        let l2v = layer2_bufs.as_ref().map(|(f2, b2)| [&f2.pos, &f2.nrm, &b2.pos, &b2.nrm].map(array_view));
        let layer2_views = match &l2v {
            Some(v) => [&v[0], &v[1], &v[2], &v[3]],
            None => [&fpv, &fnv, &bpv, &bnv],
        };
        let emit = crate::techniques::Emit {
            ctx,
            settings: s,
            pipelines: &pipelines,
            light_buf: &light_buf,
            front_pos: &fpv,
            front_nrm: &fnv,
            back_pos: &bpv,
            back_nrm: &bnv,
            layer2: layer2_views,
            recv_pos: &rpv,
            recv_nrm: &rnv,
            materials: &geo.materials,
            stats: &stats,
            accum: &accum,
            splat_targets: &splat_targets,
            n,
            g,
            bound: view.faces.iter().map(|f| relevant_bound(scene, f, n, g)).collect(),
            reflect_branch: s.dielectric_reflection
                && scene
                    .objects
                    .iter()
                    .any(|o| o.caustic_caster && matches!(scene.material_of(o), Material::Dielectric { .. })),
        };
        pendings.push(crate::techniques::emit(&emit, &mut enc, &mut timer, nf)?);
        splat_targets.finish(ctx, &pipelines.splat, &light_buf, &accum, &mut enc, &mut timer);
        let rp = uniform("resolve_params", bytemuck::bytes_of(&CountParams { count: texels as u32, _pad: [0; 3] }));
        let rbg = dev.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("caustic_resolve"),
            layout: &resolve_pl.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: light_buf.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: rp.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: accum.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 3, resource: wgpu::BindingResource::TextureView(&rpv) },
                wgpu::BindGroupEntry { binding: 4, resource: wgpu::BindingResource::TextureView(&rnv) },
                wgpu::BindGroupEntry { binding: 5, resource: irradiance.as_entire_binding() },
            ],
        });
        {
            let mut cp = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("caustic_resolve"),
                timestamp_writes: timer.compute("caustic_resolve"),
            });
            cp.set_pipeline(&resolve_pl);
            cp.set_bind_group(0, &rbg, &[]);
            cp.dispatch_workgroups((texels as u32).div_ceil(256), 1, 1);
        }
        if let Some(t) = temporal.as_deref_mut() {
            t.record(ctx, &mut enc, Some(&mut timer), li, &irradiance, m, nf);
        }
        // Shade the camera's diffuse surfaces with this light.
        let shp = uniform(
            "shade_params",
            bytemuck::bytes_of(&ShadeParams {
                width: w,
                height: h,
                shadow_size: s.shadow_map_size,
                _pad: 0,
                camera: cam.position.extend(1.0).to_array(),
            }),
        );
        let (erp, ern, shv) = (layer_view(&eye_recv.pos, 0), layer_view(&eye_recv.nrm, 0), array_view(&shadow));
        let shbg = dev.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("shade_receivers"),
            layout: &shade_pl.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: light_buf.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: shp.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(&erp) },
                wgpu::BindGroupEntry { binding: 3, resource: wgpu::BindingResource::TextureView(&ern) },
                wgpu::BindGroupEntry { binding: 4, resource: wgpu::BindingResource::TextureView(&shv) },
                wgpu::BindGroupEntry { binding: 5, resource: wgpu::BindingResource::Sampler(&shadow_sampler) },
                wgpu::BindGroupEntry { binding: 6, resource: wgpu::BindingResource::TextureView(&rpv) },
                wgpu::BindGroupEntry { binding: 7, resource: irradiance.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 8, resource: geo.materials.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 9, resource: radiance.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 10, resource: caustic_rad.as_entire_binding() },
            ],
        });
        {
            let mut cp = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("shade_receivers"),
                timestamp_writes: timer.compute("shade_receivers"),
            });
            cp.set_pipeline(&shade_pl);
            cp.set_bind_group(0, &shbg, &[]);
            cp.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), 1);
        }
        let _ = li;
        per_light.push(PerLight {
            accum,
            irradiance,
            stats,
            faces: nf,
            scale,
            recv,
            casters: (front, back),
            casters2: layer2_bufs,
        });
    }

    // 5. Composite.
    let out_full = storage("image", img_bytes);
    let out_caustic = storage("caustic_image", img_bytes);
    let cpar = uniform(
        "composite_params",
        bytemuck::bytes_of(&CompositeParams {
            world_to_clip: cam_clip.to_cols_array_2d(),
            camera: cam.position.extend(1.0).to_array(),
            width: w,
            height: h,
            _pad: [0; 2],
        }),
    );
    let views = [
        &eye_recv.pos,
        &eye_recv.nrm,
        &eye_front.pos,
        &eye_front.nrm,
        &eye_back.pos,
        &eye_back.nrm,
        &eye_front2.pos,
        &eye_front2.nrm,
        &eye_back2.pos,
        &eye_back2.nrm,
    ]
    .map(|t| layer_view(t, 0));
    let cbg = dev.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("composite"),
        layout: &composite_pl.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: cpar.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&views[0]) },
            wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(&views[1]) },
            wgpu::BindGroupEntry { binding: 3, resource: wgpu::BindingResource::TextureView(&views[2]) },
            wgpu::BindGroupEntry { binding: 4, resource: wgpu::BindingResource::TextureView(&views[3]) },
            wgpu::BindGroupEntry { binding: 5, resource: wgpu::BindingResource::TextureView(&views[4]) },
            wgpu::BindGroupEntry { binding: 6, resource: wgpu::BindingResource::TextureView(&views[5]) },
            wgpu::BindGroupEntry { binding: 7, resource: geo.materials.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 8, resource: radiance.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 9, resource: caustic_rad.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 10, resource: out_full.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 11, resource: out_caustic.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 12, resource: wgpu::BindingResource::TextureView(&views[6]) },
            wgpu::BindGroupEntry { binding: 13, resource: wgpu::BindingResource::TextureView(&views[7]) },
            wgpu::BindGroupEntry { binding: 14, resource: wgpu::BindingResource::TextureView(&views[8]) },
            wgpu::BindGroupEntry { binding: 15, resource: wgpu::BindingResource::TextureView(&views[9]) },
        ],
    });
    {
        let mut cp = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("composite"),
            timestamp_writes: timer.compute("composite"),
        });
        cp.set_pipeline(&composite_pl);
        cp.set_bind_group(0, &cbg, &[]);
        cp.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), 1);
    }
    let submitted = std::time::Instant::now();
    ctx.queue.submit([enc.finish()]);
    ctx.device
        .poll(wgpu::PollType::Wait { submission_index: None, timeout: None })
        .map_err(|e| Error::Device(format!("{e}")))?;
    let frame_wall_ms = submitted.elapsed().as_secs_f64() * 1e3;

    // Read back.
    let image = bytes_to_image(&ctx.read_buffer(&out_full, img_bytes)?, w, h);
    let caustic = bytes_to_image(&ctx.read_buffer(&out_caustic, img_bytes)?, w, h);
    let mut caustic_maps = Vec::new();
    let mut caustic_flux_bits = Vec::new();
    let mut flux = Vec::new();
    for pl in &per_light {
        let texels = (m as u64) * (m as u64);
        let irr = ctx.read_buffer(&pl.irradiance, texels * pl.faces as u64 * 16)?;
        caustic_maps.push(
            (0..pl.faces as u64)
                .map(|f| bytes_to_image(&irr[(f * texels * 16) as usize..((f + 1) * texels * 16) as usize], m, m))
                .collect(),
        );
        let acc = ctx.read_buffer(&pl.accum, texels * pl.faces as u64 * 24)?;
        let words: &[u32] = bytemuck::cast_slice(&acc);
        caustic_flux_bits.push(words.chunks_exact(2).map(|c| (c[1] as u64) << 32 | c[0] as u64).collect());
        let st = ctx.read_buffer(&pl.stats, 48)?;
        let sw: &[u32] = bytemuck::cast_slice(&st);
        let v = |i: usize| ((sw[i + 1] as u64) << 32 | sw[i] as u64) as f64 / pl.scale;
        flux.push(FluxStats {
            emitted: v(0),
            landed: v(2),
            lost_no_exit: v(4),
            lost_tir: v(6),
            lost_no_receiver: v(8),
            lost_outside: v(10),
        });
    }
    let timings = timer.finish(ctx)?;
    let mut technique = TechniqueStats::default();
    for p in pendings {
        technique.merge(&p.finish(ctx)?);
    }

    if let Some(dir) = dump {
        dump_buffers(
            ctx,
            dir,
            &per_light
                .iter()
                .map(|p| {
                    let mut bufs =
                        vec![("receivers", &p.recv), ("caster_front", &p.casters.0), ("caster_back", &p.casters.1)];
                    if let Some((front2, back2)) = &p.casters2 {
                        bufs.extend([("caster_front2", front2), ("caster_back2", back2)]);
                    }
                    (bufs, p.faces)
                })
                .collect::<Vec<_>>(),
            &caustic_maps,
            scene.exposure,
        )?;
    }

    Ok(GpuRender {
        image,
        caustic,
        caustic_maps,
        caustic_flux_bits,
        flux,
        timings,
        frame_wall_ms,
        photons_traced: technique.photons_traced,
        batches: technique.batches,
        technique,
        adapter: format!("{} ({:?}, {})", ctx.info.name, ctx.info.backend, ctx.info.driver),
    })
}

/// Write the light-space buffers as images a person can look at: normals (0.5 + 0.5 n), depths
/// (distance from the light, normalised), and the caustic maps (tone-mapped irradiance and EXR).
fn dump_buffers(
    ctx: &GpuContext,
    dir: &Path,
    lights: &[(Vec<(&str, &GBuffer)>, u32)],
    maps: &[Vec<Image>],
    exposure: f32,
) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::Output { path: dir.into(), message: e.to_string() })?;
    for (li, (bufs, nf)) in lights.iter().enumerate() {
        for f in 0..*nf {
            for &(name, gb) in bufs {
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
                // Normals and depths are written as data, not radiance: bypass the tone curve by
                // writing them with exposure chosen so that the PNG shows the stored values.
                crate::image_io::write_display_png(&ni, &dir.join(format!("light{li}_face{f}_{name}_normal.png")))?;
                crate::image_io::write_display_png(&di, &dir.join(format!("light{li}_face{f}_{name}_depth.png")))?;
            }
            let map = &maps[li][f as usize];
            map.write(&dir.join(format!("light{li}_face{f}_caustic_map.exr")), exposure)?;
            // Caustic maps span orders of magnitude: show them with the exposure that maps the
            // 99.9th percentile to white.
            let mut l: Vec<f32> = map.luminance().into_iter().filter(|x| *x > 0.0).collect();
            l.sort_by(f32::total_cmp);
            let p = l.get(l.len().saturating_sub(1 + l.len() / 1000)).copied().unwrap_or(1.0).max(1e-9);
            map.write(&dir.join(format!("light{li}_face{f}_caustic_map.png")), 2.0 / p)?;
        }
    }
    Ok(())
}
