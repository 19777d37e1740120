//! `caustics-reference`: what the renderer is measured against, kept out of the crate an engine
//! depends on.
//!
//! - [`reference`]: the exact CPU reference renderer (its own BVH and photon tracer, independent
//!   of the GPU code): ground truth for every test and the fallback without a GPU;
//! - [`metrics`]: RMSE, PSNR, HDR-FLIP (nv-flip), energy, map agreement, statistical tests;
//! - [`io`]: image files (EXR, PNG), written atomically; [`dump`]: the renderer's intermediate
//!   buffers as files.

#![forbid(unsafe_code)]

pub mod dump;
pub mod io;
pub mod metrics;
pub mod reference;

pub use io::ImageIo;
