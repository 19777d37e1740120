//! [`Renderer::encode`]: recording one frame (what is redone, the passes in order, and the copy
//! of the statistics into the ring).

use super::stats::{StatsJob, free_slot};
use super::{FrameOutputs, FrameRequest, LightOutputs, LightState, Renderer};
use crate::caustic_spheres::frame::SphereInputs;
use crate::error::{Error, Result};
use crate::gpu::PassTimer;
use crate::passes::{DrawCtx, EyeFrame, FrameConsts, LightFrame};
use crate::scene::Scene;
use std::sync::atomic::Ordering;

impl Renderer {
    /// Record a frame into `encoder` (module documentation: what is redone, call order).
    pub fn encode(&mut self, encoder: &mut wgpu::CommandEncoder, request: FrameRequest) -> Result<FrameOutputs<'_>> {
        let enc = encoder;
        let ctx = self.ctx.clone();
        let mut s = self.settings.clone();
        let spheres_on = s.photons.technique == crate::settings::Technique::CausticSpheres;
        // The scene as drawn: its lights, then the environment's directional lights.
        let full = Scene { lights: self.lights_now(), ..self.scene.clone() };
        if spheres_on && self.spheres.is_none() {
            return Err(Error::input(
                "<renderer>",
                "technique",
                "caustic-spheres needs the objects' tables first (Renderer::set_caustic_spheres)",
            ));
        }
        // Geometry: uploaded once (again when the tessellation changes); moved objects rewrite
        // their transforms and analytic shapes.
        if self.geometry.as_ref().is_none_or(|(t, _)| *t != s.shading.tessellation) {
            ctx.drop_scopes("");
            self.geometry = Some((
                s.shading.tessellation,
                crate::passes::upload_geometry(&ctx, &self.base, &s.shading.tessellation),
            ));
            self.objects_dirty = true;
            self.lights.iter_mut().for_each(|l| *l = None);
        }
        let geo = &self.geometry.as_ref().unwrap().1;
        if self.objects_dirty {
            let t: Vec<_> = self.transforms.iter().map(crate::passes::object_transform).collect();
            ctx.queue.write_buffer(&geo.transforms, 0, bytemuck::cast_slice(&t));
            geo.write_instances(&ctx, &self.transforms);
            let m = crate::passes::material_records(&self.scene);
            ctx.queue.write_buffer(&geo.materials, 0, bytemuck::cast_slice(&m));
            self.objects_dirty = false;
        }
        let scene = &full;
        let fc = FrameConsts::new(scene, &s);
        // The lights' caustic maps (spot and point lights under caustic spheres) use the
        // emission technique; `fc` keeps which directional lights skip their photons.
        s.photons.technique = s.photons.technique.emission();
        let raster = crate::passes::raster_pipelines(&ctx);
        let dc = DrawCtx { ctx: &ctx, geo, scene };

        ctx.begin_scope("frame", enc);
        let mut timer = PassTimer::new(&ctx, 2048);
        ctx.end_scope();

        ctx.begin_scope("eye", enc);
        let eye: EyeFrame = crate::passes::record_eye(&dc, &raster, enc, &mut timer);
        ctx.end_scope();

        // The lights: redone when dirty or when their uniform record changed (a moved object
        // changes the views' bounds or the casters' extent).
        if self.lights.len() != scene.lights.len() {
            self.lights.resize_with(scene.lights.len(), || None);
            self.light_dirty.resize(scene.lights.len(), true);
        }
        let mut stages = None;
        let mut pendings = Vec::new();
        let mut redone = vec![false; scene.lights.len()];
        for (li, light) in scene.lights.iter().enumerate() {
            let (view, record, scale) = crate::passes::light_record(scene, light, &s, &fc);
            let same = self.lights[li]
                .as_ref()
                .is_some_and(|st| bytemuck::bytes_of(&st.record) == bytemuck::bytes_of(&record));
            if same && !self.light_dirty[li] {
                continue;
            }
            let pl = stages.get_or_insert_with(|| {
                crate::techniques::Stages::new(
                    &s,
                    fc.layer2,
                    [fc.reflect_branch, fc.internal_branch, fc.residual_branch],
                )
            });
            ctx.begin_scope(&format!("light{li}"), enc);
            let out = crate::passes::record_light(
                &dc,
                &raster,
                pl,
                (&s, self.inspect),
                &fc,
                (li, &view, &record, scale),
                self.temporal.as_mut(),
                enc,
                &mut timer,
            );
            ctx.end_scope();
            let (frame, pending) = out?;
            self.lights[li] = Some(LightState { record, frame });
            self.light_dirty[li] = false;
            redone[li] = true;
            pendings.push(pending);
        }
        let light_frames: Vec<&LightFrame> = self.lights.iter().map(|l| &l.as_ref().unwrap().frame).collect();

        let taps = self.shade_taps(light_frames.len());
        for (li, lf) in light_frames.iter().enumerate() {
            ctx.begin_scope(&format!("shade{li}"), enc);
            crate::passes::record_shade(&dc, &eye, lf, &s, &taps[li], enc, &mut timer);
            ctx.end_scope();
        }
        // Light between the surfaces and the medium (scenes with one): the lights' VPLs are
        // made again when a light's maps were (every change that moves them redoes the lights:
        // the medium, materials, settings, objects the light sees); a frame that only moves the
        // camera keeps them, and their scope is not begun, so its buffers are not cleared.
        if redone.iter().any(|&r| r) || self.bounce.is_none() {
            ctx.begin_scope("medium_bounce_lights", enc);
            self.bounce = crate::medium_bounce::record_lights(&dc, &light_frames, &s, enc, &mut timer);
            ctx.end_scope();
        }
        let bounce = self.bounce.as_ref();
        // Caustic spheres (their own scope): the records, weighted on the GPU by the
        // environment's visibility from each object, then `sphere_gather`.
        let mut spheres = None;
        if spheres_on && let Some(sp) = &self.spheres {
            ctx.begin_scope("spheres", enc);
            let (lights, vis) = (self.sphere_lights(&scene.lights), self.sphere_visibility_update()?);
            let own = self.scene.lights.len();
            let inputs = SphereInputs { lights: &lights, own, transforms: &self.transforms, blend: self.sphere_blend };
            let state = (&mut self.sphere_vis, vis);
            spheres = Some(crate::caustic_spheres::frame::record(&dc, &eye, sp, state, inputs, enc, &mut timer));
            ctx.end_scope();
        }
        let sphere_stats = spheres.as_ref().map(|f| f.stats.clone());
        // The beams (volume caustics, and with `SurfaceCaustics::Beams` the surface caustic,
        // added to the eye's accumulators before the composite shows them through glass).
        ctx.begin_scope("beams", enc);
        let beams = crate::beams::record_beams(&dc, &eye, &light_frames, &s, self.count_fragments, enc, &mut timer);
        ctx.end_scope();
        // The surfaces lit by the shafts' and the beams' light in the medium (before `composite`,
        // which shows them through glass).
        ctx.begin_scope("medium_bounce", enc);
        let mut beam_emitters = crate::medium_bounce::BeamEmitters::default();
        if let Some(bf) = bounce {
            beam_emitters = crate::medium_bounce::record_beam_emitters(&dc, &beams, &light_frames, &s, enc, &mut timer);
            let emitters = [&beam_emitters.scatter[..], &beam_emitters.landing_glow[..]].concat();
            crate::medium_bounce::record_surfaces(&dc, &eye, bf, &emitters, enc, &mut timer);
        }
        ctx.end_scope();
        ctx.begin_scope("composite", enc);
        let composited = crate::passes::record_composite(&dc, &eye, &light_frames, &s, enc, &mut timer);
        let crate::passes::Composited { full, caustic, segments: eye_segments } = composited;
        if let Some(bf) = bounce {
            let landing = &beam_emitters.landing;
            crate::medium_bounce::record(&dc, &eye, bf, &s, (&full, &caustic), &eye_segments, landing, enc, &mut timer);
        }
        crate::beams::record_gather(&dc, &eye, &beams, &s, (&full, &caustic), &eye_segments, enc, &mut timer);
        if let Some(f) = &spheres {
            f.record_volume(&dc, &eye, s.medium.steps, (&full, &caustic), enc, &mut timer);
        }
        let display = crate::passes::record_display(&dc, &full, enc, &mut timer);
        self.outputs = Some((full, caustic, display));
        self.beam_frames = beams;
        ctx.end_scope();

        if request.stats {
            ctx.begin_scope("stats", enc);
            let timestamps = timer.resolve(&ctx, enc);
            ctx.end_scope();
            let mut sources: Vec<(wgpu::Buffer, u64)> = Vec::new();
            let timer_job = timestamps.map(|(b, size)| {
                sources.push((b, size));
                (timer.names().to_vec(), 0, size)
            });
            for lf in &light_frames {
                sources.push((lf.stats.clone(), crate::output::FLUX_STATS_BYTES));
            }
            let piece_lists: Vec<Vec<(wgpu::Buffer, u64)>> = pendings.iter().map(|p| p.sources()).collect();
            for list in &piece_lists {
                sources.extend(list.iter().cloned());
            }
            if let Some(b) = &sphere_stats {
                sources.push((b.clone(), 8));
            }
            // Offsets in the staging buffer (copies are 4-byte aligned; every size is).
            let mut offsets = Vec::with_capacity(sources.len());
            let mut total = 0u64;
            for (_, size) in &sources {
                offsets.push(total);
                total += size.div_ceil(8) * 8;
            }
            if let Some(slot) = free_slot(&mut self.ring, &ctx, total.max(8)) {
                let staging = &self.ring[slot].staging;
                for ((b, size), off) in sources.iter().zip(&offsets) {
                    if *size > 0 {
                        enc.copy_buffer_to_buffer(b, 0, staging, *off, *size);
                    }
                }
                let mut k = usize::from(timer_job.is_some());
                let timer_job = timer_job.map(|(names, _, size)| (names, offsets[0], size));
                let mut flux = Vec::new();
                for lf in &light_frames {
                    flux.push((offsets[k], lf.scale));
                    k += 1;
                }
                let mut pend = Vec::new();
                for (p, list) in pendings.into_iter().zip(&piece_lists) {
                    let pieces = list.iter().map(|(_, size)| {
                        let piece = (offsets[k], *size);
                        k += 1;
                        piece
                    });
                    pend.push((p, pieces.collect()));
                }
                self.ring[slot].job = Some(StatsJob {
                    frame: self.frame,
                    timer: timer_job,
                    flux,
                    pendings: pend,
                    lights_redone: redone.clone(),
                    sphere_stats: sphere_stats.as_ref().map(|_| offsets[k]),
                });
                self.ring[slot].state.store(1, Ordering::Release);
            }
        }
        self.frame += 1;
        let (radiance, caustic_radiance, display) = self.outputs.as_ref().unwrap();
        Ok(FrameOutputs {
            display,
            radiance,
            caustic_radiance,
            lights: self
                .lights
                .iter()
                .zip(&redone)
                .map(|(l, redone)| {
                    let f = &l.as_ref().unwrap().frame;
                    LightOutputs {
                        irradiance: &f.irradiance_tex,
                        receiver_position: &f.recv.pos,
                        receiver_normal: &f.recv.nrm,
                        redone: *redone,
                    }
                })
                .collect(),
        })
    }
}
