//! The frame as a list of features.
//!
//! A frame is recorded by [`crate::renderer::Renderer::encode`] in two phases, each a fixed list
//! of features (`renderer::Features`: its `surfaces`, then its `along_rays`); a feature is one method
//! (photon maps, caustic spheres, beams, ...) that owns its persistent state, records its named
//! passes and hands what later features read to the [`Frame`]:
//!
//! | phase | feature | reads | makes |
//! |---|---|---|---|
//! | surfaces | `camera` (`passes::eye`) | scene | [`Frame::eye`]: camera geometry buffers, radiance accumulators |
//! | | `photon_maps` (`passes::photon_maps`) | eye | [`Frame::lights`]: per light its maps, redone only when invalid |
//! | | `shading` (`passes::eye`) | eye, lights | direct and caustic light in the accumulators |
//! | | `caustic_spheres` | eye | directional lights' caustics from the tables |
//! | | `beams` | eye, lights | the beams (a product); with `sources.local = beams` the surface caustic |
//! | | `medium_bounce` | eye, lights, beams | light the medium sends back onto surfaces |
//! | | `medium_multiple` | eye, lights | multiple scattering: its grid, the surfaces it lights |
//! | | `indirect` | eye, lights | diffuse interreflection: its cache, the surfaces it lights |
//! | along rays | `composite` (`passes::composite`) | eye, lights | [`Frame::images`]: refraction, reflection, single scattering |
//! | | `medium_bounce` | images | the surfaces' light scattered along the camera rays |
//! | | `beams` | images | the volume caustic |
//! | | `caustic_spheres` | images | the spheres' volume caustic |
//! | | `display` | images | [`Frame::display`] |
//!
//! Every contribution is a sum; the lists fix the order of the additions (so images are the same
//! bit for bit frame to frame). A feature that only keeps caches learns what changed through
//! [`Feature::changed`]. Statistics the GPU counts are copied out through [`Frame::stats`].

use crate::error::Result;
use crate::gpu::PassTimer;
use crate::settings::RenderSettings;
use std::sync::Arc;

mod types;

pub(crate) use types::{
    Composited, DEPTH_FORMAT, DrawCtx, EyeFrame, EyeSegments, FrameConsts, GBuffer, LightFrame, POS_FORMAT, texture,
};

/// What a feature records into, and what the features before it made.
pub(crate) struct Frame<'a> {
    pub dc: DrawCtx<'a>,
    /// The frame's settings.
    pub s: &'a RenderSettings,
    pub fc: &'a FrameConsts,
    pub env: &'a EnvFrame,
    /// Each object's transform relative to its pose in the scene file.
    pub transforms: &'a [glam::Affine3A],
    pub enc: &'a mut wgpu::CommandEncoder,
    pub timer: &'a mut PassTimer,
    /// The camera's buffers (`camera`).
    pub eye: Option<EyeFrame>,
    /// Every light's maps, kept or redone (`photon_maps`), and which were redone this frame.
    pub lights: Vec<Arc<LightFrame>>,
    pub redone: Vec<bool>,
    /// The composited images (`composite`) and the tone-mapped one (`display`).
    pub images: Option<Composited>,
    pub display: Option<wgpu::Texture>,
    pub stats: StatsCopies,
    /// What a feature hands to later ones beyond the above, by type (the beams' buffers for the
    /// medium bounce; the photon stages' counters for the statistics).
    pub products: Products,
}

/// Values by type: a feature puts what it made, a later one reads or takes it.
#[derive(Default)]
pub(crate) struct Products(std::collections::HashMap<std::any::TypeId, Box<dyn std::any::Any>>);

impl Products {
    pub fn put<T: 'static>(&mut self, value: T) {
        self.0.insert(std::any::TypeId::of::<T>(), Box::new(value));
    }

    pub fn get<T: 'static>(&self) -> Option<&T> {
        self.0.get(&std::any::TypeId::of::<T>()).and_then(|b| b.downcast_ref())
    }

    pub fn take<T: 'static>(&mut self) -> Option<T> {
        self.0.remove(&std::any::TypeId::of::<T>()).and_then(|b| b.downcast().ok()).map(|b| *b)
    }
}

/// The camera's buffers, once the `camera` feature made them.
pub(crate) fn eye(eye: &Option<EyeFrame>) -> &EyeFrame {
    eye.as_ref().expect("the camera feature runs first")
}

/// The lights' frames as the recording functions take them.
pub(crate) fn light_refs(lights: &[Arc<LightFrame>]) -> Vec<&LightFrame> {
    lights.iter().map(|l| &**l).collect()
}

/// The environment as the frame's features see it.
pub(crate) struct EnvFrame {
    /// The scene's own lights (the environment's directional lights follow them).
    pub own_lights: usize,
    /// Per light, its `shade_receivers` taps record.
    pub shade_taps: Vec<crate::gpu::types::EnvTapsGpu>,
}

/// GPU counters a frame copies into the statistics ring (`renderer::stats`).
#[derive(Default)]
pub(crate) struct StatsCopies {
    /// Per light, its flux words and fixed-point scale.
    pub flux: Vec<(wgpu::Buffer, f64)>,
    /// `sphere_gather`'s counters.
    pub spheres: Option<wgpu::Buffer>,
    /// `indirect_trace`'s counters (deposits a full cache lost), when the cache was rebuilt.
    pub indirect: Option<wgpu::Buffer>,
}

/// What changed between frames, for the features that keep work across frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Change {
    /// Light `i` (or an object it sees) changed.
    Light(usize),
    /// Anything every light depends on (settings, materials, the medium, inspection).
    Lights,
}

/// One method of the frame (module documentation).
pub(crate) trait Feature {
    /// Record the feature's passes before the composite (light-space work, surfaces).
    fn record(&mut self, _f: &mut Frame) -> Result<()> {
        Ok(())
    }
    /// Record the feature's passes along the camera rays, after the composite (in the
    /// `composite` scope).
    fn record_along_rays(&mut self, _f: &mut Frame) -> Result<()> {
        Ok(())
    }
    /// Forget what `change` makes stale.
    fn changed(&mut self, _change: Change) {}
}
