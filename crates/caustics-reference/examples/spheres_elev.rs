//! The caustic of one directional light through caustic spheres against the CPU reference, by
//! the light's elevation (diagnosis of the environment's caustic energy through the spheres,
//! docs/benchmarks.md, "The environment through caustic spheres"): caustic-only HDR-FLIP and
//! energy GPU/CPU, whole image and by distance of the receiver from the object's centre
//! (inside r_max, beyond it).
//! `cargo run --release --example spheres_elev -- SCENE WxH CPU_PHOTONS SPHERE_CACHE ELEV_DEG,..`
use caustics::caustic_spheres::{Blend, SphereSettings, cache::Storage};
use caustics::render::{RenderSettings, Technique};
use caustics::scene::Light;
use caustics_reference::metrics::{energy, hdr_flip};
use caustics_reference::reference::{self, Progress, ReferenceSettings, spheres};
use glam::Vec3;
use std::sync::Arc;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let mut scene = caustics::Scene::load(std::path::Path::new(&a[1])).unwrap();
    let (w, h) = a[2].split_once('x').unwrap();
    scene.camera.width = w.parse().unwrap();
    scene.camera.height = h.parse().unwrap();
    let photons: u64 = a[3].parse().unwrap();
    let cache = std::path::PathBuf::from(&a[4]);
    let elevs: Vec<f32> = a[5].split(',').map(|x| x.parse().unwrap()).collect();
    scene.environment = None;
    let obj = scene.objects.iter().position(|o| scene.material_of(o).is_specular()).unwrap();
    let ss = SphereSettings { photons: 1 << 18, ..Default::default() };
    let (sp, _) = spheres::load_or_precompute(&scene, obj, &ss, Storage::F32, &cache, &Progress::new()).unwrap();
    let sp = Arc::new(sp);
    let r_max = sp.geometry.radii[sp.geometry.radii.len() - 1];
    let c = sp.geometry.center;
    let ctx = caustics::gpu::GpuContext::new(None).unwrap();
    println!("| elevation | caustic HDR-FLIP | energy GPU/CPU | energy within r_max | energy beyond r_max |");
    println!("| ---: | ---: | ---: | ---: | ---: |");
    for e in elevs {
        let el = e.to_radians();
        // From −z (toward the camera's far side), the light travelling down and toward +z.
        let dir = Vec3::new(0.0, -el.sin(), el.cos()).normalize();
        let mut sc = scene.clone();
        sc.lights = vec![Light::Directional { direction: dir, irradiance: Vec3::splat(1.0) }];
        let s = RenderSettings {
            photons: caustics::settings::PhotonSettings {
                technique: Technique::CausticSpheres,
                count: 64,
                ..Default::default()
            },
            shading: caustics::settings::ShadingSettings { shadow_map_size: 1024, ..Default::default() },
            ..Default::default()
        };
        let mut r = caustics::renderer::Renderer::with_context(ctx.clone(), sc.clone(), s).unwrap();
        r.set_caustic_spheres(vec![(obj, sp.clone())], Blend::Triangle, false).unwrap();
        let g = r.render_once().unwrap();
        let cpu = reference::render(
            &sc,
            &ReferenceSettings { photons_per_light: photons, camera_spp: 1, ..Default::default() },
        )
        .unwrap();
        // Receiver distance per pixel: the floor point the pixel centre sees (y = 0 plane).
        let cam = &sc.camera;
        let mut near = caustics_reference::metrics::Mask::all(cam.width, cam.height);
        for y in 0..cam.height {
            for x in 0..cam.width {
                let d = cam.ray_dir(x as f32 + 0.5, y as f32 + 0.5);
                let t = if d.y < 0.0 { -cam.position.y / d.y } else { f32::INFINITY };
                let p = cam.position + d * t;
                near.include[(y * cam.width + x) as usize] = (p - c).length() <= r_max;
            }
        }
        let mut far = near.clone();
        far.include.iter_mut().for_each(|v| *v = !*v);
        let f = hdr_flip(&g.caustic, &cpu.caustic, None).unwrap().mean;
        let ratio =
            |m: Option<&caustics_reference::metrics::Mask>| energy(&g.caustic, m) / energy(&cpu.caustic, m).max(1e-30);
        println!("| {e} | {f:.3} | {:.3} | {:.3} | {:.3} |", ratio(None), ratio(Some(&near)), ratio(Some(&far)));
    }
}
