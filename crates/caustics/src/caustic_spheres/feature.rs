//! The caustic spheres feature: with `sources.distant = spheres`, the caustics of every
//! directional light (the scene's and the environment's) from the objects' tables
//! ([`super::frame::record`]: the records weighted on the GPU by the environment's visibility
//! from each object, then `sphere_gather`), and in a medium their volume caustic along the camera
//! rays (`sphere_volume`).

use super::frame::{SphereFrame, SphereInputs};
use super::gpu::GpuSpheres;
use super::visibility::{VisibilityState, VisibilityUpdate};
use crate::error::{Error, Result};
use crate::frame::{Feature, Frame, eye};
use crate::scene::Light;

/// The tables on the GPU and what a frame made of them.
pub(crate) struct SpheresFeature {
    /// The tables (`Renderer::set_caustic_spheres`).
    pub spheres: Option<GpuSpheres>,
    pub blend: super::Blend,
    /// The environment regions' visibility per object on the GPU, and what it was computed for.
    pub visibility: Option<VisibilityState>,
    /// The next frame's lights (the environment's regions spread over their sub-directions) and
    /// whether its visibility is computed again (`Renderer::encode` sets them).
    pub next: Option<(Vec<Light>, VisibilityUpdate)>,
    /// The frame's records, read again by `sphere_volume`.
    frame: Option<SphereFrame>,
}

impl Default for SpheresFeature {
    fn default() -> Self {
        SpheresFeature { spheres: None, blend: super::Blend::Triangle, visibility: None, next: None, frame: None }
    }
}

impl SpheresFeature {
    /// An error when the settings ask for caustic spheres and no tables were given.
    pub fn check(&self, on: bool) -> Result<()> {
        if on && self.spheres.is_none() {
            return Err(Error::input(
                "<renderer>",
                "sources.distant",
                "caustic spheres need the objects' tables first (Renderer::set_caustic_spheres)",
            ));
        }
        Ok(())
    }
}

impl Feature for SpheresFeature {
    fn record(&mut self, f: &mut Frame) -> Result<()> {
        self.frame = None;
        let next = self.next.take();
        let (Some(sp), Some((lights, update))) = (self.spheres.as_ref().filter(|_| f.fc.caustic_spheres), next) else {
            return Ok(());
        };
        f.dc.ctx.begin_scope("spheres", f.enc);
        let inputs =
            SphereInputs { lights: &lights, own: f.env.own_lights, transforms: f.transforms, blend: self.blend };
        let state = (&mut self.visibility, update);
        let frame = super::frame::record(&f.dc, eye(&f.eye), sp, state, inputs, f.enc, f.timer);
        f.dc.ctx.end_scope();
        f.stats.spheres = Some(frame.stats.clone());
        self.frame = Some(frame);
        Ok(())
    }

    fn record_along_rays(&mut self, f: &mut Frame) -> Result<()> {
        if let Some(frame) = &self.frame {
            let images = f.images.as_ref().expect("the composite runs first");
            let targets = (&images.full, &images.caustic);
            frame.record_volume(&f.dc, eye(&f.eye), f.s.medium.steps, targets, f.enc, f.timer);
        }
        Ok(())
    }
}
