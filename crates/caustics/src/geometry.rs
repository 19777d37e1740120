//! The scene on the GPU ([`Geometry`]): triangles, per-object material records and analytic
//! shapes, transforms, the environment map, the medium's density grid and the exact tracer's BVH,
//! uploaded once and rewritten where objects move or meshes deform (their vertices, BVH
//! triangles and boxes: [`Geometry::refit_mesh`]). Every feature's passes read it; it reads no
//! feature (so it sits below the frame's modules).

use crate::gpu::GpuContext;
use crate::gpu::pass::{Pass, SharedGroup};
use crate::gpu::types::*;
use crate::scene::{Material, Scene, Tessellation, TriMesh};
use glam::Mat4;
use std::ops::Range;

/// The scene's triangles, uploaded once (in the pose of the scene file), and the per-object
/// records the frame rewrites when objects move.
pub(crate) struct Geometry {
    pub(crate) vertices: wgpu::Buffer,
    pub(crate) indices: wgpu::Buffer,
    /// Index ranges per object.
    pub(crate) ranges: Vec<Range<u32>>,
    /// Vertex ranges per object (a deformed mesh rewrites its range: [`Geometry::refit_mesh`]).
    pub(crate) vertex_ranges: Vec<Range<u32>>,
    /// Per object: material and analytic shape (in the current pose).
    pub materials: wgpu::Buffer,
    /// Per object: [`ObjectTransform`] from the scene file's pose to the current one.
    pub transforms: wgpu::Buffer,
    /// The exact tracer's BVH (`crate::accel`): bottom levels built once, instances rewritten
    /// when objects move ([`Geometry::write_instances`]).
    pub bvh: crate::accel::SceneBvh,
    pub bvh_instances: wgpu::Buffer,
    /// The BVH's nodes and triangles (also in [`Geometry::scene`]): a deformed mesh rewrites
    /// its triangles and refits its nodes' boxes in place ([`Geometry::refit_mesh`]).
    pub bvh_nodes: wgpu::Buffer,
    pub bvh_tris: wgpu::Buffer,
    /// Per BVH instance, made at its first refit: its nodes by height, leaves first
    /// ([`crate::accel::SceneBvh::refit_levels`]), and on the GPU the same lists in one buffer,
    /// each level at an offset storage bindings accept, as (byte offset, nodes).
    refit_plans: Vec<Option<RefitPlan>>,
    /// The scene group (`shaders/shared/scene.wgsl`) over the materials, the BVH (its nodes and
    /// triangles are held only there, with these instances), the medium's density grid
    /// (R32Float, 3D; 1×1×1 holding 1 without one) and the environment map (linear radiance,
    /// Rgba32Float; 1×1 black without one), which every stage that reads the scene is given
    /// (`Pass::shared`). Made with them: the frame rewrites their contents, never the buffers.
    pub scene: SharedGroup,
}

/// The refit of one bottom level ([`Geometry::refit_plans`]).
struct RefitPlan {
    levels: Vec<Vec<u32>>,
    buffer: wgpu::Buffer,
    offsets: Vec<(u64, u32)>,
}

impl Geometry {
    /// Write the BVH instances for the objects' transforms (from the scene file's pose).
    pub(crate) fn write_instances(&self, ctx: &GpuContext, transforms: &[glam::Affine3A]) {
        let inst = self.bvh.instance_records(transforms);
        ctx.queue.write_buffer(&self.bvh_instances, 0, bytemuck::cast_slice(&inst));
    }

    /// Mesh object `object` deformed (`mesh`: its new vertices in the scene file's pose, same
    /// vertex count and triangles): its vertices and BVH triangles rewritten on the GPU (queue
    /// writes: they land before the frame's commands), and the CPU BVH refit (its instance's
    /// bounds too: the caller rewrites the instances). Returns the BVH instance whose nodes
    /// [`Geometry::record_refits`] must refit on the GPU (None: the object has no triangles in
    /// the BVH, or is no mesh).
    pub(crate) fn refit_mesh(&mut self, ctx: &GpuContext, object: usize, mesh: &TriMesh) -> Option<usize> {
        let vr = self.vertex_ranges.get(object)?.clone();
        let v: Vec<Vertex> = mesh
            .positions
            .iter()
            .zip(&mesh.normals)
            .map(|(p, n)| Vertex { position: p.to_array(), normal: n.to_array(), object: object as u32 })
            .collect();
        // As many as uploaded (the caller keeps the counts): never past the object's range.
        if v.len() == vr.len() {
            let at = u64::from(vr.start) * std::mem::size_of::<Vertex>() as u64;
            ctx.queue.write_buffer(&self.vertices, at, bytemuck::cast_slice(&v));
        }
        let k = self.bvh.instance_of(object)?;
        if self.refit_plans.len() < self.bvh.instances.len() {
            self.refit_plans.resize_with(self.bvh.instances.len(), || None);
        }
        let plan = self.refit_plans[k].get_or_insert_with(|| refit_plan(ctx, &self.bvh, k));
        self.bvh.refit(k, &plan.levels, &mesh.positions, &mesh.normals, &mesh.indices);
        let (_, tris) = self.bvh.instance_ranges(k);
        if tris.is_empty() {
            return None;
        }
        let at = tris.start as u64 * std::mem::size_of::<BvhTri>() as u64;
        ctx.queue.write_buffer(&self.bvh_tris, at, bytemuck::cast_slice(&self.bvh.tris[tris]));
        Some(k)
    }

    /// Record the GPU refit of BVH instances `instances` ([`Geometry::refit_mesh`]): one
    /// compute pass timed as `bvh_refit`, one dispatch per level of each, leaves first (the
    /// dispatches of a compute pass see the writes of those before them).
    pub(crate) fn record_refits(
        &self,
        ctx: &GpuContext,
        instances: &[usize],
        enc: &mut wgpu::CommandEncoder,
        timer: &mut crate::gpu::PassTimer,
    ) {
        if instances.is_empty() {
            return;
        }
        ctx.begin_scope("bvh_refit", enc);
        let mut bound = Vec::new();
        for &k in instances {
            let Some(plan) = self.refit_plans.get(k).and_then(Option::as_ref) else { continue };
            for &(offset, count) in &plan.offsets {
                let level = wgpu::BufferBinding {
                    buffer: &plan.buffer,
                    offset,
                    size: std::num::NonZeroU64::new(u64::from(count) * 4),
                };
                let pass = Pass::new(ctx, "bvh_refit")
                    .bind("level", level)
                    .bind("tris", &self.bvh_tris)
                    .bind("nodes", &self.bvh_nodes)
                    .group();
                let groups = count.div_ceil(64);
                let gx = groups.min(65535);
                bound.push((pass, [gx, groups.div_ceil(gx), 1]));
            }
        }
        ctx.end_scope();
        let mut cp = crate::gpu::pass::begin(enc, timer, "bvh_refit");
        for (pass, groups) in &bound {
            pass.dispatch_in(&mut cp, *groups);
        }
    }
}

/// The refit plan of BVH instance `k`: its levels, uploaded once, each at an offset aligned for
/// a storage binding.
fn refit_plan(ctx: &GpuContext, bvh: &crate::accel::SceneBvh, k: usize) -> RefitPlan {
    let levels = bvh.refit_levels(k);
    let align = (ctx.device.limits().min_storage_buffer_offset_alignment / 4).max(1) as usize;
    let mut words: Vec<u32> = Vec::new();
    let mut offsets = Vec::new();
    for l in &levels {
        offsets.push((words.len() as u64 * 4, l.len() as u32));
        words.extend(l);
        // Padding (never read: each level's binding ends with it).
        words.resize(words.len().div_ceil(align) * align, u32::MAX);
    }
    if words.is_empty() {
        words.push(u32::MAX);
    }
    let buffer = ctx.kept_buffer(
        "bvh_refit_levels",
        words.len() as u64 * 4,
        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
    );
    ctx.queue.write_buffer(&buffer, 0, bytemuck::cast_slice(&words));
    RefitPlan { levels, buffer, offsets }
}

/// Upload the triangles of `scene` (the pose of its file) with identity transforms.
pub(crate) fn upload_geometry(ctx: &GpuContext, scene: &Scene, t: &Tessellation) -> Geometry {
    let mut vertices: Vec<Vertex> = Vec::new();
    let mut indices: Vec<u32> = Vec::new();
    let mut ranges = Vec::new();
    let mut vertex_ranges = Vec::new();
    for (i, o) in scene.objects.iter().enumerate() {
        let m = o.shape.tessellate(t);
        let base = vertices.len() as u32;
        vertex_ranges.push(base..base + m.positions.len().min(m.normals.len()) as u32);
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
    // Read back by the refit's tests (`Renderer::read_bvh`).
    let readable = storage | wgpu::BufferUsages::COPY_SRC;
    let bvh_nodes = ctx.buffer_init("bvh_nodes", bytemuck::cast_slice(&nodes), readable);
    let bvh_tris = ctx.buffer_init("bvh_tris", bytemuck::cast_slice(&tris), readable);
    let bvh_instances = ctx.buffer_init("bvh_instances", bytemuck::cast_slice(&inst), readable);
    let materials = ctx.buffer_init("materials", bytemuck::cast_slice(&material_records(scene)), storage);
    let environment = upload_environment(ctx, scene);
    let density = upload_density(ctx, scene);
    let scene_group = scene_group(ctx, [&materials, &bvh_nodes, &bvh_tris, &bvh_instances], &density, &environment);
    let refit_plans = bvh.instances.iter().map(|_| None).collect();
    Geometry {
        bvh_instances,
        bvh_nodes,
        bvh_tris,
        refit_plans,
        bvh,
        // COPY_DST (`buffer_init` adds it): a deformed mesh rewrites its vertices.
        vertices: ctx.buffer_init("vertices", bytemuck::cast_slice(&vertices), wgpu::BufferUsages::VERTEX),
        indices: ctx.buffer_init("indices", bytemuck::cast_slice(&indices), wgpu::BufferUsages::INDEX),
        ranges,
        vertex_ranges,
        materials,
        transforms: ctx.buffer_init("object_transforms", bytemuck::cast_slice(&transforms), storage),
        scene: scene_group,
    }
}

/// The scene group (`shaders/shared/scene.wgsl`) over the per-object materials, the BVH's
/// nodes, triangles and instances (in that order), the density grid and the environment map.
pub(crate) fn scene_group(
    ctx: &GpuContext,
    buffers: [&wgpu::Buffer; 4],
    density: &wgpu::Texture,
    environment: &wgpu::Texture,
) -> SharedGroup {
    let density = density_view(ctx, density);
    let environment = ctx.view(environment, Some(wgpu::TextureViewDimension::D2), 0, Some(1));
    let mut entries: Vec<wgpu::BindGroupEntry> = buffers
        .iter()
        .enumerate()
        .map(|(i, b)| wgpu::BindGroupEntry { binding: i as u32, resource: b.as_entire_binding() })
        .collect();
    entries.push(wgpu::BindGroupEntry { binding: 4, resource: wgpu::BindingResource::TextureView(&density) });
    entries.push(wgpu::BindGroupEntry { binding: 5, resource: wgpu::BindingResource::TextureView(&environment) });
    SharedGroup::new(ctx, crate::gpu::SCENE_GROUP, &entries)
}

/// The scene group of `scene` without a geometry upload, for one-off work that reads part of
/// it: `buffers` (materials and BVH, as [`scene_group`] takes them) where given, else one zeroed
/// record each (nothing to hit); the scene's density grid and environment map.
pub(crate) fn scene_group_of(ctx: &GpuContext, scene: &Scene, buffers: Option<[&wgpu::Buffer; 4]>) -> SharedGroup {
    let storage = wgpu::BufferUsages::STORAGE;
    let sizes = [
        std::mem::size_of::<MaterialGpu>(),
        std::mem::size_of::<BvhNode>(),
        std::mem::size_of::<BvhTri>(),
        std::mem::size_of::<BvhInstance>(),
    ];
    let empty = sizes.map(|n| ctx.buffer_init("scene_placeholder", &vec![0; n], storage));
    let buffers = buffers.unwrap_or([&empty[0], &empty[1], &empty[2], &empty[3]]);
    scene_group(ctx, buffers, &upload_density(ctx, scene), &upload_environment(ctx, scene))
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
            Material::Dielectric { ior, ext_ior, absorption } => {
                (KIND_DIELECTRIC, [ior, ext_ior, 0.0, 0.0], absorption.extend(0.0).to_array())
            }
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
fn upload_density(ctx: &GpuContext, scene: &Scene) -> wgpu::Texture {
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
fn density_view(ctx: &GpuContext, t: &wgpu::Texture) -> wgpu::TextureView {
    ctx.view(t, Some(wgpu::TextureViewDimension::D3), 0, None)
}
