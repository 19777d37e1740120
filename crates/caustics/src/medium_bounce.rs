//! Light that diffuse surfaces and the medium exchange, with one scattering event in the
//! medium (docs/media.md, "Light between surfaces and the medium"): light → floor → fog
//! → camera (and the caustic's light → glass → floor → fog → camera), light → fog → floor
//! → camera, the glow's light back on the floor (light → floor → fog → floor → camera), and the
//! volume caustic's light → glass → fog → floor → camera.
//!
//! Six passes:
//! - `medium_bounce_lights` (per light, after the lights' maps): each block of
//!   `RenderSettings::medium_bounce_grid`² blocks of each face of the light's receiver map
//!   becomes one virtual point light (VPL): the flux its diffuse receivers reflect (direct
//!   light, shadowed, and the caustic map's light, both attenuated on their way from the
//!   light), at the flux-weighted mean point, as a Lambertian disk with the same spread.
//! - `medium_bounce_shafts` (per light): the same blocks' light rays cut into slices; each
//!   slice's scattered flux (shadowed) becomes one point emitter with the phase function.
//! - `medium_bounce_glow` (per light, with the VPLs): each surface VPL's light along 32
//!   directions of its hemisphere, scattered in 8 steps each, binned by light block and
//!   distance into point emitters (fixed-point sums).
//! - `medium_bounce_beams` (per light with beams, every frame): the beams' scattered light,
//!   sampled along each beam and binned by light block and distance into point emitters
//!   (fixed-point sums).
//! - `medium_bounce_surfaces` (before `composite`): the diffuse surfaces the camera sees lit by
//!   the shaft, glow and beam emitters, into the eye's radiance.
//! - `medium_bounce` (once, after `medium_scatter`): per pixel, the camera ray's segment in the
//!   medium gathers the surface VPLs' single scattering (`RenderSettings::medium_bounce_steps`
//!   steps), into the full image and, for the caustic part of their flux, the caustic-only
//!   image.
//!
//! Recorded only for scenes with a scattering medium and a diffuse material of nonzero albedo
//! (a black floor reflects nothing and is lit by nothing it could show: its frames are the same
//! bits as without the passes). The caustic part comes from the lights' caustic maps, so it is
//! there for the photon techniques; with `LocalSource::Beams` or the caustic spheres those
//! maps stay zero: with the beams' surface caustic `medium_bounce_beams` makes the caustic
//! share from the beams' landing light instead; with the caustic spheres only the direct
//! light's share is added.

use crate::gpu::PassTimer;
use crate::gpu::pass::Pass;
use crate::gpu::types::{BounceLightParams, BounceParams, EmitParams, SurfaceBounceParams, VplGpu};
use crate::passes::Composited;
use crate::passes::{DrawCtx, EyeFrame, LightFrame, array_view, layer_view, shadow_sampler};
use crate::settings::RenderSettings;
use glam::Vec3;

/// Whether the frame records the passes: a scattering medium, the setting on, and a diffuse
/// material that reflects.
pub(crate) fn wanted(scene: &crate::scene::Scene, s: &RenderSettings) -> bool {
    let Some(m) = &scene.medium else { return false };
    s.medium.bounce_grid > 0
        && m.sigma_s.max_element() > 0.0
        && scene.objects.iter().any(|o| {
            matches!(scene.materials.get(o.material), Some(crate::scene::Material::Diffuse { albedo }) if albedo.max_element() > 0.0)
        })
}

/// Shaft emitters per light block (`SHAFT_SLICES` in shaders/medium_bounce_shafts.wgsl).
const SHAFT_SLICES: u32 = 8;

/// The frame's virtual point lights: on surfaces (`medium_bounce_lights`) and in the shafts
/// (`medium_bounce_shafts`).
pub(crate) struct BounceFrame {
    surface: wgpu::Buffer,
    surface_count: u32,
    shafts: wgpu::Buffer,
    shaft_count: u32,
    /// Per light, its glow emitters (`medium_bounce_glow`) and their count.
    glow: Vec<(wgpu::Buffer, u32)>,
}

/// The medium's box, sigma_t and sigma_s as the stages take them, and whether it has a grid.
fn medium_params(m: &crate::scene::Medium) -> ([f32; 4], [f32; 4], [f32; 4], [f32; 4], u32) {
    let g = match m.phase {
        crate::scene::Phase::Isotropic => 0.0,
        crate::scene::Phase::HenyeyGreenstein { g } => g,
    };
    (
        m.bounds_min.extend(1.0).to_array(),
        m.bounds_max.extend(1.0).to_array(),
        (m.sigma_s + m.sigma_a).extend(0.0).to_array(),
        m.sigma_s.extend(g).to_array(),
        u32::from(m.density.is_some()),
    )
}

/// `medium_bounce_lights` and `medium_bounce_shafts` for every light: the frame's VPLs, or
/// `None` where the scene needs none ([`wanted`]).
pub(crate) fn record_lights(
    dc: &DrawCtx,
    lights: &[&LightFrame],
    s: &RenderSettings,
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) -> Option<BounceFrame> {
    if !wanted(dc.scene, s) || lights.is_empty() {
        return None;
    }
    let m = dc.scene.medium.as_ref()?;
    let ctx = dc.ctx;
    let k = s.medium.bounce_grid;
    let surface_count: u32 = lights.iter().map(|lf| lf.faces * k * k).sum();
    let shaft_count = surface_count * SHAFT_SLICES;
    let vpl_size = std::mem::size_of::<VplGpu>() as u64;
    let surface = ctx.buffer("medium_vpls", u64::from(surface_count) * vpl_size, wgpu::BufferUsages::STORAGE);
    let shafts = ctx.buffer("medium_shaft_vpls", u64::from(shaft_count) * vpl_size, wgpu::BufferUsages::STORAGE);
    let (lo, hi, sigma_t, sigma_s, heterogeneous) = medium_params(m);
    let shadow_sampler = shadow_sampler(ctx);
    let mut offset = 0;
    for lf in lights {
        let params = |offset| {
            ctx.uniform(
                "medium_bounce_light_params",
                bytemuck::bytes_of(&BounceLightParams {
                    lo,
                    hi,
                    sigma_t,
                    grid: k,
                    shadow_size: s.shading.shadow_map_size,
                    heterogeneous,
                    light_steps: s.medium.light_steps,
                    offset,
                    _pad: [0; 3],
                    sigma_s,
                }),
            )
        };
        let (rp, rn, sh) = (array_view(ctx, &lf.recv.pos), array_view(ctx, &lf.recv.nrm), array_view(ctx, &lf.shadow));
        let (lp, sp) = (params(offset), params(offset * SHAFT_SLICES));
        let lights_pass = Pass::new(ctx, "medium_bounce_lights")
            .bind("light", &lf.light_buf)
            .bind("bp", &lp)
            .bind("recv_pos", &rp)
            .bind("recv_nrm", &rn)
            .bind("irradiance", &lf.irradiance)
            .shared(&dc.geo.scene)
            .bind("shadow_map", &sh)
            .bind("shadow_sampler", &shadow_sampler)
            .bind("vpls", &surface)
            .group();
        let shafts_pass = Pass::new(ctx, "medium_bounce_shafts")
            .bind("light", &lf.light_buf)
            .bind("bp", &sp)
            .bind("recv_pos", &rp)
            .bind("shadow_map", &sh)
            .bind("shadow_sampler", &shadow_sampler)
            .shared(&dc.geo.scene)
            .bind("vpls", &shafts)
            .group();
        lights_pass.dispatch(enc, timer, [k, k, lf.faces]);
        shafts_pass.dispatch(enc, timer, [k, k, lf.faces]);
        offset += lf.faces * k * k;
    }
    let glow = record_glow(dc, lights, s, &surface, enc, timer);
    Some(BounceFrame { surface, surface_count, shafts, shaft_count, glow })
}

/// Words of each point emitter's sums (`EMIT_WORDS` in shaders/shared/medium_emit.wgsl).
const EMIT_WORDS: u64 = 24;
/// Slices per block of the beam emitters and of the glow emitters.
const BEAM_EMIT_SLICES: u32 = 16;
const GLOW_SLICES: u32 = 16;
/// Directions per surface VPL of `medium_bounce_glow` (`GLOW_DIRS`).
const GLOW_DIRS: u32 = 32;

/// A light's point emitters: the sums (zeroed), the emitters, and their parameters.
fn emitter_buffers(
    ctx: &crate::gpu::GpuContext,
    label: &str,
    m: &crate::scene::Medium,
    lf: &LightFrame,
    (grid, slices): (u32, u32),
    (vpl_offset, vpl_count): (u32, u32),
    landing: Option<(Vec3, Vec3)>,
) -> (wgpu::Buffer, wgpu::Buffer, wgpu::Buffer, u32) {
    let (mut lo, mut hi, sigma_t, sigma_s, heterogeneous) = medium_params(m);
    if let Some((a, b)) = landing {
        // (the landing points' normalization box: they need not lie in the medium)
        lo = a.extend(1.0).to_array();
        hi = b.extend(1.0).to_array();
    }
    let bins = lf.faces * grid * grid * slices;
    let params = ctx.uniform(
        &format!("{label}_params"),
        bytemuck::bytes_of(&EmitParams {
            lo,
            hi,
            sigma_s,
            sigma_t,
            grid,
            faces: lf.faces,
            bins,
            slices,
            scale: lf.scale as f32,
            heterogeneous,
            vpl_offset,
            vpl_count,
            caustic: u32::from(landing.is_some()),
            _pad: [0; 3],
        }),
    );
    // (the sums, then the samples' range of distances: two words)
    let sums =
        ctx.buffer(&format!("{label}_sums"), (u64::from(bins) * EMIT_WORDS + 2) * 4, wgpu::BufferUsages::STORAGE);
    let vpls = ctx.buffer(
        &format!("{label}_vpls"),
        u64::from(bins) * std::mem::size_of::<VplGpu>() as u64,
        wgpu::BufferUsages::STORAGE,
    );
    (params, sums, vpls, bins)
}

/// The three dispatches of an emitter stage (`emit_pass` 0, 1, 2) bound as `pass`, whose other
/// constants are `consts`: the samples' range and sums (`samples`: an indirect dispatch, or
/// workgroups of 64), the emitters per bin. Only the passes from `first_pass` are recorded.
fn record_emitter_passes<'a>(
    (pass, consts): (Pass<'a>, &[(&'a str, f64)]),
    samples: Result<(&wgpu::Buffer, u64), u32>,
    bins: u32,
    first_pass: usize,
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) {
    let constants = |p: usize| [consts, &[("emit_pass", p as f64)]].concat();
    // (the variants share one layout, so one bind group)
    let bound = pass.constants(&constants(first_pass)).group();
    for p in first_pass..3 {
        let variant = bound.variant(bound.label(), &constants(p));
        match (p, samples) {
            (2, _) => variant.dispatch(enc, timer, [bins.div_ceil(64), 1, 1]),
            (_, Ok((args, at))) => variant.dispatch_indirect(enc, timer, args, at),
            (_, Err(groups)) => variant.dispatch(enc, timer, [groups, 1, 1]),
        }
    }
}

/// The frame's emitters from the beams ([`record_beam_emitters`]).
#[derive(Default)]
pub(crate) struct BeamEmitters {
    /// Per light with beams: the light its beams scatter in the medium (point emitters for the
    /// surfaces).
    pub scatter: Vec<(wgpu::Buffer, u32)>,
    /// Where the surface caustic is the beams' (the caustic maps empty): per light with beams,
    /// the light its beams land with on diffuse surfaces (Lambertian VPLs for the camera's
    /// gather, caustic light), and their glow emitters.
    pub landing: Vec<(wgpu::Buffer, u32)>,
    pub landing_glow: Vec<(wgpu::Buffer, u32)>,
}

/// `medium_bounce_beams` for every light's beams: the volume caustic's light scattered toward
/// the surfaces (light -> glass -> fog -> floor), and where the surface caustic is the beams'
/// their landing light (light -> glass -> floor -> fog) with its glow
/// (`medium_bounce_glow`). Nothing where [`wanted`] is not or no light has beams.
pub(crate) fn record_beam_emitters(
    dc: &DrawCtx,
    frames: &[crate::beams::BeamFrame],
    lights: &[&LightFrame],
    s: &RenderSettings,
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) -> BeamEmitters {
    let mut out = BeamEmitters::default();
    let Some(m) = dc.scene.medium.as_ref().filter(|_| wanted(dc.scene, s) && s.beams_active(dc.scene)) else {
        return out;
    };
    let ctx = dc.ctx;
    let landing_bounds = landing_box(dc.scene);
    for (fi, f) in frames.iter().enumerate() {
        let lf = lights[f.light];
        let ([bp, beams, order, stats], args) = f.listed();
        let mut emit = |label: String, grid_slices, landing: Option<(Vec3, Vec3)>| {
            let (params, sums, vpls, bins) = emitter_buffers(ctx, &label, m, lf, grid_slices, (0, 0), landing);
            let pass = Pass::new(ctx, "medium_bounce_beams")
                .bind("bp", bp)
                .bind("light", &lf.light_buf)
                .bind("ep", &params)
                .bind("beams", beams)
                .bind("order", order)
                .bind("stats", stats)
                .bind("sums", &sums)
                .bind("vpls", &vpls)
                .shared(&dc.geo.scene);
            let consts = [("emit_landing", f64::from(u8::from(landing.is_some())))];
            // (one slice per block for the landing light: no range pass)
            let first = usize::from(landing.is_some());
            record_emitter_passes((pass, &consts), Ok(args), bins, first, enc, timer);
            (vpls, bins)
        };
        if s.beams_volume_active(dc.scene) {
            out.scatter.push(emit(format!("medium_bounce_beams{fi}"), (s.medium.bounce_grid, BEAM_EMIT_SLICES), None));
        }
        if s.beams_surface_active(dc.scene) {
            let (vpls, bins) =
                emit(format!("medium_bounce_landing{fi}"), (s.medium.bounce_grid, 1), Some(landing_bounds));
            let label = format!("medium_bounce_landing_glow{fi}");
            out.landing_glow.push(record_glow_of(dc, lf, s, (&vpls, 0, bins), &label, enc, timer));
            out.landing.push((vpls, bins));
        }
    }
    out
}

/// A box holding the medium's and every object's (a cube about their union, twice its largest
/// extent: objects may move), to normalize the beams' landing points by.
fn landing_box(scene: &crate::scene::Scene) -> (Vec3, Vec3) {
    let (mut lo, mut hi) = scene.bounds();
    if let Some(m) = &scene.medium {
        lo = lo.min(m.bounds_min);
        hi = hi.max(m.bounds_max);
    }
    let c = 0.5 * (lo + hi);
    let r = (hi - lo).max_element().max(1e-3);
    (c - Vec3::splat(r), c + Vec3::splat(r))
}

/// `medium_bounce_glow` for every light: its lit surfaces' light scattered in the medium toward
/// the surfaces (light -> floor -> fog -> floor), from its surface VPLs in `surface` (each
/// light's `faces × grid²` in order): per light, its glow VPLs and their count.
fn record_glow(
    dc: &DrawCtx,
    lights: &[&LightFrame],
    s: &RenderSettings,
    surface: &wgpu::Buffer,
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) -> Vec<(wgpu::Buffer, u32)> {
    let k = s.medium.bounce_grid;
    let mut offset = 0;
    let mut out = Vec::new();
    for (li, lf) in lights.iter().enumerate() {
        let count = lf.faces * k * k;
        let label = format!("medium_bounce_glow{li}");
        out.push(record_glow_of(dc, lf, s, (surface, offset, count), &label, enc, timer));
        offset += count;
    }
    out
}

/// `medium_bounce_glow` for one light over `count` of its surface VPLs from `offset` in `vpls_in`.
fn record_glow_of(
    dc: &DrawCtx,
    lf: &LightFrame,
    s: &RenderSettings,
    (vpls_in, offset, count): (&wgpu::Buffer, u32, u32),
    label: &str,
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) -> (wgpu::Buffer, u32) {
    let m = dc.scene.medium.as_ref().expect("the medium bounce runs in a medium");
    let ctx = dc.ctx;
    let (params, sums, vpls, bins) =
        emitter_buffers(ctx, label, m, lf, (s.medium.bounce_grid, GLOW_SLICES), (offset, count), None);
    let pass = Pass::new(ctx, "medium_bounce_glow")
        .bind("light", &lf.light_buf)
        .bind("ep", &params)
        .bind("surface", vpls_in)
        .bind("sums", &sums)
        .bind("vpls", &vpls)
        .shared(&dc.geo.scene);
    let groups = (count * GLOW_DIRS).div_ceil(64);
    record_emitter_passes((pass, &[]), Err(groups), bins, 0, enc, timer);
    (vpls, bins)
}

/// `medium_bounce_surfaces`: the camera's diffuse surfaces lit by the shaft emitters and the
/// beam emitters ([`record_beam_emitters`]), added into the eye's radiance (before
/// `composite`).
pub(crate) fn record_surfaces(
    dc: &DrawCtx,
    eye: &EyeFrame,
    bf: &BounceFrame,
    beam_vpls: &[(wgpu::Buffer, u32)],
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) {
    // The shaft and glow emitters stand for fog filling the space (the layer gain applies);
    // the beams' for the volume caustic's light.
    let fog = std::iter::once((&bf.shafts, bf.shaft_count)).chain(bf.glow.iter().map(|(b, n)| (b, *n)));
    for (vpls, count) in fog {
        record_surface_gather(dc, eye, (vpls, count), (true, false), enc, timer);
    }
    for (vpls, count) in beam_vpls {
        record_surface_gather(dc, eye, (vpls, *count), (false, false), enc, timer);
    }
}

/// `medium_bounce_surfaces` over `count` emitters in `vpls`: `layers`, they stand for fog
/// filling the space (the layer gain applies); `isotropic`, they scatter the same way in every
/// direction (the multiple-scattering grid's: src/medium_multiple/), else by the medium's phase
/// function about their direction.
pub(crate) fn record_surface_gather(
    dc: &DrawCtx,
    eye: &EyeFrame,
    (vpls, count): (&wgpu::Buffer, u32),
    (layers, isotropic): (bool, bool),
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) {
    let Some(m) = &dc.scene.medium else { return };
    let ctx = dc.ctx;
    let cam = &dc.scene.camera;
    let (lo, hi, sigma_t, sigma_s, heterogeneous) = medium_params(m);
    let params = ctx.uniform(
        "medium_bounce_surface_params",
        bytemuck::bytes_of(&SurfaceBounceParams {
            lo,
            hi,
            sigma_t: [sigma_t[0], sigma_t[1], sigma_t[2], if isotropic { 0.0 } else { sigma_s[3] }],
            camera: cam.position.extend(1.0).to_array(),
            width: cam.width,
            height: cam.height,
            count,
            heterogeneous,
            layers: u32::from(layers),
            _pad: [0; 3],
        }),
    );
    let (ep, en) = (layer_view(ctx, &eye.recv.pos, 0), layer_view(ctx, &eye.recv.nrm, 0));
    Pass::new(ctx, "medium_bounce_surfaces")
        .bind("sp", &params)
        .bind("vpls", vpls)
        .bind("eye_pos", &ep)
        .bind("eye_nrm", &en)
        .shared(&dc.geo.scene)
        .bind("radiance", &eye.radiance)
        .dispatch(enc, timer, [cam.width.div_ceil(8), cam.height.div_ceil(8), 1]);
}

/// `medium_bounce`: the surface VPLs' single scattering along every camera ray, added into the
/// composited images (full, caustic-only), after `medium_scatter`; then
/// (`medium_bounce_segments`) along the segments `composite` kept of the paths beyond the
/// specular surfaces, into the full image.
pub(crate) fn record(f: &mut crate::frame::Frame, bf: &BounceFrame, landing: &[(wgpu::Buffer, u32)]) {
    let (eye, out) = (crate::frame::eye(&f.eye), f.images.as_ref().expect("the composite runs first"));
    let lists = std::iter::once((&bf.surface, bf.surface_count)).chain(landing.iter().map(|(b, n)| (b, *n)));
    for (vpls, count) in lists {
        record_camera_gather(&f.dc, eye, (vpls, count), f.s, out, f.enc, f.timer);
    }
}

/// `medium_bounce` over one list of surface VPLs (`count` of them in `vpls`).
fn record_camera_gather(
    dc: &DrawCtx,
    eye: &EyeFrame,
    (vpls, count): (&wgpu::Buffer, u32),
    s: &RenderSettings,
    out: &Composited,
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) {
    let Some(m) = &dc.scene.medium else { return };
    let ctx = dc.ctx;
    let cam = &dc.scene.camera;
    let (w, h) = (cam.width, cam.height);
    let (lo, hi, sigma_t, sigma_s, heterogeneous) = medium_params(m);
    let params = ctx.uniform(
        "medium_bounce_params",
        bytemuck::bytes_of(&BounceParams {
            clip_to_world: eye.cam_clip.inverse().to_cols_array_2d(),
            camera: cam.position.extend(1.0).to_array(),
            lo,
            hi,
            sigma_s,
            sigma_t,
            width: w,
            height: h,
            steps: s.medium.bounce_steps,
            count,
            heterogeneous,
            _pad: [0; 3],
        }),
    );
    let (rv, sv) = (layer_view(ctx, &eye.recv.pos, 0), layer_view(ctx, &eye.front.pos, 0));
    let pass = Pass::new(ctx, "medium_bounce")
        .constants(&[("bounce_segments", 0.0)])
        .bind("bp", &params)
        .bind("vpls", vpls)
        .bind("recv_pos", &rv)
        .bind("spec_pos", &sv)
        .bind("out_full", &out.full)
        .bind("out_caustic", &out.caustic)
        .shared(&dc.geo.scene)
        .bind_all(out.segments.bindings())
        .group();
    pass.dispatch(enc, timer, [w.div_ceil(8), h.div_ceil(8), 1]);
    if out.segments.kept {
        let segments = pass.variant("medium_bounce_segments", &[("bounce_segments", 1.0)]);
        segments.dispatch_indirect(enc, timer, &out.segments.args, 0);
    }
}

/// The medium bounce feature: the lights' virtual point lights (kept while no light is redone),
/// the surfaces they and the beams light before the composite, and their light scattered along
/// the camera rays after it.
#[derive(Default)]
pub(crate) struct MediumBounce {
    bounce: Option<BounceFrame>,
    emitters: BeamEmitters,
}

impl crate::frame::Feature for MediumBounce {
    fn record(&mut self, f: &mut crate::frame::Frame) -> crate::Result<()> {
        let lights = crate::frame::light_refs(&f.lights);
        // The lights' VPLs are made again when a light's maps were (every change that moves them
        // redoes the lights: the medium, materials, settings, objects the light sees); a frame
        // that only moves the camera keeps them, and their scope is not begun, so its buffers
        // are not cleared.
        if f.redone.iter().any(|&r| r) || self.bounce.is_none() {
            f.dc.ctx.begin_scope("medium_bounce_lights", f.enc);
            self.bounce = record_lights(&f.dc, &lights, f.s, f.enc, f.timer);
            f.dc.ctx.end_scope();
        }
        // The surfaces lit by the shafts' and the beams' light in the medium (before
        // `composite`, which shows them through glass).
        f.dc.ctx.begin_scope("medium_bounce", f.enc);
        self.emitters = BeamEmitters::default();
        if let Some(bf) = &self.bounce {
            let beams = f.products.get::<Vec<crate::beams::BeamFrame>>().map_or(&[][..], |b| &b[..]);
            self.emitters = record_beam_emitters(&f.dc, beams, &lights, f.s, f.enc, f.timer);
            let emitters = [&self.emitters.scatter[..], &self.emitters.landing_glow[..]].concat();
            record_surfaces(&f.dc, crate::frame::eye(&f.eye), bf, &emitters, f.enc, f.timer);
        }
        f.dc.ctx.end_scope();
        Ok(())
    }

    fn record_along_rays(&mut self, f: &mut crate::frame::Frame) -> crate::Result<()> {
        let Some(bf) = &self.bounce else { return Ok(()) };
        record(f, bf, &self.emitters.landing);
        Ok(())
    }
}
