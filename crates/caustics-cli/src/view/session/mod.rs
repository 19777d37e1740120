//! The viewer's state and everything it can do, without a window: a [`Session`] owns the
//! persistent [`Renderer`] on the caller's device, takes [`Action`]s (what the mouse, keys and
//! panels ask for), renders frames on demand and keeps the CPU reference job. The window
//! (`window.rs`) and the panels (`ui/`) only translate input into actions; the tests drive a
//! session the same way without a display.

mod action;
mod frames;
mod interact;

use super::camera::Orbit;
use super::pick::Selection;
use super::reference::{Job, Rgba};
pub use action::{Action, Mods, ViewMode};
use caustics::image_io::Image;
use caustics::render::RenderSettings;
use caustics::renderer::{FrameStats, Renderer};
use caustics::scene::Material;
use caustics::temporal::TemporalSettings;
use caustics::{Result, Scene};
use caustics_reference::reference::ReferenceSettings;
use caustics_reference::reference::geometry::Accel;
use interact::Drag;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

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
    /// The animation's time (seconds; `waves` objects), and while it plays the wall clock of
    /// the latest step.
    time: f32,
    playing: Option<Instant>,
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
            time: 0.0,
            playing: None,
        })
    }

    /// Whether the scene has animated objects (`waves`): the panel then shows play and time.
    pub fn animated(&self) -> bool {
        self.base.is_animated()
    }
    /// The animation's time (seconds).
    pub fn time(&self) -> f32 {
        self.time
    }
    /// Whether the animation plays.
    pub fn playing(&self) -> bool {
        self.playing.is_some()
    }

    /// Pose the animated objects at `t` seconds (a change of the view: a new reference
    /// generation).
    fn set_time(&mut self, t: f32) -> Result<()> {
        self.renderer.set_time(t)?;
        self.time = t;
        self.geometry_version += 1;
        self.view_changed();
        Ok(())
    }

    /// While playing: the time advanced by the wall clock since the latest step (called before
    /// each frame).
    fn advance(&mut self) -> Result<()> {
        let Some(last) = self.playing else { return Ok(()) };
        let now = Instant::now();
        // A long stall (a reference computed, a window dragged) is not made up for.
        let dt = (now - last).as_secs_f32().min(0.25);
        self.playing = Some(now);
        self.set_time(self.time + dt)
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
    /// Whether the next [`Session::render`] will render (something changed, or the animation
    /// plays).
    pub fn needs_frame(&self) -> bool {
        self.dirty || self.playing.is_some()
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

    /// Replace the scene with the file at `path` (our JSON, `.gltf` or `.glb`): a fresh
    /// renderer with the same settings at the view's size; the temporal filter and the caustic
    /// spheres' arguments carry over, the selection, reference and animation start again. A
    /// file that does not load leaves the session as it was (the error in the panel); the new
    /// scene's warnings go to the panel's status line.
    fn open(&mut self, path: &std::path::Path) -> Result<()> {
        let scene = Scene::load(path)?;
        let warnings = scene.warnings.clone();
        let cam = &self.scene().camera;
        let (width, height) = (cam.width, cam.height);
        let mut next =
            Session::new(&self.device, &self.queue, scene, self.settings().clone(), self.screenshot_dir.clone())?;
        next.sphere_args = self.sphere_args.clone();
        next.apply(Action::Resize { width, height })?;
        if self.temporal {
            next.apply(Action::SetTemporal(true))?;
        }
        next.status = match warnings.len() {
            0 => format!("opened {}", path.display()),
            n => format!(
                "opened {} ({n} warning{}):\n{}",
                path.display(),
                if n == 1 { "" } else { "s" },
                warnings.join("\n")
            ),
        };
        *self = next;
        Ok(())
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
            Action::SetTechnique(t) => self.change_settings(|s| s.photons.emission = t),
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
            Action::Open(path) => self.open(&path),
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
            Action::SetTime(t) => {
                if t == self.time {
                    return Ok(());
                }
                self.set_time(t)
            }
            Action::Play(on) => {
                self.playing = on.then(Instant::now);
                self.dirty = true;
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
}
