//! The precomputation of caustic spheres on the GPU, in the engine crate: per stored light
//! direction, photons of a unit-irradiance directional light traced through the object alone
//! by the exact GPU tracer (`shaders/sphere_trace.wgsl` over `shaders/shared/raytrace.wgsl`),
//! the photons that leave it read back and deposited on the spheres in photon order on the CPU
//! ([`CausticSpheres::deposit`]): the same bits in every run on one device. The CPU
//! precomputation (`caustics_reference::reference::spheres::precompute`) stays as its check
//! (`tests/gpu/sphere_build.rs`).
//!
//! Why deposit on the CPU: this is a precomputation, not the frame path; the deposit sums each
//! cell in f64 in photon order, which a GPU would have to reproduce with fixed-point atomics or
//! a sort, and the read-back (48 bytes per photon) costs less than the tracing.

use super::{CausticSpheres, DirectionLayout, Escaped, SphereGeometry, SphereSettings};
use crate::error::{Error, Result};
use crate::gpu::pass::Pass;
use crate::gpu::{GpuContext, PassTimer};
use crate::scene::{Scene, Shape};
use glam::Vec3;
use std::f32::consts::PI;

/// Photons traced per dispatch (and read back at once: 48 MiB).
const CHUNK: u64 = 1 << 20;

/// The caustic spheres of object `object` of `scene` (the scene file's pose), precomputed on
/// the GPU of `ctx` for the octahedral layout of `settings`.
pub fn build(ctx: &GpuContext, scene: &Scene, object: usize, settings: &SphereSettings) -> Result<CausticSpheres> {
    build_with(ctx, scene, object, settings, None, &mut |_, _| true)
}

/// [`build`] for the light directions `dirs` (None: the octahedral layout of `settings`),
/// calling `progress(photons done, photons in all)` after each batch; it returning false
/// cancels the precomputation ([`Error::Cancelled`]).
pub fn build_with(
    ctx: &GpuContext,
    scene: &Scene,
    object: usize,
    settings: &SphereSettings,
    dirs: Option<Vec<Vec3>>,
    progress: &mut dyn FnMut(u64, u64) -> bool,
) -> Result<CausticSpheres> {
    settings.validate()?;
    let tracer = Tracer::new(ctx, scene, object)?;
    let dirs = dirs.unwrap_or_else(|| DirectionLayout::new(settings.directions).dirs);
    let geometry = SphereGeometry::for_shape(&scene.objects[object].shape, settings);
    let mut sp = CausticSpheres::empty(*settings, geometry, dirs.clone());
    let total = settings.photons * dirs.len() as u64;
    let mut done = 0;
    for (k, d) in dirs.iter().enumerate() {
        let photons = tracer.escaping(*d, settings, k as u32 ^ 0x9e37_79b9, &mut |n| {
            done += n;
            progress(done, total)
        })?;
        sp.deposit(k, &photons);
    }
    Ok(sp)
}

/// The photons of a unit-irradiance directional light travelling along `dir` that leave
/// object `object` of `scene` after at least one specular interaction (flux in m² per W/m² of
/// light), traced on the GPU with seed `seed`, in photon order: what [`build`] deposits (the
/// GPU twin of the CPU reference's `spheres::escaping`).
pub fn escaping(
    ctx: &GpuContext,
    scene: &Scene,
    object: usize,
    dir: Vec3,
    settings: &SphereSettings,
    seed: u32,
) -> Result<Vec<Escaped>> {
    settings.validate()?;
    Tracer::new(ctx, scene, object)?.escaping(dir, settings, seed, &mut |_| true)
}

/// One object alone on the GPU: its materials record and BVH.
struct Tracer {
    ctx: GpuContext,
    shape: Shape,
    /// The object alone as the scene group (materials and BVH) of `sphere_trace`.
    scene: crate::gpu::pass::SharedGroup,
}

impl Tracer {
    fn new(ctx: &GpuContext, scene: &Scene, object: usize) -> Result<Tracer> {
        let Some(o) = scene.objects.get(object) else {
            return Err(Error::input(&scene.source, "objects", format!("no object {object}")));
        };
        if !scene.material_of(o).is_specular() {
            return Err(Error::input(&scene.source, format!("objects[{object}]"), "not a specular (caustic) object"));
        }
        let mut alone = scene.clone();
        alone.objects = vec![o.clone()];
        alone.lights.clear();
        alone.environment = None;
        alone.medium = None;
        let ctx = ctx.with_own_pool();
        let bvh = crate::accel::SceneBvh::build(&alone);
        let (nodes, tris) = bvh.gpu_arrays();
        let inst = bvh.instance_records(&[glam::Affine3A::IDENTITY]);
        let mats = crate::geometry::material_records(&alone);
        let storage = wgpu::BufferUsages::STORAGE;
        let buffers = [
            ctx.buffer_init("materials", bytemuck::cast_slice(&mats), storage),
            ctx.buffer_init("bvh_nodes", bytemuck::cast_slice(&nodes), storage),
            ctx.buffer_init("bvh_tris", bytemuck::cast_slice(&tris), storage),
            ctx.buffer_init("bvh_instances", bytemuck::cast_slice(&inst), storage),
        ];
        let [a, b, c, d] = &buffers;
        let scene = crate::geometry::scene_group_of(&ctx, &alone, Some([a, b, c, d]));
        Ok(Tracer { ctx, shape: o.shape.clone(), scene })
    }

    /// The escaping photons along `dir`, batch by batch (`batch(photons)` after each; false
    /// cancels).
    fn escaping(
        &self,
        dir: Vec3,
        settings: &SphereSettings,
        seed: u32,
        batch: &mut dyn FnMut(u64) -> bool,
    ) -> Result<Vec<Escaped>> {
        let ctx = &self.ctx;
        let n = settings.photons;
        if n > u64::from(u32::MAX) {
            return Err(Error::input("<command line>", "--sphere-photons", "at most 2^32 - 1 photons per direction"));
        }
        // The disc over the object's bounding sphere, as the CPU reference's.
        let (lo, hi) = self.shape.bounds();
        let c = (lo + hi) * 0.5;
        let radius = (hi - lo).length() * 0.5 * 1.0001 + 1e-6;
        let dir = dir.normalize();
        let (du, dv) = super::basis(dir);
        let back = 2.0 * radius + 1e-3;
        let flux = PI * radius * radius / n as f32;
        let frame = [c.extend(radius), dir.extend(back), du.extend(flux), dv.extend(f32::INFINITY)];
        let storage = wgpu::BufferUsages::STORAGE;
        let frame = ctx.buffer_init("trace_frame", bytemuck::cast_slice(&frame.map(|v| v.to_array())), storage);
        let mut out = Vec::new();
        let mut first = 0u64;
        while first < n {
            let count = (n - first).min(CHUNK);
            let counts = [n as u32, first as u32, count as u32, settings.max_depth, seed];
            let counts = ctx.buffer_init("trace_counts", bytemuck::cast_slice(&counts), storage);
            let size = count * 48;
            let escaped = ctx.buffer("escaped", size, storage | wgpu::BufferUsages::COPY_SRC);
            let mut enc = ctx.device.create_command_encoder(&Default::default());
            let groups = (count as u32).div_ceil(64);
            Pass::new(ctx, "sphere_trace")
                .bind("trace_frame", &frame)
                .bind("trace_counts", &counts)
                .shared(&self.scene)
                .bind("escaped", &escaped)
                .dispatch(&mut enc, &mut PassTimer::disabled(), [groups.min(65535), groups.div_ceil(65535), 1]);
            ctx.queue.submit([enc.finish()]);
            let bytes = ctx.read_buffer(&escaped, size)?;
            let v: &[[f32; 4]] = bytemuck::cast_slice(&bytes);
            for p in v.chunks_exact(3).filter(|p| p[0][3] > 0.0) {
                let v3 = |a: [f32; 4]| Vec3::new(a[0], a[1], a[2]);
                out.push(Escaped { origin: v3(p[0]), dir: v3(p[1]), flux: v3(p[2]) });
            }
            first += count;
            if !batch(count) {
                return Err(Error::Cancelled);
            }
        }
        Ok(out)
    }
}
