//! The GPU photon tracers (exact; exact with the first hit from the light's buffer;
//! image-space) against the CPU reference, one run per scene:
//! caustic maps (energy ratio, relative RMSE, and the CPU reference's own noise at the GPU's
//! photon count) and the camera's caustic image in the caustic region (HDR-FLIP, energy), with
//! GPU ms of the photon pass and photons per ms.
//!
//! `cargo run --release -p caustics-reference --example tracers -- [--grid N] [--map M]
//!  [--cpu-photons P] [--technique T] [--out DIR] [--caustic-paths all|first-diffuse]
//!  [--only-exact] [--cpu-noise] SCENE...`
//!
//! The caustic region: pixels where the reference's or the GPU's caustic exceeds 2 % of the
//! reference's 99.5th-percentile luminance (a misplaced caustic counts against the GPU).
//!
//! `--caustic-paths first-diffuse` restricts the reference's caustic image to the paths the GPU
//! renders (light → specular chain → first diffuse surface → camera; `CausticPaths`); the
//! default `all` is the reference's full caustic light. `--cpu-noise` also renders the
//! reference with a second seed and prints its region FLIP and energy against the first (the
//! reference's own noise in those figures, the region taken the same way), and the region
//! energy of the paths the restriction leaves out (`CausticPaths::Rest`, same seed) over the
//! restricted image's. `--only-exact` runs the exact tracer alone.
use caustics::image_io::Image;
use caustics::render::{RenderSettings, Technique, Tracer};
use caustics_reference::ImageIo as _;
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
    let (mut grid, mut map, mut cpu_photons, mut technique, mut out) =
        (512u32, 256u32, 8_000_000u64, Technique::Basic, None::<std::path::PathBuf>);
    let (mut paths, mut only_exact, mut cpu_noise) = (CausticPaths::All, false, false);
    let mut scenes = Vec::new();
    while let Some(a) = args.next() {
        match a.as_str() {
            "--grid" => grid = args.next().unwrap().parse().unwrap(),
            "--map" => map = args.next().unwrap().parse().unwrap(),
            "--cpu-photons" => cpu_photons = args.next().unwrap().parse().unwrap(),
            "--technique" => technique = Technique::parse(&args.next().unwrap()).expect("a technique"),
            "--out" => out = Some(args.next().unwrap().into()),
            "--caustic-paths" => paths = CausticPaths::parse(&args.next().unwrap()).expect("all|first-diffuse|rest"),
            "--only-exact" => only_exact = true,
            "--cpu-noise" => cpu_noise = true,
            _ => scenes.push(a),
        }
    }
    let ctx = caustics::gpu::GpuContext::new(None).expect("a GPU adapter");
    println!("adapter: {}", ctx.info.name);
    println!(
        "| scene | tracer | map energy | map rel. RMSE | CPU noise at GPU count | ratio | region FLIP | region energy | photon ms | photons/ms |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for path in &scenes {
        let mut scene = caustics::Scene::load(std::path::Path::new(path)).expect("scene");
        scene.camera.width = scene.camera.width.min(320);
        scene.camera.height = scene.camera.height.min(320);
        let name = std::path::Path::new(path).file_stem().unwrap().to_string_lossy().to_string();
        let rs = |photons: u64, seed: u64| ReferenceSettings {
            photons_per_light: photons,
            caustic_map_size: map,
            camera_spp: 1,
            seed,
            caustic_paths: paths,
            ..Default::default()
        };
        let t0 = std::time::Instant::now();
        let cpu = reference::render(&scene, &rs(cpu_photons, 0)).expect("reference");
        println!("{name}: CPU reference ({paths:?}) {:.1} s", t0.elapsed().as_secs_f64());
        if cpu_noise {
            // The reference's own noise: seed 1 against seed 0, the region taken the same way.
            let cpu1 = reference::render(&scene, &rs(cpu_photons, 1)).expect("reference");
            let mask = region(&cpu.caustic, &cpu1.caustic);
            let flip = metrics::hdr_flip(&cpu1.caustic, &cpu.caustic, Some(&mask)).expect("flip");
            let e = metrics::energy_ratio(&cpu1.caustic, &cpu.caustic, Some(&mask)).expect("energy");
            println!(
                "{name}: CPU reference noise ({paths:?}, {cpu_photons} photons, seed 1 vs 0): region FLIP {:.3}, region energy {e:.4}",
                flip.mean
            );
            // All = first-diffuse + rest, photon by photon (`CausticPaths`).
            let class = |c: CausticPaths| {
                if c == paths {
                    cpu.caustic.clone()
                } else {
                    reference::render(&scene, &ReferenceSettings { caustic_paths: c, ..rs(cpu_photons, 0) })
                        .expect("reference")
                        .caustic
                }
            };
            let first = class(CausticPaths::FirstDiffuse);
            let rest = class(CausticPaths::Rest);
            let mut all = first.clone();
            for (a, r) in all.pixels.iter_mut().zip(&rest.pixels) {
                for k in 0..3 {
                    a[k] += r[k];
                }
            }
            let mask = region(&all, &all);
            let er = metrics::energy_ratio(&rest, &first, Some(&mask)).expect("energy");
            let ea = metrics::energy_ratio(&all, &first, Some(&mask)).expect("energy");
            let fl = metrics::hdr_flip(&first, &all, Some(&mask)).expect("flip");
            println!(
                "{name}: in the full caustic's region: rest / first-diffuse energy {er:.4}, all / first-diffuse {ea:.4}, FLIP first-diffuse vs all {:.3}",
                fl.mean
            );
        }
        let mut rows = Vec::new();
        let variants = [
            ("exact", Tracer::Exact, false),
            ("exact, first hit in buffer", Tracer::Exact, true),
            ("image-space", Tracer::ImageSpace, false),
        ];
        for (label, tracer, first_hit_from_buffer) in variants {
            if only_exact && (tracer != Tracer::Exact || first_hit_from_buffer) {
                continue;
            }
            let s = RenderSettings {
                photons: caustics::settings::PhotonSettings {
                    count: grid,
                    caustic_map_size: map,
                    technique,
                    tracer,
                    ..Default::default()
                },
                shading: caustics::settings::ShadingSettings { shadow_map_size: 1024, ..Default::default() },
                testing: caustics::settings::TestingSettings { first_hit_from_buffer, ..Default::default() },
                ..Default::default()
            };
            let gpu = caustics::render::render(&ctx, &scene, &s).expect("gpu render");
            let relevant = gpu.technique.relevant.max(1);
            let photon_ms: f64 = gpu
                .timings
                .iter()
                .filter(|(n, _)| n.contains("trace") || n.contains("refine") || n.contains("hcm"))
                .map(|(_, ms)| ms)
                .sum();
            rows.push((label, gpu, relevant, photon_ms));
        }
        // The CPU reference's own noise at the GPU's photon count (relevant photons of the exact
        // tracer's run), against the same high-count reference.
        let cpu_lo = reference::caustic_maps(&scene, &rs(rows[0].2, 7)).expect("reference");
        let noise = metrics::map_agreement(&cpu_lo[0][0], &cpu.caustic_maps[0][0]).rel_rmse;
        for (tracer, gpu, _, photon_ms) in &rows {
            let m = metrics::map_agreement(&gpu.caustic_maps[0][0], &cpu.caustic_maps[0][0]);
            let mask = region(&cpu.caustic, &gpu.caustic);
            let flip = metrics::hdr_flip(&gpu.caustic, &cpu.caustic, Some(&mask)).expect("flip");
            let e = metrics::energy_ratio(&gpu.caustic, &cpu.caustic, Some(&mask)).expect("energy");
            let per_ms = if *photon_ms > 0.0 { gpu.photons_traced as f64 / photon_ms } else { f64::NAN };
            let f = &gpu.flux[0];
            eprintln!(
                "{name} {tracer}: flux landed {:.4} of emitted, outside the light's view {:.4}, no receiver {:.4}",
                f.landed / f.emitted,
                f.lost_outside / f.emitted,
                f.lost_no_receiver / f.emitted
            );
            println!(
                "| {name} | {tracer} | {:.4} | {:.4} | {noise:.4} | {:.2} | {:.3} | {e:.4} | {photon_ms:.1} | {per_ms:.0} |",
                m.energy_ratio,
                m.rel_rmse,
                m.rel_rmse / noise,
                flip.mean
            );
            if let Some(dir) = &out {
                std::fs::create_dir_all(dir).unwrap();
                gpu.caustic.write(&dir.join(format!("{name}_{tracer}_caustic.exr")), 1.0).unwrap();
                gpu.image.write(&dir.join(format!("{name}_{tracer}.png")), 1.0).unwrap();
            }
        }
        if let Some(dir) = &out {
            cpu.caustic.write(&dir.join(format!("{name}_cpu_caustic.exr")), 1.0).unwrap();
            cpu.image.write(&dir.join(format!("{name}_cpu.png")), 1.0).unwrap();
        }
    }
}
