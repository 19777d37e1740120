//! The beams feature: adaptive beam tracing for the spot and point lights (`record_beams`:
//! their surface caustic before the composite), and their volume caustic along the camera
//! rays after it (`record_gather`).

use crate::error::Result;
use crate::frame::{Feature, Frame, eye, light_refs};

/// The beams of the last frame (kept for the statistics read-back).
#[derive(Default)]
pub(crate) struct Beams {
    /// Count the beam hulls' fragments (`Renderer::render_once`, which reads them).
    pub count_fragments: bool,
    pub frames: Vec<super::BeamFrame>,
}

impl Feature for Beams {
    fn record(&mut self, f: &mut Frame) -> Result<()> {
        f.dc.ctx.begin_scope("beams", f.enc);
        let lights = light_refs(&f.lights);
        let beams = super::record_beams(&f.dc, eye(&f.eye), &lights, f.s, self.count_fragments, f.enc, f.timer);
        f.products.put(beams);
        f.dc.ctx.end_scope();
        Ok(())
    }

    fn record_along_rays(&mut self, f: &mut Frame) -> Result<()> {
        let images = f.images.as_ref().expect("the composite runs first");
        let beams: Vec<super::BeamFrame> = f.products.take().unwrap_or_default();
        super::record_gather(&f.dc, eye(&f.eye), &beams, f.s, images, f.enc, f.timer);
        self.frames = beams;
        Ok(())
    }
}
