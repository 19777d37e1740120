//! The checks of [`RenderSettings`] that need the adapter and the scene: texture and
//! storage-binding limits, the photon plans of the hierarchical and adaptive techniques.

use crate::error::{Error, Result};
use crate::gpu::GpuContext;
use crate::lightspace::LightView;
use crate::scene::Scene;
use crate::settings::{Emission, RenderSettings};

impl RenderSettings {
    /// The largest caustic map (power of two, at most `preferred`) whose accumulation buffer
    /// fits this adapter's storage-binding limit for every light of `scene` (a point light's
    /// cube has six faces).
    pub fn fitting_caustic_map_size(ctx: &GpuContext, scene: &Scene, preferred: u32) -> u32 {
        let max_bind = ctx.device.limits().max_storage_buffer_binding_size;
        let faces = scene.lights.iter().map(|l| LightView::new(scene, l).faces.len() as u64).max().unwrap_or(1);
        let mut m = preferred.next_power_of_two().min(2048);
        while m > 16 && (m as u64).pow(2) * faces * 24 > max_bind {
            m /= 2;
        }
        m
    }

    /// Check the settings (every section, [`RenderSettings::validate_sections`]) and their fit
    /// to the adapter's limits and `scene`; errors name the setting by its path
    /// (`photons.caustic_map_size`).
    pub fn validate(&self, ctx: &GpuContext, scene: &Scene) -> Result<()> {
        let cl = |f: &str, m: String| Err(Error::input("<settings>", f, m));
        if let Err((field, msg)) = self.validate_sections() {
            return cl(field, msg);
        }
        let max_tex = ctx.device.limits().max_texture_dimension_2d;
        // A multiple of 16: the map is copied into its texture row by row, and a copy's rows
        // must be a multiple of 256 bytes (16 RGBA32F texels).
        let m = self.photons.caustic_map_size;
        if !(16..=2048).contains(&m) || m > max_tex || !m.is_multiple_of(16) {
            return cl(
                "photons.caustic_map_size",
                format!("must be a multiple of 16 from 16 to {} texels (got {m})", max_tex.min(2048)),
            );
        }
        if !(16..=max_tex).contains(&self.shading.shadow_map_size) {
            return cl(
                "shading.shadow_map_size",
                format!("must be 16 to {max_tex} texels (got {})", self.shading.shadow_map_size),
            );
        }
        if let Some(g) = scene.medium.as_ref().and_then(|m| m.density.as_ref()) {
            let max3 = ctx.device.limits().max_texture_dimension_3d;
            if g.dims.iter().any(|&n| n > max3) {
                return Err(crate::Error::input(
                    &scene.source,
                    "medium.density.path",
                    format!(
                        "the density grid's {}×{}×{} voxels exceed this adapter's 3D texture limit {max3}",
                        g.dims[0], g.dims[1], g.dims[2]
                    ),
                ));
            }
        }
        let hull_parts = crate::gpu::types::BEAM_HULL_PARTS as usize;
        let beam_record = std::mem::size_of::<crate::gpu::types::BeamGpu>()
            .max(hull_parts * std::mem::size_of::<crate::gpu::types::BeamHull>());
        let beam_bytes = u64::from(self.beams.capacity) * beam_record as u64;
        let max_bind = ctx.device.limits().max_storage_buffer_binding_size;
        if beam_bytes > max_bind {
            return cl(
                "beams.capacity",
                format!(
                    "{} beams need {} MiB, over this adapter's {} MiB storage-binding limit",
                    self.beams.capacity,
                    beam_bytes >> 20,
                    max_bind >> 20
                ),
            );
        }
        if let Some(why) = self.beams.volume.unsupported(ctx) {
            return cl("beams.volume", why);
        }
        let c = &scene.camera;
        if c.width > max_tex || c.height > max_tex {
            return cl(
                "camera.size",
                format!("{}x{} exceeds this adapter's texture limit {max_tex}", c.width, c.height),
            );
        }
        let faces = scene.lights.iter().map(|l| self.light_view(scene, l).faces.len() as u64).max().unwrap_or(1);
        let accum = (m as u64).pow(2) * faces * 24;
        if accum > max_bind {
            return cl(
                "photons.caustic_map_size",
                format!(
                    "a {m}x{m} caustic map with {faces} face(s) needs {0} MiB, over this adapter's {1} MiB storage-binding limit",
                    accum >> 20,
                    max_bind >> 20
                ),
            );
        }
        if self.photons.emission == Emission::Basic && self.photons.memory > max_bind {
            return cl("photons.memory", format!("must be between 2 KiB and {} MiB", max_bind >> 20));
        }
        match self.photons.emission {
            Emission::Basic => {}
            Emission::Hierarchical => {
                crate::techniques::hierarchical::HierarchicalPlan::new(self, max_bind)?;
            }
            Emission::AdaptiveLevel | Emission::AdaptiveError => {
                crate::techniques::adaptive::AdaptivePlan::new(self, max_bind)?;
            }
        }
        if (c.width as u64 * c.height as u64 * 16) > max_bind {
            return cl("camera.size", "the image exceeds this adapter's storage-binding limit".into());
        }
        // The medium beyond glass keeps `EYE_SEGMENTS` segments per pixel (`composite`).
        let seg_bytes = c.width as u64
            * c.height as u64
            * crate::gpu::types::EYE_SEGMENTS
            * std::mem::size_of::<crate::gpu::types::EyeSegmentGpu>() as u64;
        if self.medium_segments_active(scene) && seg_bytes > max_bind {
            return cl(
                "camera.size",
                format!(
                    "{}x{} with a medium needs {} MiB of segments beyond glass, over this adapter's {} MiB storage-binding limit (render smaller, or without the medium beyond glass: medium.beyond_specular = false)",
                    c.width,
                    c.height,
                    seg_bytes >> 20,
                    max_bind >> 20
                ),
            );
        }
        Ok(())
    }
}
