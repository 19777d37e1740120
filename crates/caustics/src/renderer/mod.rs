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
//! scale), the vertices of deformed meshes ([`Renderer::set_mesh_vertices`]: their BVH refit,
//! not rebuilt), the settings and the temporal filter. A fresh renderer brought to the same state
//! renders the same maps and image bit for bit as one that got there frame by frame.
//!
//! This file holds the renderer's state and its setters and getters; [`Renderer::encode`] lives in
//! `encode`, the environment's lights in `environment`, the statistics ring in `stats`, and the
//! blocking read-backs and one-shot render in `readback`.

use crate::error::{Error, Result};
use crate::frame::Change;
use crate::gpu::GpuContext;
pub use crate::gpu::ResourceCounts;
use crate::output::FluxStats;
use crate::passes::Geometry;
use crate::scene::environment_lights::{self, EnvironmentLight};
use crate::scene::{Camera, Light, Material, Scene, Shape};
use crate::settings::RenderSettings;
use crate::techniques::TechniqueStats;
use crate::temporal::{TemporalFilter, TemporalSettings};
use glam::{Affine3A, Vec3};
use std::sync::Arc;

mod encode;
mod environment;
mod features;
mod readback;
mod stats;

pub use readback::BvhReadback;
use stats::StatsSlot;

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
    /// Per light, in the order of [`Renderer::lights`]: its maps.
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
    /// Interreflection: photon deposits that found no slot in the cache (`indirect.capacity`
    /// too small; that light is missing from the frame).
    pub indirect_lost_deposits: u64,
    /// Interreflection, in frames that rebuilt the cache: the flux (W; r, g, b) reaching
    /// diffuse surfaces at each bounce order from 2 (after one diffuse bounce; the last entry
    /// holds order 9 and up), summed over the lights. Empty otherwise.
    pub indirect_order_flux: Vec<[f64; 3]>,
}

/// What an environment segmentation was made for: D and the split rule.
type SegmentKey = (u32, environment_lights::SplitRule);
/// The segmentation and the sub-directions per region (`RenderSettings::env_taps`).
type TapsKey = (SegmentKey, u32);

/// The persistent GPU renderer (module documentation).
pub struct Renderer {
    ctx: GpuContext,
    /// The scene as loaded, and as it is now (object transforms baked in).
    base: Scene,
    scene: Scene,
    transforms: Vec<Affine3A>,
    settings: RenderSettings,
    geometry: Option<(crate::scene::Tessellation, Geometry)>,
    objects_dirty: bool,
    /// Mesh objects deformed since the last frame ([`Renderer::set_mesh_vertices`]): the next
    /// frame rewrites their vertices and refits their BVH.
    deformed: Vec<usize>,
    /// Counts mesh deformations (part of what keys the caustic spheres' visibility).
    deformations: u64,
    /// The frame's features and their persistent state ([`crate::frame`]).
    features: features::Features,
    frame: u64,
    outputs: Option<(wgpu::Buffer, wgpu::Buffer, wgpu::Texture)>,
    ring: Vec<StatsSlot>,
    latest: Option<FrameStats>,
    last_error: Option<String>,
    /// The environment's segmentation in the map's own frame, and the D it was made for.
    env_segments: Option<(SegmentKey, Arc<Vec<EnvironmentLight>>)>,
    /// Each region's sub-directions (`crate::env_taps`) and the (segmentation, K) they are for.
    env_taps: Option<(TapsKey, Arc<Vec<crate::env_taps::RegionTaps>>)>,
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
        if let Some(w) = settings.absorption_warning(&scene) {
            eprintln!("warning: {w}");
        }
        let n = scene.objects.len();
        Ok(Renderer {
            ctx,
            base: scene.clone(),
            scene,
            transforms: vec![Affine3A::IDENTITY; n],
            settings,
            geometry: None,
            objects_dirty: true,
            deformed: Vec::new(),
            deformations: 0,
            features: features::Features::default(),
            frame: 0,
            outputs: None,
            ring: Vec::new(),
            latest: None,
            last_error: None,
            env_segments: None,
            env_taps: None,
        }
        .with_env_segments())
    }

    fn with_env_segments(mut self) -> Renderer {
        self.refresh_env_segments();
        self
    }

    /// The device and caches it renders with.
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// The scene as it is now: camera, lights and objects with their transforms applied.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The settings as they are now.
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
    /// `sources.distant = spheres` they give the caustics of every directional light
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
        self.features.spheres.spheres = Some(crate::caustic_spheres::gpu::GpuSpheres::new(&self.ctx, objects, half)?);
        self.features.spheres.blend = blend;
        Ok(())
    }

    /// Caustic spheres: the compiled variant (section 6 of the paper: per frame, every light
    /// summed into one table per object by `sphere_compile`, then one lookup per object in
    /// `sphere_gather`) or the direct one (a lookup per light and blended direction; the
    /// default). No effect before `set_caustic_spheres`.
    pub fn set_caustic_spheres_compiled(&mut self, compiled: bool) {
        if let Some(sp) = self.features.spheres.spheres.as_mut() {
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
        if let Some(sp) = self.features.spheres.spheres.as_mut() {
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
        if let Some(sp) = self.features.spheres.spheres.as_mut() {
            sp.stack_limit = limit;
        }
        Ok(())
    }

    /// Bytes of the caustic sphere tables on the GPU (0 without).
    pub fn caustic_sphere_bytes(&self) -> u64 {
        self.features.spheres.spheres.as_ref().map_or(0, |s| s.bytes)
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
        self.features.changed(Change::Light(index));
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
        self.redo_lights_seeing(before, after);
        self.objects_dirty = true;
        Ok(())
    }

    /// Redo the lights whose views see the box `before` or `after` (an object's bounds before
    /// and after it changed).
    fn redo_lights_seeing(&mut self, before: (Vec3, Vec3), after: (Vec3, Vec3)) {
        for (l, light) in self.lights_now().iter().enumerate() {
            let view = self.settings.light_view(&self.scene, light);
            if view.faces.iter().any(|f| box_in_view(before, f.world_to_clip) || box_in_view(after, f.world_to_clip)) {
                self.features.changed(Change::Light(l));
            }
        }
    }

    /// Pose the scene's animated objects (`waves`) at time `t` (seconds; the scene file poses
    /// them at 0): each one's mesh is deformed ([`Renderer::set_mesh_vertices`]: its BVH refit
    /// on the GPU in the next frame, the lights that see it redone). Nothing else changes.
    pub fn set_time(&mut self, t: f32) -> Result<()> {
        if !t.is_finite() {
            return Err(Error::input("<renderer>", "time", format!("must be a finite number of seconds (got {t})")));
        }
        for i in 0..self.base.objects.len() {
            if let Some(w) = self.base.objects[i].waves.clone() {
                let m = w.mesh(t);
                self.set_mesh_vertices(i, &m.positions, &m.normals)?;
            }
        }
        Ok(())
    }

    /// Deform mesh object `index`: its vertices' new `positions` and shading `normals`, in the
    /// scene file's pose (its transform, [`Renderer::set_object_transform`], still applies), as
    /// many as the mesh has; its triangles stay. The next frame rewrites the vertices on the GPU
    /// and refits the mesh's BVH there (its topology kept, its boxes recomputed: the pass
    /// `bvh_refit` of the frame's timings). The lights that see the mesh before or after are
    /// redone. An object that is no mesh, a wrong count or a value that is not finite is
    /// refused and changes nothing. Precomputed caustic spheres of the object
    /// ([`Renderer::set_caustic_spheres`]) are not recomputed: they stay those of its old shape.
    pub fn set_mesh_vertices(&mut self, index: usize, positions: &[Vec3], normals: &[Vec3]) -> Result<()> {
        let field = |f: &str| format!("objects[{index}]{f}");
        let Some(o) = self.base.objects.get(index) else {
            return Err(Error::input("<renderer>", field(""), "no such object"));
        };
        let Shape::Mesh(m) = &o.shape else {
            return Err(Error::input(
                "<renderer>",
                field(".shape"),
                "is not a mesh: only a mesh's vertices can be set",
            ));
        };
        for (name, given, want) in [("positions", positions, m.positions.len()), ("normals", normals, m.normals.len())]
        {
            if given.len() != want {
                return Err(Error::input(
                    "<renderer>",
                    field(&format!(".{name}")),
                    format!("the mesh has {want} vertices, {} {name} were given", given.len()),
                ));
            }
            if let Some(i) = given.iter().position(|v| !v.is_finite()) {
                return Err(Error::input("<renderer>", field(&format!(".{name}[{i}]")), "values must be finite"));
            }
        }
        let Shape::Mesh(m) = &mut self.base.objects[index].shape else { unreachable!("checked above") };
        if m.positions == positions && m.normals == normals {
            return Ok(());
        }
        let mesh = Arc::make_mut(m);
        mesh.positions.copy_from_slice(positions);
        mesh.normals.copy_from_slice(normals);
        let base = &self.base.objects[index].shape;
        let t = self.transforms[index];
        let shape = if t == Affine3A::IDENTITY {
            // The scene file's pose: the same mesh (a fresh renderer of the deformed scene has it).
            base.clone()
        } else {
            base.transformed(&t).map_err(|m| Error::input("<renderer>", field(".transform"), m))?
        };
        let before = self.scene.objects[index].shape.bounds();
        self.scene.objects[index].shape = shape;
        let after = self.scene.objects[index].shape.bounds();
        self.redo_lights_seeing(before, after);
        if !self.deformed.contains(&index) {
            self.deformed.push(index);
        }
        self.deformations += 1;
        Ok(())
    }

    /// Replace material `index` (same kind of surface or not). Every light is redone, since any
    /// of them may see an object made of it.
    pub fn set_material(&mut self, index: usize, material: Material) -> Result<()> {
        if index >= self.scene.materials.len() {
            return Err(Error::input("<renderer>", format!("materials[{index}]"), "no such material"));
        }
        let ok = match material {
            Material::Diffuse { albedo } => albedo.is_finite() && albedo.min_element() >= 0.0,
            Material::Dielectric { ior, ext_ior, absorption } => {
                ior.is_finite()
                    && ext_ior.is_finite()
                    && ior > 0.0
                    && ext_ior > 0.0
                    && absorption.is_finite()
                    && absorption.min_element() >= 0.0
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
            // (once, when the settings start using beams or caustic spheres)
            if let Some(w) = settings.absorption_warning(&self.scene)
                && self.settings.absorption_warning(&self.scene).is_none()
            {
                eprintln!("warning: {w}");
            }
            self.settings = settings;
            self.refresh_env_segments();
            self.invalidate();
        }
        Ok(())
    }

    /// What the next frames copy out for inspection (coverage masks, traced photons: tests and
    /// tools). Changing it redoes every light, so that the copies are made.
    pub fn set_inspect(&mut self, inspect: crate::settings::Inspect) {
        if inspect != self.features.photon_maps.inspect {
            self.features.photon_maps.inspect = inspect;
            self.invalidate();
        }
    }

    /// Turn the temporal filter of the caustic maps on (with these settings) or off. The
    /// filter runs when a light's maps are redone; kept maps stay as they were filtered.
    pub fn set_temporal(&mut self, temporal: Option<TemporalSettings>) -> Result<()> {
        match temporal {
            None => {
                if self.features.photon_maps.temporal.take().is_some() {
                    self.invalidate();
                }
            }
            Some(t) => {
                t.validate()?;
                match &mut self.features.photon_maps.temporal {
                    Some(f) => f.settings = t,
                    None => {
                        self.features.photon_maps.temporal = Some(TemporalFilter::new(t));
                        self.invalidate();
                    }
                }
            }
        }
        Ok(())
    }

    /// Redo every light on the next frame (what a full frame does).
    pub fn invalidate(&mut self) {
        self.features.changed(Change::Lights);
    }

    /// Whether the next frame would still refine a progressive cache (`indirect.history` > 1,
    /// within its frames after a change of a light or an object): a frame loop that renders
    /// only on change keeps rendering while this holds, then the image is settled.
    pub fn refining(&self) -> bool {
        self.features.indirect.refining()
    }

    /// GPU objects this renderer created so far (read-backs included).
    pub fn created(&self) -> ResourceCounts {
        self.ctx.created()
    }

    /// The last overflow or failure reported by the GPU statistics, if any.
    pub fn last_error(&self) -> Option<&str> {
        self.last_error.as_deref()
    }
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
