//! The innermost sphere's radius against the caustic of one directional light (diagnosis of the
//! environment's caustic energy through the spheres, docs/benchmarks.md): per elevation and per
//! r_min (a factor of the distance from the centre to the object's nearest surface point), the
//! CPU evaluation of a one-direction table (rotated onto the light: exact for a ball) against
//! the CPU reference, caustic-only HDR-FLIP and energy, whole image and the receivers nearer
//! the centre than the innermost sphere of the old layout (1.02 R) apart.
//! `cargo run --release -p caustics-reference --example spheres_rmin -- SCENE WxH CPU_PHOTONS ELEV_DEG,.. FACTOR,..`
use caustics::caustic_spheres::{Blend, CausticSpheres, DirectionLayout, SphereGeometry, SphereSettings, radii};
use caustics::scene::Light;
use caustics_reference::metrics::{Mask, energy, hdr_flip};
use caustics_reference::reference::{self, ReferenceSettings, spheres};
use glam::Vec3;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let mut scene = caustics::Scene::load(std::path::Path::new(&a[1])).unwrap();
    let (w, h) = a[2].split_once('x').unwrap();
    scene.camera.width = w.parse().unwrap();
    scene.camera.height = h.parse().unwrap();
    let photons: u64 = a[3].parse().unwrap();
    let elevs: Vec<f32> = a[4].split(',').map(|x| x.parse().unwrap()).collect();
    let factors: Vec<f32> = a[5].split(',').map(|x| x.parse().unwrap()).collect();
    scene.environment = None;
    let obj = scene.objects.iter().position(|o| scene.material_of(o).is_specular()).unwrap();
    let ss = SphereSettings { photons: 1 << 18, ..Default::default() };
    let base = SphereGeometry::for_shape(&scene.objects[obj].shape, &ss);
    let nearest = caustics::caustic_spheres::nearest_surface(&scene.objects[obj].shape, base.center);
    let r_max = base.radii[base.radii.len() - 1];
    let down = Vec3::NEG_Y;
    let esc = spheres::escaping(&scene, obj, down, &ss, 0x9e37_79b9);
    let tables: Vec<(f32, CausticSpheres)> = factors
        .iter()
        .map(|&f| {
            let g = SphereGeometry { radii: radii(f * nearest, r_max, ss.spheres), ..base.clone() };
            let mut sp = CausticSpheres::empty(ss, g, vec![down]);
            sp.deposit(0, &esc);
            (f, sp)
        })
        .collect();
    let layout = DirectionLayout::new(3);
    if std::env::var("FLOOR").is_ok() {
        floor_check(&scene, obj, &ss, &elevs, &factors, nearest, r_max, &base);
        return;
    }
    let c = base.center;
    println!("nearest surface {nearest}, r_max {r_max}");
    println!("| elevation | r_min / nearest | caustic HDR-FLIP | energy | energy r < 1.02 R | energy beyond |");
    println!("| ---: | ---: | ---: | ---: | ---: | ---: |");
    for e in elevs {
        let el = e.to_radians();
        let dir = Vec3::new(0.0, -el.sin(), el.cos()).normalize();
        let mut sc = scene.clone();
        sc.lights = vec![Light::Directional { direction: dir, irradiance: Vec3::splat(1.0) }];
        let cpu = reference::render(
            &sc,
            &ReferenceSettings { photons_per_light: photons, camera_spp: 1, ..Default::default() },
        )
        .unwrap();
        let cam = &sc.camera;
        let mut inner = Mask::all(cam.width, cam.height);
        for y in 0..cam.height {
            for x in 0..cam.width {
                let d = cam.ray_dir(x as f32 + 0.5, y as f32 + 0.5);
                let t = if d.y < 0.0 { -cam.position.y / d.y } else { f32::INFINITY };
                let p = cam.position + d * t;
                inner.include[(y * cam.width + x) as usize] = (p - c).length() < 1.02 * nearest;
            }
        }
        let mut outer = inner.clone();
        outer.include.iter_mut().for_each(|v| *v = !*v);
        for (f, sp) in &tables {
            let ssn: u32 = std::env::var("SS").ok().and_then(|v| v.parse().ok()).unwrap_or(1);
            let img = spheres::render_caustic(&sc, &[(obj, sp)], &layout, Blend::Triangle, ssn);
            let fl = hdr_flip(&img, &cpu.caustic, None).unwrap().mean;
            let ratio = |m: Option<&Mask>| energy(&img, m) / energy(&cpu.caustic, m).max(1e-30);
            if std::env::var("ROWS").is_ok() {
                for y in 0..cam.height {
                    let (mut a, mut b) = (0.0, 0.0);
                    for x in 0..cam.width {
                        a += img.get(x, y)[1];
                        b += cpu.caustic.get(x, y)[1];
                    }
                    if a > 1e-3 || b > 1e-3 {
                        println!("row {y}: spheres {a:.4} reference {b:.4}");
                    }
                }
            }
            println!(
                "| {e} | {f} | {fl:.3} | {:.3} | {:.3} | {:.3} |",
                ratio(None),
                ratio(Some(&inner)),
                ratio(Some(&outer))
            );
        }
    }
}

/// The floor's caustic irradiance (the plane y = 0, 1 W/m² light) straight from the escaping
/// photons (their hits binned in 2 cm squares) against the table of that light direction looked
/// up at the squares' centres: sums by ring of distance from the object's centre.
#[allow(clippy::too_many_arguments)]
fn floor_check(
    scene: &caustics::Scene,
    obj: usize,
    ss: &SphereSettings,
    elevs: &[f32],
    factors: &[f32],
    nearest: f32,
    r_max: f32,
    base: &SphereGeometry,
) {
    let (n, half) = (300usize, 3.0f32);
    let cell = 2.0 * half / n as f32;
    let c = base.center;
    let rings = [0.0f32, 0.52, 0.55, 0.6, 0.7, 0.8, 1.0, 1.5, 2.0, 4.0, 10.0];
    for &e in elevs {
        let el = e.to_radians();
        let dir = Vec3::new(0.0, -el.sin(), el.cos()).normalize();
        let esc = spheres::escaping(scene, obj, dir, ss, 0x1234);
        let mut hist = vec![0f64; n * n];
        for p in &esc {
            if p.dir.y >= 0.0 {
                continue;
            }
            let t = -p.origin.y / p.dir.y;
            if t <= 0.0 {
                continue;
            }
            let h = p.origin + p.dir * t;
            let (i, j) = (((h.x + half) / cell).floor(), ((h.z + half) / cell).floor());
            if i < 0.0 || j < 0.0 || i >= n as f32 || j >= n as f32 {
                continue;
            }
            hist[j as usize * n + i as usize] += (p.flux.x + p.flux.y + p.flux.z) as f64 / 3.0;
        }
        for &f in factors {
            let g = SphereGeometry { radii: radii(f * nearest, r_max, ss.spheres), ..base.clone() };
            let mut sp = CausticSpheres::empty(*ss, g, vec![dir]);
            sp.deposit(0, &esc);
            let mut sums = vec![(0f64, 0f64); rings.len() - 1];
            for j in 0..n {
                for i in 0..n {
                    let x = Vec3::new(-half + (i as f32 + 0.5) * cell, 0.0, -half + (j as f32 + 0.5) * cell);
                    let r = (x - c).length();
                    let Some(k) = rings.windows(2).position(|w| r >= w[0] && r < w[1]) else { continue };
                    let v = sp.irradiance_of(0, x, Vec3::Y, dir);
                    sums[k].0 += hist[j * n + i];
                    sums[k].1 += ((v.x + v.y + v.z) / 3.0 * cell * cell) as f64;
                }
            }
            let tot: (f64, f64) = sums.iter().fold((0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
            print!("elev {e} f {f}: total photons {:.4} table {:.4} ({:.3}) | ", tot.0, tot.1, tot.1 / tot.0);
            for (k, s) in sums.iter().enumerate() {
                if s.0 > 1e-4 || s.1 > 1e-4 {
                    print!("{}-{}: {:.4}/{:.4} ", rings[k], rings[k + 1], s.1, s.0);
                }
            }
            println!();
        }
    }
}
