//! The GPU tests, one module per subject, in one test binary: one link of wgpu and naga, one
//! device whose pipelines every test shares (each shader is compiled once), and cargo's test
//! threads balanced over all of them. Run one with
//! `cargo test --release -p caustics --test gpu -- MODULE::TEST --exact`. Without an adapter
//! the tests skip with a printed reason, except in CI (`CI=true`), where they fail.
//! Binaries of their own: `gpu_bits` (the frame's recorded hashes) and `gpu_budget` (the
//! time-budget controller times frames: no other test may run beside it).

#[path = "../common/mod.rs"]
mod common;
#[path = "../common/temp_scene.rs"]
mod temp_scene;

mod absorption;
mod adaptive;
mod basic;
mod beams;
mod caustic_spheres;
mod environment;
mod exact;
mod gltf_roundtrip;
mod golden;
mod indirect;
mod layers;
mod lens;
mod light_layers;
mod medium;
mod refit;
mod renderer;
mod shared;
mod sphere_build;
mod sphere_volume;
mod spill;
mod splat;
mod spot_profile;
mod temporal;
mod water;
mod wide_lights;
