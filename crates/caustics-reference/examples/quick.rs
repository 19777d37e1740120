//! Render a scene on the GPU and write the image, the caustic image and the light-space dumps.
//! `cargo run --release --example quick -- SCENE OUT_DIR [PHOTONS]`
use caustics_reference::ImageIo as _;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let scene = caustics::Scene::load(std::path::Path::new(&args[1])).unwrap();
    let out = std::path::Path::new(&args[2]);
    std::fs::create_dir_all(out).unwrap();
    let ctx = caustics::gpu::GpuContext::new(None).unwrap();
    let mut s = caustics::render::RenderSettings::default();
    if let Some(n) = args.get(3) {
        s.photons.count = n.parse().unwrap();
    }
    let t = std::time::Instant::now();
    let (r, dump) = caustics::render::render_dump(&ctx, &scene, &s).unwrap();
    caustics_reference::dump::write(&out.join("dump"), &dump).unwrap();
    println!("{:?} {:?} {:?} {}", t.elapsed(), r.flux, r.timings, r.adapter);
    r.image.write(&out.join("image.png"), scene.exposure).unwrap();
    r.image.write(&out.join("image.exr"), 1.0).unwrap();
    r.caustic.write(&out.join("caustic.exr"), 1.0).unwrap();
    println!("sum image {} caustic {}", r.image.sum(), r.caustic.sum());
}
