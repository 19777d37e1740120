//! `caustics`: render scenes with caustics on the GPU (or the CPU reference), compare images,
//! list adapters, view scenes interactively. Exit codes: 0 success, 2 bad input (scene, settings,
//! paths), 130 cancelled by Ctrl-C, 1 anything else.

mod bench;
mod bench_beams;
mod compare;
mod progress;
mod scene_args;
mod settings_args;
mod spheres;
mod view;

use anyhow::Result;
use caustics::render::{GpuRender, RenderSettings};
use caustics::{Error, Scene};
use caustics_reference::ImageIo as _;
use clap::{Parser, Subcommand, ValueEnum};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Parser)]
#[command(name = "caustics", version, about = "Real-time caustics on wgpu, with an exact CPU reference renderer")]
#[command(after_help = "Examples:
  caustics render                                   the built-in scene (a glass ball) to caustics.png
  caustics render scenes/mirror_ring.json -o ring.exr --photons 2048
  caustics render scenes/smoke_puff.json --set beams.cutoff=0.01 --set medium.bounce_grid=0
  caustics render --print-settings > my.json; caustics render --settings my.json
  caustics render scenes/glass_bunny.json --dump dump/   also writes the light-space buffers
  caustics render scenes/glass_sphere.json --backend cpu -o reference.exr
  caustics convert scenes/glass_bunny.json -o bunny.glb   the scene as glTF 2.0
  caustics compare out.exr references/a_glass_sphere_caustic.exr --mask references/a_glass_sphere_specmask.png
  caustics view scenes/two_spheres.json             the interactive viewer
  caustics info                                     adapters, features and limits")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Backend {
    /// The GPU if an adapter exists, else the CPU reference (with a notice).
    Auto,
    Gpu,
    Cpu,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene to PNG (tone-mapped) or EXR (linear radiance, W/(m^2 sr)).
    Render {
        /// Scene file (JSON, see docs/scene-format.md, or glTF 2.0 .gltf/.glb, see docs/gltf.md);
        /// the built-in glass-ball scene if omitted.
        scene: Option<PathBuf>,
        /// glTF scenes: the camera, by node or camera name or index into the file's cameras
        /// (default: the scene's first camera, else a view framing the scene).
        #[arg(long, value_name = "NAME|INDEX")]
        camera: Option<String>,
        #[command(flatten)]
        environment: scene_args::EnvironmentFileArgs,
        /// Output image (.png or .exr; an EXR's header holds the settings it was rendered with).
        #[arg(short, long, default_value = "caustics.png")]
        output: PathBuf,
        /// Image size WxH, overriding the scene's camera.
        #[arg(long, value_parser = parse_size)]
        size: Option<(u32, u32)>,
        #[arg(long, value_enum, default_value = "auto")]
        backend: Backend,
        /// Adapter to use (a part of its name, see `caustics info`).
        #[arg(long)]
        adapter: Option<String>,
        /// Write the intermediate buffers (light-space normals, depths, caustic maps) here.
        #[arg(long)]
        dump: Option<PathBuf>,
        /// Also write the caustic light alone (same format as the output) to this file.
        #[arg(long)]
        caustic_output: Option<PathBuf>,
        /// Pose the scene's animated objects (`waves`) at this time, in seconds (default 0).
        #[arg(long)]
        time: Option<f32>,
        #[command(flatten)]
        grid: settings_args::GridArgs,
        #[command(flatten)]
        settings: Box<settings_args::SettingsArgs>,
    },
    /// Precompute the caustic spheres of a scene's caustic objects into the cache (what
    /// `render --technique caustic-spheres` loads).
    Precompute {
        /// Scene file (JSON); the built-in glass-ball scene if omitted.
        scene: Option<PathBuf>,
        #[command(flatten)]
        sphere_args: spheres::SphereArgs,
        /// Where the tables are built: the GPU's exact tracer, or the CPU reference (its check).
        #[arg(long, value_enum, default_value_t = spheres::On::Gpu)]
        on: spheres::On,
    },
    /// Write a scene as glTF 2.0 (.glb, or .gltf with the buffer embedded): meshes, materials,
    /// lights and camera for other programs, and the exact scene in the CAUSTICS_scene
    /// extension, which `caustics render` reads back bit for bit (docs/gltf.md, "Export").
    Convert {
        /// Scene file (JSON, or glTF); the built-in glass-ball scene if omitted.
        scene: Option<PathBuf>,
        /// Output file, .glb or .gltf (written whole, then renamed into place).
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Compare two images (EXR or PNG): RMSE, relative MSE, PSNR, FLIP, energy ratio.
    Compare {
        a: PathBuf,
        b: PathBuf,
        /// Only compare where this mask is black (e.g. a reference's *_specmask.png).
        #[arg(long)]
        mask: Option<PathBuf>,
        /// Write a difference heat map (PNG).
        #[arg(long)]
        heatmap: Option<PathBuf>,
    },
    /// Compare photon emission techniques on one scene (Table 1 of Wyman & Nichols 2009):
    /// photons splatted, relevant photons, coverage, GPU ms per pass, memory, batches.
    Bench(Box<bench::BenchArgs>),
    /// The interactive viewer: orbit, move lights and objects, switch techniques live, compare
    /// with the CPU reference (a window; needs a GPU adapter).
    View(Box<view::ViewArgs>),
    /// List GPU adapters with their features and limits.
    Info,
}

/// The scene at `path` (the built-in one without), with the glTF camera `camera` chooses
/// (`--camera`).
pub(crate) fn load_scene(path: Option<&Path>, camera: Option<&str>) -> Result<Scene, Error> {
    match (path, camera) {
        (Some(p), c) => Scene::load_with_camera(p, c),
        (None, Some(_)) => {
            Err(Error::input("<command line>", "--camera", "chooses a camera of a glTF scene: name one"))
        }
        (None, None) => Ok(Scene::default_scene()),
    }
}

/// `--time T`: the scene posed at `t` seconds (a warning where nothing in it moves).
pub(crate) fn at_time(scene: &Scene, t: f32) -> Result<Scene, Error> {
    if !t.is_finite() {
        return Err(Error::input("<command line>", "--time", format!("must be a finite number of seconds (got {t})")));
    }
    if !scene.is_animated() {
        eprintln!("warning: --time {t}: {} has no animated object (`waves`); nothing moves", scene.source);
    }
    Ok(scene.at_time(t))
}

pub(crate) fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or("expected WxH, e.g. 800x600")?;
    let w: u32 = w.trim().parse().map_err(|_| format!("bad width \"{w}\""))?;
    let h: u32 = h.trim().parse().map_err(|_| format!("bad height \"{h}\""))?;
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        return Err(format!("{w}x{h}: each side must be 1 to 16384 pixels"));
    }
    Ok((w, h))
}

/// Keep Mesa's device-selection layer from printing "error: XDG_RUNTIME_DIR is invalid or not
/// set in the environment." (twice) on machines without a Wayland session. The layer
/// (`VK_LAYER_MESA_device_select`, an implicit Vulkan layer installed with Mesa's drivers)
/// calls `wl_display_connect` inside every `vkEnumeratePhysicalDevices` when the instance
/// enables `VK_KHR_wayland_surface`, which wgpu always does; libwayland-client prints that line
/// when the connection cannot even be attempted. Only where no Wayland display can be reached
/// (no `WAYLAND_SOCKET`, neither `XDG_RUNTIME_DIR` nor `WAYLAND_DISPLAY` an absolute path) and
/// the user chose nothing about the layer, it is switched off through the variable its manifest
/// names for that (`disable_environment`: `NODEVICE_SELECT=1`). Real errors still print.
#[expect(unsafe_code, reason = "std::env::set_var is unsafe in edition 2024; called before any thread exists")]
fn quiet_headless_vulkan() {
    let var = |k: &str| std::env::var_os(k).filter(|v| !v.is_empty());
    let absolute = |k: &str| var(k).is_some_and(|v| std::path::Path::new(&v).is_absolute());
    let wayland = var("WAYLAND_SOCKET").is_some() || absolute("XDG_RUNTIME_DIR") || absolute("WAYLAND_DISPLAY");
    if !wayland && var("NODEVICE_SELECT").is_none() && var("MESA_VK_DEVICE_SELECT").is_none() {
        // SAFETY: called first thing in `main`, before any other thread exists.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
}

fn main() -> ExitCode {
    quiet_headless_vulkan();
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.downcast_ref::<Error>().is_some_and(|e| matches!(e, Error::Cancelled)) => {
            eprintln!("cancelled: nothing was written");
            ExitCode::from(progress::CANCELLED_EXIT)
        }
        Err(mut e) => {
            flag_names(&mut e);
            let input = e.downcast_ref::<Error>().is_some_and(Error::is_input);
            eprintln!("error: {e:#}");
            ExitCode::from(if input { 2 } else { 1 })
        }
    }
}

/// The library names a GPU-less machine's way out; the command line has a flag for it.
fn flag_names(e: &mut anyhow::Error) {
    if let Some(Error::NoAdapter(m)) = e.downcast_mut::<Error>()
        && m.ends_with("render with the CPU reference")
    {
        *m += " (`--backend cpu`)";
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Info => info(),
        Command::Bench(args) => bench::run(*args),
        Command::View(args) => view::run(*args),
        Command::Precompute { scene, sphere_args, on } => {
            let scene = match &scene {
                Some(p) => Scene::load(p)?,
                None => Scene::default_scene(),
            };
            let ctx = match on {
                spheres::On::Gpu => Some(caustics::gpu::GpuContext::new(None)?),
                spheres::On::Cpu => None,
            };
            let builder = ctx.as_ref().map_or(spheres::Builder::Cpu, spheres::Builder::Gpu);
            let built = spheres::build(&scene, &sphere_args, builder)?;
            if built.is_empty() {
                println!("{}: no caustic object, nothing to precompute", scene.source);
            }
            Ok(())
        }
        Command::Convert { scene, output } => {
            let scene = load_scene(scene.as_deref(), None)?;
            for w in &scene.warnings {
                eprintln!("warning: {w}");
            }
            caustics::scene::write_gltf(&scene, &output)?;
            println!("wrote {}", output.display());
            Ok(())
        }
        Command::Compare { a, b, mask, heatmap } => Ok(compare::run(&a, &b, mask.as_deref(), heatmap.as_deref())?),
        Command::Render {
            scene,
            camera,
            environment,
            output,
            size,
            backend,
            adapter,
            dump,
            caustic_output,
            time,
            grid,
            settings,
        } => {
            let resolved = settings.resolve(RenderSettings::default(), Some(&grid))?;
            if settings.print_settings {
                println!("{}", serde_json::to_string_pretty(&resolved.to_json())?);
                return Ok(());
            }
            let cpu = resolved.cpu.clone();
            let mut settings = resolved.render.clone();
            let caustic_spheres = settings.caustic_spheres();
            check_output(&output)?;
            if let Some(c) = &caustic_output {
                check_output(c)?;
            }
            let mut scene = environment.apply(load_scene(scene.as_deref(), camera.as_deref())?)?;
            for w in &scene.warnings {
                eprintln!("warning: {w}");
            }
            if let Some(t) = time {
                scene = at_time(&scene, t)?;
            }
            if let Some((w, h)) = size {
                scene.camera.width = w;
                scene.camera.height = h;
            }
            let ctx = match backend {
                Backend::Cpu => None,
                Backend::Gpu => Some(caustics::gpu::GpuContext::new(adapter.as_deref())?),
                Backend::Auto => match caustics::gpu::GpuContext::new(adapter.as_deref()) {
                    Ok(c) => Some(c),
                    Err(e @ Error::Input { .. }) => return Err(e.into()),
                    Err(e) => {
                        eprintln!("notice: {e}");
                        eprintln!("notice: rendering with the CPU reference renderer instead");
                        None
                    }
                },
            };
            println!("scene: {} ({}), {}x{}", scene.name, scene.source, scene.camera.width, scene.camera.height);
            match ctx {
                Some(ctx) => {
                    if !resolved.caustic_map_given {
                        settings.photons.caustic_map_size =
                            RenderSettings::fitting_caustic_map_size(&ctx, &scene, settings.photons.caustic_map_size);
                    }
                    // What the image is rendered with, stored in its header (EXR).
                    let used =
                        settings_args::Resolved { render: settings.clone(), ..resolved.clone() }.to_json().to_string();
                    if !caustic_spheres {
                        progress::exit_on_ctrl_c();
                    }
                    let t0 = std::time::Instant::now();
                    let out = match dump.as_deref() {
                        Some(_) if caustic_spheres => {
                            return Err(Error::input(
                                "<command line>",
                                "--dump",
                                "not available with caustic spheres (no light-space caustic maps for directional lights)",
                            )
                            .into());
                        }
                        _ if caustic_spheres => {
                            let sphere_args = &resolved.spheres;
                            let tables = spheres::build(&scene, sphere_args, spheres::Builder::Gpu(&ctx))?;
                            progress::exit_on_ctrl_c();
                            let t0 = std::time::Instant::now();
                            let mut r = caustics::renderer::Renderer::with_context(
                                ctx.clone(),
                                scene.clone(),
                                settings.clone(),
                            )?;
                            r.set_caustic_spheres(
                                tables,
                                caustics::caustic_spheres::Blend::Triangle,
                                sphere_args.half,
                            )?;
                            r.set_caustic_spheres_compiled(sphere_args.sphere_compiled);
                            let out = r.render_once()?;
                            println!(
                                "caustic spheres on the GPU: {:.1} MiB; render {:.1} ms",
                                r.caustic_sphere_bytes() as f64 / (1 << 20) as f64,
                                t0.elapsed().as_secs_f64() * 1e3
                            );
                            out
                        }
                        Some(dir) => {
                            let (out, images) = caustics::render::render_dump(&ctx, &scene, &settings)?;
                            progress::begin_outputs();
                            caustics_reference::dump::write(dir, &images)?;
                            out
                        }
                        None => caustics::render::render(&ctx, &scene, &settings)?,
                    };
                    let wall = t0.elapsed().as_secs_f64() * 1e3;
                    report_gpu(&out, wall);
                    progress::begin_outputs();
                    out.image.write_with_settings(&output, scene.exposure, Some(&used))?;
                    if let Some(c) = &caustic_output {
                        out.caustic.write_with_settings(c, scene.exposure, Some(&used))?;
                    }
                }
                None => {
                    if caustic_spheres {
                        eprintln!("notice: the CPU reference renders the exact caustics, not the caustic spheres");
                    }
                    if settings.sources.local != caustics::render::LocalSource::Photons {
                        eprintln!(
                            "notice: the CPU reference renders the exact caustics; sources.local applies to the GPU"
                        );
                    }
                    let caustic_paths = caustics_reference::reference::CausticPaths::parse(&cpu.caustic_paths)
                        .ok_or_else(|| {
                            Error::input(
                                "<command line>",
                                "cpu.caustic_paths",
                                format!("must be all, first-diffuse or rest (got \"{}\")", cpu.caustic_paths),
                            )
                        })?;
                    let diffuse_orders = caustics_reference::reference::DiffuseOrders::parse(&cpu.diffuse_orders)
                        .ok_or_else(|| {
                            Error::input(
                                "<command line>",
                                "cpu.diffuse_orders",
                                format!(
                                    "must be all, N, A-B (A <= B) or A- (diffuse bounce orders, 0 and up) (got \"{}\")",
                                    cpu.diffuse_orders
                                ),
                            )
                        })?;
                    let rs = caustics_reference::reference::ReferenceSettings {
                        photons_per_light: (settings.photons.count as u64).pow(2),
                        camera_spp: cpu.spp,
                        seed: cpu.seed,
                        medium_single_scattering_only: cpu.single_scattering,
                        max_depth: cpu.max_depth,
                        caustic_paths,
                        diffuse_orders,
                        // The caustic maps get a spill face where the GPU's would (at the GPU's
                        // default caustic map size when none is given).
                        spill_faces: scene.lights.iter().any(|l| settings.uses_spill_face(&scene, l)),
                        partial_reflections: cpu.partial_reflections,
                        medium_beam_photons: cpu.medium_beams,
                        medium_beam_radius: cpu.medium_beam_radius,
                        specular_view_photons: cpu.specular_view_photons,
                        specular_view_radius: cpu.specular_view_radius,
                        ..Default::default()
                    };
                    let used = resolved.to_json().to_string();
                    let t0 = std::time::Instant::now();
                    let out = progress::reference_render(&scene, &rs)?;
                    println!("backend: CPU reference, {:.1} s", t0.elapsed().as_secs_f64());
                    println!("{}", out.stats);
                    out.image.write_with_settings(&output, scene.exposure, Some(&used))?;
                    if let Some(c) = &caustic_output {
                        out.caustic.write_with_settings(c, scene.exposure, Some(&used))?;
                    }
                }
            }
            println!("wrote {}", output.display());
            Ok(())
        }
    }
}

/// Fail early, before any work, when the output cannot be written.
fn check_output(path: &Path) -> Result<(), Error> {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    if !matches!(ext.as_deref(), Some("png") | Some("exr")) {
        return Err(Error::input(
            "<command line>",
            "--output",
            format!("{}: the output must end in .png or .exr", path.display()),
        ));
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !dir.is_dir() {
        return Err(Error::input(
            "<command line>",
            "--output",
            format!("{}: folder {} does not exist", path.display(), dir.display()),
        ));
    }
    if path.is_dir() {
        return Err(Error::input("<command line>", "--output", format!("{} is a folder", path.display())));
    }
    Ok(())
}

fn report_gpu(out: &GpuRender, wall_ms: f64) {
    println!("adapter: {}", out.adapter);
    let t = &out.technique;
    println!("photons: {} traced in {} batch(es)", out.photons_traced, out.batches);
    for (li, (b, _)) in out.beams.iter().enumerate() {
        println!(
            "beams (light {li}): {} rendered ({} on the residual branch); kept per level {:?}, traced per level {:?}; {} lost at the last level (no corner on a caustic path), {} grazing, {} over capacity, {} cut by the energy cutoff, {} dropped without light",
            b.beams,
            b.residual,
            b.kept_per_level,
            b.visited_per_level,
            b.inconsistent,
            b.grazing,
            b.overflow,
            b.cut,
            b.dark
        );
    }
    println!(
        "technique {}: {} photons splatted, {} relevant (dense {}^2 photons hitting a caster), coverage {:.2} %, photon memory {:.1} MiB (peak {:.1} MiB)",
        t.technique,
        t.photons_splatted,
        t.relevant,
        t.grid,
        100.0 * t.coverage(),
        t.photon_bytes as f64 / (1 << 20) as f64,
        t.peak_photon_bytes as f64 / (1 << 20) as f64
    );
    if t.corners_traced > 0 {
        println!("caustic triangles: {} cell-corner photons traced", t.corners_traced);
    }
    if t.levels.len() > 1 {
        for l in &t.levels {
            println!(
                "  level {:>6}^2: {:>10} cells, {:>10} traced, {:>10} emitted",
                l.grid, l.cells, l.traced, l.emitted
            );
        }
    }
    if out.timings.is_empty() {
        println!("GPU pass timings: unavailable (no timestamp queries on this adapter)");
    } else {
        println!("{:<22} {:>10}", "pass", "GPU ms");
        let mut total = 0.0;
        for (name, ms) in &out.timings {
            println!("{name:<22} {ms:>10.3}");
            total += ms;
        }
        println!("{:<22} {:>10.3}", "total", total);
        let photon_ms: f64 = out.timings.iter().filter(|(n, _)| n.starts_with("photon_")).map(|(_, ms)| ms).sum();
        if photon_ms > 0.0 {
            println!("photons per ms (trace + splat): {:.0}", out.photons_traced as f64 / photon_ms);
        }
    }
    // Watts with four decimals, or four significant digits for small fluxes (a scene in
    // millimetres carries microwatts).
    let w = |x: f64| if x == 0.0 || x.abs() >= 0.01 { format!("{x:.4}") } else { format!("{x:.4e}") };
    for (i, f) in out.flux.iter().enumerate() {
        println!(
            "light {i}: caustic flux {} W onto casters, {} W in the caustic map; lost: {} W no exit, {} W total internal reflection, {} W no receiver, {} W outside the map; {} W in Fresnel branches not traced",
            w(f.emitted),
            w(f.landed),
            w(f.lost_no_exit),
            w(f.lost_tir),
            w(f.lost_no_receiver),
            w(f.lost_outside),
            w(f.untraced_branches)
        );
    }
    println!("frame: {:.1} ms from submission to completion (host clock)", out.frame_wall_ms);
    println!("wall time: {wall_ms:.0} ms");
}

fn info() -> Result<()> {
    let adapters = caustics::gpu::list_adapters();
    if adapters.is_empty() {
        println!(
            "no GPU adapter found. Install a GPU driver or Mesa's software Vulkan driver (apt-get install mesa-vulkan-drivers); `caustics render` falls back to the CPU reference."
        );
    }
    for a in adapters {
        let i = a.get_info();
        let f = a.features();
        let l = a.limits();
        println!("{} ({:?}, {:?}, driver {} {})", i.name, i.backend, i.device_type, i.driver, i.driver_info);
        for (name, feat) in [
            ("timestamp queries", wgpu::Features::TIMESTAMP_QUERY),
            ("timestamps inside passes", wgpu::Features::TIMESTAMP_QUERY_INSIDE_PASSES),
            ("float32 atomics", wgpu::Features::SHADER_FLOAT32_ATOMIC),
            ("int64 atomics (min/max)", wgpu::Features::SHADER_INT64_ATOMIC_MIN_MAX),
            ("subgroups", wgpu::Features::SUBGROUP),
        ] {
            println!("  {name:<26} {}", if f.contains(feat) { "yes" } else { "no" });
        }
        println!("  max texture 2D            {}", l.max_texture_dimension_2d);
        println!("  max storage binding       {} MiB", l.max_storage_buffer_binding_size >> 20);
        println!("  max buffer                {} MiB", l.max_buffer_size >> 20);
    }
    Ok(())
}
