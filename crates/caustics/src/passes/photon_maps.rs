//! The photon maps feature: per light, its light-space buffers, the emission technique's photon
//! stage, the resolve, the temporal filter and the shading tiles (`passes::record_light`),
//! redone only when the light's uniform record changed or something it sees did.

use super::LightFrame;
use crate::error::Result;
use crate::frame::{Change, Feature, Frame};
use crate::gpu::types::LightGpu;
use crate::settings::Inspect;
use crate::temporal::TemporalFilter;
use std::sync::Arc;

/// A light's kept products and the uniform record they were made from.
pub(crate) struct LightState {
    pub record: LightGpu,
    pub frame: Arc<LightFrame>,
}

/// Every light's photon maps ([`Frame::lights`]).
#[derive(Default)]
pub(crate) struct PhotonMaps {
    /// Per light of the frame (the scene's, then the environment's), its kept maps.
    pub states: Vec<Option<LightState>>,
    /// Per light, whether it must be redone.
    pub dirty: Vec<bool>,
    /// What the light passes copy out for inspection.
    pub inspect: Inspect,
    pub temporal: Option<TemporalFilter>,
}

impl PhotonMaps {
    /// Forget every light's maps (their resources are gone).
    pub fn forget(&mut self) {
        self.states.iter_mut().for_each(|l| *l = None);
    }

    /// The kept frame of light `li`, if it was made.
    pub fn frame(&self, li: usize) -> Option<&LightFrame> {
        self.states.get(li).and_then(|l| l.as_ref()).map(|l| &*l.frame)
    }
}

impl Feature for PhotonMaps {
    fn record(&mut self, f: &mut Frame) -> Result<()> {
        let scene = f.dc.scene;
        let n = scene.lights.len();
        if self.states.len() != n {
            self.states.resize_with(n, || None);
            self.dirty.resize(n, true);
        }
        let (fc, s) = (f.fc, f.s);
        let mut stages = None;
        let mut pendings: Vec<crate::techniques::Pending> = Vec::new();
        f.redone = vec![false; n];
        for (li, light) in scene.lights.iter().enumerate() {
            let (view, record, scale) = super::light_record(scene, light, s, fc);
            let same = self.states[li]
                .as_ref()
                .is_some_and(|st| bytemuck::bytes_of(&st.record) == bytemuck::bytes_of(&record));
            if same && !self.dirty[li] {
                continue;
            }
            let pl = stages.get_or_insert_with(|| {
                crate::techniques::Stages::new(
                    s,
                    fc.layer2,
                    [fc.reflect_branch, fc.internal_branch, fc.residual_branch],
                )
            });
            f.dc.ctx.begin_scope(&format!("light{li}"), f.enc);
            let job = super::LightJob { index: li, view: &view, record: &record, scale };
            let out = super::record_light(f, pl, self.inspect, job, self.temporal.as_mut());
            f.dc.ctx.end_scope();
            let (frame, pending) = out?;
            self.states[li] = Some(LightState { record, frame: Arc::new(frame) });
            self.dirty[li] = false;
            f.redone[li] = true;
            pendings.push(pending);
        }
        f.lights = self.states.iter().map(|l| l.as_ref().expect("every light recorded").frame.clone()).collect();
        f.products.put(pendings);
        f.stats.flux = f.lights.iter().map(|l| (l.stats.clone(), l.scale)).collect();
        Ok(())
    }

    fn changed(&mut self, change: Change) {
        match change {
            Change::Light(i) => {
                if self.dirty.len() <= i {
                    self.dirty.resize(i + 1, true);
                }
                self.dirty[i] = true;
            }
            Change::Lights => self.dirty.iter_mut().for_each(|d| *d = true),
        }
    }
}
