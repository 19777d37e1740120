//! Rays against the scene on the GPU, through the exact photon tracer's own traversal
//! (`shaders/shared/raytrace.wgsl` over [`crate::accel`]): the `ray_query` pass. For tests
//! against brute force, and for tools that need what the tracer sees (picking).

use crate::error::{Error, Result};
use crate::gpu::types::{QueryParams, RayQuery, RayResult};
use crate::gpu::{GpuContext, bind};
use crate::scene::Scene;
use glam::{Affine3A, Vec3};

/// A ray: origin, unit direction, and the largest distance searched.
#[derive(Debug, Clone, Copy)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
    pub t_max: f32,
}

/// The nearest surface a ray meets.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayHit {
    pub t: f32,
    pub object: u32,
    /// The mesh's triangle index (None for analytic shapes).
    pub triangle: Option<u32>,
    /// Geometric normal (unit; a mesh triangle's by its winding, an analytic shape's outward).
    pub normal: Vec3,
}

/// What a batch of rays found.
#[derive(Debug, Clone)]
pub struct RayCast {
    /// Per ray: the closest hit (closest-hit queries), or a hit with `t == 0` when anything is
    /// in the way (any-hit queries).
    pub hits: Vec<Option<RayHit>>,
    /// Rays that would have overflowed the traversal stack (their result may miss a surface).
    pub stack_overflows: u64,
}

/// How a batch is cast.
#[derive(Debug, Clone, Copy)]
pub struct CastOptions {
    /// Any hit (occlusion) instead of the closest.
    pub any_hit: bool,
    /// Traversal stack entries to use, at most [`crate::accel::BVH_STACK`] (the default);
    /// lower only to see overflows detected.
    pub stack_limit: u32,
}

impl Default for CastOptions {
    fn default() -> Self {
        CastOptions { any_hit: false, stack_limit: crate::accel::BVH_STACK as u32 }
    }
}

/// Cast `rays` against `scene`, each object moved by `transforms[object]` from the scene file's
/// pose (none: as loaded). Builds the scene's BVH, uploads it, dispatches `ray_query`, reads the
/// results back (blocking).
pub fn cast_rays(
    ctx: &GpuContext,
    scene: &Scene,
    transforms: &[Affine3A],
    rays: &[Ray],
    opts: CastOptions,
) -> Result<RayCast> {
    if opts.stack_limit == 0 || opts.stack_limit as usize > crate::accel::BVH_STACK {
        return Err(Error::input(
            "<ray cast>",
            "stack_limit",
            format!("must be 1 to {} (got {})", crate::accel::BVH_STACK, opts.stack_limit),
        ));
    }
    if rays.is_empty() {
        return Ok(RayCast { hits: Vec::new(), stack_overflows: 0 });
    }
    let ctx = ctx.with_own_pool();
    let bvh = crate::accel::SceneBvh::build(scene);
    let (nodes, tris) = bvh.gpu_arrays();
    let inst = bvh.instance_records(transforms);
    let mut moved = scene.clone();
    for (o, t) in moved.objects.iter_mut().zip(transforms) {
        o.shape = o.shape.transformed(t).map_err(|m| Error::input("<ray cast>", "transforms", m))?;
    }
    let mats = crate::passes::material_records(&moved);
    let queries: Vec<RayQuery> = rays
        .iter()
        .map(|r| RayQuery { o: r.origin.extend(r.t_max).to_array(), d: r.dir.extend(0.0).to_array() })
        .collect();
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    ctx.begin_scope("ray_query", &mut enc);
    let storage = wgpu::BufferUsages::STORAGE;
    let size = (rays.len() * std::mem::size_of::<RayResult>()) as u64;
    let results = crate::gpu::storage(&ctx, "ray_results", size, wgpu::BufferUsages::empty());
    let pl = ctx.compute_pipeline_with("ray_query", &[("bvh_stack_limit", f64::from(opts.stack_limit))]);
    let params = QueryParams { count: rays.len() as u32, any_hit: u32::from(opts.any_hit), _pad: [0; 2] };
    let bufs = [
        ctx.buffer_init("materials", bytemuck::cast_slice(&mats), storage),
        ctx.buffer_init("bvh_nodes", bytemuck::cast_slice(&nodes), storage),
        ctx.buffer_init("bvh_tris", bytemuck::cast_slice(&tris), storage),
        ctx.buffer_init("bvh_instances", bytemuck::cast_slice(&inst), storage),
        ctx.buffer_init("rays", bytemuck::cast_slice(&queries), storage),
    ];
    let u = ctx.uniform("query_params", bytemuck::bytes_of(&params));
    let mut res: Vec<wgpu::BindingResource> = bufs.iter().map(|b| b.as_entire_binding()).collect();
    res.push(results.as_entire_binding());
    res.push(u.as_entire_binding());
    let bg = bind(&ctx, &pl, "ray_query", &res);
    ctx.end_scope();
    {
        let mut cp = enc.begin_compute_pass(&Default::default());
        cp.set_pipeline(&pl);
        cp.set_bind_group(0, &bg, &[]);
        let groups = (rays.len() as u32).div_ceil(64);
        cp.dispatch_workgroups(groups.min(65535), groups.div_ceil(65535), 1);
    }
    ctx.queue.submit([enc.finish()]);
    let bytes = ctx.read_buffer(&results, size)?;
    let out: &[RayResult] = bytemuck::cast_slice(&bytes);
    let mut stack_overflows = 0;
    let hits = out
        .iter()
        .map(|r| {
            stack_overflows += u64::from(r.overflows);
            (r.t >= 0.0 && r.object != u32::MAX).then(|| RayHit {
                t: r.t,
                object: r.object,
                triangle: (r.triangle != u32::MAX).then_some(r.triangle),
                normal: Vec3::new(r.ng[0], r.ng[1], r.ng[2]),
            })
        })
        .collect();
    Ok(RayCast { hits, stack_overflows })
}
