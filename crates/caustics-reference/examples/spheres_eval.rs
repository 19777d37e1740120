//! Caustic spheres measured on the CPU (docs/benchmarks.md, "Caustic spheres"):
//!
//! `cargo run --release --example spheres_eval -- interp SCENE OUT [N S W H PHOTONS SIZE]`:
//! the object's spheres blended for an in-between light direction against spheres traced
//! directly for that direction (triangle and quad blends), HDR-FLIP of the caustic images.
//!
//! `cargo run --release --example spheres_eval -- lights SCENE OUT [N S W H PHOTONS SIZE REF_PHOTONS]`:
//! three coloured directional lights through the spheres against the CPU reference's caustic.
use caustics::caustic_spheres::{Blend, DirectionLayout, SphereSettings};
use caustics::scene::Light;
use caustics_reference::ImageIo as _;
use caustics_reference::metrics::{Mask, hdr_flip};
use caustics_reference::reference::{self, Progress, ReferenceSettings, spheres};
use glam::Vec3;
use std::time::Instant;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let mode = a[1].as_str();
    let mut scene = caustics::Scene::load(std::path::Path::new(&a[2])).unwrap();
    let out = std::path::PathBuf::from(&a[3]);
    std::fs::create_dir_all(&out).unwrap();
    let num = |i: usize, d: u64| a.get(i).map_or(d, |s| s.parse().unwrap());
    let s = SphereSettings {
        directions: num(4, 7) as u32,
        spheres: num(5, 16) as u32,
        width: num(6, 64) as u32,
        height: num(7, 48) as u32,
        photons: num(8, 1 << 18),
        max_depth: 16,
    };
    let size = num(9, 256) as u32;
    scene.camera.width = size;
    scene.camera.height = size;
    let obj = scene.objects.iter().position(|o| scene.material_of(o).is_specular()).unwrap();
    let layout = DirectionLayout::new(s.directions);
    let t = Instant::now();
    let sp = spheres::precompute(&scene, obj, &s, None, &Progress::new()).unwrap();
    let pre = t.elapsed().as_secs_f64();
    println!(
        "precompute: {} directions x {} photons, {:.1} s; table {:.1} MiB (f32), {:.1} MiB (f16); radii {:.3}..{:.3}",
        layout.dirs.len(),
        s.photons,
        pre,
        sp.bytes() as f64 / (1 << 20) as f64,
        sp.bytes() as f64 / (2 << 20) as f64,
        sp.geometry.radii[0],
        sp.geometry.radii[s.spheres as usize - 1]
    );
    let flip = |x: &caustics::image_io::Image, y: &caustics::image_io::Image| {
        let all = hdr_flip(x, y, None).unwrap().mean;
        let lit_or = {
            let mut m = Mask::all(y.width, y.height);
            for (i, (p, q)) in x.pixels.iter().zip(&y.pixels).enumerate() {
                m.include[i] = p.iter().chain(q).any(|v| *v > 0.0);
            }
            m
        };
        let caustic = hdr_flip(x, y, Some(&lit_or)).unwrap().mean;
        (all, caustic, lit_or.count())
    };
    match mode {
        "interp" => {
            for l in [Vec3::new(0.28, -1.0, 0.17), Vec3::new(-0.45, -1.0, 0.3), Vec3::new(0.6, -0.8, -0.35)] {
                let l = l.normalize();
                println!("light {l}: weights {:?}", layout.weights(l, Blend::Triangle));
                scene.lights = vec![Light::Directional { direction: l, irradiance: Vec3::splat(2.0) }];
                let direct = spheres::precompute(&scene, obj, &s, Some(vec![l]), &Progress::new()).unwrap();
                let img = |sp: &caustics::caustic_spheres::CausticSpheres, b| {
                    spheres::render_caustic(&scene, &[(obj, sp)], &layout, b, 2)
                };
                let d = img(&direct, Blend::Triangle);
                let tri = img(&sp, Blend::Triangle);
                let quad = img(&sp, Blend::Quad);
                let (fa, fc, n) = flip(&tri, &d);
                let (qa, qc, _) = flip(&quad, &d);
                println!(
                    "| {} | ({:.2}, {:.2}, {:.2}) | {fa:.4} | {fc:.4} | {qa:.4} | {qc:.4} | {n} | {:.3} | {:.3} |",
                    scene.name,
                    l.x,
                    l.y,
                    l.z,
                    tri.sum() / d.sum(),
                    quad.sum() / d.sum()
                );
                let tag = format!("{}_{:.2}_{:.2}", scene.name, l.x, l.z);
                d.write(&out.join(format!("{tag}_direct.exr")), 1.0).unwrap();
                tri.write(&out.join(format!("{tag}_tri.exr")), 1.0).unwrap();
                d.write(&out.join(format!("{tag}_direct.png")), 1.0).unwrap();
                tri.write(&out.join(format!("{tag}_tri.png")), 1.0).unwrap();
                quad.write(&out.join(format!("{tag}_quad.png")), 1.0).unwrap();
            }
        }
        "lights" => {
            scene.lights = vec![
                Light::Directional {
                    direction: Vec3::new(0.3, -1.0, 0.2).normalize(),
                    irradiance: Vec3::new(2.0, 0.3, 0.3),
                },
                Light::Directional {
                    direction: Vec3::new(-0.4, -1.0, 0.1).normalize(),
                    irradiance: Vec3::new(0.3, 2.0, 0.3),
                },
                Light::Directional {
                    direction: Vec3::new(0.05, -1.0, -0.45).normalize(),
                    irradiance: Vec3::new(0.3, 0.3, 2.0),
                },
            ];
            let t = Instant::now();
            let img = spheres::render_caustic(&scene, &[(obj, &sp)], &layout, Blend::Triangle, 2);
            let eval = t.elapsed().as_secs_f64();
            let rs = ReferenceSettings { photons_per_light: num(10, 4_000_000), camera_spp: 1, ..Default::default() };
            let t = Instant::now();
            let r = reference::render(&scene, &rs).unwrap();
            let rt = t.elapsed().as_secs_f64();
            let (fa, fc, n) = flip(&img, &r.caustic);
            // The reference's own noise: a second reference of another seed against it.
            let r2 = reference::render(&scene, &ReferenceSettings { seed: 1, ..rs.clone() }).unwrap();
            let (na, nc, _) = flip(&r2.caustic, &r.caustic);
            println!("reference vs reference (seed 1): HDR-FLIP {na:.4} (caustic pixels {nc:.4})");
            println!(
                "| {} | 3 coloured | {fa:.4} | {fc:.4} | {n} | {:.3} | CPU eval {eval:.2} s, reference {rt:.1} s |",
                scene.name,
                img.sum() / r.caustic.sum()
            );
            img.write(&out.join(format!("{}_3lights_spheres.png", scene.name)), 1.0).unwrap();
            r.caustic.write(&out.join(format!("{}_3lights_reference.png", scene.name)), 1.0).unwrap();
            img.write(&out.join(format!("{}_3lights_spheres.exr", scene.name)), 1.0).unwrap();
            r.caustic.write(&out.join(format!("{}_3lights_reference.exr", scene.name)), 1.0).unwrap();
        }
        _ => panic!("mode interp or lights"),
    }
}
