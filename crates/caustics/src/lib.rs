//! `caustics`: real-time caustics on wgpu, in physical units, with an exact CPU reference
//! renderer (`caustics-reference`) as ground truth.
//!
//! An engine drives a [`Renderer`] on its own device, frame after frame: it records into the
//! engine's command encoder, redoes only what changed and allocates nothing after the first
//! frame of a configuration. The names an engine needs are at the crate root:
//!
//! - [`Scene`]: the scene (JSON, `docs/scene-format.md`), validated on load.
//! - [`RenderSettings`]: the settings, in sections ([`settings`]), each validating itself.
//! - [`Renderer`], [`FrameRequest`], [`FrameOutputs`], [`FrameStats`]: the persistent renderer.
//! - [`render()`] and [`GpuRender`]: one frame, read back (the command line, tests, benchmarks).
//! - [`GpuContext`]: a device with what the renderer needs; [`Error`], [`Result`].
//!
//! ```
//! use caustics::{FrameRequest, GpuContext, RenderSettings, Renderer, Scene};
//! # fn main() -> caustics::Result<()> {
//! // The engine's device and queue; here the crate's own (`GpuContext::device_requirements`
//! // says what to ask of an adapter).
//! let gpu = match GpuContext::new(None) {
//!     Ok(gpu) => gpu,
//!     Err(e) if std::env::var("CI").as_deref() != Ok("true") => {
//!         eprintln!("no GPU adapter, nothing to show: {e}");
//!         return Ok(());
//!     }
//!     Err(e) => return Err(e),
//! };
//! let mut scene = Scene::default_scene(); // or Scene::load(path)?
//! scene.camera.width = 32;
//! scene.camera.height = 24;
//! let mut settings = RenderSettings::default();
//! settings.photons.count = 64;
//! settings.photons.caustic_map_size = 64;
//! let mut renderer = Renderer::new(&gpu.device, &gpu.queue, scene, settings)?;
//! for _frame in 0..2 {
//!     // Per frame: set_camera, set_light, set_object_transform, set_settings as they change.
//!     let mut encoder = gpu.device.create_command_encoder(&Default::default());
//!     let out = renderer.encode(&mut encoder, FrameRequest { stats: true })?;
//!     // out.display: tone-mapped Rgba8Unorm; out.radiance: linear W/(m² sr) per pixel;
//!     // out.lights[i].irradiance: light i's caustic map (W/m²).
//!     let _ = out.display;
//!     gpu.queue.submit([encoder.finish()]);
//! }
//! // Statistics arrive a frame or more later and never block (`wait_stats` waits).
//! let stats = renderer.wait_stats()?.expect("the frames asked for statistics");
//! assert!(stats.flux[0].landed > 0.0, "the glass ball focuses light onto the floor");
//! # Ok(())
//! # }
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub(crate) mod accel;
pub mod beams;
/// The GPU renderer's BVH built on the CPU as a renderer does, for `caustics bench --load`.
#[doc(hidden)]
pub fn build_scene_bvh(scene: &Scene) -> (usize, usize) {
    let b = accel::SceneBvh::build(scene);
    (b.nodes.len(), b.tris.len())
}
pub mod budget;
pub mod caustic_spheres;
pub(crate) mod env_taps;
pub mod error;
pub(crate) mod frame;
pub(crate) mod geometry;
pub mod gpu;
pub mod image_io;
pub(crate) mod indirect;
pub mod lightspace;
pub(crate) mod medium_bounce;
pub(crate) mod medium_multiple;
pub mod output;
pub(crate) mod passes;
pub mod raycast;
pub mod render;
pub mod renderer;
pub mod scene;
pub mod settings;
pub use techniques::splat;
pub(crate) mod techniques;
pub mod temporal;

pub use error::{Error, Result};
pub use gpu::GpuContext;
pub use image_io::Image;
pub use output::{FluxStats, GpuRender};
pub use render::render;
pub use renderer::{FrameOutputs, FrameRequest, FrameStats, LightOutputs, Renderer};
pub use scene::Scene;
pub use settings::RenderSettings;
