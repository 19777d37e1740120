//! `caustics bench`: the photon emission techniques side by side on one scene, light and device,
//! like Table 1 of Wyman & Nichols 2009 (photons splatted at each equivalent photon grid), plus
//! relevant photons, coverage, photons traced and evaluated, GPU milliseconds per pass, speed
//! relative to basic caustic maps, photon memory, batches, and how far each caustic map lies from
//! the dense one (HDR-FLIP). Printed, and written as markdown and JSON.
//!
//! With `--frames N`, the frame-loop benchmark instead ([`frame_loop`]): the persistent renderer
//! driven frame by frame through the phases `full`, `camera`, `light` and `object`.

use anyhow::{Context, Result, bail};
use caustics::Scene;
use caustics::image_io::Image;
use caustics::render::{GpuRender, RenderSettings};
use caustics::techniques::Technique;
use clap::Args;
use serde_json::{Value, json};
use std::fmt::Write as _;
use std::path::PathBuf;

#[derive(Args)]
pub struct BenchArgs {
    /// Scene file (JSON); the built-in glass-ball scene if omitted.
    scene: Option<PathBuf>,
    /// Techniques to compare, comma-separated: basic, hierarchical, adaptive-level, adaptive-error,
    /// caustic-spheres (the sphere options below).
    #[arg(long, default_value = "basic,hierarchical,adaptive-level,adaptive-error")]
    technique: String,
    /// Equivalent photon grids: a range of powers of two `LO..HI`, or a comma-separated list.
    #[arg(long, default_value = "256..4096")]
    photons: String,
    /// Caustic map size per light-view face (texels).
    #[arg(long, default_value_t = 1024)]
    caustic_map: u32,
    /// Memory for photon storage, MiB.
    #[arg(long, default_value_t = 64)]
    photon_memory: u64,
    /// Adaptive techniques: the coarse grid the hierarchy starts from.
    #[arg(long, default_value_t = 64)]
    base_grid: u32,
    /// Maximal caustic map error: convergence tolerance in caustic-map texels (0: one texel).
    #[arg(long, default_value_t = 0.0)]
    max_error_tolerance: f32,
    /// Maximal caustic map error: check every level as the paper does (no skipping of the levels
    /// where a cluster's spread predicts no convergence).
    #[arg(long)]
    no_error_skip: bool,
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
    /// Splat mode for every technique: fixed, multires, thin-lens, thick-lens, triangles.
    #[arg(long, default_value = "triangles")]
    splat: String,
    /// Photon tracer for every technique (the two side by side against the CPU reference:
    /// the retired `tracers` example, docs/benchmarks.md).
    #[arg(long, default_value = "exact", value_parser = crate::tracer_parser())]
    tracer: caustics::render::Tracer,
    /// Also time the CPU reference renderer with this many photon paths per light, on one
    /// thread and on all (photon paths and rays per second; written to bench_SCENE_cpu.md).
    /// With `--technique none` only the CPU reference is timed.
    #[arg(long, default_value_t = 0)]
    cpu_photons: u64,
    /// Frame-loop benchmark: render this many frames of each phase (`full`, `camera`, `light`,
    /// `object`) with the persistent renderer, for each technique and photon grid given, and
    /// report frame ms (median, p95), GPU ms per pass and resource creations per phase, the
    /// first frame apart (frameloop_SCENE.md and .json).
    #[arg(long, default_value_t = 0)]
    frames: u32,
    /// Frame-loop benchmark: the phases to run, comma-separated, in the order of `full`,
    /// `camera`, `light`, `object` (all four if omitted).
    #[arg(long, default_value = "full,camera,light,object")]
    phases: String,
    /// Caustic spheres (`--technique caustic-spheres`): the precomputed tables' settings.
    #[command(flatten)]
    sphere_args: crate::spheres::SphereArgs,
    /// Where the caustic on diffuse surfaces of spot and point lights comes from.
    #[arg(long, default_value = "photons", value_parser = crate::surface_caustics_parser())]
    surface_caustics: caustics::render::SurfaceCaustics,
    /// Spill faces of spot lights (auto, off, on; see `caustics render --help`).
    #[arg(long, default_value = "auto", value_parser = crate::spill_faces_parser())]
    spill_faces: caustics::render::SpillFaces,
    /// The volume caustic's beams (scenes with a medium; see `caustics render --help`).
    #[command(flatten)]
    beams: crate::BeamArgs,
    /// Scenes with a medium: the light lit surfaces and the medium exchange, virtual point
    /// lights per side of each light face (0: off, to time the beams alone; see `caustics
    /// render --help`).
    #[arg(long, default_value_t = 16)]
    medium_bounce_grid: u32,
    /// Scenes with a medium: leave out the medium beyond the first specular surface (see
    /// `caustics render --help`).
    #[arg(long)]
    no_medium_beyond_specular: bool,
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

pub fn run(a: &BenchArgs) -> Result<()> {
    if a.frames > 0 {
        return crate::bench::frame_loop(a);
    }
    if a.cpu_photons > 0 {
        cpu_bench(a)?;
    }
    if a.technique == "none" {
        return Ok(());
    }
    let (techniques, grids, splat, scene) = setup(a)?;
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
                shadow_map_size: 1024,
                // Table 1 counts one photon per cell, as the paper (which has no reflected
                // branch at glass) does: the transmitted branch only.
                dielectric_reflection: false,
                ..settings(a, t, n, splat)
            };
            if n > t.max_photons() {
                skipped.push((t, n, format!("{t} supports grids up to {}", t.max_photons())));
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
                            crate::spheres::attach(&mut r, &scene, &a.sphere_args, &mut sphere_tables)?;
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

fn find(runs: &[Run], t: Technique, n: u32) -> Option<&Run> {
    runs.iter().find(|r| r.technique == t && r.n == n)
}

/// Mean HDR-FLIP between two caustic maps (all lights and faces, concatenated).
fn map_flip(a: &GpuRender, b: &GpuRender) -> Option<f64> {
    let cat = |r: &GpuRender| -> Option<Image> {
        let maps: Vec<&Image> = r.caustic_maps.iter().flatten().collect();
        let w = maps.first()?.width;
        let mut img = Image::new(w, w * maps.len() as u32);
        for (k, m) in maps.iter().enumerate() {
            img.pixels[k * (w * w) as usize..(k + 1) * (w * w) as usize].copy_from_slice(&m.pixels);
        }
        Some(img)
    };
    caustics_reference::metrics::hdr_flip(&cat(a)?, &cat(b)?, None).ok().map(|f| f.mean)
}

fn mib(b: u64) -> String {
    format!("{:.2}", b as f64 / (1 << 20) as f64)
}

fn markdown(
    scene: &str,
    adapter: &str,
    a: &BenchArgs,
    grids: &[u32],
    techniques: &[Technique],
    runs: &[Run],
    skipped: &[(Technique, u32, String)],
) -> String {
    let mut s = String::new();
    let coverage = runs.first().map_or(0.0, |r| r.out.technique.coverage());
    let _ = writeln!(s, "# Photon emission techniques: {scene}\n");
    let _ = writeln!(
        s,
        "Adapter: {adapter}. Caustic map {0}x{0}, photon memory {1} MiB, base grid {2}, splat {7}, tracer {9}, max-error tolerance {3} texels (0: one texel){8}, camera {4}x{5}. Coverage (casters in the light's view): **{6:.2} %**.\n",
        a.caustic_map,
        a.photon_memory,
        a.base_grid,
        a.max_error_tolerance,
        a.size.0,
        a.size.1,
        100.0 * coverage,
        a.splat,
        if a.no_error_skip {
            ", every level checked (the paper's traversal)"
        } else {
            ", hopeless check levels skipped"
        },
        a.tracer,
    );
    let _ = writeln!(s, "## Photons splatted (Table 1 of Wyman & Nichols 2009)\n");
    let mut head = String::from("| photon grid | relevant |");
    let mut rule = String::from("| ---: | ---: |");
    for t in techniques {
        let _ = write!(head, " {t} |");
        rule.push_str(" ---: |");
    }
    for t in techniques.iter().filter(|t| !matches!(t, Technique::Basic)) {
        let _ = write!(head, " {t} / relevant |");
        rule.push_str(" ---: |");
    }
    let _ = writeln!(s, "{head}\n{rule}");
    for &n in grids {
        let relevant = runs.iter().find(|r| r.n == n).map(|r| r.out.technique.relevant);
        let _ = write!(s, "| {n}² | {} |", relevant.map_or("-".into(), |v| v.to_string()));
        for &t in techniques {
            let _ = write!(
                s,
                " {} |",
                find(runs, t, n).map_or("N/A".into(), |r| r.out.technique.photons_splatted.to_string())
            );
        }
        for &t in techniques.iter().filter(|t| !matches!(t, Technique::Basic)) {
            let v = find(runs, t, n).and_then(|r| {
                let rel = r.out.technique.relevant;
                (rel > 0).then(|| format!("{:.3}", r.out.technique.photons_splatted as f64 / rel as f64))
            });
            let _ = write!(s, " {} |", v.unwrap_or("N/A".into()));
        }
        s.push('\n');
    }
    let _ = writeln!(
        s,
        "\n## Work, time and memory\n\nTraced: photons traced (with caustic triangles over the adaptive hierarchy, + the cell-corner photons traced for the quads). Evaluated: cells kept over all levels of the hierarchy plus photons traced below the last level (adaptive), or cells plus photons splatted (hierarchical); divided by the relevant photons. Photon GPU ms: coverage mip, tracing, traversal and splat (timestamp queries); speed-up: basic's photon GPU ms at the same grid over this technique's. Frame ms: host wall-clock from the frame's submission to its completion (all GPU work of the frame, no recording, pipeline builds or read-back); frame speed-up: basic's frame ms over this technique's. Where pass timestamps miss work (lavapipe: the basic technique's splat escapes its own, see docs/benchmarks.md), compare the frame columns. Wall ms: the whole render call.\n"
    );
    let _ = writeln!(
        s,
        "| photon grid | technique | traced | evaluated / relevant | photon GPU ms | speed-up vs basic | frame GPU ms | frame ms | frame speed-up vs basic | wall ms | photon memory MiB | peak used MiB | batches | FLIP vs dense |"
    );
    let _ = writeln!(
        s,
        "| ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"
    );
    for &n in grids {
        for &t in techniques {
            let Some(r) = find(runs, t, n) else { continue };
            let ts = &r.out.technique;
            let basic = find(runs, Technique::Basic, n);
            let speed = basic.map_or("-".into(), |b| format!("{:.2}", b.photon_ms / r.photon_ms.max(1e-9)));
            let frame_speed =
                basic.map_or("-".into(), |b| format!("{:.2}", b.frame_wall_ms / r.frame_wall_ms.max(1e-9)));
            let dense =
                basic.or_else(|| find(runs, Technique::AdaptiveLevel, n).filter(|_| t != Technique::AdaptiveLevel));
            let flip = match dense {
                Some(d) if !std::ptr::eq(d, r) => map_flip(&r.out, &d.out).map_or("-".into(), |f| format!("{f:.4}")),
                _ => "-".into(),
            };
            let eval = if ts.relevant > 0 && t != Technique::Basic {
                format!("{:.3}", ts.evaluated as f64 / ts.relevant as f64)
            } else {
                "-".into()
            };
            let traced = if ts.corners_traced > 0 {
                format!("{} (+{} corners)", ts.photons_traced, ts.corners_traced)
            } else {
                ts.photons_traced.to_string()
            };
            let _ = writeln!(
                s,
                "| {n}² | {t} | {traced} | {eval} | {:.1} | {speed} | {:.1} | {:.1} | {frame_speed} | {:.0} | {} | {} | {} | {flip} |",
                r.photon_ms,
                r.frame_ms,
                r.frame_wall_ms,
                r.wall_ms,
                mib(ts.photon_bytes),
                mib(ts.peak_photon_bytes),
                ts.batches
            );
        }
    }
    let _ = writeln!(
        s,
        "\nFLIP vs dense: mean HDR-FLIP of the caustic map against basic caustic maps at the same grid (against adaptive-level where basic cannot run).\n"
    );
    let _ = writeln!(s, "## GPU milliseconds per pass\n");
    let mut passes: Vec<String> = Vec::new();
    for r in runs {
        for (p, _) in &r.out.timings {
            if is_photon_pass(p) && !passes.contains(p) {
                passes.push(p.clone());
            }
        }
    }
    let _ = writeln!(s, "| photon grid | technique | {} |", passes.join(" | "));
    let _ = writeln!(s, "| ---: | --- |{}", " ---: |".repeat(passes.len()));
    for r in runs {
        let cells: Vec<String> = passes
            .iter()
            .map(|p| r.out.timings.iter().find(|(q, _)| q == p).map_or("-".into(), |(_, ms)| format!("{ms:.1}")))
            .collect();
        let _ = writeln!(s, "| {}² | {} | {} |", r.n, r.technique, cells.join(" | "));
    }
    let _ = writeln!(s, "\n## Photons per level (adaptive)\n");
    let _ = writeln!(s, "| photon grid | technique | level grid | cells kept | photons traced | photons emitted |");
    let _ = writeln!(s, "| ---: | --- | ---: | ---: | ---: | ---: |");
    for r in runs.iter().filter(|r| r.technique.is_adaptive()) {
        for l in &r.out.technique.levels {
            let _ = writeln!(
                s,
                "| {}² | {} | {}² | {} | {} | {} |",
                r.n, r.technique, l.grid, l.cells, l.traced, l.emitted
            );
        }
    }
    if !skipped.is_empty() {
        let _ = writeln!(s, "\nNot run:\n");
        for (t, n, why) in skipped {
            let _ = writeln!(s, "- {t} at {n}²: {why}");
        }
    }
    s
}

fn to_json(scene: &str, adapter: &str, a: &BenchArgs, runs: &[Run], skipped: &[(Technique, u32, String)]) -> Value {
    let rows: Vec<Value> = runs
        .iter()
        .map(|r| {
            let ts = &r.out.technique;
            let basic = find(runs, Technique::Basic, r.n).filter(|b| !std::ptr::eq(*b, r));
            json!({
                "technique": r.technique.name(),
                "photon_grid": r.n,
                "photons_splatted": ts.photons_splatted,
                "photons_traced": ts.photons_traced,
                "corners_traced": ts.corners_traced,
                "relevant": ts.relevant,
                "evaluated": ts.evaluated,
                "coverage": ts.coverage(),
                "photon_gpu_ms": r.photon_ms,
                "frame_gpu_ms": r.frame_ms,
                "frame_wall_ms": r.frame_wall_ms,
                "wall_ms": r.wall_ms,
                "speedup_vs_basic": basic.map(|b| b.photon_ms / r.photon_ms.max(1e-9)),
                "frame_speedup_vs_basic": basic.map(|b| b.frame_wall_ms / r.frame_wall_ms.max(1e-9)),
                "flip_vs_basic": basic.and_then(|b| map_flip(&r.out, &b.out)),
                "photon_bytes": ts.photon_bytes,
                "peak_photon_bytes": ts.peak_photon_bytes,
                "batches": ts.batches,
                "flux_landed_w": r.out.flux.iter().map(|f| f.landed).sum::<f64>(),
                "passes_ms": r.out.timings.iter().map(|(p, ms)| (p.clone(), json!(ms))).collect::<serde_json::Map<_, _>>(),
                "levels": ts.levels.iter().map(|l| json!({"grid": l.grid, "cells": l.cells, "traced": l.traced, "emitted": l.emitted})).collect::<Vec<_>>(),
            })
        })
        .collect();
    json!({
        "scene": scene,
        "adapter": adapter,
        "caustic_map": a.caustic_map,
        "photon_memory_mib": a.photon_memory,
        "base_grid": a.base_grid,
        "max_error_tolerance": a.max_error_tolerance,
        "error_skip_hopeless": !a.no_error_skip,
        "runs": rows,
        "not_run": skipped.iter().map(|(t, n, why)| json!({"technique": t.name(), "photon_grid": n, "why": why})).collect::<Vec<_>>(),
    })
}

/// Photon paths and rays per second of the CPU reference on the bench scene, one thread and all.
fn cpu_bench(a: &BenchArgs) -> Result<()> {
    let mut scene = match &a.scene {
        Some(p) => Scene::load(p)?,
        None => Scene::default_scene(),
    };
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

/// The phases of the frame-loop benchmark, in order.
const PHASES: [&str; 4] = ["full", "camera", "light", "object"];

/// `--phases`: the phases named, each known and once, in the order of [`PHASES`].
fn parse_phases(s: &str) -> Result<Vec<&'static str>> {
    let names: Vec<&str> = s.split(',').map(str::trim).filter(|p| !p.is_empty()).collect();
    for p in &names {
        if !PHASES.contains(p) {
            let known = PHASES.join(", ");
            return Err(caustics::Error::input(
                "<command line>",
                "--phases",
                format!("unknown phase \"{p}\" (known: {known})"),
            )
            .into());
        }
    }
    let phases: Vec<&'static str> = PHASES.iter().copied().filter(|p| names.contains(p)).collect();
    if phases.is_empty() {
        let known = PHASES.join(", ");
        return Err(
            caustics::Error::input("<command line>", "--phases", format!("no phase given (known: {known})")).into()
        );
    }
    Ok(phases)
}

/// What changes in each phase's frame `i` (of `n`), applied to the renderer before the frame.
/// `full` changes all three at once (camera, every light, the first caster), so that every pass
/// of the frame has to be redone while the renderer (its resources, pipelines) stays the same.
fn animate(r: &mut caustics::renderer::Renderer, base: &Scene, phase: &str, i: u32, n: u32) -> caustics::Result<()> {
    use glam::{Affine3A, Vec3};
    let phi = std::f32::consts::TAU * (i as f32 + 1.0) / n.max(1) as f32;
    let (camera, light, object) = match phase {
        "full" => (true, true, true),
        "camera" => (true, false, false),
        "light" => (false, true, false),
        _ => (false, false, true),
    };
    if camera {
        // Orbit about the look-at point, around the up axis, a full turn over the phase.
        let c = &base.camera;
        let up = c.up.normalize();
        let rel = c.position - c.look_at;
        let mut cam = c.clone();
        cam.position = c.look_at + glam::Quat::from_axis_angle(up, phi) * rel;
        r.set_camera(cam)?;
    }
    if light {
        // The light moves on a small circle (5 % of the scene's size) across its direction.
        let (lo, hi) = base.bounds();
        let radius = 0.05 * (hi - lo).length();
        let lights = if phase == "full" { base.lights.len() } else { base.lights.len().min(1) };
        for k in 0..lights {
            let mut l = base.lights[k].clone();
            match &mut l {
                caustics::scene::Light::Spot { position, direction, .. } => {
                    let (u, v) = direction.any_orthonormal_pair();
                    *position += radius * (phi.cos() * u + phi.sin() * v);
                }
                caustics::scene::Light::Point { position, .. } => {
                    *position += radius * Vec3::new(phi.cos(), 0.0, phi.sin());
                }
                caustics::scene::Light::Directional { direction, .. } => {
                    let (u, v) = direction.any_orthonormal_pair();
                    *direction = (*direction + 0.05 * (phi.cos() * u + phi.sin() * v)).normalize();
                }
            }
            r.set_light(k, l)?;
        }
    }
    if object && let Some(k) = base.objects.iter().position(|o| o.caustic_caster) {
        // The first caster moves on a small circle and turns about the up axis through its centre.
        let (lo, hi) = base.objects[k].shape.bounds();
        let centre = 0.5 * (lo + hi);
        let radius = 0.1 * (hi - lo).length();
        let offset = radius * Vec3::new(phi.cos() - 1.0, 0.0, phi.sin());
        let t = Affine3A::from_translation(centre + offset)
            * Affine3A::from_rotation_y(phi)
            * Affine3A::from_translation(-centre);
        r.set_object_transform(k, t)?;
    }
    Ok(())
}

/// One frame's measurements.
struct FrameSample {
    /// Host clock: encode() to the GPU's completion of the submitted work.
    frame_ms: f64,
    /// Host clock: submission to completion (the work encode() left in the caller's encoder).
    submit_ms: f64,
    /// CPU time of the whole process (every thread: on lavapipe the "GPU" too) from encode() to
    /// completion, NaN where the system does not say (`process_cpu_ns`).
    cpu_ms: f64,
    timings: Vec<(String, f64)>,
    created: u64,
    photons_traced: u64,
    lights_redone: usize,
}

/// CPU time the process's threads have run so far (Linux: the first field of each
/// `/proc/self/task/*/schedstat`, nanoseconds). On a software device (lavapipe) the "GPU" is the
/// process's own threads, so a frame's CPU time measures its work on a loaded machine better than
/// its wall time, which also counts the time other processes held the cores.
fn process_cpu_ns() -> Option<u64> {
    let mut total = 0u64;
    for t in std::fs::read_dir("/proc/self/task").ok()? {
        let path = t.ok()?.path().join("schedstat");
        // A thread that ended since the listing has no file any more: skip it.
        let Ok(text) = std::fs::read_to_string(path) else { continue };
        total += text.split_whitespace().next()?.parse::<u64>().ok()?;
    }
    Some(total)
}

fn percentile(v: &[f64], p: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let k = ((s.len() - 1) as f64 * p).round() as usize;
    s[k]
}

fn frame(r: &mut caustics::renderer::Renderer) -> Result<FrameSample> {
    use caustics::renderer::FrameRequest;
    let before = r.created().total();
    let c0 = process_cpu_ns();
    let t0 = std::time::Instant::now();
    let mut enc = r.context().device.create_command_encoder(&Default::default());
    r.encode(&mut enc, FrameRequest { stats: true })?;
    let t1 = std::time::Instant::now();
    let ctx = r.context();
    ctx.queue.submit([enc.finish()]);
    ctx.device
        .poll(wgpu::PollType::Wait { submission_index: None, timeout: None })
        .map_err(|e| anyhow::anyhow!("waiting for the frame: {e}"))?;
    let t2 = std::time::Instant::now();
    let cpu_ms = match (c0, process_cpu_ns()) {
        (Some(a), Some(b)) => b.saturating_sub(a) as f64 * 1e-6,
        _ => f64::NAN,
    };
    let stats = r.wait_stats()?.unwrap_or_default();
    Ok(FrameSample {
        frame_ms: (t2 - t0).as_secs_f64() * 1e3,
        submit_ms: (t2 - t1).as_secs_f64() * 1e3,
        cpu_ms,
        timings: stats.timings,
        created: r.created().total() - before,
        photons_traced: stats.technique.photons_traced,
        lights_redone: stats.lights_redone.iter().filter(|&&b| b).count(),
    })
}

/// Per phase: the first frame and the later ones.
struct Phase {
    name: &'static str,
    first: FrameSample,
    rest: Vec<FrameSample>,
}

impl Phase {
    fn frame_ms(&self) -> Vec<f64> {
        self.rest.iter().map(|f| f.frame_ms).collect()
    }
    fn pass_median(&self, pass: &str) -> Option<f64> {
        let v: Vec<f64> = self
            .rest
            .iter()
            .filter_map(|f| f.timings.iter().filter(|(p, _)| p == pass).map(|(_, ms)| *ms).reduce(|a, b| a + b))
            .collect();
        (!v.is_empty()).then(|| percentile(&v, 0.5))
    }
}

/// The render settings both benchmarks give technique `t` at grid `n`.
fn settings(a: &BenchArgs, t: Technique, n: u32, splat: caustics::splat::SplatMode) -> RenderSettings {
    RenderSettings {
        photons: n,
        technique: t,
        base_grid: a.base_grid,
        max_error_tolerance: a.max_error_tolerance,
        error_skip_hopeless: !a.no_error_skip,
        caustic_map_size: a.caustic_map,
        photon_memory: a.photon_memory.saturating_mul(1 << 20),
        splat,
        tracer: a.tracer,
        surface_caustics: a.surface_caustics,
        spill_faces: a.spill_faces,
        beams: a.beams.settings(),
        medium_bounce_grid: a.medium_bounce_grid,
        medium_beyond_specular: !a.no_medium_beyond_specular,
        ..Default::default()
    }
}

/// What both benchmarks parse first: the techniques, photon grids, splat mode and scene (image
/// size applied), and the output folder made.
fn setup(a: &BenchArgs) -> Result<(Vec<Technique>, Vec<u32>, caustics::splat::SplatMode, Scene)> {
    let techniques: Vec<Technique> = a
        .technique
        .split(',')
        .map(|t| Technique::parse(t).with_context(|| format!("--technique: unknown technique \"{t}\"")))
        .collect::<Result<_>>()?;
    let grids = parse_grids(&a.photons)?;
    let splat = caustics::splat::SplatMode::parse(&a.splat)
        .with_context(|| format!("--splat: unknown splat mode \"{}\"", a.splat))?;
    let mut scene = match &a.scene {
        Some(p) => Scene::load(p)?,
        None => Scene::default_scene(),
    };
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    (scene.camera.width, scene.camera.height) = a.size;
    std::fs::create_dir_all(&a.out).with_context(|| format!("cannot create {}", a.out.display()))?;
    Ok((techniques, grids, splat, scene))
}

/// `caustics bench --frames N`: the frame loop of the persistent renderer, phase by phase.
pub fn frame_loop(a: &BenchArgs) -> Result<()> {
    use caustics::renderer::Renderer;
    let (techniques, grids, splat, scene) = setup(a)?;
    let phase_names = parse_phases(&a.phases)?;
    let mut ctx = Some(caustics::gpu::GpuContext::new(a.adapter.as_deref())?);
    let adapter = {
        let c = ctx.as_ref().unwrap();
        format!("{} ({:?}, {})", c.info.name, c.info.backend, c.info.driver)
    };
    println!("scene: {} ({}), adapter: {adapter}, {} frames per phase", scene.name, scene.source, a.frames);
    let mut runs: Vec<(Technique, u32, Vec<Phase>)> = Vec::new();
    let mut sphere_tables = None;
    // One renderer for everything (its context keeps the pipelines); the settings change
    // between runs.
    let mut renderer: Option<Renderer> = None;
    let total = (techniques.len() * grids.len() * phase_names.len()) as u64 * a.frames as u64;
    let bar = crate::progress::steps(total, "frames");
    for &t in &techniques {
        for &n in &grids {
            let s = settings(a, t, n, splat);
            let r = match renderer.as_mut() {
                Some(r) => {
                    r.set_settings(s)?;
                    r
                }
                None => renderer.insert(Renderer::with_context(ctx.take().unwrap(), scene.clone(), s)?),
            };
            crate::spheres::attach(r, &scene, &a.sphere_args, &mut sphere_tables)?;
            let mut phases = Vec::new();
            for &name in &phase_names {
                // Every phase starts from the scene as loaded.
                r.set_camera(scene.camera.clone())?;
                for (k, l) in scene.lights.iter().enumerate() {
                    r.set_light(k, l.clone())?;
                }
                for k in 0..scene.objects.len() {
                    r.set_object_transform(k, glam::Affine3A::IDENTITY)?;
                }
                let mut samples = Vec::new();
                bar.set_message(format!("{t} {n}^2 {name}"));
                for i in 0..a.frames {
                    bar.inc(1);
                    animate(r, &scene, name, i, a.frames)?;
                    samples.push(frame(r)?);
                }
                let first = samples.remove(0);
                let p = Phase { name, first, rest: samples };
                let ms = p.frame_ms();
                bar.suspend(|| {
                    println!(
                        "{t} {n}^2 {name:<7} first {:>9.1} ms, then median {:>9.1} ms, p95 {:>9.1} ms, CPU median {:>9.1} ms ({} frames)",
                        p.first.frame_ms,
                        percentile(&ms, 0.5),
                        percentile(&ms, 0.95),
                        percentile(&p.rest.iter().map(|f| f.cpu_ms).collect::<Vec<_>>(), 0.5),
                        ms.len()
                    )
                });
                phases.push(p);
            }
            runs.push((t, n, phases));
        }
    }
    bar.finish_and_clear();
    let name = scene.name.clone();
    let md = frame_markdown(&name, &adapter, a, &runs);
    let js = frame_json(&name, &adapter, a, &runs);
    println!("\n{md}");
    let md_path = a.out.join(format!("frameloop_{name}.md"));
    let js_path = a.out.join(format!("frameloop_{name}.json"));
    std::fs::write(&md_path, &md).with_context(|| format!("cannot write {}", md_path.display()))?;
    std::fs::write(&js_path, serde_json::to_string_pretty(&js)? + "\n")
        .with_context(|| format!("cannot write {}", js_path.display()))?;
    println!("wrote {} and {}", md_path.display(), js_path.display());
    Ok(())
}

fn fmt_ms(v: f64) -> String {
    if v.is_finite() { format!("{v:.1}") } else { "-".into() }
}

const FULL_NOTE: &str = "`full`: every frame moves the camera (orbit), every light (small circle) and the first caster (circle and turn) at once, so every pass is redone; the renderer, its resources and pipelines are kept. `camera`: an orbit about the look-at point, a full turn over the phase. `light`: the first light on a circle of 5 % of the scene's size. `object`: the first caster on a circle of 10 % of its size, turning about the up axis.";

fn frame_markdown(scene: &str, adapter: &str, a: &BenchArgs, runs: &[(Technique, u32, Vec<Phase>)]) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# Frame loop: {scene}\n");
    let _ = writeln!(
        s,
        "Adapter: {adapter}. Camera {}x{}, caustic map {2}x{2}, splat {3}, {4} frames per phase (the first apart). {FULL_NOTE}\n",
        a.size.0, a.size.1, a.caustic_map, a.splat, a.frames
    );
    let _ = writeln!(
        s,
        "Frame ms: host clock from `encode()` to the GPU's completion of the submitted encoder (median and p95 of the frames after the first); submit ms: submission to completion alone; CPU ms: the CPU time of all the process's threads over the same span (median; on a software device such as lavapipe this is the frame's work, less sensitive to load than the host clock). Created: GPU objects the renderer created per frame after the first (`Renderer::created`). Photons traced and lights redone: median per frame.\n"
    );
    let _ = writeln!(
        s,
        "| technique | photon grid | phase | first frame ms | frame ms median | frame ms p95 | submit ms median | CPU ms median | GPU ms median (sum of passes) | created per frame (median / max) | photons traced | lights redone |"
    );
    let _ = writeln!(s, "| --- | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | --- | ---: | ---: |");
    for (t, n, phases) in runs {
        for p in phases {
            let ms = p.frame_ms();
            let sub: Vec<f64> = p.rest.iter().map(|f| f.submit_ms).collect();
            let cpu: Vec<f64> = p.rest.iter().map(|f| f.cpu_ms).collect();
            let gpu: Vec<f64> = p.rest.iter().map(|f| f.timings.iter().map(|(_, ms)| ms).sum()).collect();
            let created: Vec<f64> = p.rest.iter().map(|f| f.created as f64).collect();
            let traced: Vec<f64> = p.rest.iter().map(|f| f.photons_traced as f64).collect();
            let redone: Vec<f64> = p.rest.iter().map(|f| f.lights_redone as f64).collect();
            let _ = writeln!(
                s,
                "| {t} | {n}² | {} | {} | {} | {} | {} | {} | {} | {} / {} | {} | {} |",
                p.name,
                fmt_ms(p.first.frame_ms),
                fmt_ms(percentile(&ms, 0.5)),
                fmt_ms(percentile(&ms, 0.95)),
                fmt_ms(percentile(&sub, 0.5)),
                fmt_ms(percentile(&cpu, 0.5)),
                fmt_ms(percentile(&gpu, 0.5)),
                fmt_ms(percentile(&created, 0.5)).trim_end_matches(".0"),
                created.iter().copied().fold(0.0, f64::max),
                percentile(&traced, 0.5).max(0.0) as u64,
                percentile(&redone, 0.5).max(0.0) as u64,
            );
        }
    }
    let _ = writeln!(s, "\n## GPU ms per pass (median of the frames after the first)\n");
    for (t, n, phases) in runs {
        let mut passes: Vec<String> = Vec::new();
        for p in phases {
            for f in p.rest.iter().chain(std::iter::once(&p.first)) {
                for (q, _) in &f.timings {
                    if !passes.contains(q) {
                        passes.push(q.clone());
                    }
                }
            }
        }
        let _ = writeln!(s, "{t}, {n}² photons:\n");
        let names: Vec<&str> = phases.iter().map(|p| p.name).collect();
        let _ = writeln!(s, "| pass | {} |", names.join(" | "));
        let _ = writeln!(s, "| --- |{}", " ---: |".repeat(names.len()));
        for q in &passes {
            let cells: Vec<String> = phases.iter().map(|p| p.pass_median(q).map_or("-".into(), fmt_ms)).collect();
            let _ = writeln!(s, "| {q} | {} |", cells.join(" | "));
        }
        s.push('\n');
    }
    s
}

fn frame_json(scene: &str, adapter: &str, a: &BenchArgs, runs: &[(Technique, u32, Vec<Phase>)]) -> Value {
    let sample = |f: &FrameSample| {
        json!({
            "frame_ms": f.frame_ms,
            "submit_ms": f.submit_ms,
            "cpu_ms": if f.cpu_ms.is_finite() { json!(f.cpu_ms) } else { Value::Null },
            "gpu_ms": f.timings.iter().map(|(_, ms)| ms).sum::<f64>(),
            "created": f.created,
            "photons_traced": f.photons_traced,
            "lights_redone": f.lights_redone,
        })
    };
    let rows: Vec<Value> = runs
        .iter()
        .map(|(t, n, phases)| {
            let ph: serde_json::Map<String, Value> = phases
                .iter()
                .map(|p| {
                    let ms = p.frame_ms();
                    let mut passes: Vec<String> = Vec::new();
                    for f in &p.rest {
                        for (q, _) in &f.timings {
                            if !passes.contains(q) {
                                passes.push(q.clone());
                            }
                        }
                    }
                    let pass_ms: serde_json::Map<String, Value> =
                        passes.iter().map(|q| (q.clone(), json!(p.pass_median(q)))).collect();
                    let created: Vec<u64> = p.rest.iter().map(|f| f.created).collect();
                    (
                        p.name.to_string(),
                        json!({
                            "frames": p.rest.len() + 1,
                            "first_frame": sample(&p.first),
                            "frame_ms_median": percentile(&ms, 0.5),
                            "frame_ms_p95": percentile(&ms, 0.95),
                            "submit_ms_median": percentile(&p.rest.iter().map(|f| f.submit_ms).collect::<Vec<_>>(), 0.5),
                            "cpu_ms_median": percentile(&p.rest.iter().map(|f| f.cpu_ms).collect::<Vec<_>>(), 0.5),
                            "pass_ms_median": pass_ms,
                            "created_per_frame": created,
                            "frames_after_first": p.rest.iter().map(sample).collect::<Vec<_>>(),
                        }),
                    )
                })
                .collect();
            json!({ "technique": t.name(), "photon_grid": n, "phases": ph })
        })
        .collect();
    json!({
        "scene": scene,
        "adapter": adapter,
        "camera": [a.size.0, a.size.1],
        "caustic_map": a.caustic_map,
        "splat": a.splat,
        "frames_per_phase": a.frames,
        "full_phase": FULL_NOTE,
        "frame_ms": "host clock from encode() to the GPU's completion of the submitted encoder",
        "runs": rows,
    })
}
