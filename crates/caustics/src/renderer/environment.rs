//! The renderer's environment light: its segmentation into directional lights and their taps,
//! the light list a frame draws, the environment's rotation, and what the caustic spheres need
//! of it (their lights, the rays of their visibility of its regions).

use super::Renderer;
use crate::caustic_spheres::visibility::{VisibilityRays, VisibilityUpdate};
use crate::error::{Error, Result};
use crate::scene::Light;
use crate::scene::environment_lights::{self, EnvironmentLight};
use std::sync::Arc;

impl Renderer {
    /// Segment the environment for the current `env_lights` setting, in the map's own frame,
    /// unless that is done already (once per D).
    pub(super) fn refresh_env_segments(&mut self) {
        let key = (self.settings.environment.lights, self.settings.environment.split);
        if self.env_segments.as_ref().is_none_or(|(k, _)| *k != key) {
            self.env_segments = Some((key, self.env_segments()));
        }
        let tkey = (key, self.settings.environment.taps);
        if let Some(env) = &self.scene.environment
            && self.env_taps.as_ref().is_none_or(|(k, _)| *k != tkey)
        {
            let taps = crate::env_taps::region_taps(env, &self.env_segments(), self.settings.environment.taps as usize);
            self.env_taps = Some((tkey, Arc::new(taps)));
        }
    }

    /// Per light of [`Renderer::lights`], its `shade_receivers` taps record
    /// (`crate::env_taps`): none for the scene's own lights, an environment region's
    /// sub-directions turned into the world for the environment's.
    pub(super) fn shade_taps(&self, lights: usize) -> Vec<crate::gpu::types::EnvTapsGpu> {
        let mut out = vec![crate::gpu::types::EnvTapsGpu::zeroed_record(); self.scene.lights.len()];
        if let (Some(env), Some((_, taps))) = (&self.scene.environment, &self.env_taps) {
            let r = environment_lights::rotation(env.rotate_y);
            let pivot = self.scene.caster_bounds().map_or(glam::Vec3::ZERO, |(a, b)| 0.5 * (a + b));
            for (region, t) in self.env_segments().iter().zip(taps.iter()) {
                if region.facing.max_element() > 0.0 {
                    out.push(crate::env_taps::record(t, region.centre, r, pivot));
                }
            }
        }
        out.resize(lights, crate::gpu::types::EnvTapsGpu::zeroed_record());
        out
    }

    /// The environment's segmentation for the current `env_lights` setting, in the map's own
    /// frame (the kept one); empty without an environment.
    pub(super) fn env_segments(&self) -> Arc<Vec<EnvironmentLight>> {
        let Some(env) = &self.scene.environment else {
            return Arc::new(Vec::new());
        };
        let key = (self.settings.environment.lights, self.settings.environment.split);
        match &self.env_segments {
            Some((k, segs)) if *k == key => segs.clone(),
            _ => Arc::new(environment_lights::segment_map_with(env, key.0 as usize, key.1)),
        }
    }

    /// The environment's regions as they light the scene now (all `env_lights` of them, black
    /// ones included; centres in world space, the environment's rotation applied): their
    /// directional lights follow the scene's own lights in [`Renderer::lights`] (black ones
    /// left out). Empty without an environment.
    pub fn environment_lights(&self) -> Vec<EnvironmentLight> {
        let rot = self.scene.environment.as_ref().map_or(0.0, |e| e.rotate_y);
        environment_lights::rotate(&self.env_segments(), rot)
    }

    /// Every light the renderer draws, in the order of the per-light outputs and statistics:
    /// the scene's lights, then one directional light per region of the environment that
    /// carries any light ([`Renderer::environment_lights`] in order, black regions skipped).
    pub fn lights(&self) -> Vec<Light> {
        self.lights_now()
    }

    pub(super) fn lights_now(&self) -> Vec<Light> {
        let mut lights = self.scene.lights.clone();
        // Every frame: rotate the kept regions' centres only (`environment_lights` would clone
        // each region's texel list too).
        let r = environment_lights::rotation(self.scene.environment.as_ref().map_or(0.0, |e| e.rotate_y));
        lights.extend(
            self.env_segments()
                .iter()
                .filter(|l| l.facing.max_element() > 0.0)
                .map(|l| Light::Directional { direction: -(r * l.centre).normalize(), irradiance: l.facing }),
        );
        lights
    }

    /// Caustic spheres under an environment: whether the frame computes the caustic objects'
    /// visibility of the environment's drawn (non-black) regions again (on the GPU,
    /// [`crate::caustic_spheres::visibility`]), and the rays it casts: when an object moved, the
    /// environment turned or its segmentation changed. The parts are the drawn regions in the
    /// order of the light list, each cut into its sub-regions where it has taps (the order of
    /// `spread_lights`' lights): a sub-region below a floor is hidden even where its region is
    /// partly seen.
    pub(super) fn sphere_visibility_update(&self) -> Result<VisibilityUpdate> {
        let (Some(sp), Some(env)) = (&self.features.spheres.spheres, &self.scene.environment) else {
            return Ok(VisibilityUpdate::None);
        };
        let objects: Vec<usize> = sp.objects.iter().map(|o| o.0).collect();
        let mut key: Vec<u32> = vec![
            env.rotate_y.to_bits(),
            self.settings.environment.lights,
            self.settings.environment.split as u32,
            self.settings.environment.taps,
        ];
        for t in &self.transforms {
            key.extend(t.to_cols_array().iter().map(|v| v.to_bits()));
        }
        // A deformed mesh may hide other regions.
        key.extend([self.deformations as u32, (self.deformations >> 32) as u32]);
        key.extend(objects.iter().map(|&o| o as u32));
        if self.features.spheres.visibility.as_ref().is_some_and(|v| v.key == key) {
            return Ok(VisibilityUpdate::Keep);
        }
        let taps = self.env_taps.as_ref().map(|(_, t)| t.clone()).filter(|_| self.settings.environment.taps >= 2);
        let k = (self.settings.environment.taps as usize).min(crate::gpu::types::MAX_ENV_TAPS);
        let mut regions = Vec::new();
        for (i, region) in self.env_segments().iter().enumerate() {
            if region.facing.max_element() <= 0.0 {
                continue;
            }
            match taps.as_ref().and_then(|t| t.get(i)).filter(|t| !t.is_empty()) {
                Some(_) => regions.extend(environment_lights::subdivide(env, region, k)),
                None => regions.push(region.clone()),
            }
        }
        let (dirs, weights) = crate::raycast::region_rays(env, &regions, env.rotate_y);
        let mut parts = Vec::with_capacity(regions.len());
        let mut first = 0u32;
        for r in &regions {
            parts.push((first, r.members.len() as u32));
            first += r.members.len() as u32;
        }
        let centres = objects
            .iter()
            .map(|&o| crate::raycast::object_centre(&self.base, &self.transforms, o))
            .collect::<Result<Vec<_>>>()?;
        Ok(VisibilityUpdate::New(VisibilityRays { key, objects, centres, dirs, weights, parts }))
    }

    /// Caustic spheres under an environment: per caustic object (its index), the visibility of
    /// each part (drawn region, or its sub-regions where it has taps) as the frames compute it
    /// on the GPU (`Renderer::region_visibility`'s values, bit for bit); empty before the first
    /// frame or without an environment. Blocking read-back: for tests and tools, not frames.
    #[doc(hidden)]
    pub fn sphere_visibility_read(&self) -> Result<Vec<(usize, Vec<f32>)>> {
        let Some(v) = &self.features.spheres.visibility else { return Ok(Vec::new()) };
        let bytes = self.ctx.read_buffer(&v.buffer, v.buffer.size())?;
        let values: &[f32] = bytemuck::cast_slice(&bytes);
        let n = v.parts as usize;
        Ok(v.objects.iter().enumerate().map(|(i, &o)| (o, values[i * n..(i + 1) * n].to_vec())).collect())
    }

    /// The directional lights whose caustics the caustic spheres draw: `lights` (the frame's
    /// list) with the environment's regions spread over their sub-directions (`env_taps`)
    /// where it has taps.
    pub(super) fn sphere_lights(&self, lights: &[Light]) -> Vec<Light> {
        match (&self.scene.environment, &self.env_taps) {
            (Some(env), Some((_, taps))) if self.settings.environment.taps >= 2 => {
                let drawn: Vec<bool> = self.env_segments().iter().map(|l| l.facing.max_element() > 0.0).collect();
                let rot = environment_lights::rotation(env.rotate_y);
                crate::caustic_spheres::gpu::spread_lights(lights, self.scene.lights.len(), taps, &drawn, rot)
            }
            _ => lights.to_vec(),
        }
    }

    /// Turn the environment to `rotate_y_deg` degrees about +Y (the scene format's
    /// `rotate_y_deg`, absolute): the background and reflections follow, and the environment's
    /// directional lights turn with it (their directions rotated, no re-segmentation), so their
    /// maps are redone on the next frame. An error without an environment.
    pub fn set_environment_rotation(&mut self, rotate_y_deg: f32) -> Result<()> {
        if !rotate_y_deg.is_finite() {
            return Err(Error::input("<renderer>", "environment.rotate_y_deg", "must be finite"));
        }
        let rad = rotate_y_deg.to_radians();
        for s in [&mut self.scene, &mut self.base] {
            let Some(env) = s.environment.as_mut() else {
                return Err(Error::input("<renderer>", "environment", "the scene has no environment light"));
            };
            if env.rotate_y != rad {
                Arc::make_mut(env).set_rotate_y(rad);
            }
        }
        Ok(())
    }

    /// The environment's rotation about +Y, degrees (None without an environment).
    pub fn environment_rotation(&self) -> Option<f32> {
        self.scene.environment.as_ref().map(|e| e.rotate_y.to_degrees())
    }

    /// Per region of [`Renderer::environment_lights`], the unoccluded fraction of its radiance
    /// seen from object `object`'s centre past the other objects as they are now
    /// ([`crate::raycast::region_visibility`]: exact rays, blocking, not pooled: call it
    /// when objects moved or the environment turned, not every frame). Empty without an
    /// environment.
    pub fn region_visibility(&self, object: usize) -> Result<Vec<f32>> {
        let Some(env) = self.scene.environment.clone() else {
            return Ok(Vec::new());
        };
        let lights = self.environment_lights();
        crate::raycast::region_visibility(&self.ctx, &self.base, &self.transforms, &env, &lights, object, env.rotate_y)
    }
}
