//! Spill faces (`RenderSettings::spill_faces`) against the CPU reference: per scene, the GPU's
//! camera caustic image with spill faces off and auto against the restricted reference
//! (`--caustic-paths first-diffuse` of `tracers`): region HDR-FLIP and energy, the flux
//! bookkeeping, and the frame's GPU time (median of `--frames` frames of the persistent
//! renderer, the light redone each frame).
//!
//! `cargo run --release -p caustics-reference --example spill_eval -- [--grid N] [--map M]
//!  [--cpu-photons P] [--frames F] [--cpu-noise] [--timing] SCENE...`
//!
//! `--timing`: no reference; the frames of `off` and `auto` alternate (one renderer each), so
//! that a change in the machine's load falls on both, and the medians and their ratio print
//! (wall time, and the sum of the GPU pass timings where the adapter has timestamp queries).
//!
//! The region is `tracers`' (pixels where the reference's or the GPU's caustic exceeds 2 % of
//! the reference's 99.5th-percentile luminance), taken per run.
use caustics::image_io::Image;
use caustics::render::{RenderSettings, SpillFaces, Tracer};
use caustics_reference::metrics::{self, Mask};
use caustics_reference::reference::{self, CausticPaths, ReferenceSettings};

fn region(cpu: &Image, gpu: &Image) -> Mask {
    let mut l: Vec<f32> = cpu.luminance().into_iter().filter(|&x| x > 0.0).collect();
    l.sort_by(f32::total_cmp);
    let p = l.get((l.len() as f64 * 0.995) as usize).copied().unwrap_or(0.0);
    let t = 0.02 * p;
    let sel: Vec<bool> = cpu.luminance().iter().zip(gpu.luminance()).map(|(&a, b)| a > t || b > t).collect();
    let mut img = Image::new(cpu.width, cpu.height);
    for (px, s) in img.pixels.iter_mut().zip(&sel) {
        *px = if *s { [1.0; 3] } else { [0.0; 3] };
    }
    Mask::from_image(&img, false)
}

fn main() {
    let mut args = std::env::args().skip(1);
    let (mut grid, mut map, mut cpu_photons, mut frames, mut cpu_noise) =
        (1024u32, 1024u32, 8_000_000u64, 5usize, false);
    let mut scenes = Vec::new();
    let mut timing = false;
    while let Some(a) = args.next() {
        match a.as_str() {
            "--grid" => grid = args.next().unwrap().parse().unwrap(),
            "--map" => map = args.next().unwrap().parse().unwrap(),
            "--cpu-photons" => cpu_photons = args.next().unwrap().parse().unwrap(),
            "--frames" => frames = args.next().unwrap().parse().unwrap(),
            "--cpu-noise" => cpu_noise = true,
            "--timing" => timing = true,
            _ => scenes.push(a),
        }
    }
    let ctx = caustics::gpu::GpuContext::new(None).expect("a GPU adapter");
    println!("adapter: {}", ctx.info.name);
    if timing {
        for path in &scenes {
            time_frames(&ctx, path, grid, map, frames);
        }
        return;
    }
    println!("| scene | spill | faces | region FLIP | region energy | landed | outside | frame wall ms (median) |");
    println!("|---|---|---:|---:|---:|---:|---:|---:|");
    for path in &scenes {
        let mut scene = caustics::Scene::load(std::path::Path::new(path)).expect("scene");
        scene.camera.width = scene.camera.width.min(320);
        scene.camera.height = scene.camera.height.min(320);
        let name = std::path::Path::new(path).file_stem().unwrap().to_string_lossy().to_string();
        let rs = |seed: u64| ReferenceSettings {
            photons_per_light: cpu_photons,
            caustic_map_size: 64,
            camera_spp: 1,
            seed,
            caustic_paths: CausticPaths::FirstDiffuse,
            ..Default::default()
        };
        let t0 = std::time::Instant::now();
        let cpu = reference::render(&scene, &rs(0)).expect("reference");
        eprintln!("{name}: CPU reference {:.1} s", t0.elapsed().as_secs_f64());
        if cpu_noise {
            let cpu1 = reference::render(&scene, &rs(1)).expect("reference");
            let mask = region(&cpu.caustic, &cpu1.caustic);
            let flip = metrics::hdr_flip(&cpu1.caustic, &cpu.caustic, Some(&mask)).expect("flip");
            let e = metrics::energy_ratio(&cpu1.caustic, &cpu.caustic, Some(&mask)).expect("energy");
            println!(
                "{name}: reference noise ({cpu_photons} photons, seed 1 vs 0): region FLIP {:.3}, energy {e:.4}",
                flip.mean
            );
        }
        for spill in [SpillFaces::Off, SpillFaces::Auto] {
            let s = RenderSettings {
                photons: caustics::settings::PhotonSettings {
                    count: grid,
                    caustic_map_size: map,
                    tracer: Tracer::Exact,
                    ..Default::default()
                },
                shading: caustics::settings::ShadingSettings { spill_faces: spill, ..Default::default() },
                ..Default::default()
            };
            let faces = s.light_view(&scene, &scene.lights[0]).faces.len();
            let mut r = caustics::renderer::Renderer::with_context(ctx.clone(), scene.clone(), s).expect("renderer");
            let gpu = r.render_once().expect("gpu render");
            let mut ms = Vec::new();
            for _ in 0..frames {
                let l = r.lights()[0].clone();
                r.set_light(0, l).expect("light");
                let f = r.render_once().expect("frame");
                ms.push(f.frame_wall_ms);
            }
            ms.sort_by(f64::total_cmp);
            let med = ms.get(ms.len() / 2).copied().unwrap_or(f64::NAN);
            let mask = region(&cpu.caustic, &gpu.caustic);
            let flip = metrics::hdr_flip(&gpu.caustic, &cpu.caustic, Some(&mask)).expect("flip");
            let e = metrics::energy_ratio(&gpu.caustic, &cpu.caustic, Some(&mask)).expect("energy");
            let f = &gpu.flux[0];
            println!(
                "| {name} | {spill} | {faces} | {:.3} | {e:.4} | {:.4} | {:.4} | {med:.0} |",
                flip.mean,
                f.landed / f.emitted,
                f.lost_outside / f.emitted
            );
        }
    }
}

/// Median frame wall time (light redone every frame) with spill faces off and auto, frames
/// alternating between the two renderers.
fn time_frames(ctx: &caustics::gpu::GpuContext, path: &str, grid: u32, map: u32, frames: usize) {
    let mut scene = caustics::Scene::load(std::path::Path::new(path)).expect("scene");
    scene.camera.width = scene.camera.width.min(320);
    scene.camera.height = scene.camera.height.min(320);
    let mut rs: Vec<_> = [SpillFaces::Off, SpillFaces::Auto]
        .into_iter()
        .map(|spill| {
            let s = RenderSettings {
                photons: caustics::settings::PhotonSettings {
                    count: grid,
                    caustic_map_size: map,
                    tracer: Tracer::Exact,
                    ..Default::default()
                },
                shading: caustics::settings::ShadingSettings { spill_faces: spill, ..Default::default() },
                ..Default::default()
            };
            let mut r = caustics::renderer::Renderer::with_context(ctx.clone(), scene.clone(), s).expect("renderer");
            r.render_once().expect("first frame");
            (spill, r, Vec::new(), Vec::new())
        })
        .collect();
    let mut last = Vec::new();
    for _ in 0..frames {
        for (_, r, ms, gpu_ms) in rs.iter_mut() {
            let l = r.lights()[0].clone();
            r.set_light(0, l).expect("light");
            let out = r.render_once().expect("frame");
            ms.push(out.frame_wall_ms);
            gpu_ms.push(out.timings.iter().map(|(_, t)| t).sum::<f64>());
            last = out.timings;
        }
    }
    // The GPU passes of the last frame (empty without timestamp queries), by time.
    last.sort_by(|a, b| b.1.total_cmp(&a.1));
    println!("{path}: slowest passes of the last auto frame: {:?}", &last[..last.len().min(10)]);
    let mut med = Vec::new();
    for (spill, _, ms, gpu_ms) in rs.iter_mut() {
        ms.sort_by(f64::total_cmp);
        gpu_ms.sort_by(f64::total_cmp);
        let (m, g) = (ms[ms.len() / 2], gpu_ms[gpu_ms.len() / 2]);
        println!("{path} {spill}: frame wall ms {ms:?}, median {m:.0}; GPU pass ms (sum) median {g:.0}");
        med.push((m, g));
    }
    println!("{path}: auto / off: wall {:.3}, GPU passes {:.3}", med[1].0 / med[0].0, med[1].1 / med[0].1);
}
