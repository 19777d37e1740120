//! `caustics bench --frames N`: the frame-loop benchmark of the persistent renderer, phase by
//! phase (`full`, `camera`, `light`, `object`, `mesh`): the scene's animation, per-frame samples, and the
//! markdown and JSON report.

use super::{BenchArgs, settings, setup};
use anyhow::{Context, Result};
use caustics::Scene;
use caustics::settings::Technique;
use serde_json::{Value, json};
use std::fmt::Write as _;

/// The phases of the frame-loop benchmark, in order.
const PHASES: [&str; 5] = ["full", "camera", "light", "object", "mesh"];

/// The frame rate the `mesh` phase advances an animated scene's time by (frames per second).
const MESH_FPS: f32 = 30.0;

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
    if phase == "mesh" {
        deform(r, base, i)?;
        return Ok(());
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

/// The `mesh` phase's frame `i`: an animated scene (`waves`) at time (i + 1) / 30 s; else the
/// first mesh object's vertices swell and shrink along their normals (a wave of 1 % of its size
/// running across it), so every frame rewrites its vertices and refits its BVH on the GPU.
fn deform(r: &mut caustics::renderer::Renderer, base: &Scene, i: u32) -> caustics::Result<()> {
    if base.is_animated() {
        return r.set_time((i as f32 + 1.0) / MESH_FPS);
    }
    let Some((k, m)) = base.objects.iter().enumerate().find_map(|(k, o)| match &o.shape {
        caustics::scene::Shape::Mesh(m) => Some((k, m)),
        _ => None,
    }) else {
        return Ok(());
    };
    let (lo, hi) = m.bounds();
    let size = (hi - lo).max_element();
    let phi = (i as f32 + 1.0) * 0.7;
    let positions: Vec<glam::Vec3> = m
        .positions
        .iter()
        .zip(&m.normals)
        .map(|(p, n)| *p + 0.01 * size * (phi + 6.0 * (p.x - lo.x) / size).sin() * *n)
        .collect();
    r.set_mesh_vertices(k, &positions, &m.normals)
}

/// Whether the scene has a mesh for the `mesh` phase to deform.
fn has_mesh(scene: &Scene) -> bool {
    scene.objects.iter().any(|o| matches!(o.shape, caustics::scene::Shape::Mesh(_)))
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

/// `caustics bench --frames N`: the frame loop of the persistent renderer, phase by phase.
pub fn frame_loop(a: &BenchArgs) -> Result<()> {
    use caustics::renderer::Renderer;
    let (techniques, grids, scene) = setup(a)?;
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
            let s = settings(a, t, n);
            let r = match renderer.as_mut() {
                Some(r) => {
                    r.set_settings(s)?;
                    r
                }
                None => renderer.insert(Renderer::with_context(ctx.take().unwrap(), scene.clone(), s)?),
            };
            crate::spheres::attach(r, &scene, &a.spheres, &mut sphere_tables)?;
            let mut phases = Vec::new();
            for &name in &phase_names {
                // Every phase starts from the scene as loaded.
                r.set_camera(scene.camera.clone())?;
                for (k, l) in scene.lights.iter().enumerate() {
                    r.set_light(k, l.clone())?;
                }
                for (k, o) in scene.objects.iter().enumerate() {
                    r.set_object_transform(k, glam::Affine3A::IDENTITY)?;
                    if let caustics::scene::Shape::Mesh(m) = &o.shape {
                        r.set_mesh_vertices(k, &m.positions, &m.normals)?;
                    }
                }
                if name == "mesh" && !has_mesh(&scene) {
                    bar.inc(a.frames as u64);
                    bar.suspend(|| println!("{t} {n}^2 mesh: skipped, the scene has no mesh to deform"));
                    continue;
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

const FULL_NOTE: &str = "`full`: every frame moves the camera (orbit), every light (small circle) and the first caster (circle and turn) at once, so every pass is redone; the renderer, its resources and pipelines are kept. `camera`: an orbit about the look-at point, a full turn over the phase. `light`: the first light on a circle of 5 % of the scene's size. `object`: the first caster on a circle of 10 % of its size, turning about the up axis. `mesh`: a mesh's vertices change every frame (an animated scene's waves at 30 frames a second, else the first mesh swelling along its normals by 1 % of its size): its vertices rewritten and its BVH refit on the GPU (`bvh_refit`), the lights that see it redone.";

fn frame_markdown(scene: &str, adapter: &str, a: &BenchArgs, runs: &[(Technique, u32, Vec<Phase>)]) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# Frame loop: {scene}\n");
    let _ = writeln!(
        s,
        "Adapter: {adapter}. Camera {}x{}, caustic map {2}x{2}, splat {3}, {4} frames per phase (the first apart). {FULL_NOTE}\n",
        a.size.0, a.size.1, a.base.photons.caustic_map_size, a.base.photons.splat, a.frames
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
        "caustic_map": a.base.photons.caustic_map_size,
        "splat": a.base.photons.splat.name(),
        "frames_per_phase": a.frames,
        "full_phase": FULL_NOTE,
        "frame_ms": "host clock from encode() to the GPU's completion of the submitted encoder",
        "runs": rows,
    })
}
