//! Environment lighting on the GPU (the environment segmented into D directional lights)
//! against the CPU reference under the same map: HDR-FLIP and energy of the full image and of
//! the caustic-only image, per D.
//! `cargo run --release --example env_lights -- SCENE WxH GRID CPU_PHOTONS SPP D1,D2,.. [OUT_DIR]`
//! (`CAUSTIC_MAP=M` in the environment: caustic map size, default 512; `SPLIT_RULES=both`: each
//! D with the default split rule and the paper's)
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
    println!(
        "| D | lights drawn | full HDR-FLIP | full energy GPU/CPU | caustic HDR-FLIP | caustic energy GPU/CPU | frame ms |"
    );
    println!("| --- | --- | --- | --- | --- | --- | --- |");
    let rules: Vec<caustics::scene::environment_lights::SplitRule> = match std::env::var("SPLIT_RULES") {
        Ok(v) if v == "both" => vec![Default::default(), caustics::scene::environment_lights::SplitRule::Total],
        _ => vec![Default::default()],
    };
    for (d, rule) in ds.iter().flat_map(|&d| rules.iter().map(move |&r| (d, r))) {
        let s = caustics::render::RenderSettings {
            env_split: rule,
            photons: grid,
            caustic_map_size: std::env::var("CAUSTIC_MAP").map_or(512, |v| v.parse().unwrap()),
            shadow_map_size: 1024,
            env_lights: d,
            ..Default::default()
        };
        let mut r = caustics::renderer::Renderer::with_context(ctx.clone(), scene.clone(), s).unwrap();
        let drawn = r.lights().len();
        let g = r.render_once().unwrap();
        let ff = hdr_flip(&g.image, &cpu.image, None).unwrap().mean;
        let fc = hdr_flip(&g.caustic, &cpu.caustic, None).unwrap().mean;
        let ef = energy(&g.image, None) / energy(&cpu.image, None);
        let ec = energy(&g.caustic, None) / energy(&cpu.caustic, None);
        let d = if rules.len() > 1 { format!("{d} ({rule:?})") } else { d.to_string() };
        println!("| {d} | {drawn} | {ff:.3} | {ef:.3} | {fc:.3} | {ec:.3} | {:.0} |", g.frame_wall_ms);
        if let Some(o) = &out {
            g.image.write(&o.join(format!("gpu_d{d}.exr")), 1.0).unwrap();
            g.caustic.write(&o.join(format!("gpu_d{d}_caustic.exr")), 1.0).unwrap();
            g.image.write(&o.join(format!("gpu_d{d}.png")), scene.exposure).unwrap();
            g.caustic.write(&o.join(format!("gpu_d{d}_caustic.png")), scene.exposure).unwrap();
        }
    }
}
