//! Environment lighting on the GPU (the environment segmented into D directional lights)
//! against the CPU reference under the same map: HDR-FLIP and energy of the full image and of
//! the caustic-only image, per D.
//! `cargo run --release --example env_lights -- SCENE WxH GRID CPU_PHOTONS SPP D1,D2,.. [OUT_DIR]`
//! (`CAUSTIC_MAP=M` in the environment: caustic map size, default 512; `SPLIT_RULES=both`: each
//! D with the default split rule and the paper's; `TAPS=0,16`: each D with each number of
//! sub-directions per region, `RenderSettings::env_taps`; `FLUX=1`: where each light's flux went; `DECOMPOSE=1`: also the CPU
//! reference lit by the D directional lights, against both; `PASS_MS=1`: GPU ms of the passes;
//! `SPHERES=1`: the technique `caustic-spheres` instead of basic maps, the caustic objects'
//! tables (N = 7, s = 16, 64 × 48, `SPHERE_PHOTONS` per direction, default 2^18) read from or
//! built into `SPHERE_CACHE` (default `.caustics-cache`); `SPHERES=both`: each D with both;
//! `SPHERE_SAMPLES=n`: n × n points per pixel of `sphere_gather`'s box filter)
use caustics_reference::ImageIo as _;
use caustics_reference::metrics::{energy, hdr_flip};

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let mut scene = caustics::Scene::load(std::path::Path::new(&a[1])).unwrap();
    let (w, h) = a[2].split_once('x').unwrap();
    scene.camera.width = w.parse().unwrap();
    scene.camera.height = h.parse().unwrap();
    let grid: u32 = a[3].parse().unwrap();
    let photons: u64 = a[4].parse().unwrap();
    let spp: u32 = a[5].parse().unwrap();
    let ds: Vec<u32> = a[6].split(',').map(|x| x.parse().unwrap()).collect();
    let out = a.get(7).map(std::path::PathBuf::from);
    if let Some(o) = &out {
        std::fs::create_dir_all(o).unwrap();
    }
    let t = std::time::Instant::now();
    let rs = caustics_reference::reference::ReferenceSettings {
        photons_per_light: photons,
        camera_spp: spp,
        ..Default::default()
    };
    let cpu = caustics_reference::reference::render(&scene, &rs).unwrap();
    eprintln!("CPU reference: {:.1} s", t.elapsed().as_secs_f64());
    if let Some(o) = &out {
        cpu.image.write(&o.join("cpu.exr"), 1.0).unwrap();
        cpu.caustic.write(&o.join("cpu_caustic.exr"), 1.0).unwrap();
        cpu.image.write(&o.join("cpu.png"), scene.exposure).unwrap();
        cpu.caustic.write(&o.join("cpu_caustic.png"), scene.exposure).unwrap();
    }
    let ctx = caustics::gpu::GpuContext::new(None).unwrap();
    // Caustic spheres (the paper's method for the D region lights): per caustic object its table.
    let sphere_modes: Vec<bool> = match std::env::var("SPHERES").as_deref() {
        Ok("both") => vec![false, true],
        Ok(_) => vec![true],
        Err(_) => vec![false],
    };
    let tables: Vec<(usize, std::sync::Arc<caustics::caustic_spheres::CausticSpheres>)> =
        if sphere_modes.contains(&true) {
            let ss = caustics::caustic_spheres::SphereSettings {
                photons: std::env::var("SPHERE_PHOTONS").map_or(1 << 18, |v| v.parse().unwrap()),
                ..Default::default()
            };
            let dir = std::path::PathBuf::from(std::env::var("SPHERE_CACHE").unwrap_or(".caustics-cache".into()));
            let t = std::time::Instant::now();
            let v: Vec<_> = (0..scene.objects.len())
                .filter(|&o| scene.objects[o].caustic_caster && scene.material_of(&scene.objects[o]).is_specular())
                .map(|o| {
                    let (sp, origin) = caustics_reference::reference::spheres::load_or_precompute(
                        &scene,
                        o,
                        &ss,
                        caustics::caustic_spheres::cache::Storage::F32,
                        &dir,
                        &caustics_reference::reference::Progress::new(),
                    )
                    .unwrap();
                    eprintln!("caustic spheres of object {o}: {origin:?}");
                    (o, std::sync::Arc::new(sp))
                })
                .collect();
            eprintln!("caustic spheres: {:.1} s", t.elapsed().as_secs_f64());
            v
        } else {
            Vec::new()
        };
    println!(
        "| D | lights drawn | full HDR-FLIP | full energy GPU/CPU | caustic HDR-FLIP | caustic energy GPU/CPU | frame ms |"
    );
    println!("| --- | --- | --- | --- | --- | --- | --- |");
    let rules: Vec<caustics::scene::environment_lights::SplitRule> = match std::env::var("SPLIT_RULES") {
        Ok(v) if v == "both" => vec![Default::default(), caustics::scene::environment_lights::SplitRule::Total],
        _ => vec![Default::default()],
    };
    let taps: Vec<u32> = std::env::var("TAPS")
        .map_or(vec![caustics::settings::DEFAULT_ENV_TAPS], |v| v.split(',').map(|x| x.parse().unwrap()).collect());
    let mut runs = Vec::new();
    for &d in &ds {
        for &r in &rules {
            for &t in &taps {
                for &sph in &sphere_modes {
                    runs.push((d, r, t, sph));
                }
            }
        }
    }
    let mut decomposed = std::collections::HashMap::new();
    for &(d, rule, env_taps, sph) in &runs {
        let d_num = d;
        let s = caustics::render::RenderSettings {
            photons: caustics::settings::PhotonSettings {
                technique: if sph { caustics::render::Technique::CausticSpheres } else { Default::default() },
                count: grid,
                caustic_map_size: std::env::var("CAUSTIC_MAP").map_or(512, |v| v.parse().unwrap()),
                ..Default::default()
            },
            shading: caustics::settings::ShadingSettings { shadow_map_size: 1024, ..Default::default() },
            environment: caustics::settings::EnvironmentSettings { split: rule, taps: env_taps, lights: d },
            ..Default::default()
        };
        let mut r = caustics::renderer::Renderer::with_context(ctx.clone(), scene.clone(), s).unwrap();
        if sph {
            r.set_caustic_spheres(tables.clone(), caustics::caustic_spheres::Blend::Triangle, false).unwrap();
            if let Ok(n) = std::env::var("SPHERE_SAMPLES") {
                r.set_caustic_sphere_samples(n.parse().unwrap()).unwrap();
            }
        }
        let drawn = r.lights().len();
        let g = r.render_once().unwrap();
        let ff = hdr_flip(&g.image, &cpu.image, None).unwrap().mean;
        let fc = hdr_flip(&g.caustic, &cpu.caustic, None).unwrap().mean;
        let ef = energy(&g.image, None) / energy(&cpu.image, None);
        let ec = energy(&g.caustic, None) / energy(&cpu.caustic, None);
        let mut d = if rules.len() > 1 { format!("{d} ({rule:?})") } else { d.to_string() };
        if taps.len() > 1 {
            d = format!("{d}, K = {env_taps}");
        }
        let tag = format!("{}{}", d.replace([' ', ',', '(', ')', '='], ""), if sph { "_spheres" } else { "" });
        if sph {
            d = format!("{d}, spheres");
        }
        println!("| {d} | {drawn} | {ff:.3} | {ef:.3} | {fc:.3} | {ec:.3} | {:.0} |", g.frame_wall_ms);
        if std::env::var("PASS_MS").is_ok() {
            // GPU time of the shading passes (all lights) and of the whole frame's passes.
            let shade: f64 = g.timings.iter().filter(|(n, _)| n == "shade_receivers").map(|(_, t)| t).sum();
            let all: f64 = g.timings.iter().map(|(_, t)| t).sum();
            println!("pass ms {d}: shade_receivers {shade:.1}, all passes {all:.1}");
        }
        if std::env::var("DECOMPOSE").is_ok() {
            // The CPU reference lit by the very directional lights the GPU draws (no map; the
            // same photon total): against the reference under the map it is the error of the
            // directional approximation alone; the GPU against it, the GPU's own error.
            let mut sd = scene.clone();
            sd.lights = r.lights();
            sd.environment = None;
            let rsd = caustics_reference::reference::ReferenceSettings {
                photons_per_light: photons / drawn.max(1) as u64,
                camera_spp: 1,
                ..Default::default()
            };
            // The same D lights for every technique and K: rendered once per (D, rule).
            let cd = decomposed
                .entry((d_num, rule as u32))
                .or_insert_with(|| caustics_reference::reference::render(&sd, &rsd).unwrap());
            let f_dir = hdr_flip(&cd.caustic, &cpu.caustic, None).unwrap().mean;
            let e_dir = energy(&cd.caustic, None) / energy(&cpu.caustic, None);
            let f_gpu = hdr_flip(&g.caustic, &cd.caustic, None).unwrap().mean;
            let e_gpu = energy(&g.caustic, None) / energy(&cd.caustic, None);
            println!(
                "decompose {d}: CPU(D lights) vs CPU(map): caustic HDR-FLIP {f_dir:.3} energy {e_dir:.3}; GPU vs CPU(D lights): caustic HDR-FLIP {f_gpu:.3} energy {e_gpu:.3}"
            );
            if let Some(o) = &out {
                cd.caustic.write(&o.join(format!("cpu_lights_d{tag}_caustic.exr")), 1.0).unwrap();
            }
        }
        if std::env::var("FLUX").is_ok() {
            // Per light: elevation of the light's source direction, its irradiance (mean of
            // the channels), the flux onto the casters over E·(the casters' cross-section if
            // one sphere), and where the flux went, as fractions of it.
            let area = scene.objects.iter().find_map(|o| match o.shape {
                caustics::scene::Shape::Sphere { radius, .. } if o.caustic_caster => {
                    Some(std::f64::consts::PI * (radius as f64).powi(2))
                }
                _ => None,
            });
            for (l, (light, f)) in r.lights().iter().zip(&g.flux).enumerate() {
                let caustics::scene::Light::Directional { direction, irradiance } = light else { continue };
                let e = irradiance.element_sum() as f64 / 3.0;
                let elev = (-direction.y).asin().to_degrees();
                let em = f.emitted.max(1e-30);
                println!(
                    "light {l:2} elev {elev:6.1} E {e:8.3} onto/(E·A) {:.3} landed {:.3} no_exit {:.3} tir {:.3} no_recv {:.3} outside {:.3} untraced {:.3}",
                    area.map_or(0.0, |a| f.emitted / (e * a)),
                    f.landed / em,
                    f.lost_no_exit / em,
                    f.lost_tir / em,
                    f.lost_no_receiver / em,
                    f.lost_outside / em,
                    f.untraced_branches / em
                );
            }
        }
        if let Some(o) = &out {
            g.image.write(&o.join(format!("gpu_d{tag}.exr")), 1.0).unwrap();
            g.caustic.write(&o.join(format!("gpu_d{tag}_caustic.exr")), 1.0).unwrap();
            g.image.write(&o.join(format!("gpu_d{tag}.png")), scene.exposure).unwrap();
            g.caustic.write(&o.join(format!("gpu_d{tag}_caustic.png")), scene.exposure).unwrap();
        }
    }
}
