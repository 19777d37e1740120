//! A light's passes: its uniform record and photon crop, the light-space buffers, the photon
//! stage, `caustic_resolve`, the temporal filter, the shading tiles, and its flux bookkeeping.

use super::raster::{Draw, RasterPass, Subset};
use super::{DEPTH_FORMAT, FrameConsts, GBuffer, LightFrame, array_view, texture};
use crate::error::Result;
use crate::gpu::pass::Pass;
use crate::gpu::types::*;
use crate::gpu::{GpuContext, PassTimer};
use crate::lightspace::{CasterBox, LightView, caster_box};
use crate::output::FluxStats;
use crate::scene::{Light, Scene};
use crate::settings::Emission;
use crate::settings::RenderSettings;
use glam::Vec3;

/// The light's uniform record: its faces, kind and power, the frame's grid sizes and splat, and
/// the medium its photons cross.
fn light_gpu(
    view: &LightView,
    light: &Light,
    s: &RenderSettings,
    fc: &FrameConsts,
    scale: f64,
    crop: [f32; 4],
    medium: Option<&crate::scene::Medium>,
) -> LightGpu {
    let (n, m, g, sigma, grid_steps) = (fc.n, fc.m, fc.g, s.photons.splat_sigma, s.medium.light_steps);
    let (caster_radius, multi_bounce) = (fc.caster_radius, fc.multi_bounce);
    let lens = s.photons.splat.lens_flag(s.photons.emission);
    let mut faces = [FaceGpu { world_to_clip: [[0.0; 4]; 4], clip_to_world: [[0.0; 4]; 4], origin: [0.0; 4] }; 6];
    for (f, face) in view.faces.iter().enumerate() {
        faces[f] = FaceGpu {
            world_to_clip: face.world_to_clip.to_cols_array_2d(),
            clip_to_world: face.world_to_clip.inverse().to_cols_array_2d(),
            origin: face.origin_or_dir.extend(if face.orthographic { 1.0 } else { 0.0 }).to_array(),
        };
    }
    let (kind, power, axis, cone, start) = match light {
        Light::Spot { direction, cone_angle, falloff_start, intensity, .. } => {
            (LIGHT_SPOT, *intensity, *direction, *cone_angle, *falloff_start)
        }
        Light::Point { intensity, .. } => {
            (LIGHT_POINT, *intensity, Vec3::Y, std::f32::consts::PI, std::f32::consts::PI)
        }
        Light::Directional { direction, irradiance } => (LIGHT_DIRECTIONAL, *irradiance, *direction, 0.0, 0.0),
    };
    LightGpu {
        faces,
        info: [view.faces.len() as u32, kind, n, m],
        power: power.extend(cone.cos()).to_array(),
        axis: axis.extend(cone).to_array(),
        params: [start, scale as f32, sigma, g as f32],
        extra: [caster_radius, view.scene_radius, view.tan_half_fov, multi_bounce],
        splat: [lens, if view.has_spill() { SPILL_FACE_PRESENT as f32 } else { 0.0 }, spot_profile(light), 0.0],
        crop,
        // Photons carry their path's transmittance (w: 1 homogeneous, 2 a density grid marched
        // in `medium_light_steps` steps per segment, in sigma_t's w).
        medium_lo: medium
            .map_or([0.0; 4], |m| m.bounds_min.extend(if m.density.is_some() { 2.0 } else { 1.0 }).to_array()),
        medium_hi: medium.map_or([0.0; 4], |m| m.bounds_max.extend(0.0).to_array()),
        medium_sigma_t: medium.map_or([0.0; 4], |m| (m.sigma_s + m.sigma_a).extend(grid_steps as f32).to_array()),
    }
}

/// `LightGpu::splat`'s z: a spot light's profile (0 linear in the angle, 1 glTF's curve).
fn spot_profile(light: &Light) -> f32 {
    match light {
        Light::Spot { profile: crate::scene::SpotProfile::Gltf, .. } => 1.0,
        _ => 0.0,
    }
}

/// Upper bound of the flux (W, r + g + b) a light can send through its view: sets the
/// fixed-point scale so that no sum can overflow 2^53.
fn flux_bound(view: &LightView, light: &Light) -> f64 {
    match light {
        Light::Spot { intensity, cone_angle, .. } => {
            let sum = intensity.x + intensity.y + intensity.z;
            sum as f64 * std::f64::consts::TAU * (1.0 - (*cone_angle as f64).cos()).max(1e-9)
        }
        Light::Point { intensity, .. } => (intensity.x + intensity.y + intensity.z) as f64 * 4.0 * std::f64::consts::PI,
        Light::Directional { irradiance, .. } => {
            let inv = view.faces[0].world_to_clip.inverse();
            let ex = inv.transform_vector3(Vec3::new(2.0, 0.0, 0.0));
            let ey = inv.transform_vector3(Vec3::new(0.0, 2.0, 0.0));
            (irradiance.x + irradiance.y + irradiance.z) as f64 * ex.cross(ey).length() as f64
        }
    }
    .max(1e-12)
}

/// The whole face in NDC (lo.x, lo.y, hi.x, hi.y): `LightGpu.crop` of an uncropped grid.
const FULL_FACE: [f32; 4] = [-1.0, -1.0, 1.0, 1.0];

/// The NDC rectangle (lo.x, lo.y, hi.x, hi.y) over which `photon_trace` spreads the N × N grid of
/// an orthographic (directional-light) face: the casters' bounding box as the face sees it, plus
/// one cell of the cropped grid and one caster-buffer texel (G) on each side, clamped to the
/// face. The whole face when there are no casters or the box reaches behind the view. Each
/// photon's flux is E × its (smaller) cell's area, so the total follows; the shadow, receiver and
/// caustic maps stay on the whole face.
fn photon_crop(scene: &Scene, face: &crate::lightspace::LightFace, n: u32, g: u32) -> [f32; 4] {
    let CasterBox::Ndc(a, b) = caster_box(scene, face) else { return FULL_FACE };
    let margin = (b - a) / n.saturating_sub(2).max(1) as f32 + glam::Vec2::splat(2.0 / g as f32);
    let (a, b) = ((a - margin).max(glam::Vec2::splat(-1.0)), (b + margin).min(glam::Vec2::splat(1.0)));
    if b.x <= a.x || b.y <= a.y {
        return FULL_FACE;
    }
    [a.x, a.y, b.x, b.y]
}

/// An upper bound of the relevant photons (cells of the N × N grid whose caster-buffer texel
/// holds a caster) of one face: the cells within one texel of the casters' bounding box as the
/// face sees it (the whole face when the box reaches behind the light).
fn relevant_bound(scene: &Scene, face: &crate::lightspace::LightFace, n: u32, g: u32) -> u64 {
    let all = (n as u64).pow(2);
    let (a, b) = match caster_box(scene, face) {
        CasterBox::NoCasters => return 0,
        CasterBox::Behind => return all,
        CasterBox::Ndc(a, b) => (a, b),
    };
    let margin = 2.0 * (n / g) as f64 + 2.0;
    let side = |lo: f32, hi: f32| {
        let (lo, hi) = (lo.clamp(-1.0, 1.0) as f64, hi.clamp(-1.0, 1.0) as f64);
        ((hi - lo) * 0.5 * n as f64 + margin).min(n as f64)
    };
    ((side(a.x, b.x) * side(a.y, b.y)).ceil() as u64).min(all)
}

/// A light's view, its uniform record and the fixed-point scale of its flux sums.
pub(crate) fn light_record(
    scene: &Scene,
    light: &Light,
    s: &RenderSettings,
    fc: &FrameConsts,
) -> (LightView, LightGpu, f64) {
    let view = s.light_view(scene, light);
    let scale = (1u64 << 52) as f64 / flux_bound(&view, light);
    // A directional light's view covers the whole scene: the basic technique's dense grid is
    // spread over the casters only. The hierarchical technique keeps the whole face (its tiles
    // follow a coverage mip of the full grid, and its statistics and batch plan count whole-face
    // cells); the adaptive techniques and beams trace their own grids (not photon_trace).
    // Spot and point lights keep the whole face (their views already frame the light's cone or
    // cube).
    let crop = match light {
        Light::Directional { .. } if s.photons.emission == Emission::Basic => {
            photon_crop(scene, &view.faces[0], fc.n, fc.g)
        }
        _ => FULL_FACE,
    };
    let medium = scene.medium.as_ref();
    let lg = light_gpu(&view, light, s, fc, scale, crop, medium);
    (view, lg, scale)
}

/// Everything one light does in a frame: the light-space buffers of every face, the technique's
/// photon stage, `caustic_resolve`, the temporal filter, and the copy of the map into a texture.
/// One light of the frame as `record_light` takes it: its index, view, uniform record and the
/// fixed-point scale of its flux sums (`light_record`).
pub(crate) struct LightJob<'a> {
    pub index: usize,
    pub view: &'a LightView,
    pub record: &'a LightGpu,
    pub scale: f64,
}

pub(crate) fn record_light(
    f: &mut crate::frame::Frame,
    stages: &crate::techniques::Stages,
    inspect: crate::settings::Inspect,
    job: LightJob,
    temporal: Option<&mut crate::temporal::TemporalFilter>,
) -> Result<(LightFrame, crate::techniques::Pending)> {
    let (dc, s, fc) = (&f.dc, f.s, f.fc);
    let (enc, timer) = (&mut *f.enc, &mut *f.timer);
    let raster = &super::raster_pipelines(dc.ctx);
    let LightJob { index: li, view, record: lg, scale } = job;
    let (ctx, scene) = (dc.ctx, dc.scene);
    let (n, g, m) = (fc.n, fc.g, fc.m);
    let nf = view.faces.len() as u32;
    // The faces that emit photons and have caster buffers: all but a spill face, which only
    // receives (shadow, receiver and caustic maps).
    let ne = view.emit_faces as u32;
    let light_buf = ctx.uniform("light", bytemuck::bytes_of(lg));
    let shadow = texture(ctx, "light_shadow", s.shading.shadow_map_size, s.shading.shadow_map_size, nf, DEPTH_FORMAT);
    let recv = GBuffer::new(ctx, "light_receivers", m, m, nf);
    let front = GBuffer::new(ctx, "light_caster_front", g, g, ne);
    let back = GBuffer::new(ctx, "light_caster_back", g, g, ne);
    let layer2_bufs = fc.layer2.then(|| {
        (GBuffer::new(ctx, "light_caster_front2", g, g, ne), GBuffer::new(ctx, "light_caster_back2", g, g, ne))
    });
    for (f, face) in view.faces.iter().enumerate() {
        let (f, clip) = (f as u32, face.world_to_clip);
        let draw = |subset| Draw { world_to_clip: clip, layer: f, subset };
        let shadow_pass =
            RasterPass { name: "light_shadow", pipeline: &raster.depth_only, color: None, depth: &shadow };
        dc.pass(enc, timer, shadow_pass, draw(Subset::All));
        dc.pass(enc, timer, RasterPass::gbuffer("light_receivers", &raster.none, &recv), draw(Subset::Diffuse));
        if f >= ne {
            continue;
        }
        for (name, pl, gb, subset) in [
            ("light_caster_front", &raster.none, &front, Subset::Casters),
            ("light_caster_back", &raster.back, &back, Subset::Casters),
        ] {
            dc.pass(enc, timer, RasterPass::gbuffer(name, pl, gb), draw(subset));
        }
        // The second caster layer: the casters again, with a per-object depth peel against
        // this face's first layer (two-sided front, back faces), as the camera's.
        if let Some((front2, back2)) = &layer2_bufs {
            let names = [("light_caster_front2", front2), ("light_caster_back2", back2)];
            dc.peel(enc, timer, raster, &front, draw(Subset::Casters), names);
        }
    }
    let texels = (m as u64) * (m as u64) * nf as u64;
    let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
    let accum = ctx.buffer("caustic_flux", texels * 24, usage);
    let irradiance = ctx.buffer("caustic_irradiance", texels * 16, usage);
    let stats = ctx.buffer("flux_stats", crate::output::FLUX_STATS_BYTES, usage);
    let splat_targets = crate::splat::SplatTargets::new(ctx, s.photons.splat, texels, nf);
    let [fpv, fnv, bpv, bnv, rpv, rnv] =
        [&front.pos, &front.nrm, &back.pos, &back.nrm, &recv.pos, &recv.nrm].map(|t| array_view(ctx, t));
    let l2v = layer2_bufs.as_ref().map(|(f2, b2)| [&f2.pos, &f2.nrm, &b2.pos, &b2.nrm].map(|t| array_view(ctx, t)));
    let layer2_views = match &l2v {
        Some(v) => [&v[0], &v[1], &v[2], &v[3]],
        None => [&fpv, &fnv, &bpv, &bnv],
    };
    let emit = crate::techniques::Emit {
        ctx,
        settings: s,
        inspect,
        stages,
        light_buf: &light_buf,
        front_pos: &fpv,
        front_nrm: &fnv,
        back_pos: &bpv,
        back_nrm: &bnv,
        layer2: layer2_views,
        recv_pos: &rpv,
        recv_nrm: &rnv,
        geo: dc.geo,
        stats: &stats,
        accum: &accum,
        splat_targets: &splat_targets,
        n,
        g,
        bound: view.faces[..view.emit_faces].iter().map(|f| relevant_bound(scene, f, n, g)).collect(),
        reflect_branch: fc.reflect_branch,
        internal_branch: fc.internal_branch,
        residual_branch: fc.residual_branch,
        // Caustic spheres' directional lights, and spot and point lights whose surface caustic
        // comes from their beams (`LocalSource::Beams`): their maps stay zero, so the
        // shading adds no photon caustic for them.
        skip_photons: (fc.caustic_spheres && matches!(scene.lights[li], Light::Directional { .. }))
            || s.surface_caustics_from_beams(&scene.lights[li]),
    };
    let pending = crate::techniques::emit(&emit, enc, timer, ne)?;
    splat_targets.finish(ctx, s.photons.splat, &light_buf, &accum, enc, timer);
    let rp = ctx.uniform("resolve_params", bytemuck::bytes_of(&CountParams { count: texels as u32, _pad: [0; 3] }));
    Pass::new(ctx, "caustic_resolve")
        .bind("light", &light_buf)
        .bind("rp", &rp)
        .bind("accum", &accum)
        .bind("recv_pos", &rpv)
        .bind("recv_nrm", &rnv)
        .bind("irradiance", &irradiance)
        .dispatch(enc, timer, [(texels as u32).div_ceil(256), 1, 1]);
    if let Some(t) = temporal {
        t.record(ctx, enc, Some(timer), li, crate::temporal::CausticMaps { buffer: &irradiance, size: m, faces: nf });
    }
    let (caustic_mask, shadow_tiles) =
        record_tiles(ctx, (m, s.shading.shadow_map_size, nf), &irradiance, &shadow, enc, timer);
    let irradiance_tex = ctx.texture(
        "caustic_irradiance",
        wgpu::Extent3d { width: m, height: m, depth_or_array_layers: nf },
        wgpu::TextureFormat::Rgba32Float,
        wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST | wgpu::TextureUsages::COPY_SRC,
    );
    enc.copy_buffer_to_texture(
        wgpu::TexelCopyBufferInfo {
            buffer: &irradiance,
            layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(m * 16), rows_per_image: Some(m) },
        },
        irradiance_tex.as_image_copy(),
        wgpu::Extent3d { width: m, height: m, depth_or_array_layers: nf },
    );
    let frame = LightFrame {
        light_buf,
        faces: nf,
        emit_faces: ne,
        scale,
        shadow,
        recv,
        casters: (front, back),
        casters2: layer2_bufs,
        accum,
        irradiance,
        stats,
        irradiance_tex,
        caustic_mask,
        shadow_tiles,
    };
    Ok((frame, pending))
}

/// `caustic_mask` and `shadow_tiles`: per tile of a light's finished caustic map, whether any
/// texel holds light, and per tile of its shadow map the depth range, so that `shade_receivers`
/// skips the lookups whose result they decide (made once per light's maps: a camera-only frame
/// does not redo them). `(m, shadow, faces)`: the two map sizes per face and the faces.
fn record_tiles(
    ctx: &GpuContext,
    (m, shadow_size, nf): (u32, u32, u32),
    irradiance: &wgpu::Buffer,
    shadow: &wgpu::Texture,
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) -> (wgpu::Buffer, wgpu::Buffer) {
    let ct = m.div_ceil(SHADE_TILE);
    let st = shadow_size.div_ceil(SHADE_TILE);
    let mask = ctx.buffer("caustic_mask", (ct * ct * nf) as u64 * 4, wgpu::BufferUsages::STORAGE);
    let tiles = ctx.buffer("shadow_tiles", (st * st * nf) as u64 * 8, wgpu::BufferUsages::STORAGE);
    let mp = ctx.uniform("mask_params", bytemuck::bytes_of(&TileParams { size: m, tiles: ct, faces: nf, _pad: 0 }));
    let tp = ctx
        .uniform("tile_params", bytemuck::bytes_of(&TileParams { size: shadow_size, tiles: st, faces: nf, _pad: 0 }));
    let shv = array_view(ctx, shadow);
    let mask_pass = Pass::new(ctx, "caustic_mask").bind("mp", &mp).bind("irradiance", irradiance).bind("mask", &mask);
    let tiles_pass = Pass::new(ctx, "shadow_tiles").bind("tp", &tp).bind("shadow_map", &shv).bind("tiles", &tiles);
    let (mask_pass, tiles_pass) = (mask_pass.group(), tiles_pass.group());
    mask_pass.dispatch(enc, timer, [ct.div_ceil(8), ct.div_ceil(8), nf]);
    tiles_pass.dispatch(enc, timer, [st.div_ceil(8), st.div_ceil(8), nf]);
    (mask, tiles)
}

/// The flux bookkeeping from a light's `flux_stats` words (fixed point, `scale` per watt).
pub(crate) fn flux_stats(words: &[u8], scale: f64) -> FluxStats {
    let sw: Vec<u32> = words.chunks_exact(4).map(|c| u32::from_le_bytes(c.try_into().unwrap())).collect();
    let v = |i: usize| ((sw[i + 1] as u64) << 32 | sw[i] as u64) as f64 / scale;
    FluxStats {
        emitted: v(0),
        landed: v(2),
        lost_no_exit: v(4),
        lost_tir: v(6),
        lost_no_receiver: v(8),
        lost_outside: v(10),
        untraced_branches: v(14),
        stack_overflows: u64::from(sw[12]),
    }
}
