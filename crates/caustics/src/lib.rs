//! `caustics`: real-time caustics on wgpu, with an exact CPU reference renderer.
//!
//! - [`scene`]: the scene format, meshes, the validated [`scene::Scene`].
//! - [`image_io`]: HDR images and tone mapping.
//! - [`renderer`]: the persistent GPU renderer an engine drives frame by frame.
//!
//! The CPU reference renderer, image metrics and image files are in `caustics-reference`.

#![forbid(unsafe_code)]

pub mod accel;
pub mod beams;
pub mod budget;
pub mod caustic_spheres;
pub mod env_taps;
pub mod error;
pub mod gpu;
pub mod image_io;
pub mod lightspace;
pub(crate) mod medium_bounce;
pub mod output;
pub mod passes;
pub mod raycast;
pub mod render;
pub mod renderer;
pub mod scene;
pub mod settings;
pub mod splat;
pub mod techniques;
pub mod temporal;

pub use error::{Error, Result};
pub use scene::Scene;
