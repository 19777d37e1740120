//! `caustics render --dump DIR`: the renderer's intermediate buffers as files.

use crate::io::{ImageIo, write_display_png};
use caustics::error::{Error, Result};
use caustics::render::{DumpImage, DumpKind};
use std::path::Path;

/// Write `images` into `dir` (created if missing): display values as PNG; radiance as EXR and as
/// PNG with its exposure.
pub fn write(dir: &Path, images: &[DumpImage]) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::Output { path: dir.into(), message: e.to_string() })?;
    for d in images {
        match d.kind {
            DumpKind::Display => write_display_png(&d.image, &dir.join(format!("{}.png", d.name)))?,
            DumpKind::Radiance { exposure } => {
                d.image.write(&dir.join(format!("{}.exr", d.name)), exposure)?;
                d.image.write(&dir.join(format!("{}.png", d.name)), exposure)?;
            }
        }
    }
    Ok(())
}
