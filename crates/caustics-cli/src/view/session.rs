//! The viewer's state and everything it can do, without a window: a [`Session`] owns the
//! persistent [`Renderer`] on the caller's device, takes [`Action`]s (what the mouse, keys and
//! panels ask for), renders frames on demand and keeps the CPU reference job. The window
//! (`window.rs`) and the panels (`ui.rs`) only translate input into actions; the tests drive a
//! session the same way without a display.

use super::camera::Orbit;
use super::pick::{self, Selection};
use super::reference::{self, Job, Rgba};
use caustics::image_io::Image;
use caustics::render::RenderSettings;
use caustics::renderer::{FrameRequest, FrameStats, Renderer};
use caustics::scene::{Light, Material};
use caustics::splat::SplatMode;
use caustics::techniques::Technique;
use caustics::temporal::TemporalSettings;
use caustics::{Error, Result, Scene};
use caustics_reference::ImageIo;
use caustics_reference::reference::ReferenceSettings;
use caustics_reference::reference::geometry::Accel;
use glam::{Affine3A, Vec2, Vec3};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Modifier keys held when a drag starts.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Mods {
    /// Ctrl (or Cmd): rotate the selected object, aim the selected spot light.
    pub rotate: bool,
}

/// What the user can ask of the viewer. Positions are image pixels of the rendered view
/// ((0,0) = top-left), motions are pixels.
#[derive(Debug, Clone)]
pub enum Action {
    /// The view area changed size: the camera's image becomes `width` × `height`.
    Resize {
        width: u32,
        height: u32,
    },
    Orbit {
        dx: f32,
        dy: f32,
    },
    Pan {
        dx: f32,
        dy: f32,
    },
    /// Wheel notches (positive: closer).
    Zoom {
        steps: f32,
    },
    /// A primary-button press: picks a light or an object, or a spot light's axis handle (or,
    /// with [`Mods::rotate`], starts rotating the selected object or aiming the selected spot
    /// light). A press on nothing keeps the selection.
    Press {
        x: f32,
        y: f32,
        mods: Mods,
    },
    /// The pointer moved with the button held.
    Drag {
        x: f32,
        y: f32,
    },
    Release,
    Select(Option<Selection>),
    SetTechnique(Technique),
    SetSplat(SplatMode),
    SetTracer(caustics::render::Tracer),
    /// The photon grid N (N × N per light-view face).
    SetPhotons(u32),
    SetTolerance(f32),
    /// Any other settings change (the panel's less common switches).
    SetSettings(Box<RenderSettings>),
    SetTemporal(bool),
    /// Time-budget mode: the photon grid (and tolerance) follows a frame time in ms; None: off.
    SetBudget(Option<f64>),
    SetLight(usize, Light),
    SetObjectTransform(usize, Affine3A),
    /// The index of refraction of dielectric material `material`.
    SetIor {
        material: usize,
        ior: f32,
    },
    /// The participating medium's scattering and absorption coefficients (1/m) and phase
    /// function; its box and density grid stay as loaded.
    SetMedium {
        sigma_s: glam::Vec3,
        sigma_a: glam::Vec3,
        phase: caustics::scene::Phase,
    },
    /// Turn the environment light to this many degrees about +Y (its directional lights turn
    /// with it, no re-segmentation).
    SetEnvironmentRotation(f32),
    /// Write the current image (PNG tone-mapped, EXR linear, by extension).
    Screenshot(PathBuf),
    /// Write the current image as the next numbered PNG + EXR pair in the screenshot folder.
    ScreenshotPair,
    SetViewMode(ViewMode),
    /// Start the CPU reference of the current view now.
    StartReference,
    CancelReference,
    /// HDR-FLIP of the GPU frame against the reference of this view (blocking, about a second).
    ComputeFlip,
}

/// What the view area shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ViewMode {
    /// The GPU renderer's image.
    #[default]
    Gpu,
    /// The CPU reference of the same view.
    Reference,
    /// GPU on the left, reference on the right of a divider.
    Split,
    /// The difference heat map.
    Difference,
}

impl ViewMode {
    pub const ALL: [ViewMode; 4] = [ViewMode::Gpu, ViewMode::Reference, ViewMode::Split, ViewMode::Difference];
    pub fn name(self) -> &'static str {
        match self {
            ViewMode::Gpu => "GPU",
            ViewMode::Reference => "CPU reference",
            ViewMode::Split => "A/B split",
            ViewMode::Difference => "difference",
        }
    }
}

#[derive(Debug, Clone)]
enum Drag {
    MoveLight {
        light: usize,
        start: Vec3,
        anchor: Vec3,
    },
    AimLight {
        light: usize,
    },
    /// The end of a spot light's axis handle, dragged in the plane facing the camera.
    AimHandle {
        light: usize,
        anchor: Vec3,
    },
    MoveObject {
        object: usize,
        t0: Affine3A,
        anchor: Vec3,
    },
    RotateObject {
        object: usize,
        t0: Affine3A,
        centre: Vec3,
        start: Vec2,
    },
}

/// The CPU reference of one view, and how the GPU image compares with it.
pub struct ReferenceView {
    pub generation: u64,
    pub image: Image,
    pub rgba: Rgba,
    /// The difference heat map against the latest GPU frame, and the mean absolute tone-mapped
    /// difference (0..1).
    pub diff: Option<(Rgba, f64)>,
    /// Relative MSE of the GPU frame against the reference.
    pub rel_mse: Option<f64>,
    /// HDR-FLIP mean of the GPU frame against the reference, when asked for
    /// ([`Action::ComputeFlip`]; it takes about a second at window sizes).
    pub flip: Option<f64>,
    /// The GPU frame compared.
    gpu: Option<Image>,
    pub seconds: f64,
    /// Bumped whenever `rgba` or `diff` change (the window re-uploads them).
    pub version: u64,
}

/// Radians of object rotation per pixel of a ctrl-drag.
const ROTATE_RAD_PER_PIXEL: f32 = 0.01;
/// Frames rendered after the last change when the temporal filter is on.
const TEMPORAL_SETTLE_FRAMES: u32 = 8;
/// The automatic reference waits this long after the last change of the view.
const REFERENCE_DELAY: Duration = Duration::from_millis(400);

/// The viewer without its window (module documentation).
pub struct Session {
    device: wgpu::Device,
    queue: wgpu::Queue,
    /// The scene as loaded, with the materials the panel changed.
    base: Scene,
    renderer: Renderer,
    orbit: Orbit,
    pub selection: Option<Selection>,
    drag: Option<Drag>,
    geometry_version: u64,
    accel: Option<(u64, Arc<Accel>)>,
    generation: u64,
    changed_at: Instant,
    dirty: bool,
    temporal: bool,
    /// Time-budget mode (`caustics::budget`), fed with the frames that redid a light.
    budget: Option<caustics::budget::BudgetController>,
    /// With the temporal filter on, frames still to render after the last change so that the
    /// filter's history converges.
    settle: u32,
    /// The latest error of the library (shown in the panel), cleared by the next success.
    pub error: Option<String>,
    /// A line about the latest thing done (screenshots).
    pub status: String,
    pub stats: Option<FrameStats>,
    /// Host milliseconds from the start of recording the latest frame to the GPU finishing it.
    pub frame_ms: Option<f64>,
    frame_started: Option<Instant>,
    frame_done: Arc<Mutex<Option<Instant>>>,
    /// A rendered frame's statistics have not arrived yet.
    stats_pending: bool,
    frames: u64,
    display: Option<wgpu::Texture>,
    pub view_mode: ViewMode,
    pub reference_settings: ReferenceSettings,
    job: Option<Job>,
    reference: Option<ReferenceView>,
    /// The generation whose reference failed (not restarted automatically).
    reference_failed: Option<u64>,
    reference_version: u64,
    screenshot_dir: PathBuf,
    screenshots: u32,
    /// `Technique::CausticSpheres`: the tables' settings (the command line's) and the tables
    /// of the base scene's caustic objects, loaded or precomputed when first needed (a moved
    /// object is looked up in its own frame, so moves keep them).
    pub sphere_args: crate::spheres::SphereArgs,
    sphere_tables: Option<Vec<(usize, Arc<caustics::caustic_spheres::CausticSpheres>)>>,
}

impl Session {
    /// A session on the caller's device (made with `GpuContext::device_requirements`).
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: Scene,
        settings: RenderSettings,
        screenshot_dir: PathBuf,
    ) -> Result<Session> {
        let renderer = Renderer::new(device, queue, scene.clone(), settings)?;
        let orbit = Orbit::from_camera(&scene.camera);
        Ok(Session {
            device: device.clone(),
            queue: queue.clone(),
            base: scene,
            renderer,
            orbit,
            selection: None,
            drag: None,
            geometry_version: 0,
            accel: None,
            generation: 0,
            changed_at: Instant::now(),
            dirty: true,
            temporal: false,
            budget: None,
            settle: 0,
            error: None,
            status: String::new(),
            stats: None,
            frame_ms: None,
            frame_started: None,
            frame_done: Arc::new(Mutex::new(None)),
            stats_pending: false,
            frames: 0,
            display: None,
            view_mode: ViewMode::Gpu,
            reference_settings: ReferenceSettings { photons_per_light: 1 << 20, camera_spp: 4, ..Default::default() },
            job: None,
            reference: None,
            reference_failed: None,
            reference_version: 0,
            screenshot_dir,
            screenshots: 0,
            sphere_args: crate::spheres::SphereArgs::default(),
            sphere_tables: None,
        })
    }

    pub fn renderer(&self) -> &Renderer {
        &self.renderer
    }
    /// The scene as it is now (camera, lights, objects moved).
    pub fn scene(&self) -> &Scene {
        self.renderer.scene()
    }
    pub fn settings(&self) -> &RenderSettings {
        self.renderer.settings()
    }
    /// The participating medium as loaded (the panel's density is relative to it).
    pub fn loaded_medium(&self) -> Option<&caustics::scene::Medium> {
        self.base.medium.as_ref()
    }
    /// The time budget's controller, when the mode is on.
    pub fn budget(&self) -> Option<&caustics::budget::BudgetController> {
        self.budget.as_ref()
    }

    pub fn temporal(&self) -> bool {
        self.temporal
    }
    /// Counts changes of the view (camera, lights, objects, materials): a reference of another
    /// generation is stale.
    #[cfg(test)]
    pub fn generation(&self) -> u64 {
        self.generation
    }
    /// Whether a light or object is being dragged.
    pub fn dragging(&self) -> bool {
        self.drag.is_some()
    }
    /// Frames rendered so far.
    pub fn frames(&self) -> u64 {
        self.frames
    }
    /// Whether the next [`Session::render`] will render (something changed).
    pub fn needs_frame(&self) -> bool {
        self.dirty
    }
    /// The latest frame's display texture (Rgba8Unorm, sRGB-encoded values).
    pub fn display(&self) -> Option<&wgpu::Texture> {
        self.display.as_ref()
    }
    /// The reference of the current view, if computed.
    pub fn reference(&self) -> Option<&ReferenceView> {
        self.reference.as_ref().filter(|r| r.generation == self.generation)
    }
    /// Progress (0..1) of the reference being computed, if one is.
    pub fn reference_progress(&self) -> Option<f64> {
        self.job.as_ref().map(|j| j.progress.fraction())
    }
    /// The base material index of object `i`.
    pub fn material_of(&self, object: usize) -> Option<(usize, Material)> {
        let o = self.base.objects.get(object)?;
        Some((o.material, *self.base.materials.get(o.material)?))
    }

    /// Do `action`; a library error is returned (and kept in [`Session::error`]) and leaves the
    /// state as it was.
    pub fn act(&mut self, action: Action) -> Result<()> {
        let r = self.apply(action);
        match &r {
            Ok(()) => {}
            Err(e) => self.error = Some(e.to_string()),
        }
        r
    }

    fn apply(&mut self, action: Action) -> Result<()> {
        match action {
            Action::Resize { width, height } => {
                let cam = self.scene().camera.clone();
                if (cam.width, cam.height) == (width, height) {
                    return Ok(());
                }
                self.set_camera(caustics::scene::Camera { width, height, ..cam })
            }
            Action::Orbit { dx, dy } => {
                self.orbit.orbit(dx, dy);
                self.camera_from_orbit()
            }
            Action::Pan { dx, dy } => {
                let cam = self.scene().camera.clone();
                self.orbit.pan(&cam, dx, dy);
                self.camera_from_orbit()
            }
            Action::Zoom { steps } => {
                self.orbit.zoom(steps);
                self.camera_from_orbit()
            }
            Action::Press { x, y, mods } => self.press(x, y, mods),
            Action::Drag { x, y } => self.drag_to(x, y),
            Action::Release => {
                self.drag = None;
                Ok(())
            }
            Action::Select(s) => {
                self.selection = s;
                Ok(())
            }
            Action::SetTechnique(t) => self.change_settings(|s| s.photons.technique = t),
            Action::SetSplat(m) => self.change_settings(|s| s.photons.splat = m),
            Action::SetTracer(t) => self.change_settings(|s| s.photons.tracer = t),
            Action::SetPhotons(n) => self.change_settings(|s| s.photons.count = n),
            Action::SetEnvironmentRotation(deg) => {
                if self.renderer.environment_rotation() == Some(deg) {
                    return Ok(());
                }
                self.renderer.set_environment_rotation(deg)?;
                self.view_changed();
                Ok(())
            }
            Action::SetTolerance(t) => self.change_settings(|s| s.adaptive.error_tolerance = t),
            Action::SetSettings(new) => self.change_settings(|s| *s = *new),
            Action::SetBudget(target) => {
                match (target, &mut self.budget) {
                    (None, _) => self.budget = None,
                    (Some(ms), Some(b)) => {
                        let mut bs = b.settings().clone();
                        bs.target_ms = ms;
                        b.set_settings(bs);
                    }
                    (Some(ms), None) => {
                        self.budget =
                            Some(caustics::budget::BudgetController::new(caustics::budget::BudgetSettings::new(ms)))
                    }
                }
                self.error = None;
                Ok(())
            }
            Action::SetTemporal(on) => {
                self.renderer.set_temporal(on.then(TemporalSettings::default))?;
                self.temporal = on;
                self.settle = if on { TEMPORAL_SETTLE_FRAMES } else { 0 };
                self.dirty = true;
                self.error = None;
                Ok(())
            }
            Action::SetLight(i, l) => {
                self.renderer.set_light(i, l)?;
                self.view_changed();
                Ok(())
            }
            Action::SetObjectTransform(i, t) => {
                self.renderer.set_object_transform(i, t)?;
                self.geometry_version += 1;
                self.view_changed();
                Ok(())
            }
            Action::SetIor { material, ior } => self.set_ior(material, ior),
            Action::SetMedium { sigma_s, sigma_a, phase } => {
                let now = self.scene().medium.as_ref().map(|m| (m.sigma_s, m.sigma_a, m.phase));
                if now == Some((sigma_s, sigma_a, phase)) {
                    return Ok(());
                }
                self.renderer.set_medium(sigma_s, sigma_a, phase)?;
                self.view_changed();
                Ok(())
            }
            Action::Screenshot(path) => self.screenshot(&path),
            Action::ScreenshotPair => self.screenshot_pair().map(|_| ()),
            Action::SetViewMode(m) => {
                self.view_mode = m;
                self.changed_at = Instant::now() - REFERENCE_DELAY;
                Ok(())
            }
            Action::StartReference => {
                self.start_reference();
                Ok(())
            }
            Action::CancelReference => {
                self.job = None;
                Ok(())
            }
            Action::ComputeFlip => {
                let generation = self.generation;
                if let Some(r) = self.reference.as_mut().filter(|r| r.generation == generation)
                    && let Some(gpu) = &r.gpu
                {
                    r.flip = Some(caustics_reference::metrics::hdr_flip(gpu, &r.image, None)?.mean);
                }
                Ok(())
            }
        }
    }

    fn set_camera(&mut self, cam: caustics::scene::Camera) -> Result<()> {
        let old = self.scene().camera.clone();
        if let Err(e) = self.renderer.set_camera(cam) {
            // The renderer keeps a camera it rejected: put the old one back.
            let _ = self.renderer.set_camera(old);
            return Err(e);
        }
        self.view_changed();
        Ok(())
    }

    fn camera_from_orbit(&mut self) -> Result<()> {
        let cam = self.orbit.apply(&self.scene().camera);
        self.set_camera(cam)
    }

    fn change_settings(&mut self, f: impl FnOnce(&mut RenderSettings)) -> Result<()> {
        let mut s = self.settings().clone();
        f(&mut s);
        // (RenderSettings has no PartialEq.)
        if format!("{s:?}") == format!("{:?}", self.settings()) {
            return Ok(());
        }
        self.renderer.set_settings(s)?;
        self.dirty = true;
        self.error = None;
        Ok(())
    }

    /// The camera, a light, an object or a material changed: the reference is stale.
    fn view_changed(&mut self) {
        self.generation += 1;
        self.changed_at = Instant::now();
        self.dirty = true;
        self.settle = if self.temporal { TEMPORAL_SETTLE_FRAMES } else { 0 };
        self.error = None;
        if let Some(j) = self.job.take() {
            j.cancel();
        }
    }

    fn accel(&mut self) -> Arc<Accel> {
        match &self.accel {
            Some((v, a)) if *v == self.geometry_version => a.clone(),
            _ => {
                let a = Arc::new(Accel::new(self.renderer.scene()));
                self.accel = Some((self.geometry_version, a.clone()));
                a
            }
        }
    }

    fn press(&mut self, x: f32, y: f32, mods: Mods) -> Result<()> {
        self.drag = None;
        if mods.rotate {
            match self.selection {
                Some(Selection::Light(i)) if matches!(self.scene().lights.get(i), Some(Light::Spot { .. })) => {
                    self.drag = Some(Drag::AimLight { light: i });
                    return self.drag_to(x, y);
                }
                Some(Selection::Object(i)) => {
                    let centre = pick::centre(&self.scene().objects[i].shape);
                    let t0 = self.renderer.object_transform(i).unwrap_or(Affine3A::IDENTITY);
                    self.drag = Some(Drag::RotateObject { object: i, t0, centre, start: Vec2::new(x, y) });
                    return Ok(());
                }
                _ => {}
            }
        }
        if let Some((i, h)) = pick::pick_handle(self.scene(), x, y) {
            self.selection = Some(Selection::Light(i));
            self.drag = Some(Drag::AimHandle { light: i, anchor: h });
            return Ok(());
        }
        let accel = self.accel();
        let picked = pick::pick(self.scene(), &accel, x, y);
        // A press on nothing keeps the selection (it starts an orbit); a click on nothing
        // deselects (the panel sends `Select(None)`).
        if let Some((s, _)) = picked {
            self.selection = Some(s);
        }
        self.drag = match picked {
            Some((Selection::Light(i), p)) => Some(Drag::MoveLight { light: i, start: p, anchor: p }),
            Some((Selection::Object(i), p)) => Some(Drag::MoveObject {
                object: i,
                t0: self.renderer.object_transform(i).unwrap_or(Affine3A::IDENTITY),
                anchor: p,
            }),
            None => None,
        };
        Ok(())
    }

    fn drag_to(&mut self, x: f32, y: f32) -> Result<()> {
        let Some(drag) = self.drag.clone() else { return Ok(()) };
        let cam = self.scene().camera.clone();
        match drag {
            Drag::MoveLight { light, start, anchor } => {
                let Some(p) = pick::on_view_plane(&cam, anchor, x, y) else { return Ok(()) };
                let l = pick::moved(&self.scene().lights[light], start + (p - anchor));
                self.apply(Action::SetLight(light, l))
            }
            Drag::AimLight { light } => {
                let accel = self.accel();
                let target = pick::scene_point(self.scene(), &accel, x, y)
                    .unwrap_or_else(|| cam.position + cam.ray_dir(x, y) * self.orbit.distance);
                let l = pick::aimed(&self.scene().lights[light], target);
                self.apply(Action::SetLight(light, l))
            }
            Drag::AimHandle { light, anchor } => {
                let Some(p) = pick::on_view_plane(&cam, anchor, x, y) else { return Ok(()) };
                let l = pick::aimed(&self.scene().lights[light], p);
                self.apply(Action::SetLight(light, l))
            }
            Drag::MoveObject { object, t0, anchor } => {
                let Some(p) = pick::on_view_plane(&cam, anchor, x, y) else { return Ok(()) };
                self.apply(Action::SetObjectTransform(object, Affine3A::from_translation(p - anchor) * t0))
            }
            Drag::RotateObject { object, t0, centre, start } => {
                let d = Vec2::new(x, y) - start;
                let t = pick::rotated_about(
                    t0,
                    centre,
                    cam.up,
                    cam.right(),
                    d.x * ROTATE_RAD_PER_PIXEL,
                    d.y * ROTATE_RAD_PER_PIXEL,
                );
                self.apply(Action::SetObjectTransform(object, t))
            }
        }
    }

    /// A new index of refraction for a dielectric material (every light is redone).
    fn set_ior(&mut self, material: usize, ior: f32) -> Result<()> {
        let Some(Material::Dielectric { ext_ior, .. }) = self.base.materials.get(material).copied() else {
            return Err(Error::input("<viewer>", format!("materials[{material}].ior"), "not a dielectric material"));
        };
        if !(ior.is_finite() && (1.0..=4.0).contains(&ior)) {
            return Err(Error::input("<viewer>", format!("materials[{material}].ior"), "must lie in [1, 4]"));
        }
        let m = Material::Dielectric { ior, ext_ior };
        self.renderer.set_material(material, m)?;
        self.base.materials[material] = m;
        // The caustic spheres were traced through the old material (their cache key has it).
        self.sphere_tables = None;
        self.view_changed();
        Ok(())
    }

    /// Render a frame if anything changed; returns whether it did. Never waits for the GPU
    /// beyond what [`Renderer::encode`] does.
    pub fn render(&mut self) -> Result<bool> {
        if !self.dirty {
            return Ok(false);
        }
        self.dirty = self.settle > 0;
        self.settle = self.settle.saturating_sub(1);
        if self.settings().photons.technique == Technique::CausticSpheres && self.sphere_tables.is_none() {
            // Blocks while a table is precomputed (a progress bar on the terminal; cached).
            if let Err(e) =
                crate::spheres::attach(&mut self.renderer, &self.base, &self.sphere_args, &mut self.sphere_tables)
            {
                self.error = Some(e.to_string());
                return Err(e);
            }
        }
        let t0 = Instant::now();
        let mut enc =
            self.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("viewer frame") });
        let display = match self.renderer.encode(&mut enc, FrameRequest { stats: true }) {
            Ok(out) => out.display.clone(),
            Err(e) => {
                self.error = Some(e.to_string());
                return Err(e);
            }
        };
        self.queue.submit([enc.finish()]);
        let done = self.frame_done.clone();
        if let Ok(mut d) = done.lock() {
            *d = None;
        }
        self.queue.on_submitted_work_done(move || {
            if let Ok(mut d) = done.lock() {
                *d = Some(Instant::now());
            }
        });
        self.frame_started = Some(t0);
        self.stats_pending = true;
        self.display = Some(display);
        self.frames += 1;
        if self.reference().is_some() {
            self.compare_with_reference();
        }
        Ok(true)
    }

    /// Collect what arrived: frame statistics, the frame's completion time, a finished
    /// reference; start the automatic reference when a comparison view waits for one. Call once
    /// per window frame.
    pub fn update(&mut self) {
        let _ = self.device.poll(wgpu::PollType::Poll);
        self.frame_time();
        match self.renderer.poll_stats() {
            Ok(Some(s)) => {
                self.arrived(s);
                self.stats_pending = false;
            }
            Ok(None) => {}
            Err(e) => {
                self.error = Some(e.to_string());
                self.stats_pending = false;
            }
        }
        if let Some(e) = self.renderer.last_error() {
            self.error = Some(e.to_string());
        }
        if self.job.as_ref().is_some_and(Job::is_finished)
            && let Some(job) = self.job.take()
        {
            let generation = job.generation;
            match job.join() {
                Ok(out) if generation == self.generation => {
                    self.reference_version += 1;
                    self.reference = Some(ReferenceView {
                        generation,
                        rgba: Rgba::tonemapped(&out.image, self.scene().exposure),
                        image: out.image,
                        diff: None,
                        rel_mse: None,
                        flip: None,
                        gpu: None,
                        seconds: out.stats.seconds,
                        version: self.reference_version,
                    });
                    self.compare_with_reference();
                }
                Ok(_) | Err(Error::Cancelled) => {}
                Err(e) => {
                    self.error = Some(format!("CPU reference: {e}"));
                    self.reference_failed = Some(generation);
                }
            }
        }
        if self.view_mode != ViewMode::Gpu
            && self.job.is_none()
            && self.reference().is_none()
            && self.reference_failed != Some(self.generation)
            && self.drag.is_none()
            && self.changed_at.elapsed() >= REFERENCE_DELAY
        {
            self.start_reference();
        }
    }

    /// The latest frame's host time, once the GPU finished it.
    fn frame_time(&mut self) {
        if let (Some(t0), Ok(mut d)) = (self.frame_started, self.frame_done.lock())
            && let Some(t1) = d.take()
        {
            self.frame_ms = Some(t1.duration_since(t0).as_secs_f64() * 1e3);
            self.frame_started = None;
        }
    }

    /// A frame's statistics arrived. The time budget learns from frames that did photon work
    /// (a camera-only frame costs the same whatever the grid).
    fn arrived(&mut self, s: FrameStats) {
        if let (Some(b), Some(ms)) = (&mut self.budget, self.frame_ms)
            && s.lights_redone.iter().any(|&r| r)
        {
            let mut next = self.renderer.settings().clone();
            if b.update(ms, &mut next)
                && let Err(e) = self.renderer.set_settings(next)
            {
                self.error = Some(e.to_string());
            }
        }
        self.stats = Some(s);
    }

    /// Whether the latest frame's statistics or completion time are still to come (the window
    /// keeps polling).
    pub fn awaiting_gpu(&self) -> bool {
        self.stats_pending || self.frame_started.is_some()
    }

    /// Wait for the statistics of the frames rendered so far (tests).
    #[cfg(test)]
    pub fn wait_stats(&mut self) {
        match self.renderer.wait_stats() {
            Ok(Some(s)) => {
                self.frame_time();
                self.arrived(s);
            }
            Ok(None) => {}
            Err(e) => self.error = Some(e.to_string()),
        }
        self.stats_pending = false;
        self.update();
    }

    /// Start the CPU reference of the current view (cancelling one in flight).
    pub fn start_reference(&mut self) {
        self.job = Some(Job::start(self.scene().clone(), self.reference_settings.clone(), self.generation));
    }

    /// Wait for the reference in flight (tests).
    #[cfg(test)]
    pub fn wait_reference(&mut self) {
        while self.job.as_ref().is_some_and(|j| !j.is_finished()) {
            std::thread::sleep(Duration::from_millis(20));
        }
        self.update();
    }

    fn compare_with_reference(&mut self) {
        let exposure = self.scene().exposure;
        let gpu = match self.renderer.read_image() {
            Ok(i) => i,
            Err(e) => {
                self.error = Some(e.to_string());
                return;
            }
        };
        self.reference_version += 1;
        let version = self.reference_version;
        if let Some(r) = self.reference.as_mut() {
            r.diff = reference::difference(&gpu, &r.image, exposure);
            r.rel_mse = caustics_reference::metrics::rel_mse(&gpu, &r.image, None).ok();
            r.flip = None;
            r.gpu = Some(gpu);
            r.version = version;
        }
    }

    /// Write the current image to `path` (.png tone-mapped, .exr linear radiance), atomically.
    pub fn screenshot(&mut self, path: &Path) -> Result<()> {
        self.render()?; // (if the view changed since the last frame)
        let img = self.renderer.read_image()?;
        img.write(path, self.scene().exposure)?;
        self.status = format!("wrote {}", path.display());
        Ok(())
    }

    /// The next free numbered screenshot name (no extension) in the screenshot folder.
    pub fn next_screenshot_stem(&mut self) -> PathBuf {
        loop {
            self.screenshots += 1;
            let s = self.screenshot_dir.join(format!("caustics-view-{:03}", self.screenshots));
            if !s.with_extension("png").exists() && !s.with_extension("exr").exists() {
                return s;
            }
        }
    }

    /// Write the current image as the next numbered PNG and EXR pair in the screenshot folder.
    pub fn screenshot_pair(&mut self) -> Result<Vec<PathBuf>> {
        self.render()?;
        let img = self.renderer.read_image()?;
        let stem = self.next_screenshot_stem();
        let paths = vec![stem.with_extension("png"), stem.with_extension("exr")];
        for p in &paths {
            img.write(p, self.scene().exposure)?;
        }
        self.status = format!("wrote {} and .exr", paths[0].display());
        Ok(paths)
    }
}
