//! Head to head (docs/benchmarks.md, "Caustic spheres"): one scene lit by D directional lights
//! on a cone around straight down, rendered with per-light adaptive caustic maps and with caustic
//! spheres in one run: frame milliseconds (host clock, submission to completion) and HDR-FLIP of
//! the caustic image against the CPU reference, per D.
//! `cargo run --release --example spheres_h2h -- SCENE SIZE PHOTONS REF_PHOTONS_PER_LIGHT D...`
use caustics::caustic_spheres::{Blend, SphereSettings};
use caustics::render::{RenderSettings, Technique};
use caustics::renderer::Renderer;
use caustics::scene::Light;
use caustics_reference::metrics::hdr_flip;
use caustics_reference::reference::{self, Progress, ReferenceSettings, spheres};
use glam::Vec3;
use std::sync::Arc;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let mut scene = caustics::Scene::load(std::path::Path::new(&a[1])).unwrap();
    let size: u32 = a[2].parse().unwrap();
    let photons: u32 = a[3].parse().unwrap();
    let ref_photons: u64 = a[4].parse().unwrap();
    let ds: Vec<usize> = a[5..].iter().map(|s| s.parse().unwrap()).collect();
    scene.camera.width = size;
    scene.camera.height = size;
    let ctx = caustics::gpu::GpuContext::new(None).unwrap();
    let obj = scene.objects.iter().position(|o| scene.material_of(o).is_specular()).unwrap();
    let ss = SphereSettings { photons: 1 << 17, ..Default::default() };
    let t = std::time::Instant::now();
    let table = Arc::new(spheres::precompute(&scene, obj, &ss, None, &Progress::new()).unwrap());
    println!("precompute {:.1} s, {:.1} MiB", t.elapsed().as_secs_f64(), table.bytes() as f64 / (1 << 20) as f64);
    println!(
        "| D | adaptive ms | spheres ms | adaptive FLIP | spheres FLIP | adaptive energy | spheres energy | reference s |"
    );
    println!("| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |");
    for d in ds {
        // D lights on a cone of 25° around straight down, 3 W/m² in all, hues around the circle.
        scene.lights = (0..d)
            .map(|i| {
                let ph = i as f32 / d as f32 * std::f32::consts::TAU;
                let th = if d == 1 { 0.0 } else { 25f32.to_radians() };
                let dir = Vec3::new(th.sin() * ph.cos(), -th.cos(), th.sin() * ph.sin());
                let hue = Vec3::new(1.0 + ph.cos(), 1.0 + (ph + 2.1).cos(), 1.0 + (ph + 4.2).cos()) * 0.5 + 0.25;
                Light::Directional { direction: dir, irradiance: hue * (3.0 / d as f32 / hue.element_sum() * 3.0) }
            })
            .collect();
        let base = RenderSettings {
            photons: caustics::settings::PhotonSettings {
                count: photons,
                technique: Technique::AdaptiveLevel,
                caustic_map_size: 512,
                ..Default::default()
            },
            shading: caustics::settings::ShadingSettings { shadow_map_size: 1024, ..Default::default() },
            ..Default::default()
        };
        let run = |s: RenderSettings| {
            let mut r = Renderer::with_context(ctx.clone(), scene.clone(), s).unwrap();
            r.set_caustic_spheres(vec![(obj, table.clone())], Blend::Triangle, false).unwrap();
            let _ = r.render_once().unwrap(); // pipelines built
            let mut best = f64::INFINITY;
            let mut out = None;
            for _ in 0..3 {
                let mut r2 = Renderer::with_context(ctx.clone(), scene.clone(), r.settings().clone()).unwrap();
                r2.set_caustic_spheres(vec![(obj, table.clone())], Blend::Triangle, false).unwrap();
                let o = r2.render_once().unwrap();
                best = best.min(o.frame_wall_ms);
                out = Some(o);
            }
            (best, out.unwrap())
        };
        let (ma, oa) = run(base.clone());
        let (ms, os) = run(RenderSettings {
            photons: caustics::settings::PhotonSettings {
                technique: caustics::render::Technique::CausticSpheres,
                ..base.photons
            },
            ..base
        });
        let t = std::time::Instant::now();
        let r = reference::render(
            &scene,
            &ReferenceSettings { photons_per_light: ref_photons, camera_spp: 1, ..Default::default() },
        )
        .unwrap();
        let rt = t.elapsed().as_secs_f64();
        let fa = hdr_flip(&oa.caustic, &r.caustic, None).unwrap().mean;
        let fs = hdr_flip(&os.caustic, &r.caustic, None).unwrap().mean;
        println!(
            "| {d} | {ma:.0} | {ms:.0} | {fa:.4} | {fs:.4} | {:.3} | {:.3} | {rt:.0} |",
            oa.caustic.sum() / r.caustic.sum(),
            os.caustic.sum() / r.caustic.sum()
        );
    }
}
