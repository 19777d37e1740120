//! The compiled variant of caustic spheres against the direct one (docs/benchmarks.md, "the
//! compiled variant"): one scene lit by D directional lights on a cone around straight down,
//! one persistent renderer per D; steady frames (the lights' shadow maps kept, so a frame is
//! the eye passes, the shading, `sphere_compile` + `sphere_gather` and the composite) with the
//! direct and the compiled variant, alternately: host ms per frame (submission to completion,
//! median of FRAMES), the passes' timestamps, and the relative L1 and energy of the compiled
//! caustic image against the direct one.
//! `cargo run --release --example spheres_compiled -- SCENE SIZE FRAMES D...`
use caustics::caustic_spheres::{Blend, SphereSettings};
use caustics::image_io::Image;
use caustics::render::{GpuRender, RenderSettings, Technique};
use caustics::renderer::Renderer;
use caustics::scene::Light;
use caustics_reference::reference::{Progress, spheres};
use glam::Vec3;
use std::sync::Arc;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn rel_l1(a: &Image, b: &Image) -> f64 {
    let (mut d, mut s) = (0.0f64, 0.0f64);
    for (x, y) in a.pixels.iter().zip(&b.pixels) {
        for c in 0..3 {
            d += (x[c] - y[c]).abs() as f64;
            s += y[c].abs() as f64;
        }
    }
    d / s.max(1e-30)
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let mut scene = caustics::Scene::load(std::path::Path::new(&a[1])).unwrap();
    let size: u32 = a[2].parse().unwrap();
    let frames: usize = a[3].parse().unwrap();
    let ds: Vec<usize> = a[4..].iter().map(|s| s.parse().unwrap()).collect();
    scene.camera.width = size;
    scene.camera.height = size;
    let ctx = caustics::gpu::GpuContext::new(None).unwrap();
    println!("adapter: {} ({:?}, {})", ctx.info.name, ctx.info.backend, ctx.info.driver);
    let obj = scene.objects.iter().position(|o| scene.material_of(o).is_specular()).unwrap();
    let ss = SphereSettings { photons: 1 << 16, ..Default::default() };
    let t = std::time::Instant::now();
    let table = Arc::new(spheres::precompute(&scene, obj, &ss, None, &Progress::new()).unwrap());
    println!("precompute {:.1} s, {:.1} MiB", t.elapsed().as_secs_f64(), table.bytes() as f64 / (1 << 20) as f64);
    println!(
        "| D | records | direct frame ms | compiled frame ms | direct gather ms (ts) | compiled gather + compile ms (ts) | rel. L1 | energy |"
    );
    println!("| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |");
    for d in ds {
        scene.lights = (0..d)
            .map(|i| {
                let ph = i as f32 / d as f32 * std::f32::consts::TAU;
                let th = if d == 1 { 0.0 } else { 25f32.to_radians() };
                let dir = Vec3::new(th.sin() * ph.cos(), -th.cos(), th.sin() * ph.sin());
                let hue = Vec3::new(1.0 + ph.cos(), 1.0 + (ph + 2.1).cos(), 1.0 + (ph + 4.2).cos()) * 0.5 + 0.25;
                Light::Directional { direction: dir, irradiance: hue * (3.0 / d as f32 / hue.element_sum() * 3.0) }
            })
            .collect();
        let s = RenderSettings {
            photons: caustics::settings::PhotonSettings {
                count: 64,
                technique: Technique::CausticSpheres,
                caustic_map_size: 128,
                ..Default::default()
            },
            shading: caustics::settings::ShadingSettings { shadow_map_size: 512, ..Default::default() },
            ..Default::default()
        };
        let mut r = Renderer::with_context(ctx.clone(), scene.clone(), s).unwrap();
        r.set_caustic_spheres(vec![(obj, table.clone())], Blend::Triangle, false).unwrap();
        let ts =
            |o: &GpuRender, pass: &str| -> f64 { o.timings.iter().filter(|(p, _)| p == pass).map(|(_, m)| m).sum() };
        let mut wall = [Vec::new(), Vec::new()];
        let mut pass = [Vec::new(), Vec::new()];
        let mut last: [Option<GpuRender>; 2] = [None, None];
        for compiled in [false, true] {
            r.set_caustic_spheres_compiled(compiled);
            let _ = r.render_once().unwrap(); // pipelines built
        }
        for _ in 0..frames {
            for (k, compiled) in [false, true].into_iter().enumerate() {
                r.set_caustic_spheres_compiled(compiled);
                let o = r.render_once().unwrap();
                wall[k].push(o.frame_wall_ms);
                pass[k].push(ts(&o, "sphere_gather") + ts(&o, "sphere_compile"));
                last[k] = Some(o);
            }
        }
        let (dr, co) = (last[0].take().unwrap(), last[1].take().unwrap());
        let records = d * 3;
        println!(
            "| {d} | {records} | {:.1} | {:.1} | {:.3} | {:.3} | {:.4} | {:.4} |",
            median(wall[0].clone()),
            median(wall[1].clone()),
            median(pass[0].clone()),
            median(pass[1].clone()),
            rel_l1(&co.caustic, &dr.caustic),
            co.caustic.sum() / dr.caustic.sum()
        );
    }
}
