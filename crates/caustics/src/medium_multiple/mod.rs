//! Multiple scattering in the medium (docs/media.md, "Multiple scattering"): the light that
//! scatters twice or more in the fog, which single scattering leaves out (0.72 of the CPU
//! reference's energy in thin fog, 0.16 in a dense fog room before this existed).
//!
//! The method, chosen by what the rest of the frame already draws exactly: the first
//! scattering event along every light path (direct light, the volume caustic, the light lit
//! surfaces send into the fog) is drawn by `medium_scatter`, the beams and `medium_bounce`;
//! what is left is smooth (every further event spreads the light over the phase function), so
//! a coarse world-space grid holds it well and a photon random walk (a volumetric photon map,
//! Jensen & Christensen 1998, binned into cells) fills it exactly for every light kind, through
//! glass, water, mirrors and diffuse bounces, in homogeneous media and density grids:
//! - `medium_ms_trace` (per light): photons on random walks; each scattering event after its
//!   path's first in the medium (or after two diffuse bounces) adds the scattered flux to its
//!   cell (64-bit fixed point, deterministic);
//! - `medium_ms_resolve` (per light, then once with `ms_emitters`): the sums in watts, and every
//!   2 × 2 × 2 block of cells as an isotropic point emitter;
//! - `medium_bounce_surfaces` (before `composite`): the surfaces the camera sees lit by those
//!   emitters (light → fog → fog → floor);
//! - `medium_ms_view` (after `medium_scatter`): the camera rays through the grid, and the
//!   segments `composite` kept of the paths beyond glass and mirrors.
//!
//! The grid and its emitters depend on the lights, the objects and the medium only: a frame
//! that only moves the camera keeps them and records the gathers (cheap). Not modelled: a
//! Henyey–Greenstein lobe's direction beyond the first event (the grid is
//! isotropic), and visibility between an emitter and the surface it lights.

use crate::frame::{Feature, Frame};
use crate::gpu::pass::Pass;
use crate::gpu::types::{MS_BLOCK, MsParams, VplGpu};
use crate::passes::{DrawCtx, LightFrame, layer_view};
use crate::settings::RenderSettings;

/// Events (scattering, surfaces) per photon path at most: a dense fog of albedo 0.95 loses
/// 0.95^256 of its flux there.
const MAX_EVENTS: u32 = 256;

/// Whether the frame draws multiple scattering: a scattering medium, lights and the setting on.
pub(crate) fn wanted(scene: &crate::scene::Scene, s: &RenderSettings) -> bool {
    scene.medium.as_ref().is_some_and(|m| m.sigma_s.max_element() > 0.0)
        && s.medium.multiple_photons > 0
        && (!scene.lights.is_empty() || scene.environment.is_some())
}

/// Cells per axis: `grid` along the box's longest side, the others in proportion (at least 2).
fn dims(m: &crate::scene::Medium, grid: u32) -> [u32; 3] {
    let e = m.bounds_max - m.bounds_min;
    let l = e.max_element().max(1e-6);
    let d = |x: f32| ((x / l * grid as f32).round() as u32).clamp(2, grid.max(2));
    [d(e.x), d(e.y), d(e.z)]
}

/// The stages' parameters (the camera's part left zero where `eye` is `None`).
fn params(
    dc: &DrawCtx,
    s: &RenderSettings,
    eye: Option<&crate::passes::EyeFrame>,
    photons_seed: (u32, u32),
) -> MsParams {
    let scene = dc.scene;
    let m = scene.medium.as_ref().expect("multiple scattering needs a medium");
    let g = match m.phase {
        crate::scene::Phase::Isotropic => 0.0,
        crate::scene::Phase::HenyeyGreenstein { g } => g,
    };
    let sigma_t = m.sigma_s + m.sigma_a;
    let max_density = m.density.as_ref().map_or(1.0, |d| d.max);
    // The disk a directional light's photons start from: the bounding sphere of the objects
    // and the box.
    let (lo, hi) = scene.bounds();
    let (lo, hi) = (lo.min(m.bounds_min), hi.max(m.bounds_max));
    let (centre, radius) = (0.5 * (lo + hi), 0.5 * (hi - lo).length());
    let d = dims(m, s.medium.multiple_grid);
    let cam = &scene.camera;
    MsParams {
        clip_to_world: eye.map_or([[0.0; 4]; 4], |e| e.cam_clip.inverse().to_cols_array_2d()),
        camera: cam.position.extend(1.0).to_array(),
        lo: m.bounds_min.extend(1.0).to_array(),
        hi: m.bounds_max.extend(1.0).to_array(),
        sigma_s: m.sigma_s.extend(g).to_array(),
        sigma_t: sigma_t.extend(sigma_t.max_element() * max_density).to_array(),
        disk: centre.extend(radius.max(1e-3)).to_array(),
        dims: [d[0], d[1], d[2], u32::from(m.density.is_some())],
        photons: photons_seed.0,
        seed: photons_seed.1,
        _pad: [0; 2],
        width: cam.width,
        height: cam.height,
        steps: s.medium.steps,
        max_events: MAX_EVENTS,
    }
}

/// Photons of light `i` of a photon walk with `photons` per light, among `lights` of which the
/// scene's `own` come first: the environment's directional lights after them share one light's
/// photons (each is a part of one light), at least 1024 each.
pub(crate) fn photons_of_light(photons: u32, i: usize, (lights, own): (usize, usize)) -> u32 {
    if i < own { photons } else { (photons / (lights - own) as u32).max(1024) }
}

/// The grid of the lights' multiply scattered power and its emitters.
struct MsFrame {
    cells: wgpu::Buffer,
    vpls: wgpu::Buffer,
    emitters: u32,
}

/// `medium_ms_trace` and `medium_ms_resolve` for every light, then the emitters.
fn record_lights(
    dc: &DrawCtx,
    (lights, own): (&[&LightFrame], usize),
    s: &RenderSettings,
    enc: &mut wgpu::CommandEncoder,
    timer: &mut crate::gpu::PassTimer,
) -> Option<MsFrame> {
    if !wanted(dc.scene, s) || lights.is_empty() {
        return None;
    }
    let ctx = dc.ctx;
    let d = dims(dc.scene.medium.as_ref()?, s.medium.multiple_grid);
    let count = d[0] * d[1] * d[2];
    let emitters = d.iter().map(|x| x.div_ceil(MS_BLOCK)).product::<u32>();
    let cells = ctx.buffer("medium_ms_cells", u64::from(count) * 16, wgpu::BufferUsages::STORAGE);
    let vpls = ctx.buffer(
        "medium_ms_vpls",
        u64::from(emitters) * std::mem::size_of::<VplGpu>() as u64,
        wgpu::BufferUsages::STORAGE,
    );
    let mut last = None;
    for (i, lf) in lights.iter().enumerate() {
        let photons = photons_of_light(s.medium.multiple_photons, i, (lights.len(), own));
        let groups = photons.div_ceil(64);
        let gx = groups.min(65535);
        let p = ctx.uniform("medium_ms_params", bytemuck::bytes_of(&params(dc, s, None, (photons, i as u32 + 1))));
        let sums = ctx.buffer(&format!("medium_ms_sums{i}"), u64::from(count) * 24, wgpu::BufferUsages::STORAGE);
        Pass::new(ctx, "medium_ms_trace")
            .bind("light", &lf.light_buf)
            .bind("mp", &p)
            .bind("sums", &sums)
            .shared(&dc.geo.scene)
            .dispatch(enc, timer, [gx, groups.div_ceil(gx), 1]);
        let resolve = Pass::new(ctx, "medium_ms_resolve")
            .bind("light", &lf.light_buf)
            .bind("mp", &p)
            .bind("sums", &sums)
            .bind("cells", &cells)
            .bind("vpls", &vpls)
            .group();
        resolve.dispatch(enc, timer, [count.div_ceil(64), 1, 1]);
        last = Some(resolve);
    }
    let emit = last?.variant("medium_ms_emitters", &[("ms_emitters", 1.0)]);
    emit.dispatch(enc, timer, [emitters.div_ceil(64), 1, 1]);
    Some(MsFrame { cells, vpls, emitters })
}

/// The multiple-scattering feature: the grid (kept while no light is redone), the surfaces its
/// emitters light before the composite, and the camera rays through it after `medium_scatter`.
#[derive(Default)]
pub(crate) struct MediumMultiple {
    grid: Option<MsFrame>,
}

impl Feature for MediumMultiple {
    fn record(&mut self, f: &mut Frame) -> crate::Result<()> {
        if f.redone.iter().any(|&r| r) || self.grid.is_none() {
            f.dc.ctx.begin_scope("medium_ms_lights", f.enc);
            let lights = crate::frame::light_refs(&f.lights);
            self.grid = record_lights(&f.dc, (&lights, f.env.own_lights), f.s, f.enc, f.timer);
            f.dc.ctx.end_scope();
        }
        let Some(grid) = &self.grid else { return Ok(()) };
        f.dc.ctx.begin_scope("medium_ms", f.enc);
        let eye = crate::frame::eye(&f.eye);
        crate::medium_bounce::record_surface_gather(
            &f.dc,
            eye,
            (&grid.vpls, grid.emitters),
            (true, true),
            f.enc,
            f.timer,
        );
        f.dc.ctx.end_scope();
        Ok(())
    }

    fn record_along_rays(&mut self, f: &mut Frame) -> crate::Result<()> {
        let Some(grid) = &self.grid else { return Ok(()) };
        let (eye, out) = (crate::frame::eye(&f.eye), f.images.as_ref().expect("the composite runs first"));
        let ctx = f.dc.ctx;
        let p = ctx.uniform("medium_ms_view_params", bytemuck::bytes_of(&params(&f.dc, f.s, Some(eye), (0, 0))));
        let (rv, sv) = (layer_view(ctx, &eye.recv.pos, 0), layer_view(ctx, &eye.front.pos, 0));
        let cam = &f.dc.scene.camera;
        let pass = Pass::new(ctx, "medium_ms_view")
            .constants(&[("ms_segments", 0.0)])
            .bind("mp", &p)
            .bind("cells", &grid.cells)
            .bind("recv_pos", &rv)
            .bind("spec_pos", &sv)
            .bind("out_full", &out.full)
            .bind_all(out.segments.bindings())
            .shared(&f.dc.geo.scene)
            .group();
        pass.dispatch(f.enc, f.timer, [cam.width.div_ceil(8), cam.height.div_ceil(8), 1]);
        if out.segments.kept {
            let segments = pass.variant("medium_ms_view_segments", &[("ms_segments", 1.0)]);
            segments.dispatch_indirect(f.enc, f.timer, &out.segments.args, 0);
        }
        Ok(())
    }
}
