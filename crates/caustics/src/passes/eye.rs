//! The camera's passes: its geometry buffers (`record_eye`) and the shading of its diffuse
//! surfaces per light (`record_shade`).

use super::raster::{Draw, Raster, RasterPass, Subset, has_specular_meshes};
use super::{DrawCtx, EyeFrame, GBuffer, LightFrame, array_view, layer_view};
use crate::error::Result;
use crate::frame::{Feature, Frame};
use crate::gpu::pass::Pass;
use crate::gpu::types::*;
use crate::gpu::{GpuContext, PassTimer};
use crate::settings::RenderSettings;

/// The camera's passes: `eye_receivers`, `eye_specular_front`, `eye_specular_back` and the
/// second specular layer.
pub(crate) fn record_eye(
    dc: &DrawCtx,
    raster: &Raster,
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) -> EyeFrame {
    let (ctx, scene) = (dc.ctx, dc.scene);
    let cam = &scene.camera;
    let (lo, hi) = scene.bounds();
    let far = (cam.position.distance((lo + hi) * 0.5) + (hi - lo).length() * 0.5) * 1.05;
    let near = crate::lightspace::near_plane(far);
    let cam_clip = cam.view_to_clip(near, far) * cam.world_to_view();
    let (w, h) = (cam.width, cam.height);
    let recv = GBuffer::new(ctx, "eye_receivers", w, h, 1);
    let front = GBuffer::new(ctx, "eye_specular_front", w, h, 1);
    let back = GBuffer::new(ctx, "eye_specular_back", w, h, 1);
    for (name, pl, gb, subset) in [
        ("eye_receivers", &raster.none, &recv, Subset::Diffuse),
        ("eye_specular_front", &raster.none, &front, Subset::Specular),
        ("eye_specular_back", &raster.back, &back, Subset::Specular),
    ] {
        dc.pass(enc, timer, RasterPass::gbuffer(name, pl, gb), Draw { world_to_clip: cam_clip, layer: 0, subset });
    }
    // The second specular layer (meshes behind the first layer's object), front and back; not
    // drawn in scenes without specular meshes, where `composite` does not read it.
    let front2 = GBuffer::new(ctx, "eye_specular_front2", w, h, 1);
    let back2 = GBuffer::new(ctx, "eye_specular_back2", w, h, 1);
    if has_specular_meshes(scene) {
        let draw = Draw { world_to_clip: cam_clip, layer: 0, subset: Subset::SpecularMeshes };
        dc.peel(enc, timer, raster, &front, draw, [("eye_specular_front2", &front2), ("eye_specular_back2", &back2)]);
    }
    let img_bytes = (w as u64) * (h as u64) * 16;
    let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
    EyeFrame {
        recv,
        front,
        back,
        front2,
        back2,
        cam_clip,
        radiance: ctx.buffer("radiance", img_bytes, usage),
        caustic: ctx.buffer("caustic_radiance", img_bytes, usage),
    }
}

/// The shadow maps' comparison sampler (bilinear percentage-closer lookups), shared by the
/// shading and the medium passes.
pub(crate) fn shadow_sampler(ctx: &GpuContext) -> wgpu::Sampler {
    ctx.sampler(
        "shadow",
        &wgpu::SamplerDescriptor {
            label: Some("shadow"),
            compare: Some(wgpu::CompareFunction::LessEqual),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            address_mode_u: wgpu::AddressMode::ClampToEdge,
            address_mode_v: wgpu::AddressMode::ClampToEdge,
            ..Default::default()
        },
    )
}

/// `shade_receivers`: the camera's diffuse surfaces lit by one light (added into the eye's
/// radiance accumulators).
pub(crate) fn record_shade(
    dc: &DrawCtx,
    eye: &EyeFrame,
    lf: &LightFrame,
    s: &RenderSettings,
    taps: &crate::gpu::types::EnvTapsGpu,
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) {
    let ctx = dc.ctx;
    let cam = &dc.scene.camera;
    let (w, h) = (cam.width, cam.height);
    let shadow_sampler = shadow_sampler(ctx);
    let shp = ctx.uniform(
        "shade_params",
        bytemuck::bytes_of(&ShadeParams {
            width: w,
            height: h,
            shadow_size: s.shading.shadow_map_size,
            tiles: s.testing.shading_tiles as u32,
            camera: cam.position.extend(1.0).to_array(),
            medium_lo: dc.scene.medium.as_ref().map_or([0.0; 4], |m| m.bounds_min.extend(1.0).to_array()),
            medium_hi: dc.scene.medium.as_ref().map_or([0.0; 4], |m| m.bounds_max.extend(1.0).to_array()),
            sigma_t: dc.scene.medium.as_ref().map_or([0.0; 4], |m| (m.sigma_s + m.sigma_a).extend(0.0).to_array()),
            medium_grid: match dc.scene.medium.as_ref().and_then(|m| m.density.as_ref()) {
                Some(_) => [1, s.medium.light_steps, 0, 0],
                None => [0; 4],
            },
        }),
    );
    let tapb = ctx.uniform("env_taps", bytemuck::bytes_of(taps));
    let (erp, ern) = (layer_view(ctx, &eye.recv.pos, 0), layer_view(ctx, &eye.recv.nrm, 0));
    let (shv, rpv) = (array_view(ctx, &lf.shadow), array_view(ctx, &lf.recv.pos));
    Pass::new(ctx, "shade_receivers")
        .bind("light", &lf.light_buf)
        .bind("sp", &shp)
        .bind("eye_pos", &erp)
        .bind("eye_nrm", &ern)
        .bind("shadow_map", &shv)
        .bind("shadow_sampler", &shadow_sampler)
        .bind("recv_pos", &rpv)
        .bind("irradiance", &lf.irradiance)
        .bind("radiance", &eye.radiance)
        .bind("caustic", &eye.caustic)
        .shared(&dc.geo.scene)
        .bind("taps", &tapb)
        .bind("caustic_mask", &lf.caustic_mask)
        .bind("shadow_tiles", &lf.shadow_tiles)
        .dispatch(enc, timer, [w.div_ceil(8), h.div_ceil(8), 1]);
}

/// The camera's geometry buffers and accumulators (`record_eye`), first in the frame.
#[derive(Default)]
pub(crate) struct Camera;

impl Feature for Camera {
    fn record(&mut self, f: &mut Frame) -> Result<()> {
        f.dc.ctx.begin_scope("eye", f.enc);
        f.eye = Some(record_eye(&f.dc, &super::raster_pipelines(f.dc.ctx), f.enc, f.timer));
        f.dc.ctx.end_scope();
        Ok(())
    }
}

/// The camera's diffuse surfaces lit by every light (`record_shade`, one scope per light).
#[derive(Default)]
pub(crate) struct Shading;

impl Feature for Shading {
    fn record(&mut self, f: &mut Frame) -> Result<()> {
        let eye = crate::frame::eye(&f.eye);
        for (li, lf) in f.lights.iter().enumerate() {
            f.dc.ctx.begin_scope(&format!("shade{li}"), f.enc);
            record_shade(&f.dc, eye, lf, f.s, &f.env.shade_taps[li], f.enc, f.timer);
            f.dc.ctx.end_scope();
        }
        Ok(())
    }
}
