//! A light's beam parameters and the chunking of the ordered list: [`BeamParams`] from the
//! settings and scene, the chunks `beam_gather` and `beam_surface` dispatch over (their sizes,
//! records and scale), and the beams a slot of the hierarchy can hold.

use crate::gpu::GpuContext;
use crate::gpu::types::{
    BEAM_FLAG_CHAINS, BEAM_FLAG_GRID, BEAM_FLAG_REFLECTION, BEAM_KINDS, BEAM_PARTS, BeamLevel, BeamParams,
};
use crate::scene::{Phase, Scene, Shape};
use crate::settings::BeamSettings;
use glam::{Mat4, Vec3};

/// The chunks of the ordered list that `beam_gather` and `beam_surface` dispatch over, one
/// dispatch each, recorded for the most beams the hierarchy can keep (no read-back of the
/// count); `beam_order` writes each chunk's indirect dispatch size, none for a chunk past the
/// beams it listed. (Adaptive 16² + 3's hierarchy has 43520 slots: 1024 gather chunks recorded
/// for its 10⁴ beams; on lavapipe the empty dispatches were not measurably slower, the
/// gather's work per beam dominates: docs/benchmarks.md, "Beams: reflected branches shrunk,
/// the target met".)
#[derive(Clone, Copy, Debug)]
pub(super) struct Chunks {
    /// Beams per gather chunk, and gather chunks.
    pub(super) gather: u32,
    pub(super) gather_n: u32,
    /// Beams per surface chunk, and surface chunks (their dispatch sizes follow the gather's).
    pub(super) surface: u32,
    pub(super) surface_n: u32,
}

impl Chunks {
    /// Chunks for the beams `bp` can hold, at most `kinds` per slot ([`kinds`]), `scale` times
    /// the sizes lavapipe's loop limit allows ([`chunk_scale`]).
    pub(super) fn new(bp: &BeamParams, foot: &[f32; 4], (kinds, scale): (u64, u32)) -> Chunks {
        let (pixel_samples, surface_samples, flags) = (bp.pixel_samples, bp.surface_samples, bp.flags);
        let most = most_beams(bp.capacity, bp.slots, kinds);
        // With a density grid every point of a beam marches the grid toward its base and the
        // camera (2 x BEAM_GRID_STEPS lookups): a beam costs a pixel that many times more.
        let grid = if flags & BEAM_FLAG_GRID != 0 { GRID_COST } else { 1 };
        // A beam costs a pixel its rays and, where it is thin, its footprint's lines (counted as
        // one ray more: a beam's thin part is short, and `many_overlapping_beams_sum_like_one`
        // checks thousands of thin beams in one pixel; chunks of fewer beams multiply the
        // dispatches and binds).
        let rays = pixel_samples.max(1) * pixel_samples.max(1) + u32::from(foot[0] > 0.0);
        let gather = (GATHER_CHUNK * scale / rays / grid).max(1);
        // (a small beam's exact clip is some 40 loop iterations: counted as 16 points at least)
        let points = surface_samples.clamp(1, 8).pow(2);
        let surface = (SURFACE_CHUNK * scale / points.max(16) / grid).max(1);
        Chunks { gather, gather_n: most.div_ceil(gather), surface, surface_n: most.div_ceil(surface) }
    }

    /// `beam_order`'s uniform (`ch` in beam_order.wgsl).
    pub(super) fn gpu(&self) -> BeamLevel {
        BeamLevel { level: self.gather, offset: self.gather_n, next_offset: self.surface, base_count: self.surface_n }
    }

    /// The indirect arguments' buffer (beam_order writes them): 3 words per chunk, then
    /// `beam_hull`'s dispatch (3 words) and `beam_raster`'s draw (4 words).
    pub(super) fn dispatch_buffer(&self, ctx: &GpuContext) -> wgpu::Buffer {
        crate::gpu::storage(ctx, "beam_chunk_dispatch", self.hull_args() + 28, wgpu::BufferUsages::INDIRECT)
    }

    /// Byte offset of `beam_hull`'s indirect dispatch size (`beam_raster`'s draw follows it).
    pub(super) fn hull_args(&self) -> u64 {
        12 * u64::from(self.gather_n + self.surface_n)
    }
}

/// The footprint uniform of `beam_gather` (`foot` in beam_gather.wgsl).
pub(super) fn footprint(b: &BeamSettings) -> [f32; 4] {
    [b.footprint, b.footprint_lines as f32, 0.0, 0.0]
}

pub(super) fn params(
    scene: &Scene,
    clip_to_world: Mat4,
    b: &BeamSettings,
    max_depth: u32,
    faces: u32,
    slots: u64,
) -> BeamParams {
    let m = scene.medium.as_ref();
    let g = m.map_or(0.0, |m| match m.phase {
        Phase::Isotropic => 0.0,
        Phase::HenyeyGreenstein { g } => g,
    });
    let cam = &scene.camera;
    BeamParams {
        clip_to_world: clip_to_world.to_cols_array_2d(),
        world_to_clip: clip_to_world.inverse().to_cols_array_2d(),
        camera: cam.position.extend(1.0).to_array(),
        lo: m.map_or([0.0; 4], |m| m.bounds_min.extend(0.0).to_array()),
        hi: m.map_or([0.0; 4], |m| m.bounds_max.extend(0.0).to_array()),
        sigma_s: m.map_or(Vec3::ZERO, |m| m.sigma_s).extend(g).to_array(),
        sigma_t: m.map_or(Vec3::ZERO, |m| m.sigma_s + m.sigma_a).extend(0.0).to_array(),
        grid: b.grid,
        levels: b.levels,
        faces,
        max_depth,
        normal_cos: b.normal_threshold_deg.to_radians().cos(),
        depth_rel: b.depth_threshold,
        energy: b.energy_threshold,
        camera_size: b.camera_threshold,
        surface_samples: b.surface_samples,
        capacity: b.capacity,
        slots: slots as u32,
        samples: b.samples,
        width: cam.width,
        height: cam.height,
        flags: if b.reflection { BEAM_FLAG_REFLECTION } else { 0 }
            | if m.is_some_and(|m| m.density.is_some()) { BEAM_FLAG_GRID } else { 0 }
            | if chains(scene) { BEAM_FLAG_CHAINS } else { 0 },
        pixel_samples: b.pixel_samples,
        linearity: b.linearity_threshold,
        residual: if b.reflection { b.residual } else { 0.0 },
        cut: m.map_or(0.0, |m| cut_factor(m, b.cutoff)),
        _pad: 0,
    }
}

/// The energy cutoff's factor (`BeamParams::cut`, `cut_tail` in shaders/shared/beam_trace.wgsl),
/// in m/W: the largest scattering coefficient the medium has (σs's largest channel, times the
/// density grid's largest value where it has one) times the phase function's largest value,
/// over the cutoff radiance; 0 without a cutoff.
fn cut_factor(m: &crate::scene::Medium, cutoff: f32) -> f32 {
    if cutoff <= 0.0 {
        return 0.0;
    }
    let g = match m.phase {
        Phase::Isotropic => 0.0f32,
        Phase::HenyeyGreenstein { g } => g.abs(),
    };
    // (Henyey-Greenstein's largest value, at 0° for g > 0: (1 + g) / (4π (1 - g)²))
    let phase = (1.0 + g) / (4.0 * std::f32::consts::PI * (1.0 - g) * (1.0 - g));
    let density = m.density.as_ref().map_or(1.0, |d| d.max);
    m.sigma_s.max_element() * density * phase / cutoff
}
/// The most beams a light's ordered list can hold: `capacity`, and at most `kinds` per slot of
/// the hierarchy.
fn most_beams(capacity: u32, slots: u32, kinds: u64) -> u32 {
    u64::from(capacity).min(kinds * u64::from(slots)).max(1) as u32
}

/// Whether light can cross `scene`'s medium from one specular surface to another: unless it
/// has at most one specular object, a sphere or a rectangle (which light leaving it never meets
/// again). Then the beams' second layer and the branches reflected at a second dielectric exist
/// ([`BEAM_FLAG_CHAINS`]).
fn chains(scene: &Scene) -> bool {
    let mut specular = scene.objects.iter().filter(|o| scene.materials[o.material].is_specular());
    match (specular.next(), specular.next()) {
        (None, _) => false,
        (Some(o), None) => !matches!(o.shape, Shape::Sphere { .. } | Shape::Rectangle { .. }),
        _ => true,
    }
}

/// The beams a slot of the hierarchy can hold under beam parameters `bp`: [`KINDS`], or without
/// [`BEAM_FLAG_CHAINS`] ([`chains`]) the parts of the last segments of the first three branches
/// and, where it is on, the residual branch alone. Only the number of gather and surface chunks
/// recorded depends on it (those past the beams kept are empty dispatches).
pub(super) fn kinds(bp: &BeamParams) -> u64 {
    if bp.flags & BEAM_FLAG_CHAINS != 0 { KINDS } else { (3 + u64::from(bp.residual > 0.0)) * u64::from(BEAM_PARTS) }
}
/// The chunk records of one chunked stage (`chunk` in beam_gather.wgsl and beam_surface.wgsl),
/// all in one buffer of constants, one record per storage-offset alignment: each chunk's bind
/// group binds its own record.
///
/// Read from storage, not a uniform per chunk: lavapipe (Mesa 22.3) specializes a shader on the
/// uniform values its loops read, compiling and keeping a new variant at every bind of a chunk
/// (some 0.5 MB each, kept until the device is dropped: docs/beams.md, "Beams: memory").
pub(super) struct ChunkRecords {
    buffer: wgpu::Buffer,
    stride: u64,
}

impl ChunkRecords {
    pub(super) fn new(ctx: &GpuContext, label: &str, n: u32, chunk: u32) -> ChunkRecords {
        let size = std::mem::size_of::<BeamLevel>();
        let stride = u64::from(ctx.device.limits().min_storage_buffer_offset_alignment).max(size as u64);
        let mut bytes = vec![0u8; stride as usize * n.max(1) as usize];
        for c in 0..n {
            let at = stride as usize * c as usize;
            let record = BeamLevel { level: c, offset: c * chunk, next_offset: 0, base_count: chunk };
            bytes[at..at + size].copy_from_slice(bytemuck::bytes_of(&record));
        }
        ChunkRecords { buffer: ctx.constants(label, &bytes), stride }
    }

    /// Chunk `c`'s record.
    pub(super) fn binding(&self, c: u32) -> wgpu::BindingResource<'_> {
        wgpu::BindingResource::Buffer(wgpu::BufferBinding {
            buffer: &self.buffer,
            offset: self.stride * u64::from(c),
            size: wgpu::BufferSize::new(std::mem::size_of::<BeamLevel>() as u64),
        })
    }
}

/// How many times larger than lavapipe allows the chunks of `beam_gather` and `beam_surface`
/// are: [`BeamSettings::chunk_scale`], or where that is 0 (automatic), 1 on a CPU adapter
/// (lavapipe's shaders end an invocation's loops after some 65536 iterations in all, which sizes
/// [`GATHER_CHUNK`] and [`SURFACE_CHUNK`]) and [`GPU_CHUNK_SCALE`] on a GPU, where every chunk is
/// a dispatch and a barrier and no loop limit applies. (Not yet measured on a GPU.)
pub(super) fn chunk_scale(ctx: &GpuContext, b: &BeamSettings) -> u32 {
    match b.chunk_scale {
        0 if ctx.info.device_type == wgpu::DeviceType::Cpu => 1,
        0 => GPU_CHUNK_SCALE,
        n => n,
    }
}

/// [`chunk_scale`] on GPUs: 16 (a chunk of the default gather is then 2048 beams instead of 128,
/// so the default 16² + 3 hierarchy's 10⁴ beams take 5 dispatches instead of 78, and its worst
/// case, the capacity of 131 072 beams, 64 recorded dispatches instead of 1024).
const GPU_CHUNK_SCALE: u32 = 16;

/// Beams per slot of the hierarchy ([`BEAM_KINDS`]): six branches (transmitted, reflected at
/// the first surface, reflected once inside, the same two at a second dielectric, the residual
/// branch) times two
/// layers (the path's last segment, and the one between its last two specular objects) times
/// four parts (a last-level triangle whose corners take different paths: one beam per path,
/// and one for its orphans, the light on paths none of its corners takes).
pub(super) const KINDS: u64 = BEAM_KINDS as u64;

/// Beams one `beam_gather` dispatch loops over per camera ray (beam_gather.wgsl says why).
const GATHER_CHUNK: u32 = 256;

/// Beam × surface point tests one `beam_surface` dispatch makes per pixel at most (a chunk is
/// this over the points per pixel): a point test is a few dozen operations, so chunks are
/// larger than the gather's, and a pixel's loops stay far below lavapipe's limit of about
/// 65536 iterations per invocation.
const SURFACE_CHUNK: u32 = 4096;

/// How many times more a beam costs a pixel's loops in a medium with a density grid (its
/// points march the grid: `Chunks::new`), so chunks are that much smaller.
const GRID_COST: u32 = 2;
