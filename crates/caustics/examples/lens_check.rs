//! Stored splat diameters (thin lens, thick lens, ray differentials) against the true beam size
//! (the area of the cell's image, from neighbouring photons of the dense grid), per scene.
//! `cargo run --release --example lens_check -- SCENE GRID MAP_SIZE`
use caustics::render::{RenderSettings, SplatMode, render};
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let scene = caustics::Scene::load(std::path::Path::new(&a[1])).unwrap();
    let n: u32 = a[2].parse().unwrap();
    let m: u32 = a[3].parse().unwrap();
    let ctx = caustics::gpu::GpuContext::new(None).unwrap();
    for mode in [SplatMode::ThinLens, SplatMode::ThickLens, SplatMode::Differential] {
        let s = RenderSettings {
            photons: n,
            caustic_map_size: m,
            shadow_map_size: 512,
            splat: mode,
            dielectric_reflection: false,
            keep_photons: true,
            ..Default::default()
        };
        let out = render(&ctx, &scene, &s, None).unwrap();
        let ph = &out.technique.photons;
        let at = |i: u32, j: u32| &ph[(j * n + i) as usize];
        let mut r = Vec::new();
        let mut tr = Vec::new();
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                let (p, px, py) = (at(i, j), at(i + 1, j), at(i, j + 1));
                if p.face == u32::MAX || px.face != p.face || py.face != p.face {
                    continue;
                }
                if p.flux[3] != px.flux[3] || p.flux[3] != py.flux[3] {
                    continue;
                }
                let dx = [px.pos[0] - p.pos[0], px.pos[1] - p.pos[1]];
                let dy = [py.pos[0] - p.pos[0], py.pos[1] - p.pos[1]];
                let t = (dx[0] * dy[1] - dx[1] * dy[0]).abs().sqrt();
                let d = f32::from_bits(p._pad);
                if t > 0.0 && d > 0.0 {
                    r.push(d / t);
                    tr.push(t);
                }
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
