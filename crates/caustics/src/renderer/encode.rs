//! [`Renderer::encode`]: recording one frame: the scene's GPU resources brought up to date, then
//! the features in their fixed order ([`crate::frame`]), then the statistics' copies.

use super::{FrameOutputs, FrameRequest, LightOutputs, Renderer};
use crate::error::Result;
use crate::frame::{EnvFrame, Frame, StatsCopies};
use crate::gpu::PassTimer;
use crate::passes::FrameConsts;
use crate::scene::Scene;

impl Renderer {
    /// Record a frame into `encoder` (module documentation: what is redone, call order).
    pub fn encode(&mut self, encoder: &mut wgpu::CommandEncoder, request: FrameRequest) -> Result<FrameOutputs<'_>> {
        self.features.spheres.check(self.settings.caustic_spheres())?;
        let (refits, deformed) = self.update_geometry();
        match self.record_frame(encoder, request, &refits) {
            Ok(redone) => Ok(self.frame_outputs(&redone)),
            Err(e) => {
                // An encoder whose frame failed is not submitted: the next frame refits the
                // deformed meshes again (the same work: the CPU's refit gives the same boxes).
                for o in deformed {
                    if !self.deformed.contains(&o) {
                        self.deformed.push(o);
                    }
                }
                Err(e)
            }
        }
    }

    /// [`Renderer::encode`] after the geometry's update (`refits`: the BVH instances to refit on
    /// the GPU): the frame's passes; per light, whether it was redone.
    fn record_frame(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        request: FrameRequest,
        refits: &[usize],
    ) -> Result<Vec<bool>> {
        let ctx = self.ctx.clone();
        // The scene as drawn: its lights, then the environment's directional lights.
        let scene = Scene { lights: self.lights_now(), ..self.scene.clone() };
        self.prepare_spheres(&scene)?;
        let fc = FrameConsts::new(&scene, &self.settings);
        let env = self.env_frame(scene.lights.len());
        let mut timer = self.frame_timer(encoder);
        let geo = &self.geometry.as_ref().expect("uploaded").1;
        geo.record_refits(&ctx, refits, encoder, &mut timer);
        let mut f = Frame {
            dc: crate::passes::DrawCtx { ctx: &ctx, geo, scene: &scene },
            s: &self.settings,
            fc: &fc,
            env: &env,
            transforms: &self.transforms,
            enc: encoder,
            timer: &mut timer,
            eye: None,
            lights: Vec::new(),
            redone: Vec::new(),
            images: None,
            display: None,
            stats: StatsCopies::default(),
            products: Default::default(),
        };
        for feature in self.features.surfaces() {
            feature.record(&mut f)?;
        }
        ctx.begin_scope("composite", f.enc);
        for feature in self.features.along_rays() {
            feature.record_along_rays(&mut f)?;
        }
        ctx.end_scope();
        let (images, display) = (f.images.take().expect("composited"), f.display.take().expect("displayed"));
        let (stats, redone) = (std::mem::take(&mut f.stats), std::mem::take(&mut f.redone));
        let pendings = f.products.take().unwrap_or_default();
        if request.stats {
            self.copy_stats(encoder, &mut timer, (stats, pendings), redone.clone());
        }
        self.outputs = Some((images.full, images.caustic, display));
        self.frame += 1;
        Ok(redone)
    }

    /// The frame's pass timer (its query set and buffers in the `frame` scope).
    fn frame_timer(&self, encoder: &mut wgpu::CommandEncoder) -> PassTimer {
        self.ctx.begin_scope("frame", encoder);
        let timer = PassTimer::new(&self.ctx, 2048);
        self.ctx.end_scope();
        timer
    }

    /// Caustic spheres: the frame's lights and whether it computes the environment's visibility
    /// again, for the feature.
    fn prepare_spheres(&mut self, scene: &Scene) -> Result<()> {
        if self.settings.caustic_spheres() {
            self.features.spheres.next = Some((self.sphere_lights(&scene.lights), self.sphere_visibility_update()?));
        }
        Ok(())
    }

    /// The scene's GPU resources: uploaded once (again when the tessellation changes, which
    /// forgets every light's maps); moved objects rewrite their transforms and analytic shapes;
    /// deformed meshes rewrite their vertices and BVH triangles and refit the BVH on the CPU.
    /// Returns the BVH instances whose nodes the frame refits on the GPU
    /// (`Geometry::record_refits`, once the frame's timer is made) and the deformed objects.
    fn update_geometry(&mut self) -> (Vec<usize>, Vec<usize>) {
        let tessellation = self.settings.shading.tessellation;
        if self.geometry.as_ref().is_none_or(|(t, _)| *t != tessellation) {
            self.ctx.drop_scopes("");
            // Built from the meshes as they are now: nothing to refit.
            self.deformed.clear();
            self.geometry = Some((tessellation, crate::passes::upload_geometry(&self.ctx, &self.base, &tessellation)));
            self.objects_dirty = true;
            self.features.photon_maps.forget();
        }
        let geo = &mut self.geometry.as_mut().expect("uploaded").1;
        let mut refits = Vec::new();
        let deformed = std::mem::take(&mut self.deformed);
        for &object in &deformed {
            let crate::scene::Shape::Mesh(m) = &self.base.objects[object].shape else { continue };
            refits.extend(geo.refit_mesh(&self.ctx, object, m));
            self.objects_dirty = true;
        }
        if self.objects_dirty {
            let t: Vec<_> = self.transforms.iter().map(crate::passes::object_transform).collect();
            self.ctx.queue.write_buffer(&geo.transforms, 0, bytemuck::cast_slice(&t));
            geo.write_instances(&self.ctx, &self.transforms);
            let m = crate::passes::material_records(&self.scene);
            self.ctx.queue.write_buffer(&geo.materials, 0, bytemuck::cast_slice(&m));
            self.objects_dirty = false;
        }
        (refits, deformed)
    }

    /// The environment as this frame's features see it (`lights`: the frame's light count).
    fn env_frame(&self, lights: usize) -> EnvFrame {
        EnvFrame { own_lights: self.scene.lights.len(), shade_taps: self.shade_taps(lights) }
    }

    /// What the last frame made, for the caller.
    fn frame_outputs(&self, redone: &[bool]) -> FrameOutputs<'_> {
        let (radiance, caustic_radiance, display) = self.outputs.as_ref().expect("a frame was recorded");
        let maps = &self.features.photon_maps;
        let lights = (0..redone.len()).map(|li| {
            let f = maps.frame(li).expect("every light recorded");
            LightOutputs {
                irradiance: &f.irradiance_tex,
                receiver_position: &f.recv.pos,
                receiver_normal: &f.recv.nrm,
                redone: redone[li],
            }
        });
        FrameOutputs { display, radiance, caustic_radiance, lights: lights.collect() }
    }
}
