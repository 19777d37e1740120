//! `caustics compare A B [--mask M] [--heatmap H]`: every metric of `caustics_reference::metrics`, A (the
//! image under test) against B (the reference).

use caustics::image_io::Image;
use caustics_reference::ImageIo as _;
use caustics_reference::metrics::{self, Mask};
use std::path::Path;

/// Print the metrics table; write the heat map if asked. The mask selects the pixels where it is
/// black (a reference's `*_specmask.png` is white on specular pixels).
pub fn run(a: &Path, b: &Path, mask: Option<&Path>, heatmap: Option<&Path>) -> caustics::Result<()> {
    let ia = Image::read(a)?;
    let ib = Image::read(b)?;
    let m = match mask {
        Some(p) => {
            let m = Mask::read(p, true)?;
            if m.width != ia.width || m.height != ia.height {
                return Err(caustics::Error::input(
                    p.display().to_string(),
                    "",
                    format!("mask is {}×{} but the images are {}×{}", m.width, m.height, ia.width, ia.height),
                ));
            }
            Some(m)
        }
        None => None,
    };
    if ia.width != ib.width || ia.height != ib.height {
        return Err(caustics::Error::input(
            b.display().to_string(),
            "",
            format!("is {}×{} but {} is {}×{}", ib.width, ib.height, a.display(), ia.width, ia.height),
        ));
    }
    let r = metrics::compare(&ia, &ib, m.as_ref())?;
    println!("A: {}", a.display());
    println!("B: {} (reference)", b.display());
    match mask {
        Some(p) => println!("pixels: {} of {} (black in {})", r.pixels, ia.pixels.len(), p.display()),
        None => println!("pixels: {} (all)", r.pixels),
    }
    println!("{:<22} {:>14}", "metric", "value");
    println!("{:<22} {:>14.6e}", "RMSE", r.rmse);
    println!("{:<22} {:>14.6e}", "relative MSE", r.rel_mse);
    println!("{:<22} {:>14.3}", "PSNR (dB)", r.psnr);
    println!(
        "{:<22} {:>14.5}   (HDR-FLIP: LDR-FLIP max over {} exposures, {:+.2} to {:+.2} stops)",
        "mean FLIP", r.flip.mean, r.flip.exposures, r.flip.start_exposure, r.flip.stop_exposure
    );
    println!("{:<22} {:>14.6e}", "energy A", r.energy_a);
    println!("{:<22} {:>14.6e}", "energy B", r.energy_b);
    println!("{:<22} {:>14.6}", "energy ratio A/B", r.energy_ratio);
    if let Some(h) = heatmap {
        metrics::write_heatmap(h, &ia, &ib, m.as_ref(), &r.flip)?;
        println!("heat map: {} (left: FLIP error; right: luminance difference, red = A brighter)", h.display());
    }
    Ok(())
}
