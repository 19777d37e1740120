//! Caustic spheres measured on the CPU (docs/benchmarks.md, "Caustic spheres"):
//!
//! `cargo run --release --example spheres_eval -- interp SCENE OUT [N S W H PHOTONS SIZE]`:
//! the object's spheres blended for an in-between light direction against spheres traced
//! directly for that direction (triangle and quad blends), HDR-FLIP of the caustic images.
//!
//! `cargo run --release --example spheres_eval -- curve SCENE OUT [N S W H PHOTONS SIZE TRUTH_PHOTONS]`:
//! the error of the blend (per warp: `Warp::Rotate`, the paper's, and `Warp::Exit`) against a
//! direct trace of TRUTH_PHOTONS as a function of the angle to the nearest stored direction,
//! with the direct trace's own noise (two seeds); only the three stored directions the path
//! needs are traced.
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
    // `curve`: only the three directions of the measured triangle are traced (the blend reads
    // no others), so the table can have many photons per direction.
    let l0 = Vec3::new(0.28, -1.0, 0.17).normalize();
    let sp = if mode == "curve" {
        let g = caustics::caustic_spheres::SphereGeometry::for_shape(&scene.objects[obj].shape, &s);
        let mut t = caustics::caustic_spheres::CausticSpheres::empty(s, g, layout.dirs.clone());
        for (k, w) in layout.weights(l0, Blend::Triangle) {
            if w > 0.0 {
                let d = layout.dirs[k as usize];
                t.deposit(k as usize, &spheres::escaping(&scene, obj, d, &s, k as u64 ^ 0x9e37_79b9));
            }
        }
        t
    } else {
        spheres::precompute(&scene, obj, &s, None, &Progress::new()).unwrap()
    };
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
        "curve" => {
            // Error of the blend against a direct trace as a function of the angular distance
            // to the nearest stored direction: along a path from a stored direction to the
            // centroid of a triangle of the layout (the farthest point from all three).
            let wts = layout.weights(l0, Blend::Triangle);
            let tri: Vec<Vec3> = wts.iter().filter(|x| x.1 > 0.0).map(|x| layout.dirs[x.0 as usize]).collect();
            let a0 = layout.dirs[wts.iter().max_by(|x, y| x.1.total_cmp(&y.1)).unwrap().0 as usize];
            let centroid = (tri.iter().copied().sum::<Vec3>()).normalize();
            // The direct trace ("truth") with its own photon count (default: the table's).
            let st = SphereSettings { photons: num(10, s.photons), ..s };
            let direct = |scene: &caustics::Scene, l: Vec3, seed: u64| {
                let g = sp.geometry.clone();
                let mut t = caustics::caustic_spheres::CausticSpheres::empty(st, g, vec![l]);
                t.deposit(0, &spheres::escaping(scene, obj, l, &st, seed));
                t
            };
            use caustics::caustic_spheres::Warp;
            let warps = [
                ("rotate", Warp::Rotate),
                ("shear", Warp::Exit(0)),
                ("exit1", Warp::Exit(1)),
                ("exit2", Warp::Exit(2)),
            ];
            println!(
                "| angle to nearest | noise (seed vs seed) | nearest rotate | {} |",
                warps.map(|w| w.0).join(" | ")
            );
            for f in [0.0f32, 0.15, 0.3, 0.5, 0.75, 1.0] {
                let l = a0.lerp(centroid, f).normalize();
                let ang =
                    layout.dirs.iter().map(|d| d.dot(l).clamp(-1.0, 1.0).acos()).fold(9.0f32, f32::min).to_degrees();
                scene.lights = vec![Light::Directional { direction: l, irradiance: Vec3::splat(2.0) }];
                let d1 = direct(&scene, l, 0x1234_5678);
                let d2 = direct(&scene, l, 0x8765_4321);
                let render =
                    |f: &(dyn Fn(Vec3, Vec3, Vec3) -> Vec3 + Sync)| spheres::render_caustic_with(&scene, obj, f, 2);
                let ref_img = render(&|p, n, l| d1.irradiance_of(0, p, n, l));
                let noise = render(&|p, n, l| d2.irradiance_of(0, p, n, l));
                let near = {
                    let k = layout.dirs.iter().enumerate().max_by(|x, y| x.1.dot(l).total_cmp(&y.1.dot(l))).unwrap().0;
                    render(&|p, n, l| sp.irradiance_of(k, p, n, l))
                };
                let mut row = format!("| {ang:.1}° | {:.4} | {:.4}", flip(&noise, &ref_img).0, flip(&near, &ref_img).0);
                for (name, w) in warps {
                    let img = render(&|p, n, l| sp.irradiance_warped(p, n, l, &layout, Blend::Triangle, w));
                    let (fa, _, _) = flip(&img, &ref_img);
                    row += &format!(" | {fa:.4} (E {:.3})", img.sum() / ref_img.sum());
                    if f == 1.0 {
                        img.write(&out.join(format!("{}_curve_{name}.png", scene.name)), 1.0).unwrap();
                    }
                }
                if f == 1.0 {
                    ref_img.write(&out.join(format!("{}_curve_direct.png", scene.name)), 1.0).unwrap();
                }
                println!("{row} |");
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
