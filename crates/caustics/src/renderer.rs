//! The persistent renderer: what an engine drives frame by frame on its own device.
//!
//! ```no_run
//! # fn f(device: &wgpu::Device, queue: &wgpu::Queue, scene: caustics::Scene) -> caustics::Result<()> {
//! use caustics::renderer::{FrameRequest, Renderer};
//! let mut r = Renderer::new(device, queue, scene, caustics::render::RenderSettings::default())?;
//! loop {
//!     // Change what moved (camera, lights, object transforms, settings): uniform writes only.
//!     let mut cam = r.scene().camera.clone();
//!     cam.position.x += 0.01;
//!     r.set_camera(cam)?;
//!     let mut enc = device.create_command_encoder(&Default::default());
//!     let out = r.encode(&mut enc, FrameRequest { stats: true })?;
//!     let _display = out.display; // tone-mapped image, Rgba8Unorm (sRGB-encoded values)
//!     queue.submit([enc.finish()]);
//!     // Statistics of an earlier frame, once the GPU has finished it (never blocks).
//!     if let Some(stats) = r.poll_stats()? {
//!         let _ = stats.frame;
//!     }
//! #   break;
//! }
//! # Ok(()) }
//! ```
//!
//! Call order: the encoder `encode` records into is submitted before the next call of `encode`
//! or `poll_stats`.
//!
//! Work that did not change is not redone: every frame records the camera's passes, shading and
//! composite; a light's passes (its light-space buffers, photon stage, resolve and temporal
//! filter) only when the light, the settings, or an object it sees changed, or when asked by
//! [`Renderer::invalidate`]. Resources come from the context's pool ([`crate::gpu::pool`]): after
//! the first frame of a configuration, frames create no GPU objects ([`Renderer::created`]).
//!
//! State is the loaded scene plus what changed since: the camera, the lights, a transform per
//! object (relative to the pose the scene file gives, a rotation, translation and uniform
//! scale), the settings and the temporal filter. A fresh renderer brought to the same state
//! renders the same maps and image bit for bit as one that got there frame by frame.

use crate::error::{Error, Result};
pub use crate::gpu::ResourceCounts;
use crate::gpu::types::LightGpu;
use crate::gpu::{GpuContext, PassTimer};
use crate::image_io::Image;
use crate::output::{FluxStats, GpuRender};
use crate::passes::{DrawCtx, EyeFrame, FrameConsts, Geometry, LightFrame, bytes_to_image};
use crate::scene::environment_lights::{self, EnvironmentLight};
use crate::scene::{Camera, Light, Material, Scene};
use crate::settings::RenderSettings;
use crate::techniques::{Pending, TechniqueStats};
use crate::temporal::{TemporalFilter, TemporalSettings};
use glam::Affine3A;
use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};

/// What a frame should produce beyond the image.
#[derive(Debug, Clone, Copy, Default)]
pub struct FrameRequest {
    /// Copy this frame's statistics (pass times, photon counts, flux bookkeeping, overflow
    /// flags) for [`Renderer::poll_stats`]; frames without it record no copies.
    pub stats: bool,
}

/// Textures of one light, valid until the light's maps are next redone.
pub struct LightOutputs<'a> {
    /// Caustic irradiance (W/m²) per face: a 2D array texture (M × M × faces, Rgba32Float).
    pub irradiance: &'a wgpu::Texture,
    /// The receiver map: world position and object id (w, −1 where empty) per face.
    pub receiver_position: &'a wgpu::Texture,
    /// The receiver map's shading normals per face.
    pub receiver_normal: &'a wgpu::Texture,
    /// Whether this frame recomputed the light's maps (false: kept from an earlier frame).
    pub redone: bool,
}

/// What [`Renderer::encode`] recorded.
pub struct FrameOutputs<'a> {
    /// The image tone-mapped with the scene's exposure (ACES fit), sRGB-encoded values in an
    /// Rgba8Unorm texture (`TEXTURE_BINDING | COPY_SRC`), camera width × height.
    pub display: &'a wgpu::Texture,
    /// Linear radiance, W/(m² sr), `vec4<f32>` per pixel row-major (`STORAGE | COPY_SRC`).
    pub radiance: &'a wgpu::Buffer,
    /// Caustic light only, on the diffuse surfaces the camera sees directly.
    pub caustic_radiance: &'a wgpu::Buffer,
    pub lights: Vec<LightOutputs<'a>>,
}

/// Statistics of one frame, read back asynchronously.
#[derive(Debug, Clone, Default)]
pub struct FrameStats {
    /// The frame's number (counted from 0 by [`Renderer::encode`]).
    pub frame: u64,
    /// GPU milliseconds per named pass (empty without timestamp queries).
    pub timings: Vec<(String, f64)>,
    /// Per light: flux bookkeeping of the light's latest photon stage.
    pub flux: Vec<FluxStats>,
    /// Photon work done in this frame (zero when every light's maps were kept).
    pub technique: TechniqueStats,
    /// Per light: whether this frame redid the light's passes.
    pub lights_redone: Vec<bool>,
    /// An overflow the GPU detected (the frame's caustic map is incomplete), as a message.
    pub overflow: Option<String>,
    /// Caustic spheres: occlusion rays of `sphere_gather` (one per pixel and caustic object)
    /// that overflowed the BVH stack (their pixels got no caustic from that object).
    pub sphere_stack_overflows: u64,
}

/// A light's kept products and what they were made from.
struct LightState {
    record: LightGpu,
    frame: LightFrame,
}

/// One slot of the statistics ring: a staging buffer the frame's counters are copied into.
struct StatsSlot {
    staging: wgpu::Buffer,
    /// 0 free, 1 recorded (not yet mapped), 2 mapping, 3 mapped, 4 failed.
    state: Arc<AtomicU8>,
    job: Option<StatsJob>,
}

/// How to read a slot: its frame, and what lies where in the staging buffer.
struct StatsJob {
    frame: u64,
    timer: Option<(Vec<String>, u64, u64)>,
    /// Per light: offset of its flux words and its fixed-point scale.
    flux: Vec<(u64, f64)>,
    /// Per redone light: its technique's pending statistics and their (offset, size) pieces.
    pendings: Vec<(Pending, Vec<(u64, u64)>)>,
    lights_redone: Vec<bool>,
    /// Offset of `sphere_gather`'s counters, when it ran.
    sphere_stats: Option<u64>,
}

const STATS_SLOTS: usize = 3;

/// What an environment segmentation was made for: D and the split rule.
type SegmentKey = (u32, environment_lights::SplitRule);
/// The segmentation and the sub-directions per region (`RenderSettings::env_taps`).
type TapsKey = (SegmentKey, u32);
/// Per caustic-sphere object, the visibility of each drawn environment light.
type SphereVisibility = std::collections::HashMap<usize, Vec<f32>>;

/// The persistent GPU renderer (module documentation).
pub struct Renderer {
    ctx: GpuContext,
    /// The scene as loaded, and as it is now (object transforms baked in).
    base: Scene,
    scene: Scene,
    transforms: Vec<Affine3A>,
    settings: RenderSettings,
    inspect: crate::settings::Inspect,
    temporal: Option<TemporalFilter>,
    geometry: Option<(crate::scene::Tessellation, Geometry)>,
    objects_dirty: bool,
    lights: Vec<Option<LightState>>,
    light_dirty: Vec<bool>,
    frame: u64,
    outputs: Option<(wgpu::Buffer, wgpu::Buffer, wgpu::Texture)>,
    /// The last frame's beam buffers per light with beams (`crate::beams`).
    beam_frames: Vec<crate::beams::BeamFrame>,
    /// The lights' virtual point lights of `crate::medium_bounce`, kept while no light is redone.
    bounce: Option<crate::medium_bounce::BounceFrame>,
    /// Count the beam hulls' fragments in the frame being encoded (`render_once`, which reads
    /// the beam statistics; `BEAM_FLAG_FRAGMENTS`).
    count_fragments: bool,
    ring: Vec<StatsSlot>,
    latest: Option<FrameStats>,
    last_error: Option<String>,
    /// The environment's segmentation in the map's own frame, and the D it was made for.
    env_segments: Option<(SegmentKey, Arc<Vec<EnvironmentLight>>)>,
    /// Each region's sub-directions (`crate::env_taps`) and the (segmentation, K) they are for.
    env_taps: Option<(TapsKey, Arc<Vec<crate::env_taps::RegionTaps>>)>,
    /// Caustic spheres of the caustic objects (`set_caustic_spheres`), used when
    /// the technique is `Technique::CausticSpheres`.
    spheres: Option<crate::caustic_spheres::gpu::GpuSpheres>,
    sphere_blend: crate::caustic_spheres::Blend,
    /// The environment regions' visibility per sphere object, and what it was computed for.
    sphere_vis: Option<(Vec<u32>, Arc<SphereVisibility>)>,
}

impl Renderer {
    /// A renderer for `scene` on the caller's device (made with at least
    /// [`GpuContext::device_requirements`]). Settings are checked against the device's limits.
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, scene: Scene, settings: RenderSettings) -> Result<Renderer> {
        Renderer::with_context(GpuContext::from_device(device, queue), scene, settings)
    }

    /// A renderer on a context's device (the command line's convenience): it shares the
    /// context's pipelines and keeps its resources in a pool of its own.
    pub fn with_context(ctx: GpuContext, scene: Scene, settings: RenderSettings) -> Result<Renderer> {
        let ctx = ctx.with_own_pool();
        ctx.check_device()?;
        settings.validate(&ctx, &scene)?;
        let n = scene.objects.len();
        let lights = scene.lights.len();
        Ok(Renderer {
            ctx,
            base: scene.clone(),
            scene,
            transforms: vec![Affine3A::IDENTITY; n],
            settings,
            inspect: Default::default(),
            temporal: None,
            geometry: None,
            objects_dirty: true,
            lights: (0..lights).map(|_| None).collect(),
            light_dirty: vec![true; lights],
            frame: 0,
            outputs: None,
            beam_frames: Vec::new(),
            bounce: None,
            count_fragments: false,
            ring: Vec::new(),
            latest: None,
            last_error: None,
            env_segments: None,
            env_taps: None,
            spheres: None,
            sphere_blend: crate::caustic_spheres::Blend::Triangle,
            sphere_vis: None,
        }
        .with_env_segments())
    }

    fn with_env_segments(mut self) -> Renderer {
        self.refresh_env_segments();
        self
    }

    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// The scene as it is now: camera, lights and objects with their transforms applied.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    pub fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    /// Move the camera or change the image size (no light is redone).
    pub fn set_camera(&mut self, camera: Camera) -> Result<()> {
        if camera.width == 0 || camera.height == 0 {
            return Err(Error::input("<renderer>", "camera.width", "the image must be at least 1x1"));
        }
        let old = std::mem::replace(&mut self.scene.camera, camera);
        if let Err(e) = self.settings.validate(&self.ctx, &self.scene) {
            self.scene.camera = old;
            return Err(e);
        }
        Ok(())
    }

    /// The precomputed caustic spheres of caustic objects (object index, table in the object's
    /// scene-file pose), uploaded now (as half floats with `half`: half the memory); with
    /// `Technique::CausticSpheres` they give the caustics of every directional light
    /// (`sphere_gather`), blended as `blend` says.
    pub fn set_caustic_spheres(
        &mut self,
        objects: Vec<(usize, std::sync::Arc<crate::caustic_spheres::CausticSpheres>)>,
        blend: crate::caustic_spheres::Blend,
        half: bool,
    ) -> Result<()> {
        if let Some((oi, _)) = objects.iter().find(|(oi, _)| *oi >= self.base.objects.len()) {
            return Err(Error::input("<renderer>", format!("objects[{oi}]"), "no such object"));
        }
        self.spheres = Some(crate::caustic_spheres::gpu::GpuSpheres::new(&self.ctx, objects, half)?);
        self.sphere_blend = blend;
        Ok(())
    }

    /// Caustic spheres: the compiled variant (section 6 of the paper: per frame, every light
    /// summed into one table per object by `sphere_compile`, then one lookup per object in
    /// `sphere_gather`) or the direct one (a lookup per light and blended direction; the
    /// default). No effect before `set_caustic_spheres`.
    pub fn set_caustic_spheres_compiled(&mut self, compiled: bool) {
        if let Some(sp) = self.spheres.as_mut() {
            sp.compiled = compiled;
        }
    }

    /// Caustic spheres: the points per pixel side of `sphere_gather`'s box filter (1 to 16;
    /// default `caustic_spheres::gpu::PIXEL_SAMPLES`; 1: the pixel's centre, as the CPU
    /// evaluation with one ray per pixel). No effect before `set_caustic_spheres`.
    pub fn set_caustic_sphere_samples(&mut self, samples: u32) -> Result<()> {
        if !(1..=16).contains(&samples) {
            return Err(Error::input("<renderer>", "sphere_samples", format!("must be 1 to 16 (got {samples})")));
        }
        if let Some(sp) = self.spheres.as_mut() {
            sp.pixel_samples = samples;
        }
        Ok(())
    }

    /// Caustic spheres: lower the BVH stack of `sphere_gather`'s occlusion rays (1 to
    /// `accel::BVH_STACK`), for tests that check overflows are counted
    /// (`FrameStats::sphere_stack_overflows`). No effect before `set_caustic_spheres`.
    pub fn set_caustic_sphere_stack_limit(&mut self, limit: u32) -> Result<()> {
        if limit == 0 || limit as usize > crate::accel::BVH_STACK {
            return Err(Error::input(
                "<renderer>",
                "stack_limit",
                format!("must be 1 to {} (got {limit})", crate::accel::BVH_STACK),
            ));
        }
        if let Some(sp) = self.spheres.as_mut() {
            sp.stack_limit = limit;
        }
        Ok(())
    }

    /// Bytes of the caustic sphere tables on the GPU (0 without).
    pub fn caustic_sphere_bytes(&self) -> u64 {
        self.spheres.as_ref().map_or(0, |s| s.bytes)
    }

    /// Replace light `index` (its kind may change: a point light's six faces are made on the
    /// next frame). Only this light is redone.
    pub fn set_light(&mut self, index: usize, light: Light) -> Result<()> {
        if index >= self.scene.lights.len() {
            return Err(Error::input("<renderer>", format!("lights[{index}]"), "no such light"));
        }
        let old = std::mem::replace(&mut self.scene.lights[index], light);
        if let Err(e) = self.settings.validate(&self.ctx, &self.scene) {
            self.scene.lights[index] = old;
            return Err(e);
        }
        self.light_dirty[index] = true;
        Ok(())
    }

    /// The transform of object `index` relative to its pose in the scene file.
    pub fn object_transform(&self, index: usize) -> Option<Affine3A> {
        self.transforms.get(index).copied()
    }

    /// Move object `index`: `transform` (a rotation, translation and uniform scale) is applied to
    /// its pose in the scene file. The lights that see the object before or after are redone.
    pub fn set_object_transform(&mut self, index: usize, transform: Affine3A) -> Result<()> {
        let Some(o) = self.base.objects.get(index) else {
            return Err(Error::input("<renderer>", format!("objects[{index}]"), "no such object"));
        };
        let shape = o
            .shape
            .transformed(&transform)
            .map_err(|m| Error::input("<renderer>", format!("objects[{index}].transform"), m))?;
        if transform == self.transforms[index] {
            return Ok(());
        }
        let before = self.scene.objects[index].shape.bounds();
        self.scene.objects[index].shape = shape;
        let after = self.scene.objects[index].shape.bounds();
        self.transforms[index] = transform;
        let lights = self.lights_now();
        if self.light_dirty.len() < lights.len() {
            self.light_dirty.resize(lights.len(), true);
        }
        for (l, light) in lights.iter().enumerate() {
            let view = self.settings.light_view(&self.scene, light);
            if view.faces.iter().any(|f| box_in_view(before, f.world_to_clip) || box_in_view(after, f.world_to_clip)) {
                self.light_dirty[l] = true;
            }
        }
        self.objects_dirty = true;
        Ok(())
    }

    /// Segment the environment for the current `env_lights` setting, in the map's own frame,
    /// unless that is done already (once per D).
    fn refresh_env_segments(&mut self) {
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
    fn shade_taps(&self, lights: usize) -> Vec<crate::gpu::types::EnvTapsGpu> {
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
    fn env_segments(&self) -> Arc<Vec<EnvironmentLight>> {
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

    fn lights_now(&self) -> Vec<Light> {
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

    /// Caustic spheres under an environment: per sphere object, the visibility of each drawn
    /// environment light (the non-black regions of [`Renderer::environment_lights`], in the order
    /// of [`Renderer::lights`] after the scene's own), from [`crate::raycast::region_visibility`].
    /// Kept until an object moves, the environment turns or its segmentation changes; recomputing
    /// it casts rays on the GPU and waits for them (a read-back, outside the steady state).
    fn sphere_visibility(&mut self) -> Result<Option<Arc<SphereVisibility>>> {
        let (Some(sp), Some(env)) = (&self.spheres, &self.scene.environment) else {
            return Ok(None);
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
        key.extend(objects.iter().map(|&o| o as u32));
        if let Some((k, v)) = &self.sphere_vis
            && *k == key
        {
            return Ok(Some(v.clone()));
        }
        // The drawn (non-black) regions in the order of the light list, each cut into its
        // sub-regions where it has taps (the order of `spread_lights`' lights): a sub-region
        // below a floor is hidden even where its region is partly seen.
        let taps = self.env_taps.as_ref().map(|(_, t)| t.clone()).filter(|_| self.settings.environment.taps >= 2);
        let k = (self.settings.environment.taps as usize).min(crate::gpu::types::MAX_ENV_TAPS);
        let mut parts = Vec::new();
        for (i, region) in self.env_segments().iter().enumerate() {
            if region.facing.max_element() <= 0.0 {
                continue;
            }
            match taps.as_ref().and_then(|t| t.get(i)).filter(|t| !t.is_empty()) {
                Some(_) => parts.extend(environment_lights::subdivide(env, region, k)),
                None => parts.push(region.clone()),
            }
        }
        let env = env.clone();
        let mut map = std::collections::HashMap::new();
        for &o in &objects {
            let v = crate::raycast::region_visibility(
                &self.ctx,
                &self.base,
                &self.transforms,
                &env,
                &parts,
                o,
                env.rotate_y,
            )?;
            map.insert(o, v);
        }
        let v = Arc::new(map);
        self.sphere_vis = Some((key, v.clone()));
        Ok(Some(v))
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

    /// Replace material `index` (same kind of surface or not). Every light is redone, since any
    /// of them may see an object made of it.
    pub fn set_material(&mut self, index: usize, material: Material) -> Result<()> {
        if index >= self.scene.materials.len() {
            return Err(Error::input("<renderer>", format!("materials[{index}]"), "no such material"));
        }
        let ok = match material {
            Material::Diffuse { albedo } => albedo.is_finite() && albedo.min_element() >= 0.0,
            Material::Dielectric { ior, ext_ior } => {
                ior.is_finite() && ext_ior.is_finite() && ior > 0.0 && ext_ior > 0.0
            }
            Material::Mirror { reflectance } => reflectance.is_finite() && reflectance.min_element() >= 0.0,
            Material::Conductor { eta, k } => eta.is_finite() && k.is_finite() && eta.min_element() > 0.0,
        };
        if !ok {
            return Err(Error::input(
                "<renderer>",
                format!("materials[{index}]"),
                "values must be finite and positive",
            ));
        }
        if material != self.scene.materials[index] {
            self.scene.materials[index] = material;
            self.base.materials[index] = material;
            self.objects_dirty = true;
            self.invalidate();
        }
        Ok(())
    }

    /// Change the scene's participating medium's coefficients (σs, σa in 1/m, times the
    /// density grid's values where it has one) and phase function; its box and grid stay. Bad
    /// values (negative, not finite, |g| ≥ 1) or a scene without a medium are refused and change
    /// nothing. Every light is redone when anything changed (beams and the light paths through
    /// the medium depend on it).
    pub fn set_medium(&mut self, sigma_s: glam::Vec3, sigma_a: glam::Vec3, phase: crate::scene::Phase) -> Result<()> {
        let bad = |field: &str, m: &str| Error::input("<renderer>", format!("medium.{field}"), m);
        let Some(m) = self.scene.medium.as_ref() else {
            return Err(bad("sigma_s", "the scene has no medium"));
        };
        for (field, v) in [("sigma_s", sigma_s), ("sigma_a", sigma_a)] {
            if !v.is_finite() || v.min_element() < 0.0 {
                return Err(bad(field, "values must be finite and not negative"));
            }
        }
        if let crate::scene::Phase::HenyeyGreenstein { g } = phase
            && !(g.is_finite() && g.abs() < 1.0)
        {
            return Err(bad("phase.g", "must lie strictly between -1 and 1"));
        }
        if (m.sigma_s, m.sigma_a, m.phase) == (sigma_s, sigma_a, phase) {
            return Ok(());
        }
        for sc in [&mut self.scene, &mut self.base] {
            if let Some(m) = sc.medium.as_mut() {
                (m.sigma_s, m.sigma_a, m.phase) = (sigma_s, sigma_a, phase);
            }
        }
        self.invalidate();
        Ok(())
    }

    /// Change the settings; an error (named by setting) leaves the old ones in place. Every
    /// light is redone when anything changed.
    pub fn set_settings(&mut self, settings: RenderSettings) -> Result<()> {
        settings.validate(&self.ctx, &self.scene)?;
        if settings != self.settings {
            self.settings = settings;
            self.refresh_env_segments();
            self.light_dirty.iter_mut().for_each(|d| *d = true);
        }
        Ok(())
    }

    /// What the next frames copy out for inspection (coverage masks, traced photons: tests and
    /// tools). Changing it redoes every light, so that the copies are made.
    pub fn set_inspect(&mut self, inspect: crate::settings::Inspect) {
        if inspect != self.inspect {
            self.inspect = inspect;
            self.invalidate();
        }
    }

    /// Turn the temporal filter of the caustic maps on (with these settings) or off. The
    /// filter runs when a light's maps are redone; kept maps stay as they were filtered.
    pub fn set_temporal(&mut self, temporal: Option<TemporalSettings>) -> Result<()> {
        match temporal {
            None => {
                if self.temporal.take().is_some() {
                    self.invalidate();
                }
            }
            Some(t) => {
                t.validate()?;
                match &mut self.temporal {
                    Some(f) => f.settings = t,
                    None => {
                        self.temporal = Some(TemporalFilter::new(t));
                        self.invalidate();
                    }
                }
            }
        }
        Ok(())
    }

    /// Redo every light on the next frame (what a full frame does).
    pub fn invalidate(&mut self) {
        self.light_dirty.iter_mut().for_each(|d| *d = true);
    }

    /// GPU objects this renderer created so far (read-backs included).
    pub fn created(&self) -> ResourceCounts {
        self.ctx.created()
    }

    /// The last overflow or failure reported by the GPU statistics, if any.
    pub fn last_error(&self) -> Option<&str> {
        self.last_error.as_deref()
    }

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
        let sphere_vis = if spheres_on { self.sphere_visibility()? } else { None };
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
        let mut sphere_stats = None;
        // The direct sphere records, also read by `sphere_volume` in a scene with a medium.
        let mut records = Vec::new();
        if spheres_on && let Some(sp) = &self.spheres {
            ctx.begin_scope("spheres", enc);
            let n_own = self.scene.lights.len();
            let vis = |li: usize, object: usize| -> f32 {
                match (&sphere_vis, li.checked_sub(n_own)) {
                    (Some(v), Some(k)) => v.get(&object).and_then(|r| r.get(k)).copied().unwrap_or(1.0),
                    _ => 1.0,
                }
            };
            // The environment's regions spread over their sub-directions (`env_taps`).
            // (`sphere_visibility` has one value per such light.)
            let sphere_lights = match (&self.scene.environment, &self.env_taps) {
                (Some(env), Some((_, taps))) if s.environment.taps >= 2 => {
                    let drawn: Vec<bool> = self.env_segments().iter().map(|l| l.facing.max_element() > 0.0).collect();
                    let rot = environment_lights::rotation(env.rotate_y);
                    crate::caustic_spheres::gpu::spread_lights(&scene.lights, n_own, taps, &drawn, rot)
                }
                _ => scene.lights.clone(),
            };
            records = sp.records(&sphere_lights, &self.transforms, self.sphere_blend, vis);
            use crate::caustic_spheres::gpu::{record_compile, record_gather};
            sphere_stats = Some(if sp.compiled {
                // Section 6: each object's records summed into its compiled table first (the
                // records grouped by object, in the order of the tables).
                let mut grouped = Vec::with_capacity(records.len());
                for (oi, _, _) in &sp.objects {
                    grouped.extend(records.iter().filter(|r| r.base[1] == *oi as u32).copied());
                }
                let objects = sp.compiled_records(&self.transforms);
                let compiled = record_compile(&dc, sp, &grouped, &objects, enc, &mut timer);
                record_gather(&dc, &eye, (sp, &compiled), &objects, enc, &mut timer)
            } else {
                record_gather(&dc, &eye, (sp, &sp.table), &records, enc, &mut timer)
            });
            ctx.end_scope();
        }
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
        if let Some(sp) = self.spheres.as_ref().filter(|_| scene.medium.is_some() && !records.is_empty()) {
            let vol = (&sp.table, &records[..]);
            crate::caustic_spheres::gpu::record_volume(
                &dc,
                &eye,
                vol,
                s.medium.steps,
                (&full, &caustic),
                enc,
                &mut timer,
            );
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

    /// Start mapping the slots recorded by submitted frames.
    fn map_recorded(&mut self) {
        for slot in &self.ring {
            if slot.state.compare_exchange(1, 2, Ordering::AcqRel, Ordering::Acquire).is_ok() {
                let state = slot.state.clone();
                slot.staging.map_async(wgpu::MapMode::Read, .., move |r| {
                    state.store(if r.is_ok() { 3 } else { 4 }, Ordering::Release);
                });
            }
        }
    }

    /// Read the mapped slots; keep the newest frame's statistics.
    fn collect(&mut self) -> Result<()> {
        let period = self.ctx.queue.get_timestamp_period();
        let mut order: Vec<usize> = (0..self.ring.len()).collect();
        order.sort_by_key(|&i| self.ring[i].job.as_ref().map_or(0, |j| j.frame));
        for i in order {
            let slot = &mut self.ring[i];
            match slot.state.load(Ordering::Acquire) {
                3 => {}
                4 => {
                    slot.job = None;
                    slot.state.store(0, Ordering::Release);
                    return Err(Error::Device("reading the frame statistics failed".into()));
                }
                _ => continue,
            }
            let job = slot.job.take().expect("a mapped slot has a job");
            let data = slot.staging.get_mapped_range(..).map_err(|e| Error::Device(format!("{e:?}")))?.to_vec();
            slot.staging.unmap();
            slot.state.store(0, Ordering::Release);
            let piece = |off: u64, size: u64| data[off as usize..(off + size) as usize].to_vec();
            let mut stats = FrameStats {
                frame: job.frame,
                timings: job
                    .timer
                    .as_ref()
                    .map(|(names, off, size)| PassTimer::timings(names, &piece(*off, *size), period))
                    .unwrap_or_default(),
                flux: job
                    .flux
                    .iter()
                    .map(|&(off, scale)| crate::passes::flux_stats(&piece(off, crate::output::FLUX_STATS_BYTES), scale))
                    .collect(),
                lights_redone: job.lights_redone,
                ..Default::default()
            };
            stats.technique = TechniqueStats {
                technique: self.settings.photons.technique,
                grid: self.settings.photons.count,
                ..Default::default()
            };
            for (p, pieces) in job.pendings {
                let bytes: Vec<Vec<u8>> = pieces.iter().map(|&(off, size)| piece(off, size)).collect();
                match p.finish(&bytes) {
                    // The lights report their emission technique; the frame's is the setting.
                    Ok(t) => stats.technique.merge(&TechniqueStats { technique: self.settings.photons.technique, ..t }),
                    Err(e) => {
                        let m = e.to_string();
                        self.last_error = Some(m.clone());
                        stats.overflow = Some(m);
                    }
                }
            }
            if let Some(off) = job.sphere_stats {
                let c = piece(off, 4);
                stats.sphere_stack_overflows = u64::from(u32::from_le_bytes([c[0], c[1], c[2], c[3]]));
            }
            if stats.sphere_stack_overflows > 0 {
                let m = format!(
                    "{} caustic-sphere occlusion rays overflowed the BVH traversal stack: those pixels got no caustic \
                     from that object",
                    stats.sphere_stack_overflows
                );
                self.last_error = Some(m.clone());
                stats.overflow.get_or_insert(m);
            }
            let overflows: u64 = stats.flux.iter().map(|f| f.stack_overflows).sum();
            if overflows > 0 {
                let m = format!(
                    "{overflows} photon rays overflowed the BVH traversal stack ({} entries) and may have missed \
                     a surface",
                    crate::accel::BVH_STACK
                );
                self.last_error = Some(m.clone());
                stats.overflow.get_or_insert(m);
            }
            if self.latest.as_ref().is_none_or(|l| l.frame <= stats.frame) {
                self.latest = Some(stats);
            }
        }
        Ok(())
    }

    /// The statistics of the newest frame that asked for them and that the GPU has finished,
    /// if not returned before. Never blocks.
    pub fn poll_stats(&mut self) -> Result<Option<FrameStats>> {
        self.map_recorded();
        let _ = self.ctx.device.poll(wgpu::PollType::Poll);
        self.collect()?;
        Ok(self.latest.take())
    }

    /// Wait for the statistics of every submitted frame that asked for them; the newest.
    pub fn wait_stats(&mut self) -> Result<Option<FrameStats>> {
        self.map_recorded();
        self.ctx
            .device
            .poll(wgpu::PollType::Wait { submission_index: None, timeout: None })
            .map_err(|e| Error::Device(format!("{e}")))?;
        // On a device that other threads poll too, one of them may be about to run a mapping's
        // callback when our wait returns: wait for it.
        let start = std::time::Instant::now();
        while self.ring.iter().any(|s| s.state.load(Ordering::Acquire) == 2) {
            if start.elapsed().as_secs() > 60 {
                return Err(Error::Device("the frame statistics were never mapped".into()));
            }
            let _ = self.ctx.device.poll(wgpu::PollType::Poll);
            std::thread::sleep(std::time::Duration::from_micros(200));
        }
        self.collect()?;
        Ok(self.latest.take())
    }

    fn last_outputs(&self) -> Result<&(wgpu::Buffer, wgpu::Buffer, wgpu::Texture)> {
        self.outputs.as_ref().ok_or_else(|| Error::Device("no frame rendered yet".into()))
    }

    /// Read the last frame's linear radiance back (blocking; screenshots, tests).
    pub fn read_image(&self) -> Result<Image> {
        let c = &self.scene.camera;
        let data = self.ctx.read_buffer(&self.last_outputs()?.0, c.width as u64 * c.height as u64 * 16)?;
        Ok(bytes_to_image(&data, c.width, c.height))
    }

    /// Read the last frame's caustic-only radiance back (blocking).
    pub fn read_caustic_image(&self) -> Result<Image> {
        let c = &self.scene.camera;
        let data = self.ctx.read_buffer(&self.last_outputs()?.1, c.width as u64 * c.height as u64 * 16)?;
        Ok(bytes_to_image(&data, c.width, c.height))
    }

    fn light_frame(&self, light: usize) -> Result<&LightFrame> {
        self.lights
            .get(light)
            .and_then(|l| l.as_ref())
            .map(|l| &l.frame)
            .ok_or_else(|| Error::Device(format!("light {light}: no such light, or no frame rendered yet")))
    }

    /// Read light `light`'s caustic irradiance maps back, one image per face (blocking).
    pub fn read_caustic_maps(&self, light: usize) -> Result<Vec<Image>> {
        let lf = self.light_frame(light)?;
        let m = self.settings.photons.caustic_map_size;
        let texels = m as u64 * m as u64;
        let irr = self.ctx.read_buffer(&lf.irradiance, texels * lf.faces as u64 * 16)?;
        Ok((0..lf.faces as u64)
            .map(|f| bytes_to_image(&irr[(f * texels * 16) as usize..((f + 1) * texels * 16) as usize], m, m))
            .collect())
    }

    /// Read light `light`'s raw fixed-point flux per texel (r, g, b words per texel, all faces).
    pub fn read_caustic_flux_bits(&self, light: usize) -> Result<Vec<u64>> {
        let lf = self.light_frame(light)?;
        let m = self.settings.photons.caustic_map_size as u64;
        let acc = self.ctx.read_buffer(&lf.accum, m * m * lf.faces as u64 * 24)?;
        Ok(acc.chunks_exact(8).map(|c| u64::from_le_bytes(c.try_into().unwrap())).collect())
    }

    /// The light-space buffers of the last frame (and the caustic maps `maps`, one list of faces
    /// per light) as images to look at (blocking).
    pub fn dump_images(&self, maps: &[Vec<Image>]) -> Result<Vec<crate::passes::DumpImage>> {
        let n = self.scene.lights.len();
        let lights: Vec<_> = (0..n)
            .map(|l| {
                let p = self.light_frame(l)?;
                let mut bufs =
                    vec![("receivers", &p.recv), ("caster_front", &p.casters.0), ("caster_back", &p.casters.1)];
                if let Some((front2, back2)) = &p.casters2 {
                    bufs.extend([("caster_front2", front2), ("caster_back2", back2)]);
                }
                Ok((bufs, p.faces))
            })
            .collect::<Result<_>>()?;
        crate::passes::dump_images(&self.ctx, &lights, maps)
    }

    /// Render one frame, wait for it and read everything back (the one-shot render of
    /// [`crate::passes::render`]).
    pub fn render_once(&mut self) -> Result<GpuRender> {
        let ctx = self.ctx.clone();
        let val_scope = ctx.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let oom_scope = ctx.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let mut enc = ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame") });
        // (its beam statistics are read: the hulls' fragments counted too)
        self.count_fragments = true;
        let recorded = self.encode(&mut enc, FrameRequest { stats: true }).map(|_| ());
        self.count_fragments = false;
        let submitted = std::time::Instant::now();
        let polled = if recorded.is_ok() {
            ctx.queue.submit([enc.finish()]);
            ctx.device.poll(wgpu::PollType::Wait { submission_index: None, timeout: None }).map(|_| ())
        } else {
            Ok(())
        };
        let frame_wall_ms = submitted.elapsed().as_secs_f64() * 1e3;
        let oom = pollster::block_on(oom_scope.pop());
        let val = pollster::block_on(val_scope.pop());
        recorded?;
        if let Some(e) = oom {
            return Err(Error::Device(format!("out of GPU memory: {e}")));
        }
        if let Some(e) = val {
            return Err(Error::Device(format!("{e}")));
        }
        polled.map_err(|e| Error::Device(format!("{e}")))?;
        let stats = self.wait_stats()?.ok_or_else(|| Error::Device("the frame's statistics were not read".into()))?;
        if let Some(m) = stats.overflow {
            return Err(Error::Device(m));
        }
        let n = self.scene.lights.len();
        let caustic_maps = (0..n).map(|l| self.read_caustic_maps(l)).collect::<Result<Vec<_>>>()?;
        let caustic_flux_bits = (0..n).map(|l| self.read_caustic_flux_bits(l)).collect::<Result<Vec<_>>>()?;
        let technique = stats.technique;
        let beams = self.beam_frames.iter().map(|f| crate::beams::read_frame(&ctx, f)).collect::<Result<Vec<_>>>()?;
        if let Some(b) = beams.iter().find(|b| b.0.overflow > 0) {
            return Err(Error::Device(format!(
                "beam buffer overflow: {} beams did not fit (capacity {}; raise beams.capacity)",
                b.0.overflow, self.settings.beams.capacity
            )));
        }
        Ok(GpuRender {
            beams,
            image: self.read_image()?,
            caustic: self.read_caustic_image()?,
            caustic_maps,
            caustic_flux_bits,
            flux: stats.flux,
            timings: stats.timings,
            frame_wall_ms,
            photons_traced: technique.photons_traced,
            batches: technique.batches,
            technique,
            adapter: format!("{} ({:?}, {})", ctx.info.name, ctx.info.backend, ctx.info.driver),
        })
    }

    /// [`Renderer::render_once`] with `filter` as the temporal filter (it is handed back).
    pub(crate) fn render_once_filtered(&mut self, filter: &mut TemporalFilter) -> Result<GpuRender> {
        self.temporal = Some(std::mem::replace(filter, TemporalFilter::new(filter.settings)));
        let out = self.render_once();
        if let Some(f) = self.temporal.take() {
            *filter = f;
        }
        out
    }
}

/// A free statistics slot whose staging buffer holds `size` bytes (grown if needed); None when
/// every slot waits to be read (the frame's statistics are then not copied).
fn free_slot(ring: &mut Vec<StatsSlot>, ctx: &GpuContext, size: u64) -> Option<usize> {
    let staging = |size: u64| {
        let usage = wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST;
        ctx.kept_buffer("frame_statistics", size.next_power_of_two(), usage)
    };
    let i = match ring.iter().position(|s| s.state.load(Ordering::Acquire) == 0) {
        Some(i) => i,
        None if ring.len() < STATS_SLOTS => {
            ring.push(StatsSlot { staging: staging(size), state: Arc::new(AtomicU8::new(0)), job: None });
            ring.len() - 1
        }
        None => return None,
    };
    if ring[i].staging.size() < size {
        ring[i].staging = staging(size);
    }
    Some(i)
}

/// Whether an axis-aligned box can be seen in a view (conservative: a box reaching behind the
/// viewer counts as seen).
fn box_in_view((lo, hi): (glam::Vec3, glam::Vec3), world_to_clip: glam::Mat4) -> bool {
    let mut outside = [true; 6];
    for k in 0..8 {
        let p = glam::Vec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        );
        let c = world_to_clip * p.extend(1.0);
        if c.w <= 0.0 {
            return true;
        }
        let planes = [c.x < -c.w, c.x > c.w, c.y < -c.w, c.y > c.w, c.z < 0.0, c.z > c.w];
        for (o, p) in outside.iter_mut().zip(planes) {
            *o &= p;
        }
    }
    !outside.iter().any(|&o| o)
}

impl TemporalFilter {
    /// Render a frame of `scene` like [`crate::passes::render`], with every light's caustic
    /// maps filtered against this filter's history before shading.
    pub fn render(&mut self, ctx: &GpuContext, scene: &Scene, settings: &RenderSettings) -> Result<GpuRender> {
        self.settings.validate()?;
        let mut r = crate::renderer::Renderer::with_context(ctx.clone(), scene.clone(), settings.clone())?;
        let out = r.render_once_filtered(self);
        // The environment's directional lights have histories too.
        self.lights.truncate(r.lights().len());
        out
    }
}
