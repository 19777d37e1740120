//! The feature list: every feature of the frame, and the two phases' fixed orders.

use crate::frame::{Change, Feature};

/// Every feature of the frame and its persistent state.
#[derive(Default)]
pub(crate) struct Features {
    pub camera: crate::passes::Camera,
    pub photon_maps: crate::passes::PhotonMaps,
    pub shading: crate::passes::Shading,
    pub spheres: crate::caustic_spheres::SpheresFeature,
    pub beams: crate::beams::Beams,
    pub bounce: crate::medium_bounce::MediumBounce,
    pub multiple: crate::medium_multiple::MediumMultiple,
    pub indirect: crate::indirect::Indirect,
    pub composite: crate::passes::Composite,
    pub display: crate::passes::Display,
}

impl Features {
    /// Before the composite, in order.
    pub fn surfaces(&mut self) -> [&mut dyn Feature; 8] {
        [
            &mut self.camera,
            &mut self.photon_maps,
            &mut self.shading,
            &mut self.spheres,
            &mut self.beams,
            &mut self.bounce,
            &mut self.multiple,
            &mut self.indirect,
        ]
    }

    /// From the composite on, along the camera rays, in order.
    pub fn along_rays(&mut self) -> [&mut dyn Feature; 6] {
        [
            &mut self.composite,
            &mut self.bounce,
            &mut self.beams,
            &mut self.spheres,
            &mut self.multiple,
            &mut self.display,
        ]
    }

    /// Tell every feature what changed.
    pub fn changed(&mut self, change: Change) {
        for f in self.surfaces() {
            f.changed(change);
        }
        self.composite.changed(change);
        self.display.changed(change);
    }
}
