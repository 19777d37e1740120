//! Rays against the scene on the GPU, through the exact photon tracer's own traversal
//! (`shaders/shared/raytrace.wgsl` over `crate::accel`): the `ray_query` pass. For tests
//! against brute force, and for tools that need what the tracer sees (picking).

use crate::error::{Error, Result};
use crate::gpu::pass::Pass;
use crate::gpu::types::{QueryParams, RayQuery, RayResult};
use crate::gpu::{GpuContext, PassTimer};
use crate::scene::Scene;
use glam::{Affine3A, Vec2, Vec3};

/// A ray: origin, unit direction, and the largest distance searched.
#[derive(Debug, Clone, Copy)]
pub struct Ray {
    /// Origin (m).
    pub origin: Vec3,
    /// Unit direction.
    pub dir: Vec3,
    /// Largest distance searched (m).
    pub t_max: f32,
}

/// The nearest surface a ray meets.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayHit {
    /// Distance along the ray (m).
    pub t: f32,
    /// Index of the object in [`Scene::objects`].
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
    /// Traversal stack entries to use, at most `crate::accel::BVH_STACK` (the default);
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
    let mats = crate::geometry::material_records(&moved);
    let queries: Vec<RayQuery> = rays
        .iter()
        .map(|r| RayQuery { o: r.origin.extend(r.t_max).to_array(), d: r.dir.extend(0.0).to_array() })
        .collect();
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    ctx.begin_scope("ray_query", &mut enc);
    let storage = wgpu::BufferUsages::STORAGE;
    let size = (rays.len() * std::mem::size_of::<RayResult>()) as u64;
    let results = crate::gpu::storage(&ctx, "ray_results", size, wgpu::BufferUsages::empty());
    let params = QueryParams { count: rays.len() as u32, any_hit: u32::from(opts.any_hit), _pad: [0; 2] };
    let [materials, bvh_nodes, bvh_tris, bvh_instances, queries] = [
        ctx.buffer_init("materials", bytemuck::cast_slice(&mats), storage),
        ctx.buffer_init("bvh_nodes", bytemuck::cast_slice(&nodes), storage),
        ctx.buffer_init("bvh_tris", bytemuck::cast_slice(&tris), storage),
        ctx.buffer_init("bvh_instances", bytemuck::cast_slice(&inst), storage),
        ctx.buffer_init("rays", bytemuck::cast_slice(&queries), storage),
    ];
    let u = ctx.uniform("query_params", bytemuck::bytes_of(&params));
    let scene_group =
        crate::geometry::scene_group_of(&ctx, scene, Some([&materials, &bvh_nodes, &bvh_tris, &bvh_instances]));
    let pass = Pass::new(&ctx, "ray_query")
        .constants(&[("bvh_stack_limit", f64::from(opts.stack_limit))])
        .shared(&scene_group)
        .bind("rays", &queries)
        .bind("results", &results)
        .bind("qp", &u)
        .group();
    ctx.end_scope();
    let groups = (rays.len() as u32).div_ceil(64);
    pass.dispatch(&mut enc, &mut PassTimer::disabled(), [groups.min(65535), groups.div_ceil(65535), 1]);
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

/// Per-region occlusion for one caustic object (section 5 of the paper): for each light of
/// `lights` (from [`crate::scene::environment_lights::segment`], world centres: the same rotation as `rotate_y`), the fraction of
/// the region's `L · Ω` (luminance weight, the split weight) that arrives unoccluded at
/// `centre` (the caustic object's centre) past `occluders` (the scene's other objects).
///
/// The paper renders each region's part of the cube map at 32×32 from the object's centre with
/// the other objects in black. We cast the rays exactly instead: one per map texel of the
/// region, from `centre` toward the texel's centre, through
/// [`cast_rays`] (the exact tracer's BVH and analytic shapes, any hit) on a
/// copy of the scene without the object itself. Why: it needs no new render pass, it is exact
/// for the texels (32×32 samples of a region of fewer texels would only repeat them, and of
/// more would miss small occluders between samples), and a map of 512×256 is 131 072 rays,
/// a few milliseconds. A black region gets visibility 1 (nothing to lose).
///
/// `env` gives the texel weights; `scene` and `transforms` the objects as they are now; the
/// object `object` is left out of the occluders. Recompute when an object moves or the
/// environment turns. Runs on the GPU, blocking; creates its own resources (not the renderer's
/// pool: it is a tool called between frames).
pub fn region_visibility(
    ctx: &crate::gpu::GpuContext,
    scene: &Scene,
    transforms: &[glam::Affine3A],
    env: &crate::scene::environment::Environment,
    lights: &[crate::scene::environment_lights::EnvironmentLight],
    object: usize,
    rotate_y: f32,
) -> Result<Vec<f32>> {
    let centre = object_centre(scene, transforms, object)?;
    let mut others = scene.clone();
    others.objects.remove(object);
    let mut other_t: Vec<glam::Affine3A> =
        (0..scene.objects.len()).map(|i| transforms.get(i).copied().unwrap_or(glam::Affine3A::IDENTITY)).collect();
    other_t.remove(object);
    let (dirs, weights) = region_rays(env, lights, rotate_y);
    let rays: Vec<Ray> = dirs.iter().map(|&dir| Ray { origin: centre, dir, t_max: f32::INFINITY }).collect();
    let hits = if others.objects.is_empty() {
        vec![None; rays.len()]
    } else {
        cast_rays(ctx, &others, &other_t, &rays, CastOptions { any_hit: true, ..Default::default() })?.hits
    };
    let mut k = 0;
    Ok(lights
        .iter()
        .map(|l| {
            let (mut all, mut free) = (0.0f64, 0.0f64);
            for _ in &l.members {
                all += weights[k];
                if hits[k].is_none() {
                    free += weights[k];
                }
                k += 1;
            }
            if all > 0.0 { (free / all) as f32 } else { 1.0 }
        })
        .collect())
}

/// The centre of object `object`'s bounds as moved by `transforms[object]` (none: as loaded),
/// where [`region_visibility`] casts its rays from.
pub(crate) fn object_centre(scene: &Scene, transforms: &[glam::Affine3A], object: usize) -> Result<Vec3> {
    if object >= scene.objects.len() {
        return Err(Error::input("<region visibility>", "object", format!("no object {object}")));
    }
    let t = transforms.get(object).copied().unwrap_or(glam::Affine3A::IDENTITY);
    let moved = scene.objects[object]
        .shape
        .transformed(&t)
        .map_err(|m| Error::input("<region visibility>", "transforms", m))?;
    let (lo, hi) = moved.bounds();
    Ok(0.5 * (lo + hi))
}

/// The rays of [`region_visibility`]: per light of `lights`, per member texel in order, the
/// world direction toward the texel's centre (the environment turned by `rotate_y`) and its
/// weight, the luminance of `L · Ω` (f64, as the sums are taken).
pub(crate) fn region_rays(
    env: &crate::scene::environment::Environment,
    lights: &[crate::scene::environment_lights::EnvironmentLight],
    rotate_y: f32,
) -> (Vec<Vec3>, Vec<f64>) {
    use crate::scene::environment_lights::{map_direction, rotation};
    let r = rotation(rotate_y);
    let mut dirs = Vec::new();
    let mut weights = Vec::new();
    for l in lights {
        for &m in &l.members {
            let (x, y) = (m % env.width, m / env.width);
            let uv = Vec2::new((x as f32 + 0.5) / env.width as f32, (y as f32 + 0.5) / env.height as f32);
            let v = env.texels[m as usize] * env.texel_solid_angle(y);
            weights.push((v.x as f64 + v.y as f64 + v.z as f64) / 3.0);
            dirs.push((r * map_direction(uv)).normalize());
        }
    }
    (dirs, weights)
}
