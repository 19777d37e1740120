//! `caustics bench`: the photon emission techniques side by side on one scene, light and device,
//! like Table 1 of Wyman & Nichols 2009 (photons splatted at each equivalent photon grid), plus
//! relevant photons, coverage, photons traced and evaluated, GPU milliseconds per pass, speed
//! relative to basic caustic maps, photon memory, batches, and how far each caustic map lies from
//! the dense one (HDR-FLIP). Printed, and written as markdown and JSON.
//!
//! With `--frames N`, the frame-loop benchmark instead ([`frame_loop`]): the persistent renderer
//! driven frame by frame through the phases `full`, `camera`, `light` and `object`.

mod frames;
mod load;
mod table;

use anyhow::{Context, Result, bail};
use caustics::Scene;
use caustics::render::{GpuRender, RenderSettings};
use caustics::settings::Technique;
use clap::Args;
use frames::frame_loop;
use std::path::PathBuf;
use table::{markdown, to_json};

#[derive(Args)]
pub struct BenchArgs {
    /// Scene file (JSON or glTF 2.0 .gltf/.glb); the built-in glass-ball scene if omitted.
    scene: Option<PathBuf>,
    /// glTF scenes: the camera, by node or camera name or index into the file's cameras.
    #[arg(long, value_name = "NAME|INDEX")]
    camera: Option<String>,
    #[command(flatten)]
    environment: crate::scene_args::EnvironmentFileArgs,
    /// Techniques to compare, comma-separated: the names `render --technique` takes (basic,
    /// hierarchical, adaptive-level, adaptive-error, caustic-spheres, beams: basic with the
    /// surface caustics from beams, instead of basic), or none (with --cpu-photons).
    #[arg(long, default_value = "basic,hierarchical,adaptive-level,adaptive-error")]
    technique: String,
    /// Equivalent photon grids: a range of powers of two `LO..HI`, or a comma-separated list.
    #[arg(long, default_value = "256..4096")]
    photons: String,
    /// Camera image size WxH (small: the bench is about the caustic map).
    #[arg(long, default_value = "64x64", value_parser = crate::parse_size)]
    size: (u32, u32),
    /// Renders per measurement; the fastest is reported.
    #[arg(long, default_value_t = 1)]
    repeat: u32,
    /// Folder for bench_SCENE.md and bench_SCENE.json.
    #[arg(long, default_value = ".")]
    out: PathBuf,
    /// Adapter to use (a part of its name, see `caustics info`).
    #[arg(long)]
    adapter: Option<String>,
    /// Also time the CPU reference renderer with this many photon paths per light, on one
    /// thread and on all (photon paths and rays per second; written to bench_SCENE_cpu.md).
    /// With `--technique none` only the CPU reference is timed.
    #[arg(long, default_value_t = 0)]
    cpu_photons: u64,
    /// Frame-loop benchmark: render this many frames of each phase (`full`, `camera`, `light`,
    /// `object`, `mesh`) with the persistent renderer, for each technique and photon grid given, and
    /// report frame ms (median, p95), GPU ms per pass and resource creations per phase, the
    /// first frame apart (frameloop_SCENE.md and .json).
    #[arg(long, default_value_t = 0)]
    frames: u32,
    /// Frame-loop benchmark: the phases to run, comma-separated, in the order of `full`,
    /// `camera`, `light`, `object`, `mesh` (all if omitted; `mesh` is skipped in a scene
    /// without a mesh).
    #[arg(long, default_value = "full,camera,light,object,mesh")]
    phases: String,
    /// Time loading the scene file (read, parse and flatten) and building its BVHs, with peak
    /// memory; CPU only, nothing rendered.
    #[arg(long)]
    load: bool,
    #[command(flatten)]
    settings: crate::settings_args::SettingsArgs,
    /// The settings every run starts from (`settings` resolved).
    #[arg(skip)]
    base: RenderSettings,
    /// The caustic spheres' tables (`--technique caustic-spheres`; `--set spheres.KEY=VALUE`).
    #[arg(skip)]
    spheres: crate::spheres::SphereArgs,
}

fn parse_grids(s: &str) -> Result<Vec<u32>> {
    let bad = || format!("--photons: expected LO..HI (powers of two) or a list N,N,..., got \"{s}\"");
    if let Some((a, b)) = s.split_once("..") {
        let a: u32 = a.trim().parse().ok().with_context(bad)?;
        let b: u32 = b.trim().parse().ok().with_context(bad)?;
        if !a.is_power_of_two() || !b.is_power_of_two() || a > b {
            bail!(bad());
        }
        let mut v = Vec::new();
        let mut n = a;
        while n <= b {
            v.push(n);
            n *= 2;
        }
        return Ok(v);
    }
    s.split(',').map(|x| x.trim().parse::<u32>().ok().with_context(bad)).collect()
}

/// One render of one technique at one grid.
struct Run {
    technique: Technique,
    n: u32,
    out: GpuRender,
    /// GPU ms of the photon stage (coverage, trace, traversal, splat) and of the whole frame.
    photon_ms: f64,
    frame_ms: f64,
    /// Host milliseconds from the frame's submission to its completion (`GpuRender::frame_wall_ms`).
    frame_wall_ms: f64,
    wall_ms: f64,
}

fn is_photon_pass(name: &str) -> bool {
    name.starts_with("photon_") || name.starts_with("adaptive_") || name.starts_with("hcm_") || name == "coverage_mip"
}

pub fn run(mut a: BenchArgs) -> Result<()> {
    if a.load {
        return load::run(&a);
    }
    let resolved = a.settings.resolve(RenderSettings::default(), None)?;
    if a.settings.print_settings {
        println!("{}", serde_json::to_string_pretty(&resolved.to_json())?);
        return Ok(());
    }
    (a.base, a.spheres) = (resolved.render, resolved.spheres);
    // As `render` and `view`: a caustic map not given is fitted to the adapter's storage-binding
    // limit (a point light's six faces at 1024² exceed lavapipe's 128 MiB).
    if !resolved.caustic_map_given && a.technique != "none" {
        let (_, _, scene) = setup(&a)?;
        let ctx = caustics::gpu::GpuContext::new(a.adapter.as_deref())?;
        a.base.photons.caustic_map_size =
            RenderSettings::fitting_caustic_map_size(&ctx, &scene, a.base.photons.caustic_map_size);
    }
    let a = &a;
    if a.frames > 0 {
        return crate::bench::frame_loop(a);
    }
    if a.cpu_photons > 0 {
        cpu_bench(a)?;
    }
    if a.technique == "none" {
        return Ok(());
    }
    let (techniques, grids, scene) = setup(a)?;
    let ctx = caustics::gpu::GpuContext::new(a.adapter.as_deref())?;
    let adapter = format!("{} ({:?}, {})", ctx.info.name, ctx.info.backend, ctx.info.driver);
    println!("scene: {} ({}), adapter: {adapter}", scene.name, scene.source);
    let mut runs: Vec<Run> = Vec::new();
    let mut skipped: Vec<(Technique, u32, String)> = Vec::new();
    let mut sphere_tables = None;
    let bar = crate::progress::steps((grids.len() * techniques.len()) as u64 * a.repeat.max(1) as u64, "bench");
    for &n in &grids {
        for &t in &techniques {
            let s = RenderSettings {
                photons: caustics::settings::PhotonSettings {
                    // Table 1 counts one photon per cell, as the paper (which has no reflected
                    // branch at glass) does: the transmitted branch only.
                    reflection: false,
                    ..settings(a, t, n).photons
                },
                shading: caustics::settings::ShadingSettings { shadow_map_size: 1024, ..settings(a, t, n).shading },
                ..settings(a, t, n)
            };
            if n > t.emission().max_photons() {
                skipped.push((t, n, format!("{t} supports grids up to {}", t.emission().max_photons())));
                continue;
            }
            let mut best: Option<Run> = None;
            for _ in 0..a.repeat.max(1) {
                bar.set_message(format!("{t} {n}^2"));
                bar.inc(1);
                let t0 = std::time::Instant::now();
                let rendered = if t == Technique::CausticSpheres {
                    caustics::renderer::Renderer::with_context(ctx.clone(), scene.clone(), s.clone()).and_then(
                        |mut r| {
                            crate::spheres::attach(&mut r, &scene, &a.spheres, &mut sphere_tables)?;
                            r.render_once()
                        },
                    )
                } else {
                    caustics::render::render(&ctx, &scene, &s)
                };
                let out = match rendered {
                    Ok(o) => o,
                    Err(e) if e.is_input() => {
                        skipped.push((t, n, e.to_string()));
                        break;
                    }
                    Err(e) => return Err(e.into()),
                };
                let wall_ms = t0.elapsed().as_secs_f64() * 1e3;
                let photon_ms = out.timings.iter().filter(|(p, _)| is_photon_pass(p)).map(|(_, ms)| ms).sum();
                let frame_ms = out.timings.iter().map(|(_, ms)| ms).sum();
                let frame_wall_ms = out.frame_wall_ms;
                let r = Run { technique: t, n, out, photon_ms, frame_ms, frame_wall_ms, wall_ms };
                // The fastest repetition by the host's clock (pass timestamps can miss work:
                // on lavapipe the basic technique's splat escapes its own).
                if best.as_ref().is_none_or(|b| r.frame_wall_ms < b.frame_wall_ms) {
                    best = Some(r);
                }
            }
            if let Some(r) = best {
                let ts = &r.out.technique;
                bar.suspend(|| println!(
                    "{n:>6}^2 {:<15} splatted {:>11} relevant {:>11} traced {:>11} photon GPU {:>9.1} ms frame {:>9.1} ms wall {:>8.0} ms batches {:>4} peak {:>7.2} MiB",
                    t.name(),
                    ts.photons_splatted,
                    ts.relevant,
                    ts.photons_traced,
                    r.photon_ms,
                    r.frame_wall_ms,
                    r.wall_ms,
                    ts.batches,
                    ts.peak_photon_bytes as f64 / (1 << 20) as f64
                ));
                runs.push(r);
            }
        }
    }
    bar.finish_and_clear();
    let name = scene.name.clone();
    let mut md = markdown(&name, &adapter, a, &grids, &techniques, &runs, &skipped);
    md.push_str(&crate::bench_beams::markdown(runs.iter().map(|r| (format!("{} {}²", r.technique, r.n), &r.out))));
    let js = to_json(&name, &adapter, a, &runs, &skipped);
    println!("\n{md}");
    let md_path = a.out.join(format!("bench_{name}.md"));
    let js_path = a.out.join(format!("bench_{name}.json"));
    std::fs::write(&md_path, &md).with_context(|| format!("cannot write {}", md_path.display()))?;
    std::fs::write(&js_path, serde_json::to_string_pretty(&js)? + "\n")
        .with_context(|| format!("cannot write {}", js_path.display()))?;
    println!("wrote {} and {}", md_path.display(), js_path.display());
    Ok(())
}

/// Photon paths and rays per second of the CPU reference on the bench scene, one thread and all.
fn cpu_bench(a: &BenchArgs) -> Result<()> {
    let mut scene = a.environment.apply(crate::load_scene(a.scene.as_deref(), a.camera.as_deref())?)?;
    (scene.camera.width, scene.camera.height) = a.size;
    let settings = caustics_reference::reference::ReferenceSettings {
        photons_per_light: a.cpu_photons,
        camera_spp: 4,
        ..Default::default()
    };
    let all = rayon::current_num_threads();
    let mut rows = Vec::new();
    for threads in [1, all] {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build()?;
        let out = pool.install(|| caustics_reference::reference::render(&scene, &settings))?;
        let st = out.stats;
        println!("CPU reference, {threads} thread(s): {st}");
        rows.push(format!(
            "| {threads} | {} | {:.3} | {:.3} | {:.3} | {:.3} | {:.2} |",
            st.photon_paths,
            st.photon_paths_per_second / 1e6,
            st.photon_paths_per_second / 1e6 / threads as f64,
            st.rays_per_second / 1e6,
            st.rays_per_second / 1e6 / threads as f64,
            st.seconds
        ));
        if all == 1 {
            break;
        }
    }
    let md = format!(
        "# CPU reference: {}\n\n{} triangles, {}x{} camera, 4 samples per pixel.\n\n| threads | photon paths | M paths/s | M paths/s per thread | M rays/s | M rays/s per thread | seconds |\n| ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n{}\n",
        scene.name,
        scene
            .objects
            .iter()
            .map(|o| match &o.shape {
                caustics::scene::Shape::Mesh(m) => m.indices.len(),
                _ => 0,
            })
            .sum::<usize>(),
        a.size.0,
        a.size.1,
        rows.join("\n")
    );
    std::fs::create_dir_all(&a.out).with_context(|| format!("cannot create {}", a.out.display()))?;
    let path = a.out.join(format!("bench_{}_cpu.md", scene.name));
    std::fs::write(&path, &md).with_context(|| format!("cannot write {}", path.display()))?;
    println!("{md}wrote {}", path.display());
    Ok(())
}

/// The render settings both benchmarks give technique `t` at grid `n`.
fn settings(a: &BenchArgs, t: Technique, n: u32) -> RenderSettings {
    let mut s = a.base.clone();
    s.photons.count = n;
    t.apply(&mut s);
    s
}

/// The techniques of `--technique`: a comma list of the names `render --technique` takes, each
/// applied over the base settings.
fn techniques(list: &str) -> Result<Vec<Technique>> {
    list.split(',')
        .map(|t| Technique::parse(t).with_context(|| format!("--technique: unknown technique \"{t}\"")))
        .collect()
}

/// What both benchmarks parse first: the techniques, photon grids and scene (image
/// size applied), and the output folder made.
fn setup(a: &BenchArgs) -> Result<(Vec<Technique>, Vec<u32>, Scene)> {
    let techniques = techniques(&a.technique)?;
    let grids = parse_grids(&a.photons)?;
    let mut scene = a.environment.apply(crate::load_scene(a.scene.as_deref(), a.camera.as_deref())?)?;
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    (scene.camera.width, scene.camera.height) = a.size;
    std::fs::create_dir_all(&a.out).with_context(|| format!("cannot create {}", a.out.display()))?;
    Ok((techniques, grids, scene))
}
