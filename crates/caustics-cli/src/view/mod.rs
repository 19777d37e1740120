//! `caustics view`: the interactive viewer (winit + egui through egui-wgpu on the renderer's
//! own device).
//!
//! - `session.rs`: the viewer without a window — state, [`session::Action`]s, frames on demand,
//!   screenshots, the CPU reference job; what the tests drive.
//! - `camera.rs`: orbit, pan, zoom; `pick.rs`: ray-cast picking and drag geometry.
//! - `reference.rs`: the background CPU reference and the difference view.
//! - `ui.rs`: the egui panels and view area (input → actions); `paint.rs`: egui-wgpu painting
//!   of the panels and the display texture into any target; `window.rs`: winit, the surface,
//!   egui-winit.

pub mod camera;
pub mod paint;
pub mod pick;
pub mod reference;
pub mod session;
pub mod ui;
mod window;

#[cfg(test)]
mod tests;

use anyhow::Result;
use caustics::render::RenderSettings;
use caustics::{Error, Scene};
use clap::Args;
use std::path::PathBuf;

#[derive(Args)]
pub struct ViewArgs {
    /// Scene file (JSON, see docs/scene-format.md, or glTF 2.0 .gltf/.glb, see docs/gltf.md);
    /// the built-in glass-ball scene if omitted.
    pub scene: Option<PathBuf>,
    /// glTF scenes: the camera, by node or camera name or index into the file's cameras
    /// (default: the scene's first camera, else a view framing the scene).
    #[arg(long, value_name = "NAME|INDEX")]
    pub camera: Option<String>,
    #[command(flatten)]
    pub environment: crate::scene_args::EnvironmentFileArgs,
    /// Initial window size WxH (logical pixels).
    #[arg(long, value_parser = crate::parse_size, default_value = "1280x800")]
    pub size: (u32, u32),
    /// Render this fraction of the view's pixels (0.25 to 1; lower is faster).
    #[arg(long, default_value_t = 1.0)]
    pub scale: f32,
    /// Adapter to use (a part of its name, see `caustics info`).
    #[arg(long)]
    pub adapter: Option<String>,
    /// Start the animation (`waves` objects) at this time, in seconds.
    #[arg(long)]
    pub time: Option<f32>,
    /// Start with the animation playing.
    #[arg(long)]
    pub play: bool,
    /// Folder for screenshots (F12).
    #[arg(long, default_value = ".")]
    pub screenshot_dir: PathBuf,
    #[command(flatten)]
    pub grid: crate::settings_args::GridArgs,
    #[command(flatten)]
    pub settings: crate::settings_args::SettingsArgs,
}

/// What the viewer starts with, checked before any window opens (bad input exits 2 without
/// flashing a window).
pub struct Start {
    pub scene: Scene,
    pub settings: RenderSettings,
    /// The caustic map size was given: kept rather than fitted to the adapter.
    pub caustic_map_given: bool,
    /// The caustic spheres' tables (`--technique caustic-spheres`, or switched to in the panel).
    pub spheres: crate::spheres::SphereArgs,
    pub args: ViewArgs,
}

/// Check the command line and load the scene.
pub fn prepare(args: ViewArgs) -> Result<Start, Error> {
    let scene = args.environment.apply(crate::load_scene(args.scene.as_deref(), args.camera.as_deref())?)?;
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    if let Some(t) = args.time
        && !t.is_finite()
    {
        return Err(Error::input("<command line>", "--time", format!("must be a finite number of seconds (got {t})")));
    }
    if !(0.25..=1.0).contains(&args.scale) {
        return Err(Error::input("<command line>", "--scale", format!("must lie in [0.25, 1] (got {})", args.scale)));
    }
    if !args.screenshot_dir.is_dir() {
        return Err(Error::input(
            "<command line>",
            "--screenshot-dir",
            format!("{} is not a folder", args.screenshot_dir.display()),
        ));
    }
    let resolved = args.settings.resolve(defaults(), Some(&args.grid))?;
    Ok(Start {
        scene,
        settings: resolved.render,
        caustic_map_given: resolved.caustic_map_given,
        spheres: resolved.spheres,
        args,
    })
}

/// The viewer's defaults: a smaller photon grid than `render`'s (changeable in the panel).
fn defaults() -> RenderSettings {
    RenderSettings {
        photons: caustics::settings::PhotonSettings { count: 512, ..Default::default() },
        ..Default::default()
    }
}

pub fn run(args: ViewArgs) -> Result<()> {
    if args.settings.print_settings {
        let resolved = args.settings.resolve(defaults(), Some(&args.grid))?;
        println!("{}", serde_json::to_string_pretty(&resolved.to_json())?);
        return Ok(());
    }
    let start = prepare(args)?;
    window::run(start)
}

/// The wgpu instance the viewer (and its tests) use: Vulkan, Metal or DX12 as the library's,
/// unless `WGPU_BACKEND` says otherwise.
pub fn instance() -> wgpu::Instance {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
    if std::env::var_os("WGPU_BACKEND").is_none() {
        desc.backends = wgpu::Backends::VULKAN | wgpu::Backends::METAL | wgpu::Backends::DX12;
    }
    wgpu::Instance::new(desc)
}

/// Pick an adapter (by name, or the best kind: discrete, integrated, virtual, software) that can
/// present to `surface` if given, and open a device with the renderer's features and limits.
pub fn open_device(
    instance: &wgpu::Instance,
    name: Option<&str>,
    surface: Option<&wgpu::Surface<'_>>,
) -> Result<(wgpu::Adapter, wgpu::Device, wgpu::Queue), Error> {
    let adapters: Vec<wgpu::Adapter> = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::all()))
        .into_iter()
        .filter(|a| surface.is_none_or(|s| a.is_surface_supported(s)))
        .collect();
    let adapter = match name {
        Some(n) => {
            let n = n.to_lowercase();
            adapters.into_iter().find(|a| a.get_info().name.to_lowercase().contains(&n)).ok_or_else(|| {
                Error::input("<command line>", "--adapter", format!("no adapter named like \"{n}\" (see `caustics info`)"))
            })?
        }
        None => adapters
            .into_iter()
            .min_by_key(|a| match a.get_info().device_type {
                wgpu::DeviceType::DiscreteGpu => 0,
                wgpu::DeviceType::IntegratedGpu => 1,
                wgpu::DeviceType::VirtualGpu => 2,
                wgpu::DeviceType::Cpu => 3,
                wgpu::DeviceType::Other => 4,
            })
            .ok_or_else(|| {
                Error::NoAdapter(
                    "no Vulkan, Metal or DX12 adapter that can present to a window was found; the viewer needs one (install a GPU driver or Mesa's software Vulkan driver: apt-get install mesa-vulkan-drivers)".into(),
                )
            })?,
    };
    let (required_features, required_limits) = caustics::gpu::GpuContext::device_requirements(&adapter);
    let info = adapter.get_info();
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("caustics view"),
        required_features,
        required_limits,
        ..Default::default()
    }))
    .map_err(|e| Error::Device(format!("cannot open {}: {e}", info.name)))?;
    Ok((adapter, device, queue))
}
