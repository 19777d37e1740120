//! How far apart the four photons of a 2 x 2 cluster land in the caustic map: the quantity the
//! maximal caustic map error metric tests. Measured on the GPU photons of the dense grid and on
//! the same light rays traced exactly on the CPU (BVH, smooth normals, transmitted path with total
//! internal reflection), so that the image-space tracer's share of the spread can be told apart
//! from the optics'. `cargo run --release --example divergence -- SCENE GRID MAP_SIZE`
use caustics::lightspace::LightView;
use caustics::render::{Inspect, RenderSettings, SplatMode, render_inspect};
use caustics::scene::Material;
use caustics_reference::reference::geometry::{Accel, spawn};
use caustics_reference::reference::optics::{fresnel_dielectric, reflect, refract};
use glam::Vec3;
use rayon::prelude::*;

/// Transmitted-path landing point of the light ray (o, d) in map texels, or None.
fn exact(scene: &caustics::Scene, accel: &Accel, view: &LightView, o: Vec3, d: Vec3, m: u32) -> Option<[f32; 2]> {
    let (mut o, mut d) = (o, d);
    let mut specular = false;
    for _ in 0..16 {
        let h = accel.intersect(o, d, f32::INFINITY)?;
        match scene.materials[scene.objects[h.object as usize].material] {
            Material::Dielectric { ior, ext_ior } => {
                let entering = d.dot(h.ng) < 0.0;
                let n = if d.dot(h.ns) < 0.0 { h.ns } else { -h.ns };
                let eta = if entering { ior / ext_ior } else { ext_ior / ior };
                let (r, cos_t) = fresnel_dielectric(-d.dot(n), eta);
                d = if r >= 1.0 { reflect(d, n) } else { refract(d, n, eta, cos_t) };
                o = spawn(h.p, h.ng, d);
                specular = true;
            }
            _ => {
                if !specular {
                    return None;
                }
                let (_, x, y) = view.project(h.p, m)?;
                return Some([x, y]);
            }
        }
    }
    None
}

fn percentiles(name: &str, mut v: Vec<f32>) {
    v.sort_by(f32::total_cmp);
    if v.is_empty() {
        return;
    }
    let q = |f: f32| v[((v.len() - 1) as f32 * f) as usize];
    let one = v.iter().filter(|&&e| e < 1.0).count() as f32 / v.len() as f32;
    println!(
        "{name}: {} clusters; extent (texels) p10 {:.3} p25 {:.3} p50 {:.3} p75 {:.3} p90 {:.3}; extent < 1 texel: {:.1} %",
        v.len(),
        q(0.1),
        q(0.25),
        q(0.5),
        q(0.75),
        q(0.9),
        100.0 * one
    );
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let scene = caustics::Scene::load(std::path::Path::new(&a[1])).unwrap();
    let n: u32 = a[2].parse().unwrap();
    let m: u32 = a[3].parse().unwrap();
    let ctx = caustics::gpu::GpuContext::new(None).unwrap();
    let s = RenderSettings {
        photons: caustics::settings::PhotonSettings {
            count: n,
            caustic_map_size: m,
            splat: SplatMode::Differential,
            reflection: false,
            ..Default::default()
        },
        shading: caustics::settings::ShadingSettings { shadow_map_size: 512, ..Default::default() },
        ..Default::default()
    };
    let out = render_inspect(&ctx, &scene, &s, Inspect { photons: true, ..Default::default() }).unwrap();
    let ph = &out.technique.photons;
    println!("{} photons kept", ph.len());
    let view = LightView::new(&scene, &scene.lights[0]);
    let accel = Accel::new(&scene);
    let clusters: Vec<(u32, u32)> = (0..n / 2).flat_map(|j| (0..n / 2).map(move |i| (i, j))).collect();
    let rows: Vec<(f32, f32, f32, f32)> = clusters
        .par_iter()
        .filter_map(|&(ci, cj)| {
            let mut g = Vec::new();
            let mut beam = f32::MAX;
            let mut c = Vec::new();
            for q in 0..4u32 {
                let (i, j) = (2 * ci + (q & 1), 2 * cj + (q >> 1));
                let p = &ph[(j * n + i) as usize];
                if p.face == u32::MAX || p.flux[3] != ph[((2 * cj) * n + 2 * ci) as usize].flux[3] {
                    return None;
                }
                let (o, d) = view.texel_ray(0, i as f32 + 0.5, j as f32 + 0.5, n);
                let e = exact(&scene, &accel, &view, o, d, m)?;
                g.push(p.pos);
                beam = beam.min(f32::from_bits(p._pad));
                c.push(e);
            }
            let ext = |v: &[[f32; 2]]| {
                let (mut lo, mut hi) = ([f32::MAX; 2], [f32::MIN; 2]);
                for p in v {
                    for k in 0..2 {
                        lo[k] = lo[k].min(p[k]);
                        hi[k] = hi[k].max(p[k]);
                    }
                }
                (hi[0] - lo[0]).max(hi[1] - lo[1])
            };
            let dist = g
                .iter()
                .zip(&c)
                .map(|(a, b)| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt())
                .fold(0.0, f32::max);
            Some((ext(&g), ext(&c), dist, ext(&g) / beam))
        })
        .collect();
    percentiles("GPU (image-space tracer)", rows.iter().map(|r| r.0).collect());
    percentiles("CPU (exact, BVH)", rows.iter().map(|r| r.1).collect());
    percentiles("GPU-CPU landing distance", rows.iter().map(|r| r.2).collect());
    percentiles("GPU extent / smallest beam", rows.iter().map(|r| r.3).collect());
}
