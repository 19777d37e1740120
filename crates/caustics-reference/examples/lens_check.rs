//! Stored splat diameters (thin lens, thick lens, ray differentials) against the true beam size
//! (the area of the cell's image, from neighbouring photons of the dense grid), per scene.
//! `cargo run --release --example lens_check -- SCENE GRID MAP_SIZE`
use caustics::render::{Inspect, RenderSettings, SplatMode, render_inspect};
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let scene = caustics::Scene::load(std::path::Path::new(&a[1])).unwrap();
    let n: u32 = a[2].parse().unwrap();
    let m: u32 = a[3].parse().unwrap();
    let ctx = caustics::gpu::GpuContext::new(None).unwrap();
    for mode in [SplatMode::ThinLens, SplatMode::ThickLens, SplatMode::Differential] {
        let s = RenderSettings {
            photons: caustics::settings::PhotonSettings {
                count: n,
                caustic_map_size: m,
                splat: mode,
                reflection: false,
                ..Default::default()
            },
            shading: caustics::settings::ShadingSettings { shadow_map_size: 512, ..Default::default() },
            ..Default::default()
        };
        let out = render_inspect(&ctx, &scene, &s, Inspect { photons: true, ..Default::default() }).unwrap();
        let mut r = Vec::new();
        let mut tr = Vec::new();
        for b in caustics::splat::beam_samples(&out.technique.photons, n) {
            if b.true_size > 0.0 && b.stored > 0.0 {
                r.push(b.stored / b.true_size);
                tr.push(b.true_size);
            }
        }
        r.sort_by(f32::total_cmp);
        tr.sort_by(f32::total_cmp);
        let q = |v: &Vec<f32>, f: f32| v[((v.len() - 1) as f32 * f) as usize];
        println!(
            "{:?}: {} photons; stored/true p10 {:.3} p25 {:.3} p50 {:.3} p75 {:.3} p90 {:.3}; true size p50 {:.3} p90 {:.3}",
            mode,
            r.len(),
            q(&r, 0.1),
            q(&r, 0.25),
            q(&r, 0.5),
            q(&r, 0.75),
            q(&r, 0.9),
            q(&tr, 0.5),
            q(&tr, 0.9)
        );
    }
}
