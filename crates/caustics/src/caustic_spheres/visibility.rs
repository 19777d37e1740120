//! Caustic spheres under an environment (section 5 of the paper): per caustic object, the
//! visible fraction of each environment (sub-)region as seen from the object's centre past the
//! other objects, computed on the GPU inside the frame (no read-back) when the objects, the
//! environment's rotation or its segmentation changed, and kept in a GPU buffer that
//! `sphere_weights` applies to the frame's records.
//!
//! The values are the bits of [`crate::raycast::region_visibility`]: the same rays (one per
//! texel of the region, from [`crate::raycast::region_rays`]) through the same exact tracer
//! (`sphere_visibility`: the frame's BVH with the object left out, where `region_visibility`
//! builds one without it), and the same f64 sums and quotient (`sphere_visibility_sum`,
//! f64 emulated on u32 pairs).

use crate::gpu::PassTimer;
use crate::gpu::pass::Pass;
use crate::passes::DrawCtx;
use glam::Vec3;

/// The rays of one visibility computation (the CPU's part, redone only when its key changes).
#[derive(Debug, Clone)]
pub(crate) struct VisibilityRays {
    /// What it is computed for (the objects' transforms, the environment's rotation and
    /// segmentation settings, the caustic objects).
    pub key: Vec<u32>,
    /// The caustic objects, in the order of the buffer's rows.
    pub objects: Vec<usize>,
    /// Per caustic object, its centre (world).
    pub centres: Vec<Vec3>,
    /// Per ray, its unit direction (world) and weight (the luminance of L·Ω).
    pub dirs: Vec<Vec3>,
    pub weights: Vec<f64>,
    /// Per part (the drawn regions, or their sub-regions, in the order of the sphere lights
    /// after the scene's own): its first ray and ray count.
    pub parts: Vec<(u32, u32)>,
}

/// What a frame does with the visibility.
pub(crate) enum VisibilityUpdate {
    /// No environment (or no caustic spheres): none.
    None,
    /// The kept values are current.
    Keep,
    /// Compute them again for these rays.
    New(VisibilityRays),
}

/// The visibility on the GPU: per caustic object (rows in the order of `objects`), per part,
/// an f32 in `buffer`.
pub(crate) struct VisibilityState {
    pub key: Vec<u32>,
    pub objects: Vec<usize>,
    pub parts: u32,
    pub buffer: wgpu::Buffer,
}

impl VisibilityState {
    /// The index in `buffer` of object `object`'s visibility of part `part` (None: no value,
    /// the weight is 1).
    pub fn index(&self, object: usize, part: usize) -> Option<u32> {
        let row = self.objects.iter().position(|&o| o == object)?;
        (part < self.parts as usize).then(|| row as u32 * self.parts + part as u32)
    }
}

/// Records `sphere_visibility` and `sphere_visibility_sum` for `rays`: the new state, whose
/// buffer the frame's later passes read (its own buffers, kept across frames, not the pool's).
pub(crate) fn record(
    dc: &DrawCtx,
    rays: VisibilityRays,
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) -> VisibilityState {
    use wgpu::util::DeviceExt;
    let ctx = dc.ctx;
    let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
    let init = |label: &str, contents: &[u8]| {
        let pad = [0u8; 16];
        let contents = if contents.is_empty() { &pad[..] } else { contents };
        ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents,
            usage: storage,
        })
    };
    let (n_rays, n_parts, n_objects) = (rays.dirs.len() as u32, rays.parts.len() as u32, rays.objects.len() as u32);
    let values = (n_parts * n_objects).max(1) as usize;
    let ones = vec![1.0f32; values];
    let buffer = init("sphere_visibility", bytemuck::cast_slice(&ones));
    let state = VisibilityState { key: rays.key, objects: rays.objects, parts: n_parts, buffer };
    if n_rays == 0 || n_parts == 0 || n_objects == 0 {
        return state;
    }
    let sizes = init("sphere_visibility_sizes", bytemuck::cast_slice(&[n_rays, n_parts, n_objects, 0]));
    let centres: Vec<[f32; 4]> =
        rays.centres.iter().zip(&state.objects).map(|(c, &o)| c.extend(o as f32).to_array()).collect();
    let centres = init("sphere_visibility_centres", bytemuck::cast_slice(&centres));
    let dirs: Vec<[f32; 4]> = rays.dirs.iter().map(|d| d.extend(f32::INFINITY).to_array()).collect();
    let dirs = init("sphere_visibility_dirs", bytemuck::cast_slice(&dirs));
    let bits = |v: f64| [v.to_bits() as u32, (v.to_bits() >> 32) as u32];
    let weights: Vec<[u32; 2]> = rays.weights.iter().map(|&w| bits(w)).collect();
    let weights = init("sphere_visibility_weights", bytemuck::cast_slice(&weights));
    // Each part's total, summed as `region_visibility` sums it.
    let parts: Vec<[u32; 4]> = rays
        .parts
        .iter()
        .map(|&(first, count)| {
            let all = rays.weights[first as usize..(first + count) as usize].iter().fold(0.0f64, |a, &w| a + w);
            let [lo, hi] = bits(all);
            [first, count, lo, hi]
        })
        .collect();
    let parts = init("sphere_visibility_parts", bytemuck::cast_slice(&parts));
    let blocked = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("sphere_visibility_blocked"),
        size: u64::from(n_rays) * u64::from(n_objects) * 4,
        usage: storage,
        mapped_at_creation: false,
    });
    let groups = (n_rays * n_objects).div_ceil(64);
    Pass::new(ctx, "sphere_visibility")
        .bind("vis_sizes", &sizes)
        .shared(&dc.geo.scene)
        .bind("vis_centres", &centres)
        .bind("vis_dirs", &dirs)
        .bind("vis_blocked", &blocked)
        .dispatch(enc, timer, [groups.min(65535), groups.div_ceil(65535), 1]);
    Pass::new(ctx, "sphere_visibility_sum")
        .bind("vis_sizes", &sizes)
        .bind("vis_parts", &parts)
        .bind("vis_weights", &weights)
        .bind("vis_blocked", &blocked)
        .bind("visibility", &state.buffer)
        .dispatch(enc, timer, [(n_parts * n_objects).div_ceil(64), 1, 1]);
    state
}
