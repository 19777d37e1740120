//! The tests without a GPU (the CPU reference, scenes, settings, shaders' validation, the budget
//! controller's model, the module graph), one module per subject, in one test binary. Run one
//! with `cargo test --release -p caustics --test cpu -- MODULE::TEST --exact`.

mod absorption;
mod budget;
mod caustic_spheres;
mod gltf;
mod gltf_export;
mod module_graph;
mod reference_caustic_paths;
mod reference_determinism;
mod reference_environment;
mod reference_heterogeneous;
mod reference_media;
mod reference_optics;
mod reference_orders;
mod reference_render;
mod reference_scenes;
mod scene_density;
mod scene_errors;
mod scene_tessellation;
mod settings;
mod shaders;
