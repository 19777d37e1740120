//! The CPU reference's image energy (sum over pixels and channels) of a scene, split into the
//! non-caustic and caustic components, with standard deviations from the per-pixel variance
//! estimates, as one JSON line: the number `tools/mitsuba/fog_check.py` compares with
//! Mitsuba's `volpath` (which renders the non-caustic component of delta lights).
//!
//! `cargo run --release -p caustics-reference --example medium_energy SCENE.json SPP [PHOTONS] [OUT.exr] [SEED]`

use caustics::Scene;
use caustics_reference::io::ImageIo;
use caustics_reference::reference::{self, ReferenceSettings};
use std::path::Path;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let scene = Scene::load(Path::new(&args[1])).unwrap_or_else(|e| panic!("{e}"));
    let spp: u32 = args.get(2).map_or(64, |s| s.parse().expect("SPP"));
    let photons: u64 = args.get(3).map_or(1_000_000, |s| s.parse().expect("PHOTONS"));
    let s = ReferenceSettings {
        photons_per_light: photons,
        camera_spp: spp,
        max_depth: 64,
        seed: args.get(5).map_or(1, |s| s.parse().expect("SEED")),
        caustic_map_size: 8,
        medium_single_scattering_only: false,
        ..Default::default()
    };
    let o = reference::render(&scene, &s).unwrap_or_else(|e| panic!("{e}"));
    let sum = |img: &caustics::image_io::Image| img.pixels.iter().flatten().map(|&v| v as f64).sum::<f64>();
    let (nc, c) = (sum(&o.nocaustic), sum(&o.caustic));
    let (vnc, vc) = (sum(&o.nocaustic_variance), sum(&o.caustic_variance));
    if let Some(out) = args.get(4).filter(|s| !s.is_empty()) {
        o.nocaustic.write(Path::new(out), 1.0).unwrap_or_else(|e| panic!("{e}"));
    }
    println!(
        "{{\"scene\": \"{}\", \"spp\": {spp}, \"seed\": {}, \"photons\": {photons}, \"sum_nocaustic\": {nc}, \"sd_nocaustic\": {}, \"sum_caustic\": {c}, \"sd_caustic\": {}, \"seconds\": {:.1}}}",
        args[1],
        s.seed,
        vnc.sqrt(),
        vc.sqrt(),
        o.stats.seconds
    );
}
