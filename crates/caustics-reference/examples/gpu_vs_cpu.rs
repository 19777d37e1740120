//! Compare the GPU basic caustic map with the CPU reference's, texel by texel.
//! `cargo run --release --example gpu_vs_cpu -- SCENE [MAP_SIZE] [GRID] [CPU_PHOTONS] [OUT_DIR]`
use caustics::image_io::Image;
use caustics_reference::ImageIo as _;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let scene = caustics::Scene::load(std::path::Path::new(&a[1])).unwrap();
    let m: u32 = a.get(2).map_or(256, |x| x.parse().unwrap());
    let n: u32 = a.get(3).map_or(1024, |x| x.parse().unwrap());
    let photons: u64 = a.get(4).map_or(4_000_000, |x| x.parse().unwrap());
    let ctx = caustics::gpu::GpuContext::new(None).unwrap();
    let s = caustics::render::RenderSettings {
        photons: caustics::settings::PhotonSettings { count: n, caustic_map_size: m, ..Default::default() },
        shading: caustics::settings::ShadingSettings { shadow_map_size: 512, ..Default::default() },
        ..Default::default()
    };
    let gpu = caustics::render::render(&ctx, &scene, &s).unwrap();
    let rs = caustics_reference::reference::ReferenceSettings {
        photons_per_light: photons,
        caustic_map_size: m,
        ..Default::default()
    };
    let cpu = caustics_reference::reference::caustic_maps(&scene, &rs).unwrap();
    for (l, (g, c)) in gpu.caustic_maps.iter().zip(&cpu).enumerate() {
        for (f, (gm, cm)) in g.iter().zip(c).enumerate() {
            let st = caustics_reference::metrics::map_agreement(gm, cm);
            println!("light {l} face {f}: {st}");
            if let Some(dir) = a.get(5) {
                let dir = std::path::Path::new(dir);
                std::fs::create_dir_all(dir).unwrap();
                let side = |img: &Image, name: &str| img.write(&dir.join(format!("l{l}f{f}_{name}.exr")), 1.0).unwrap();
                side(gm, "gpu");
                side(cm, "cpu");
            }
        }
    }
}
