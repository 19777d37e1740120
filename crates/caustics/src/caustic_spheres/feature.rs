//! The caustic spheres feature: with `sources.distant = spheres`, the caustics of every
//! directional light (the scene's and the environment's) from the objects' tables, looked up per
//! camera pixel (`sphere_gather`, or `sphere_compile` first), and in a medium their volume
//! caustic along the camera rays (`sphere_volume`).

use super::gpu::{GpuSpheres, record_compile, record_gather, record_volume};
use crate::error::{Error, Result};
use crate::frame::{Feature, Frame};
use crate::gpu::types::SphereRecord;
use crate::scene::environment_lights;
use std::sync::Arc;

/// Per caustic-sphere object, the visibility of each drawn environment light.
pub(crate) type SphereVisibility = std::collections::HashMap<usize, Vec<f32>>;

/// The tables on the GPU and what a frame made of them.
pub(crate) struct SpheresFeature {
    /// The tables (`Renderer::set_caustic_spheres`).
    pub spheres: Option<GpuSpheres>,
    pub blend: super::Blend,
    /// The environment regions' visibility per object, and what it was computed for.
    pub visibility: Option<(Vec<u32>, Arc<SphereVisibility>)>,
    /// The frame's direct records (read again by `sphere_volume`).
    records: Vec<SphereRecord>,
}

impl Default for SpheresFeature {
    fn default() -> Self {
        SpheresFeature { spheres: None, blend: super::Blend::Triangle, visibility: None, records: Vec::new() }
    }
}

impl SpheresFeature {
    /// An error when the settings ask for caustic spheres and no tables were given.
    pub fn check(&self, on: bool) -> Result<()> {
        if on && self.spheres.is_none() {
            return Err(Error::input(
                "<renderer>",
                "technique",
                "caustic-spheres needs the objects' tables first (Renderer::set_caustic_spheres)",
            ));
        }
        Ok(())
    }
}

impl Feature for SpheresFeature {
    fn record(&mut self, f: &mut Frame) -> Result<()> {
        self.records.clear();
        let Some(sp) = self.spheres.as_ref().filter(|_| f.fc.caustic_spheres) else {
            return Ok(());
        };
        f.dc.ctx.begin_scope("spheres", f.enc);
        let n_own = f.env.own_lights;
        let vis_map = self.visibility.as_ref().map(|(_, v)| v.clone());
        let vis = |li: usize, object: usize| -> f32 {
            match (&vis_map, li.checked_sub(n_own)) {
                (Some(v), Some(k)) => v.get(&object).and_then(|r| r.get(k)).copied().unwrap_or(1.0),
                _ => 1.0,
            }
        };
        // The environment's regions spread over their sub-directions (`env_taps`).
        let scene = f.dc.scene;
        let sphere_lights = match (&scene.environment, &f.env.taps) {
            (Some(env), Some(taps)) if f.s.environment.taps >= 2 => {
                let drawn: Vec<bool> = f.env.segments.iter().map(|l| l.facing.max_element() > 0.0).collect();
                let rot = environment_lights::rotation(env.rotate_y);
                super::gpu::spread_lights(&scene.lights, n_own, taps, &drawn, rot)
            }
            _ => scene.lights.clone(),
        };
        self.records = sp.records(&sphere_lights, f.transforms, self.blend, vis);
        let eye = crate::frame::eye(&f.eye);
        f.stats.spheres = Some(if sp.compiled {
            // Section 6: each object's records summed into its compiled table first (the
            // records grouped by object, in the order of the tables).
            let mut grouped = Vec::with_capacity(self.records.len());
            for (oi, _, _) in &sp.objects {
                grouped.extend(self.records.iter().filter(|r| r.base[1] == *oi as u32).copied());
            }
            let objects = sp.compiled_records(f.transforms);
            let compiled = record_compile(&f.dc, sp, &grouped, &objects, f.enc, f.timer);
            record_gather(&f.dc, eye, (sp, &compiled), &objects, f.enc, f.timer)
        } else {
            record_gather(&f.dc, eye, (sp, &sp.table), &self.records, f.enc, f.timer)
        });
        f.dc.ctx.end_scope();
        Ok(())
    }

    fn record_along_rays(&mut self, f: &mut Frame) -> Result<()> {
        let Some(sp) = self.spheres.as_ref().filter(|_| f.dc.scene.medium.is_some() && !self.records.is_empty()) else {
            return Ok(());
        };
        let images = f.images.as_ref().expect("the composite runs first");
        let eye = crate::frame::eye(&f.eye);
        let vol = (&sp.table, &self.records[..]);
        record_volume(&f.dc, eye, vol, f.s.medium.steps, (&images.full, &images.caustic), f.enc, f.timer);
        Ok(())
    }
}
