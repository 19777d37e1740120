//! Every struct the GPU sees, `#[repr(C)]` + bytemuck, mirrored from `shaders/shared/common.wgsl`
//! and the stage files. [`LAYOUTS`] lists each with its fields; `tests/cpu/shaders.rs` checks it
//! against naga's layout of the WGSL declaration in every stage (the struct's size, and each
//! member's name, offset and size), so the two cannot drift apart silently. [`Vertex`] has no
//! WGSL struct: it is the vertex buffer that the raster stages' `vs_main` reads by location.

mod beams;
mod frame;
mod indirect;
mod layout;
mod medium;
mod photons;
mod spheres;

pub use beams::*;
pub use frame::*;
pub use indirect::*;
pub use layout::*;
pub use medium::*;
pub use photons::*;
pub use spheres::*;
