//! Diffuse interreflection (docs/indirect.md): the light that reaches a diffuse surface after
//! bouncing off another (a room's walls lit by its floor, a caustic lit by a caustic), which
//! the rest of the frame leaves out (it draws the light's first diffuse hit only).
//!
//! The method, as offline photon mapping stores it and as real-time world caches (NVIDIA's
//! SHaRC, Bevy Solari's world cache) key it: photons from every light keep going after their
//! first diffuse hit, and their later diffuse hits fill a world-space hash grid of surface
//! cells, read back at the surfaces the camera sees as a density estimate in the surface's
//! plane:
//! - `indirect_trace` (per light): photons on random walks, exact through every specular
//!   surface, cosine bounces with Russian roulette by albedo; every diffuse hit after the first
//!   adds its flux, position and normal to its cell (64-bit fixed point, deterministic);
//! - `indirect_resolve` (per light): the sums in watts, added to the cells in the lights' order;
//! - `indirect_gather` (before `composite`): each pixel's diffuse surface, lit by the cells
//!   near it (radiance albedo / pi times the irradiance), so surfaces seen through glass and in
//!   mirrors show it too.
//!
//! The cache depends on the lights and the objects only: a frame that only moves the camera
//! keeps it and records the gather. With `indirect.history` N > 1 the cache is progressive
//! (`indirect_blend`): each frame blends a fresh batch into it for 6N frames after a change, so a
//! moved light fades in over about N frames instead of rebuilding from one noisy batch. Not
//! modelled yet: light the medium scatters between surfaces (a photon that scatters in fog
//! ends; the medium's features draw that light), surfaces under
//! water seen through the water surface at points the camera does not see directly.

use crate::frame::{Feature, Frame};
use crate::gpu::pass::Pass;
use crate::gpu::types::{IC_COUNTER_BASE, IC_LIGHT_WORDS, IC_ORDERS, IndirectParams};
use crate::passes::{DrawCtx, LightFrame, layer_view};
use crate::settings::RenderSettings;

/// Events (surfaces) per photon path at most.
const MAX_EVENTS: u32 = 256;

/// Words of one slot's sums (`IC_SUM_WORDS`, shaders/shared/indirect.wgsl).
const SUM_WORDS: u64 = 20;

/// Whether the frame draws interreflection: the setting on, lights and a diffuse surface.
pub(crate) fn wanted(scene: &crate::scene::Scene, s: &RenderSettings) -> bool {
    s.indirect.active()
        && (!scene.lights.is_empty() || scene.environment.is_some())
        && scene.objects.iter().any(|o| matches!(scene.material_of(o), crate::scene::Material::Diffuse { .. }))
}

/// The stages' parameters (the camera's part left zero where `camera` is `None`).
fn params(dc: &DrawCtx, s: &RenderSettings, camera: bool, (photons, light_index): (u32, u32)) -> IndirectParams {
    let scene = dc.scene;
    let (olo, ohi) = scene.bounds();
    // The disk a directional light's photons start from: the bounding sphere of the objects
    // and the medium's box.
    let (lo, hi) = scene.medium.as_ref().map_or((olo, ohi), |m| (olo.min(m.bounds_min), ohi.max(m.bounds_max)));
    let (centre, radius) = (0.5 * (lo + hi), 0.5 * (hi - lo).length());
    let h = ((ohi - olo).max_element() / s.indirect.grid as f32).max(1e-6);
    let origin = olo - glam::Vec3::splat(2.0 * h);
    let (mlo, mhi, sigma_t) = match &scene.medium {
        Some(m) => (
            m.bounds_min.extend(if m.density.is_some() { 2.0 } else { 1.0 }),
            m.bounds_max.extend(0.0),
            (m.sigma_s + m.sigma_a).extend(0.0),
        ),
        None => (glam::Vec4::ZERO, glam::Vec4::ZERO, glam::Vec4::ZERO),
    };
    let cam = &scene.camera;
    IndirectParams {
        origin: origin.extend(h).to_array(),
        disk: centre.extend(radius.max(1e-3)).to_array(),
        lo: mlo.to_array(),
        hi: mhi.to_array(),
        sigma_t: sigma_t.to_array(),
        camera: if camera { cam.position.extend(1.0).to_array() } else { [0.0; 4] },
        photons,
        seed: light_index + 1,
        capacity: s.indirect.capacity,
        bounces: s.indirect.bounces,
        max_events: MAX_EVENTS,
        width: if camera { cam.width } else { 0 },
        height: if camera { cam.height } else { 0 },
        light_index,
        alpha: 1.0,
        _pad: [0; 3],
    }
}

/// The cache: each slot's key and its cells (flux and weight, weighted position, weighted
/// normal), and the count of deposits a full table lost.
struct Cache {
    keys: wgpu::Buffer,
    cells: wgpu::Buffer,
    counters: wgpu::Buffer,
}

/// A progressive cache's own state (`indirect.history` > 1): its buffers persist across frames
/// (not pooled), so every batch's photons find the slots earlier batches keyed.
struct Progressive {
    /// What the table's slots mean: the grid (corner and side bits), capacity and lights; a
    /// change starts a new cache.
    layout: [u32; 6],
    /// The cache's keys and cells (what [`Cache`] shares).
    keys: wgpu::Buffer,
    cells: wgpu::Buffer,
    /// Batches blended in so far, and frames left to refine.
    batches: u32,
    refine_left: u32,
}

/// `indirect_trace` and `indirect_resolve` for every light: one batch of photons into `cells`
/// (zeroed by its owner) under `keys`.
fn record_lights(
    dc: &DrawCtx,
    (lights, own): (&[&LightFrame], usize),
    s: &RenderSettings,
    (keys, cells, batch): (&wgpu::Buffer, &wgpu::Buffer, u32),
    enc: &mut wgpu::CommandEncoder,
    timer: &mut crate::gpu::PassTimer,
) -> wgpu::Buffer {
    let ctx = dc.ctx;
    let capacity = u64::from(s.indirect.capacity);
    let storage = wgpu::BufferUsages::STORAGE;
    let sums = ctx.buffer("indirect_sums", capacity * SUM_WORDS * 4, storage);
    let words = IC_COUNTER_BASE + lights.len() * IC_LIGHT_WORDS;
    let counters = ctx.buffer("indirect_counters", words as u64 * 4, storage | wgpu::BufferUsages::COPY_SRC);
    for (i, lf) in lights.iter().enumerate() {
        let photons = crate::medium_multiple::photons_of_light(s.indirect.photons, i, (lights.len(), own));
        if i > 0 {
            enc.clear_buffer(&sums, 0, None);
        }
        let groups = photons.div_ceil(64);
        let gx = groups.min(65535);
        let mut ip = params(dc, s, false, (photons, i as u32));
        // Batch 0 keeps the seeds of a cache built at once; later batches draw new numbers.
        ip.seed = ip.seed.wrapping_add(batch.wrapping_mul(lights.len() as u32));
        let p = ctx.uniform("indirect_params", bytemuck::bytes_of(&ip));
        Pass::new(ctx, "indirect_trace")
            .bind("light", &lf.light_buf)
            .bind("ip", &p)
            .bind("keys", keys)
            .bind("sums", &sums)
            .bind("counters", &counters)
            .shared(&dc.geo.scene)
            .dispatch(enc, timer, [gx, groups.div_ceil(gx), 1]);
        Pass::new(ctx, "indirect_resolve")
            .bind("light", &lf.light_buf)
            .bind("ip", &p)
            .bind("keys", keys)
            .bind("sums", &sums)
            .bind("cells", cells)
            .dispatch(enc, timer, slot_groups(s));
    }
    counters
}

/// Workgroups of 64 over the table's slots.
fn slot_groups(s: &RenderSettings) -> [u32; 3] {
    let slots = s.indirect.capacity.div_ceil(64);
    let sx = slots.min(65535);
    [sx, slots.div_ceil(sx), 1]
}

/// The interreflection feature: the cache (kept while no light is redone, or refined across
/// frames) and the surfaces it lights before the composite.
#[derive(Default)]
pub(crate) struct Indirect {
    cache: Option<Cache>,
    progressive: Option<Progressive>,
}

impl Indirect {
    /// Whether the next frame would refine a progressive cache.
    pub(crate) fn refining(&self) -> bool {
        self.progressive.as_ref().is_some_and(|p| p.refine_left > 0)
    }

    /// The cache built at once from one batch (`indirect.history` = 1).
    fn rebuild(&mut self, f: &mut Frame) {
        let ctx = f.dc.ctx;
        let capacity = u64::from(f.s.indirect.capacity);
        let storage = wgpu::BufferUsages::STORAGE;
        let keys = ctx.buffer("indirect_keys", capacity * 4, storage);
        let cells = ctx.buffer("indirect_cells", capacity * 48, storage);
        let lights = crate::frame::light_refs(&f.lights);
        let counters = record_lights(&f.dc, (&lights, f.env.own_lights), f.s, (&keys, &cells, 0), f.enc, f.timer);
        self.cache = Some(Cache { keys, cells, counters });
        self.progressive = None;
    }

    /// One more batch blended into a progressive cache (`indirect.history` > 1); `changed`: a
    /// light or an object changed this frame.
    fn refine(&mut self, f: &mut Frame, changed: bool) {
        let ctx = f.dc.ctx;
        let s = f.s;
        let ip = params(&f.dc, s, false, (0, 0));
        let o = ip.origin.map(f32::to_bits);
        let layout = [o[0], o[1], o[2], o[3], s.indirect.capacity, f.lights.len() as u32];
        let capacity = u64::from(s.indirect.capacity);
        let prog = match self.progressive.take() {
            Some(p) if p.layout == layout => p,
            _ => {
                let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
                Progressive {
                    layout,
                    keys: ctx.kept_buffer("indirect_keys (progressive)", capacity * 4, usage),
                    cells: ctx.kept_buffer("indirect_cells (progressive)", capacity * 48, usage),
                    batches: 0,
                    refine_left: s.indirect.refine_frames(),
                }
            }
        };
        let mut prog = prog;
        if changed {
            prog.refine_left = s.indirect.refine_frames();
        }
        let lights = crate::frame::light_refs(&f.lights);
        let own = f.env.own_lights;
        let counters = if prog.batches == 0 {
            record_lights(&f.dc, (&lights, own), s, (&prog.keys, &prog.cells, 0), f.enc, f.timer)
        } else {
            let fresh = ctx.buffer("indirect_fresh", capacity * 48, wgpu::BufferUsages::STORAGE);
            let batch = (&prog.keys, &fresh, prog.batches);
            let counters = record_lights(&f.dc, (&lights, own), s, batch, f.enc, f.timer);
            let n = prog.batches + 1;
            let bp = IndirectParams { alpha: 1.0 / n.min(s.indirect.history) as f32, ..ip };
            let p = ctx.uniform("indirect_blend_params", bytemuck::bytes_of(&bp));
            Pass::new(ctx, "indirect_blend")
                .bind("ip", &p)
                .bind("keys", &prog.keys)
                .bind("fresh", &fresh)
                .bind("cells", &prog.cells)
                .dispatch(f.enc, f.timer, slot_groups(s));
            counters
        };
        prog.batches += 1;
        prog.refine_left = prog.refine_left.saturating_sub(1);
        self.cache = Some(Cache { keys: prog.keys.clone(), cells: prog.cells.clone(), counters });
        self.progressive = Some(prog);
    }
}

impl Feature for Indirect {
    fn record(&mut self, f: &mut Frame) -> crate::Result<()> {
        if !wanted(f.dc.scene, f.s) || f.lights.is_empty() {
            self.cache = None;
            self.progressive = None;
            return Ok(());
        }
        let changed = f.redone.iter().any(|&r| r);
        let progressive = f.s.indirect.history > 1;
        if progressive && (changed || self.refining() || self.progressive.is_none()) {
            f.dc.ctx.begin_scope("indirect_lights", f.enc);
            self.refine(f, changed);
            f.dc.ctx.end_scope();
            f.stats.indirect = self.cache.as_ref().map(|c| c.counters.clone());
        } else if !progressive && (changed || self.cache.is_none() || self.progressive.is_some()) {
            f.dc.ctx.begin_scope("indirect_lights", f.enc);
            self.rebuild(f);
            f.dc.ctx.end_scope();
            f.stats.indirect = self.cache.as_ref().map(|c| c.counters.clone());
        }
        let Some(cache) = &self.cache else { return Ok(()) };
        let ctx = f.dc.ctx;
        ctx.begin_scope("indirect", f.enc);
        let eye = crate::frame::eye(&f.eye);
        let cam = &f.dc.scene.camera;
        let p = ctx.uniform("indirect_gather_params", bytemuck::bytes_of(&params(&f.dc, f.s, true, (0, 0))));
        let (ep, en) = (layer_view(ctx, &eye.recv.pos, 0), layer_view(ctx, &eye.recv.nrm, 0));
        Pass::new(ctx, "indirect_gather")
            .bind("ip", &p)
            .bind("keys", &cache.keys)
            .bind("cells", &cache.cells)
            .bind("eye_pos", &ep)
            .bind("eye_nrm", &en)
            .shared(&f.dc.geo.scene)
            .bind("radiance", &eye.radiance)
            .dispatch(f.enc, f.timer, [cam.width.div_ceil(8), cam.height.div_ceil(8), 1]);
        ctx.end_scope();
        Ok(())
    }
}

/// The statistics in `indirect_trace`'s counters (`words`, little-endian): the deposits a full
/// cache lost, and the flux (W, r, g, b) reaching diffuse surfaces at each bounce order from 2
/// (the last entry holds order `IC_ORDERS + 1` and up), summed over the lights.
pub(crate) fn read_counters(bytes: &[u8]) -> (u64, Vec<[f64; 3]>) {
    let word = |i: usize| u32::from_le_bytes(bytes[i * 4..i * 4 + 4].try_into().expect("4 bytes"));
    let lights = (bytes.len() / 4).saturating_sub(IC_COUNTER_BASE) / IC_LIGHT_WORDS;
    let mut orders = vec![[0.0f64; 3]; IC_ORDERS];
    for l in 0..lights {
        let base = IC_COUNTER_BASE + l * IC_LIGHT_WORDS;
        let scale = f64::from(f32::from_bits(word(base + IC_ORDERS * 6)));
        if scale.is_nan() || scale <= 0.0 {
            continue;
        }
        for (k, order) in orders.iter_mut().enumerate() {
            for (c, v) in order.iter_mut().enumerate() {
                let w = base + k * 6 + c * 2;
                *v += (u64::from(word(w + 1)) << 32 | u64::from(word(w))) as f64 / scale;
            }
        }
    }
    (u64::from(word(0)), orders)
}
