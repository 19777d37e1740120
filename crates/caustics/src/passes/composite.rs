//! After shading: `composite` (image-space refraction and reflection), the medium's stages
//! (`medium_scatter`) and `display`.

use super::eye::shadow_sampler;
use super::raster::has_specular_meshes;
use super::{Composited, DrawCtx, EyeFrame, EyeSegments, LightFrame, array_view, layer_view};
use crate::error::Result;
use crate::frame::{Feature, Frame};
use crate::gpu::PassTimer;
use crate::gpu::pass::Pass;
use crate::gpu::types::*;
use crate::settings::RenderSettings;

/// `medium_scatter` (scenes with a medium; nothing is recorded or requested otherwise): two
/// dispatches per light (spot, point or directional) over the composited images. The first
/// light's attenuates both images by the transmittance along each pixel's camera ray to its
/// first surface; each adds its light's single scattering along that ray
/// (`RenderSettings::medium_steps` steps, shadowed by the light's shadow map) to the full
/// image; the second (`medium_segments`, over `composite`'s list of specular pixels) along the
/// segments the pixels' paths travel in the medium beyond their specular surfaces.
fn record_medium(
    dc: &DrawCtx,
    eye: &EyeFrame,
    lights: &[&LightFrame],
    s: &RenderSettings,
    out: &Composited,
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) {
    let segs = &out.segments;
    let Some(m) = &dc.scene.medium else { return };
    let ctx = dc.ctx;
    let cam = &dc.scene.camera;
    let (w, h) = (cam.width, cam.height);
    let shadow_sampler = shadow_sampler(ctx);
    let g = match m.phase {
        crate::scene::Phase::Isotropic => 0.0,
        crate::scene::Phase::HenyeyGreenstein { g } => g,
    };
    let scatters = m.sigma_s.max_element() > 0.0;
    let (rv, sv) = (layer_view(ctx, &eye.recv.pos, 0), layer_view(ctx, &eye.front.pos, 0));
    for (li, lf) in lights.iter().enumerate() {
        let flags = u32::from(li == 0) | (u32::from(scatters) << 1);
        let params = ctx.uniform(
            "medium_params",
            bytemuck::bytes_of(&MediumParams {
                clip_to_world: eye.cam_clip.inverse().to_cols_array_2d(),
                camera: cam.position.extend(1.0).to_array(),
                lo: m.bounds_min.extend(0.0).to_array(),
                hi: m.bounds_max.extend(0.0).to_array(),
                sigma_s: m.sigma_s.extend(g).to_array(),
                sigma_t: (m.sigma_s + m.sigma_a).extend(0.0).to_array(),
                width: w,
                height: h,
                steps: s.medium.steps,
                flags,
                shadow_size: s.shading.shadow_map_size,
                grid: u32::from(m.density.is_some()),
                light_steps: s.medium.light_steps,
                _pad: 0,
            }),
        );
        let shv = array_view(ctx, &lf.shadow);
        let pass = Pass::new(ctx, "medium_scatter")
            .constants(&[("medium_segments", 0.0)])
            .bind("light", &lf.light_buf)
            .bind("mp", &params)
            .bind("recv_pos", &rv)
            .bind("spec_pos", &sv)
            .bind("shadow_map", &shv)
            .bind("shadow_sampler", &shadow_sampler)
            .bind("out_full", &out.full)
            .bind("out_caustic", &out.caustic)
            .shared(&dc.geo.scene)
            .bind_all(segs.bindings())
            .group();
        pass.dispatch(enc, timer, [w.div_ceil(8), h.div_ceil(8), 1]);
        if scatters && segs.kept {
            // (one bind group for both variants)
            let segments = pass.variant("medium_scatter_segments", &[("medium_segments", 1.0)]);
            segments.dispatch_indirect(enc, timer, &segs.args, 0);
        }
    }
}

/// The closed dielectric object the camera is in (a camera under water), if any: a sphere by its
/// radius, a mesh by the parity of its surface crossings along three axes (the majority, so a
/// ray through an edge or a vertex does not decide alone), tested only inside the mesh's bounds.
/// Open shapes (cylinders, rectangles) have no inside.
pub(crate) fn camera_inside(scene: &crate::scene::Scene, p: glam::Vec3) -> Option<usize> {
    use crate::scene::{Material, Shape};
    scene.objects.iter().position(|o| {
        if !matches!(scene.material_of(o), Material::Dielectric { .. }) {
            return false;
        }
        match &o.shape {
            Shape::Sphere { center, radius } => p.distance(*center) < *radius,
            Shape::Mesh(m) => {
                let (lo, hi) = m.bounds();
                if !(p.cmpgt(lo).all() && p.cmplt(hi).all()) {
                    return false;
                }
                let odd = |d: glam::Vec3| {
                    let hits = m.indices.iter().filter(|t| {
                        let [a, b, c] = t.map(|i| m.positions[i as usize]);
                        crossing(p, d, a, b, c)
                    });
                    hits.count() % 2 == 1
                };
                [glam::Vec3::X, glam::Vec3::Y, glam::Vec3::Z].into_iter().filter(|d| odd(*d)).count() >= 2
            }
            _ => false,
        }
    })
}

/// Whether the ray `o + t d` (t > 0) crosses the triangle (a, b, c) (Möller–Trumbore).
fn crossing(o: glam::Vec3, d: glam::Vec3, a: glam::Vec3, b: glam::Vec3, c: glam::Vec3) -> bool {
    let (e1, e2) = (b - a, c - a);
    let q = d.cross(e2);
    let det = e1.dot(q);
    if det.abs() < 1e-20 {
        return false;
    }
    let s = (o - a) / det;
    let u = s.dot(q);
    let r = s.cross(e1);
    let v = d.dot(r);
    u >= 0.0 && v >= 0.0 && u + v <= 1.0 && e2.dot(r) > 0.0
}

/// `composite` (image-space refraction and reflection of the camera's specular surfaces) and the
/// medium (`medium_scatter`, scenes with one): (radiance image, caustic-only image). The
/// renderer adds the volume caustics (`crate::beams`), then [`record_display`].
pub(crate) fn record_composite(
    dc: &DrawCtx,
    eye: &EyeFrame,
    lights: &[&LightFrame],
    s: &RenderSettings,
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) -> Composited {
    let ctx = dc.ctx;
    let cam = &dc.scene.camera;
    let (w, h) = (cam.width, cam.height);
    let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
    let img_bytes = (w as u64) * (h as u64) * 16;
    let out_full = ctx.buffer("image", img_bytes, usage);
    let out_caustic = ctx.buffer("caustic_image", img_bytes, usage);
    // In a storage buffer, not a uniform: see `shaders/composite.wgsl` (lavapipe's inlining).
    let layer2 = has_specular_meshes(dc.scene);
    let kept = s.medium_segments_active(dc.scene);
    let medium = dc.scene.medium.as_ref().filter(|_| kept);
    let (medium_lo, medium_hi, medium_sigma_t) = match medium {
        Some(m) => (
            m.bounds_min.extend(0.0).to_array(),
            m.bounds_max.extend(f32::from(u8::from(m.density.is_some()))).to_array(),
            (m.sigma_s + m.sigma_a).extend(s.medium.steps as f32).to_array(),
        ),
        None => ([0.0; 4], [0.0; 4], [0.0; 4]),
    };
    let cpar = ctx.buffer_init(
        "composite_params",
        bytemuck::bytes_of(&CompositeParams {
            world_to_clip: eye.cam_clip.to_cols_array_2d(),
            clip_to_world: eye.cam_clip.inverse().to_cols_array_2d(),
            camera: cam.position.extend(1.0).to_array(),
            env_rotation: match &dc.scene.environment {
                Some(e) => [e.rotate_y.cos(), e.rotate_y.sin(), 1.0, 0.0],
                None => [1.0, 0.0, 0.0, 0.0],
            },
            width: w,
            height: h,
            layer2: layer2 as u32,
            camera_inside: camera_inside(dc.scene, cam.position).map_or(0, |o| o as u32 + 1),
            medium_lo,
            medium_hi,
            medium_sigma_t,
        }),
        wgpu::BufferUsages::STORAGE,
    );
    // The kept segments (a scene with a medium; else one unused slot).
    let seg_slots = if medium.is_some() { (w as u64) * (h as u64) * EYE_SEGMENTS } else { 1 };
    let segments = ctx.buffer(
        "composite_segments",
        seg_slots * std::mem::size_of::<EyeSegmentGpu>() as u64,
        wgpu::BufferUsages::STORAGE,
    );
    // The specular pixels listed by the first pass and the indirect dispatch of the second.
    let spec_list = ctx.buffer("composite_list", (w as u64) * (h as u64) * 4, wgpu::BufferUsages::STORAGE);
    let spec_count = ctx.buffer("composite_count", 16, wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC);
    // The second pass binds the count too, so it is dispatched from a copy.
    let spec_args = ctx.buffer("composite_args", 16, wgpu::BufferUsages::INDIRECT);
    let [recv_pos, recv_nrm, spec_pos, spec_nrm, back_pos, back_nrm, spec2_pos, spec2_nrm, back2_pos, back2_nrm] = [
        &eye.recv.pos,
        &eye.recv.nrm,
        &eye.front.pos,
        &eye.front.nrm,
        &eye.back.pos,
        &eye.back.nrm,
        &eye.front2.pos,
        &eye.front2.nrm,
        &eye.back2.pos,
        &eye.back2.nrm,
    ]
    .map(|t| layer_view(ctx, t, 0));
    let env = dc.scene.environment.is_some();
    let consts = |pass: u32| {
        [
            ("composite_pass", f64::from(pass)),
            ("composite_layer2", f64::from(u8::from(layer2))),
            ("composite_env", f64::from(u8::from(env))),
            ("composite_medium", f64::from(u8::from(medium.is_some()))),
        ]
    };
    let pass = Pass::new(ctx, "composite")
        .constants(&consts(0))
        .bind("cp_in", &cpar)
        .bind("recv_pos", &recv_pos)
        .bind("recv_nrm", &recv_nrm)
        .bind("spec_pos", &spec_pos)
        .bind("spec_nrm", &spec_nrm)
        .bind("back_pos", &back_pos)
        .bind("back_nrm", &back_nrm)
        .bind("spec2_pos", &spec2_pos)
        .bind("spec2_nrm", &spec2_nrm)
        .bind("back2_pos", &back2_pos)
        .bind("back2_nrm", &back2_nrm)
        .bind("radiance", &eye.radiance)
        .bind("caustic_in", &eye.caustic)
        .bind("out_full", &out_full)
        .bind("out_caustic", &out_caustic)
        .bind("spec_list", &spec_list)
        .bind("spec_count", &spec_count)
        .bind("segments", &segments)
        .shared(&dc.geo.scene)
        .group();
    pass.dispatch(enc, timer, [w.div_ceil(8), h.div_ceil(8), 1]);
    enc.copy_buffer_to_buffer(&spec_count, 0, &spec_args, 0, 16);
    pass.variant("composite_specular", &consts(1)).dispatch_indirect(enc, timer, &spec_args, 0);
    let segs = EyeSegments { kept, list: spec_list, count: spec_count, args: spec_args, segments };
    let out = Composited { full: out_full, caustic: out_caustic, segments: segs };
    record_medium(dc, eye, lights, s, &out, enc, timer);
    out
}

/// `display`: the radiance image `out_full` tone-mapped into an Rgba8Unorm texture.
pub(crate) fn record_display(
    dc: &DrawCtx,
    out_full: &wgpu::Buffer,
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) -> wgpu::Texture {
    let ctx = dc.ctx;
    let (w, h) = (dc.scene.camera.width, dc.scene.camera.height);
    let display = ctx.texture(
        "display",
        wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        wgpu::TextureFormat::Rgba8Unorm,
        wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_SRC,
    );
    let dv = ctx.view(&display, Some(wgpu::TextureViewDimension::D2), 0, Some(1));
    let dp = ctx.uniform(
        "display_params",
        bytemuck::bytes_of(&DisplayParams { width: w, height: h, exposure: dc.scene.exposure, _pad: 0 }),
    );
    Pass::new(ctx, "display").bind("dp", &dp).bind("radiance", out_full).bind("display", &dv).dispatch(
        enc,
        timer,
        [w.div_ceil(8), h.div_ceil(8), 1],
    );
    display
}

/// `composite` and the medium's single scattering: the frame's images ([`Frame::images`]),
/// first along the camera rays.
#[derive(Default)]
pub(crate) struct Composite;

impl Feature for Composite {
    fn record_along_rays(&mut self, f: &mut Frame) -> Result<()> {
        let lights = crate::frame::light_refs(&f.lights);
        f.images = Some(record_composite(&f.dc, crate::frame::eye(&f.eye), &lights, f.s, f.enc, f.timer));
        Ok(())
    }
}

/// `display`: the image tone-mapped ([`Frame::display`]), last.
#[derive(Default)]
pub(crate) struct Display;

impl Feature for Display {
    fn record_along_rays(&mut self, f: &mut Frame) -> Result<()> {
        let images = f.images.as_ref().expect("the composite runs before the display");
        f.display = Some(record_display(&f.dc, &images.full, f.enc, f.timer));
        Ok(())
    }
}
