//! Splat modes: how photons become the caustic map's flux (`docs/splatting.md`, issue 5).
//!
//! - [`SplatMode::Fixed`]: one normalised Gaussian of `splat_sigma` texels per photon
//!   (`photon_splat`), the baseline;
//! - [`SplatMode::MultiRes`]: adaptive multi-resolution splatting (Wyman & Dachsbacher 2008,
//!   section 4.1): four radii splatted at once (`splat_multires`), chosen per texel from photon
//!   counts with the Bernstein interpolant (`splat_multires_blend`);
//! - [`SplatMode::ThinLens`], [`SplatMode::ThickLens`]: each photon's splat size from the lens
//!   equations (section 4.2) with radii of curvature from the light-space normals; the tracer
//!   writes the beam diameter into the photon (`shared/trace.wgsl`), `splat_lens` splats it;
//! - [`SplatMode::Triangles`]: caustic triangles, flux spread over the triangle's area on the
//!   receiver. Basic technique: triangles between adjacent photons of the dense grid
//!   (`caustic_triangles`); adaptive techniques: each emitted cell (or merged cluster) is a
//!   self-contained *cell quad* whose four corner photons `adaptive_refine` traces
//!   (`splat_quads`); the hierarchical technique gives each compacted photon its dual quad from
//!   its neighbours in the dense tile (`hcm_traverse`, `splat_quads`). The default: the most
//!   accurate mode measured (see `docs/splatting.md`).
//!
//! Every mode puts each photon's flux into the map exactly once (normalised weights, 64-bit
//! fixed-point atomics: deterministic maps).

use crate::gpu::pass::{Bound, Pass, Resource};
use crate::gpu::types::{Photon, TraceParams};
use crate::gpu::{GpuContext, PassTimer};

pub use crate::gpu::types::{BlendParams, TriParams};
pub use crate::settings::SplatMode;

/// The compute stages of one splat mode.
pub(crate) struct SplatStages {
    pub mode: SplatMode,
    /// The splat of a photon buffer (every technique; [`SplatMode::stage`]).
    pub stage: &'static str,
    /// Caustic triangles are drawn from the dense grid (`caustic_triangles`, instead of the
    /// photon-buffer splat).
    pub grid_triangles: bool,
}

impl SplatStages {
    pub fn new(mode: SplatMode, technique: crate::settings::Emission) -> SplatStages {
        SplatStages {
            mode,
            stage: mode.stage(technique),
            grid_triangles: mode == SplatMode::Triangles && technique == crate::settings::Emission::Basic,
        }
    }
}

/// Per-light buffers a splat mode needs besides the caustic map's `accum`: multi-resolution
/// splatting's three smaller-radius flux maps, the counts and the per-face sums.
pub(crate) struct SplatTargets {
    pub extra: Vec<wgpu::Buffer>,
    pub texels: u64,
}

fn buffer(ctx: &GpuContext, label: &str, size: u64) -> wgpu::Buffer {
    ctx.buffer(label, size.max(16), wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC)
}

impl SplatTargets {
    /// `texels`: caustic-map texels of all faces of the light.
    pub fn new(ctx: &GpuContext, mode: SplatMode, texels: u64, faces: u32) -> SplatTargets {
        let extra = match mode {
            SplatMode::MultiRes => vec![
                buffer(ctx, "caustic_flux_r0", texels * 24),
                buffer(ctx, "caustic_flux_r1", texels * 24),
                buffer(ctx, "caustic_flux_r2", texels * 24),
                buffer(ctx, "caustic_counts", texels * 16),
                buffer(ctx, "caustic_sums", faces as u64 * 16),
            ],
            _ => Vec::new(),
        };
        SplatTargets { extra, texels }
    }

    /// The photon-buffer splat (labelled `photon_splat`) of `photons` into the caustic map
    /// `accum`: `params` its parameters (storage, indirect layout), and the mode's extra maps
    /// (`splat_quads`: the photons' corners, which the caller passes in `corners`).
    pub fn splat<'a>(
        &'a self,
        e: &crate::techniques::Emit<'a>,
        params: impl Resource<'a>,
        photons: &'a wgpu::Buffer,
        corners: Option<&'a wgpu::Buffer>,
    ) -> Bound {
        let st = &e.stages.splat;
        let mut pass = Pass::new(e.ctx, st.stage)
            .label("photon_splat")
            .bind("light", e.light_buf)
            .bind("sp", params)
            .bind("photons", photons)
            .bind("accum", e.accum);
        if st.mode == SplatMode::MultiRes {
            for (name, b) in ["flux0", "flux1", "flux2", "counts"].into_iter().zip(&self.extra) {
                pass = pass.bind(name, b);
            }
        }
        if st.stage == "splat_quads" {
            pass = pass.bind("corners", corners.expect("splat_quads needs the corner buffer"));
        }
        pass.group()
    }

    /// Record what the mode does after every photon of the light was splatted: the
    /// multi-resolution blend (and its flux-preserving rescale) into `accum`.
    pub fn finish(
        &self,
        ctx: &GpuContext,
        mode: SplatMode,
        light: &wgpu::Buffer,
        accum: &wgpu::Buffer,
        enc: &mut wgpu::CommandEncoder,
        timer: &mut PassTimer,
    ) {
        if mode != SplatMode::MultiRes {
            return;
        }
        let names = ["flux0", "flux1", "flux2", "counts", "sums"];
        let passes: Vec<Bound> = (0..2u32)
            .map(|pass| {
                let u = ctx.uniform(
                    "blend_params",
                    bytemuck::bytes_of(&BlendParams { count: self.texels as u32, pass_index: pass, _pad: [0; 2] }),
                );
                let blend = Pass::new(ctx, "splat_multires_blend").label("splat_blend");
                let blend = blend.bind("light", light).bind("bp", &u).bind("accum", accum);
                names.into_iter().zip(&self.extra).fold(blend, |p, (name, b)| p.bind(name, b)).group()
            })
            .collect();
        let mut cp = crate::gpu::pass::begin(enc, timer, "splat_blend");
        for pass in &passes {
            pass.dispatch_in(&mut cp, [(self.texels as u32).div_ceil(256), 1, 1]);
        }
    }
}

/// Longest triangle edge (caustic-map texels) that is not taken for a discontinuity: eight times
/// the unrefracted photon spacing M / N, and at least 32 texels. Under a directional light's
/// photon crop (`LightGpu.crop`) the true spacing is smaller; this whole-face bound is then the
/// more lenient one (both are the 32-texel floor at the usual N ≥ M / 4).
pub fn triangle_max_edge(n: u32, m: u32) -> f32 {
    (8.0 * m as f32 / n as f32).max(32.0)
}

/// Rows of photons per batch of the triangle pass: whole rows of the N × N grid that fit `batch`
/// photons (at least one).
pub fn triangle_rows(n: u32, batch: u64) -> u32 {
    ((batch / n as u64).max(1)).min(n as u64) as u32
}

/// Bytes of the triangle pass's photon buffer: the previous batch's last row (padded to the
/// storage offset alignment), then `rows` rows.
pub fn triangle_buffer_layout(n: u32, rows: u32) -> (u64, u64) {
    let stride = std::mem::size_of::<Photon>() as u64;
    let pad = (n as u64 * stride).div_ceil(256) * 256;
    (pad, pad + rows as u64 * n as u64 * stride)
}

/// What the basic technique needs to draw caustic triangles for one face: the photon buffer
/// and the row carried between batches, and the rows per batch.
pub(crate) struct GridTriangles<'a> {
    pub photons: &'a wgpu::Buffer,
    pub carry: &'a wgpu::Buffer,
    pub rows: u32,
}

/// Record the dense grid of face `f` in batches of whole rows: `photon_trace`, then
/// `caustic_triangles` over the quads whose rows are held, then the batch's last row is carried
/// to the head of the buffer for the next batch's first quad row. Returns (photons traced,
/// batches).
pub(crate) fn record_grid_triangles(
    e: &crate::techniques::Emit,
    g: &GridTriangles,
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
    f: u32,
) -> (u64, u32) {
    let (n, stride) = (e.n, std::mem::size_of::<Photon>() as u64);
    let (pad, _) = triangle_buffer_layout(n, g.rows);
    let uniform = |label: &str, bytes: &[u8]| e.ctx.uniform(label, bytes);
    let (mut r0, mut traced, mut batches) = (0u32, 0u64, 0u32);
    while r0 < n {
        let rows = g.rows.min(n - r0);
        let count = rows * n;
        let tp = uniform(
            "trace_params",
            bytemuck::bytes_of(&TraceParams { face: f, batch_offset: r0 * n, batch_count: count, tile: 0 }),
        );
        let out = wgpu::BufferBinding {
            buffer: g.photons,
            offset: pad,
            size: std::num::NonZeroU64::new(count as u64 * stride),
        };
        let trace = e.tracing("photon_trace").bind("tp", &tp).bind("photons", out).group();
        let last = r0 + rows == n;
        let quad_rows = rows + u32::from(last);
        let par = uniform(
            "triangle_params",
            bytemuck::bytes_of(&TriParams {
                n,
                r0,
                rows,
                quad_rows,
                cur_off: (pad / stride) as u32,
                has_prev: u32::from(r0 > 0),
                max_edge: triangle_max_edge(n, e.settings.photons.caustic_map_size),
                _pad: 0,
            }),
        );
        let triangles = Pass::new(e.ctx, "caustic_triangles")
            .label("photon_splat")
            .bind("light", e.light_buf)
            .bind("tp", &par)
            .bind("photons", g.photons)
            .bind("accum", e.accum)
            .group();
        trace.dispatch(enc, timer, [count.div_ceil(64), 1, 1]);
        triangles.dispatch(enc, timer, [(n + 1).div_ceil(8), quad_rows.div_ceil(8), 1]);
        if !last {
            let row = n as u64 * stride;
            enc.copy_buffer_to_buffer(g.photons, pad + (rows as u64 - 1) * row, g.carry, 0, row);
            enc.copy_buffer_to_buffer(g.carry, 0, g.photons, 0, row);
        }
        traced += count as u64;
        batches += 1;
        r0 += rows;
    }
    (traced, batches)
}

/// One photon of a dense grid with its splat diameter and the true size of its beam.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeamSample {
    /// NDC centre of the photon's grid cell.
    pub ndc: [f32; 2],
    /// The diameter the tracer stored for the splat (`Photon._pad`, caustic-map texels).
    pub stored: f32,
    /// The true size of the cell's image on the receiver: the square root of the area spanned by
    /// the photon and its +x and +y grid neighbours, in texels.
    pub true_size: f32,
}

/// Stored splat diameters against the true beam size over a dense n × n photon grid (row-major,
/// one photon per cell, e.g. `TechniqueStats::photons` of the basic technique's transmitted
/// branch): every photon whose +x and +y neighbours landed on its face by its path (same path
/// signature). For tests and tools that check the lens and ray-differential sizes. `ndc` is the
/// cell's centre on the whole face: under a directional light's photon crop (`LightGpu.crop`)
/// the grid spans the crop instead.
pub fn beam_samples(photons: &[Photon], n: u32) -> Vec<BeamSample> {
    let at = |i: u32, j: u32| &photons[(j * n + i) as usize];
    let mut out = Vec::new();
    for j in 0..n.saturating_sub(1) {
        for i in 0..n - 1 {
            let (p, px, py) = (at(i, j), at(i + 1, j), at(i, j + 1));
            if p.face == u32::MAX || px.face != p.face || py.face != p.face {
                continue;
            }
            if p.flux[3] != px.flux[3] || p.flux[3] != py.flux[3] {
                continue;
            }
            let dx = [px.pos[0] - p.pos[0], px.pos[1] - p.pos[1]];
            let dy = [py.pos[0] - p.pos[0], py.pos[1] - p.pos[1]];
            out.push(BeamSample {
                ndc: [-1.0 + (i as f32 + 0.5) * 2.0 / n as f32, 1.0 - (j as f32 + 0.5) * 2.0 / n as f32],
                stored: f32::from_bits(p._pad),
                true_size: (dx[0] * dy[1] - dx[1] * dy[0]).abs().sqrt(),
            });
        }
    }
    out
}
