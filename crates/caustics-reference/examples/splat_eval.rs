//! Error of each splat mode's caustic map against the CPU reference's, and its GPU cost.
//! `cargo run --release --example splat_eval -- SCENE[,SCENE..] PHOTONS[,..] MODES [MAP] [REF_PHOTONS]`
//! e.g. `splat_eval scenes/glass_sphere.json 256,512,1024 fixed,multires,thin-lens,triangles 512`.
//! Prints per scene, photon grid and mode: relative RMSE and mean HDR-FLIP of the caustic map
//! (light space, both maps 3x3 box-filtered for the RMSE, see metrics::map_agreement), energy
//! ratio, splat-stage GPU ms (photon_splat + splat_blend), photon stage (trace + splat) and frame
//! GPU ms.
use caustics::Scene;
use caustics::render::{RenderSettings, SplatMode, render};
use caustics_reference::{metrics, reference};
use std::path::Path;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let scenes: Vec<&str> = args[1].split(',').collect();
    let grids: Vec<u32> = args[2].split(',').map(|x| x.parse().unwrap()).collect();
    let modes: Vec<SplatMode> = args[3].split(',').map(|x| SplatMode::parse(x).expect("mode")).collect();
    let m: u32 = args.get(4).map_or(512, |x| x.parse().unwrap());
    let ref_photons: u64 = args.get(5).map_or(16_000_000, |x| x.parse().unwrap());
    let ctx = caustics::gpu::GpuContext::new(None).unwrap();
    println!("| scene | photons | mode | rel. RMSE | mean FLIP | energy | splat ms | trace+splat ms | frame ms |");
    println!("| --- | --- | --- | --- | --- | --- | --- | --- | --- |");
    for sc in scenes {
        let mut scene = Scene::load(Path::new(sc)).unwrap();
        scene.camera.height = scene.camera.height * 128 / scene.camera.width;
        scene.camera.width = 128;
        let rs =
            reference::ReferenceSettings { photons_per_light: ref_photons, caustic_map_size: m, ..Default::default() };
        let refmap = reference::caustic_maps(&scene, &rs).unwrap().remove(0).remove(0);
        for &n in &grids {
            for &mode in &modes {
                let s = RenderSettings {
                    photons: caustics::settings::PhotonSettings {
                        count: n,
                        caustic_map_size: m,
                        splat: mode,
                        ..Default::default()
                    },
                    shading: caustics::settings::ShadingSettings { shadow_map_size: 512, ..Default::default() },
                    ..Default::default()
                };
                // Warm-up render, then the measured one.
                let _ = render(&ctx, &scene, &s).unwrap();
                let out = render(&ctx, &scene, &s).unwrap();
                let map = &out.caustic_maps[0][0];
                let a = metrics::map_agreement(map, &refmap);
                let flip = metrics::hdr_flip(map, &refmap, None).unwrap();
                let t = |names: &[&str]| -> f64 {
                    out.timings.iter().filter(|(k, _)| names.contains(&k.as_str())).map(|(_, v)| v).sum()
                };
                let splat = t(&["photon_splat", "splat_blend"]);
                let photon = t(&["photon_trace", "photon_splat", "splat_blend"]);
                let frame: f64 = out.timings.iter().map(|(_, v)| v).sum();
                let name = Path::new(sc).file_stem().unwrap().to_string_lossy();
                println!(
                    "| {name} | {n}² | {mode} | {:.4} | {:.4} | {:.4} | {splat:.1} | {photon:.1} | {frame:.1} |",
                    a.rel_rmse, flip.mean, a.energy_ratio
                );
            }
        }
    }
}
