//! Image error metrics: RMSE, relative MSE, PSNR, HDR-FLIP, energy ratio, masks, a per-pixel
//! statistical test, and a difference heat map. `caustics compare` and the tests use these.
//!
//! Conventions: `a` is the image under test, `b` the reference. Every metric runs over the
//! pixels where the mask (if any) is selected; all channels count.

use crate::io::ImageIo;
use caustics::error::{Error, Result};
use caustics::image_io::{Image, luminance, srgb_encode};
use std::path::Path;

/// Which pixels a metric looks at: `true` = included.
#[derive(Debug, Clone, PartialEq)]
pub struct Mask {
    pub width: u32,
    pub height: u32,
    pub include: Vec<bool>,
}

impl Mask {
    /// Every pixel.
    pub fn all(width: u32, height: u32) -> Mask {
        Mask { width, height, include: vec![true; (width * height) as usize] }
    }
    /// From an image: pixels whose luminance is above one half are included; with `invert`,
    /// those below. The references' `NAME_specmask.png` is white on specular pixels, so compare
    /// with `Mask::from_image(&specmask, true)`.
    pub fn from_image(img: &Image, invert: bool) -> Mask {
        let include = img.pixels.iter().map(|p| (luminance(*p) > 0.5) != invert).collect();
        Mask { width: img.width, height: img.height, include }
    }
    /// Read a PNG or EXR mask (white = included).
    pub fn read(path: &Path, invert: bool) -> Result<Mask> {
        Ok(Mask::from_image(&Image::read(path)?, invert))
    }
    pub fn count(&self) -> usize {
        self.include.iter().filter(|&&b| b).count()
    }
    /// Pixels selected by both masks.
    pub fn and(&self, other: &Mask) -> Mask {
        Mask {
            width: self.width,
            height: self.height,
            include: self.include.iter().zip(&other.include).map(|(a, b)| *a && *b).collect(),
        }
    }
}

fn check_sizes(a: &Image, b: &Image, mask: Option<&Mask>) -> Result<()> {
    if a.width != b.width || a.height != b.height {
        return Err(Error::input(
            "<images>",
            "",
            format!("sizes differ: {}×{} against {}×{}", a.width, a.height, b.width, b.height),
        ));
    }
    if let Some(m) = mask
        && (m.width != a.width || m.height != a.height)
    {
        return Err(Error::input(
            "<mask>",
            "",
            format!("mask is {}×{} but the images are {}×{}", m.width, m.height, a.width, a.height),
        ));
    }
    Ok(())
}

fn selected<'a>(mask: Option<&'a Mask>, n: usize) -> impl Iterator<Item = usize> + 'a {
    (0..n).filter(move |&i| mask.is_none_or(|m| m.include[i]))
}

/// Root mean square error over the selected pixels and the three channels.
pub fn rmse(a: &Image, b: &Image, mask: Option<&Mask>) -> Result<f64> {
    check_sizes(a, b, mask)?;
    let (mut s, mut n) = (0.0f64, 0usize);
    for i in selected(mask, a.pixels.len()) {
        for k in 0..3 {
            let d = a.pixels[i][k] as f64 - b.pixels[i][k] as f64;
            s += d * d;
        }
        n += 3;
    }
    Ok(if n == 0 { 0.0 } else { (s / n as f64).sqrt() })
}

/// Relative MSE: mean of (a - b)² / (b² + ε), ε = 0.01 (the usual rendering form; robust where
/// the reference is black).
pub fn rel_mse(a: &Image, b: &Image, mask: Option<&Mask>) -> Result<f64> {
    check_sizes(a, b, mask)?;
    let (mut s, mut n) = (0.0f64, 0usize);
    for i in selected(mask, a.pixels.len()) {
        for k in 0..3 {
            let (x, y) = (a.pixels[i][k] as f64, b.pixels[i][k] as f64);
            s += (x - y) * (x - y) / (y * y + 0.01);
        }
        n += 3;
    }
    Ok(if n == 0 { 0.0 } else { s / n as f64 })
}

/// PSNR (dB) with the peak = the reference's largest selected value.
pub fn psnr(a: &Image, b: &Image, mask: Option<&Mask>) -> Result<f64> {
    let e = rmse(a, b, mask)?;
    let peak = selected(mask, b.pixels.len()).flat_map(|i| b.pixels[i]).fold(0f32, f32::max) as f64;
    Ok(if e == 0.0 { f64::INFINITY } else { 20.0 * (peak.max(1e-30) / e).log10() })
}

/// Sum over the selected pixels and channels.
pub fn energy(a: &Image, mask: Option<&Mask>) -> f64 {
    selected(mask, a.pixels.len()).map(|i| a.pixels[i].iter().map(|&c| c as f64).sum::<f64>()).sum()
}

/// Energy of `a` over energy of `b` on the selected pixels.
pub fn energy_ratio(a: &Image, b: &Image, mask: Option<&Mask>) -> Result<f64> {
    check_sizes(a, b, mask)?;
    Ok(energy(a, mask) / energy(b, mask))
}

/// HDR-FLIP result.
#[derive(Debug, Clone)]
pub struct Flip {
    /// Mean of the per-pixel error over the selected pixels, in [0, 1].
    pub mean: f64,
    /// Per-pixel error (max over the exposures).
    pub map: Vec<f32>,
    /// Exposures (log2 stops) used.
    pub start_exposure: f32,
    pub stop_exposure: f32,
    pub exposures: u32,
}

/// FLIP's ACES tone mapper (with its 0.6 pre-scale), as in the HDR-FLIP paper.
const ACES: [f32; 6] = [0.6 * 0.6 * 2.51, 0.6 * 0.03, 0.0, 0.6 * 0.6 * 2.43, 0.6 * 0.59, 0.14];

fn aces(x: f32) -> f32 {
    let x = x.max(0.0);
    ((ACES[0] * x * x + ACES[1] * x + ACES[2]) / (ACES[3] * x * x + ACES[4] * x + ACES[5])).clamp(0.0, 1.0)
}

/// HDR-FLIP (Andersson et al. 2021): LDR-FLIP (the `nv-flip` crate) of the two images tone
/// mapped (ACES) at exposures spaced one stop or less apart from `start` to `stop`, then the
/// per-pixel maximum over exposures. Start and stop come from the reference `b` as in the paper
/// and NVIDIA's FLIP tool: start = log2(x₀.₈₅ / max luminance), stop = log2(x₀.₈₅ / median
/// luminance), where x₀.₈₅ is the value the tone mapper maps to 0.85; the median is over the
/// selected pixels with non-zero luminance. 67 pixels per degree (FLIP's default).
pub fn hdr_flip(a: &Image, b: &Image, mask: Option<&Mask>) -> Result<Flip> {
    check_sizes(a, b, mask)?;
    let mut lum: Vec<f32> =
        selected(mask, b.pixels.len()).map(|i| luminance(b.pixels[i])).filter(|&l| l > 0.0).collect();
    let (w, h) = (a.width, a.height);
    if lum.is_empty() {
        // Black reference: a single exposure of 1.
        lum.push(1.0);
    }
    lum.sort_by(|x, y| x.total_cmp(y));
    let median = lum[lum.len() / 2];
    let max = *lum.last().unwrap_or(&1.0);
    let t = 0.85f32;
    let (qa, qb, qc) = (ACES[0] - t * ACES[3], ACES[1] - t * ACES[4], ACES[2] - t * ACES[5]);
    let x85 = (-qb + (qb * qb - 4.0 * qa * qc).sqrt()) / (2.0 * qa);
    let start = (x85 / max).log2();
    let stop = (x85 / median).log2().max(start);
    let exposures = ((stop - start).ceil() as u32).clamp(2, 32);
    let step = (stop - start) / (exposures - 1) as f32;
    let to8 = |img: &Image, e: f32| -> Vec<u8> {
        let s = e.exp2();
        img.pixels.iter().flat_map(|p| p.map(|c| (255.0 * srgb_encode(aces(c * s)) + 0.5) as u8)).collect()
    };
    let mut map = vec![0f32; (w * h) as usize];
    for k in 0..exposures {
        let e = start + step * k as f32;
        let ra = nv_flip::FlipImageRgb8::with_data(w, h, &to8(b, e));
        let ta = nv_flip::FlipImageRgb8::with_data(w, h, &to8(a, e));
        let m = nv_flip::flip(ra, ta, nv_flip::DEFAULT_PIXELS_PER_DEGREE).to_vec();
        for (x, y) in map.iter_mut().zip(m) {
            *x = x.max(y);
        }
    }
    let (mut s, mut n) = (0.0f64, 0usize);
    for i in selected(mask, map.len()) {
        s += map[i] as f64;
        n += 1;
    }
    Ok(Flip {
        mean: if n == 0 { 0.0 } else { s / n as f64 },
        map,
        start_exposure: start,
        stop_exposure: stop,
        exposures,
    })
}

/// Result of the per-pixel statistical test.
#[derive(Debug, Clone, PartialEq)]
pub struct ZTest {
    /// Pixels tested.
    pub pixels: usize,
    /// Mean of z² over the pixels (about 1 when the two agree within their noise).
    pub mean_z2: f64,
    /// Fraction of pixels with |z| > 3 (0.27% for Gaussian noise).
    pub frac_over_3: f64,
    /// Fraction with |z| > 4 (6e-5 for Gaussian noise).
    pub frac_over_4: f64,
    /// Fraction with |z| > 5.
    pub frac_over_5: f64,
}

/// Per-pixel test on luminance: z = (a - b) / sqrt(var_a + var_b + (rel · b)² + abs²), with
/// the per-pixel variances of the two images' values (either may be absent), a relative
/// tolerance `rel` for systematic differences one accepts (e.g. the references' stated noise),
/// and an absolute floor `abs`.
pub fn z_test(
    a: &Image,
    var_a: Option<&Image>,
    b: &Image,
    var_b: Option<&Image>,
    mask: Option<&Mask>,
    rel: f64,
    abs: f64,
) -> Result<ZTest> {
    check_sizes(a, b, mask)?;
    let (mut n, mut z2, mut o3, mut o4, mut o5) = (0usize, 0.0f64, 0usize, 0usize, 0usize);
    for i in selected(mask, a.pixels.len()) {
        let x = luminance(a.pixels[i]) as f64;
        let y = luminance(b.pixels[i]) as f64;
        let va = var_a.map_or(0.0, |v| lum_var(v.pixels[i]));
        let vb = var_b.map_or(0.0, |v| lum_var(v.pixels[i]));
        let s2 = va + vb + (rel * y) * (rel * y) + abs * abs;
        let z = (x - y) / s2.sqrt().max(1e-30);
        z2 += z * z;
        o3 += (z.abs() > 3.0) as usize;
        o4 += (z.abs() > 4.0) as usize;
        o5 += (z.abs() > 5.0) as usize;
        n += 1;
    }
    let nf = n.max(1) as f64;
    Ok(ZTest {
        pixels: n,
        mean_z2: z2 / nf,
        frac_over_3: o3 as f64 / nf,
        frac_over_4: o4 as f64 / nf,
        frac_over_5: o5 as f64 / nf,
    })
}

/// A per-pixel variance image made robust for sparse estimates: each pixel gets the larger of
/// its own variance and the mean variance over the (2r+1)² window around it. A pixel that no
/// photon reached has a batch variance of 0 although its true variance is not; its neighbours'
/// variance is the better estimate.
pub fn spread_variance(var: &Image, r: u32) -> Image {
    let (w, h) = (var.width as i64, var.height as i64);
    let r = r as i64;
    // Summed-area table per channel.
    let mut sat = vec![[0f64; 3]; ((w + 1) * (h + 1)) as usize];
    for y in 0..h {
        for x in 0..w {
            let p = var.pixels[(y * w + x) as usize];
            let i = ((y + 1) * (w + 1) + x + 1) as usize;
            for k in 0..3 {
                sat[i][k] = p[k] as f64 + sat[i - 1][k] + sat[i - (w + 1) as usize][k] - sat[i - (w + 2) as usize][k];
            }
        }
    }
    let mut out = var.clone();
    for y in 0..h {
        for x in 0..w {
            let (x0, x1, y0, y1) = ((x - r).max(0), (x + r + 1).min(w), (y - r).max(0), (y + r + 1).min(h));
            let n = ((x1 - x0) * (y1 - y0)) as f64;
            let at = |xx: i64, yy: i64| sat[(yy * (w + 1) + xx) as usize];
            let (a, b, c, d) = (at(x1, y1), at(x0, y1), at(x1, y0), at(x0, y0));
            let o = &mut out.pixels[(y * w + x) as usize];
            for k in 0..3 {
                o[k] = o[k].max(((a[k] - b[k] - c[k] + d[k]) / n) as f32);
            }
        }
    }
    out
}

/// Variance of the luminance of a pixel whose channels have variances `v` (channels taken as
/// fully correlated: an upper bound).
fn lum_var(v: [f32; 3]) -> f64 {
    let s = 0.2126 * (v[0] as f64).max(0.0).sqrt()
        + 0.7152 * (v[1] as f64).max(0.0).sqrt()
        + 0.0722 * (v[2] as f64).max(0.0).sqrt();
    s * s
}

/// All the metrics of `compare`.
#[derive(Debug, Clone)]
pub struct Report {
    pub pixels: usize,
    pub rmse: f64,
    pub rel_mse: f64,
    pub psnr: f64,
    pub flip: Flip,
    pub energy_a: f64,
    pub energy_b: f64,
    pub energy_ratio: f64,
}

/// Every metric of `a` (test) against `b` (reference).
pub fn compare(a: &Image, b: &Image, mask: Option<&Mask>) -> Result<Report> {
    check_sizes(a, b, mask)?;
    let flip = hdr_flip(a, b, mask)?;
    let (ea, eb) = (energy(a, mask), energy(b, mask));
    Ok(Report {
        pixels: mask.map_or(a.pixels.len(), Mask::count),
        rmse: rmse(a, b, mask)?,
        rel_mse: rel_mse(a, b, mask)?,
        psnr: psnr(a, b, mask)?,
        flip,
        energy_a: ea,
        energy_b: eb,
        energy_ratio: ea / eb,
    })
}

/// A heat map a person can read: left half the FLIP error (magma colours, 0 = black, 1 =
/// yellow-white), right half the signed relative luminance difference
/// (a - b) / max(b, 0.1 × mean b): black where they agree, red where `a` is brighter, blue where
/// it is darker, full colour at ±25%. Pixels outside the mask are grey. Written as PNG (or EXR:
/// then the values are linear).
pub fn write_heatmap(path: &Path, a: &Image, b: &Image, mask: Option<&Mask>, flip: &Flip) -> Result<()> {
    check_sizes(a, b, mask)?;
    let (w, h) = (a.width, a.height);
    let n = mask.map_or(b.pixels.len(), Mask::count).max(1);
    let mean = (selected(mask, b.pixels.len()).map(|i| luminance(b.pixels[i]) as f64).sum::<f64>() / n as f64) as f32;
    let floor = (0.1 * mean).max(1e-30);
    let mut out = Image::new(2 * w, h);
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let inside = mask.is_none_or(|m| m.include[i]);
            let (l, r) = if inside {
                let lb = luminance(b.pixels[i]);
                let d = ((luminance(a.pixels[i]) - lb) / lb.max(floor) / 0.25).clamp(-1.0, 1.0);
                let r = if d >= 0.0 { [d, 0.2 * d, 0.0] } else { [0.0, -0.4 * d, -d] };
                (magma(flip.map[i]), r)
            } else {
                ([0.2; 3], [0.2; 3])
            };
            out.set(x, y, l.map(caustics::image_io::srgb_decode));
            out.set(x + w, y, r.map(caustics::image_io::srgb_decode));
        }
    }
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    if ext == "png" { crate::io::write_display_png(&out, path) } else { out.write(path, 1.0) }
}

/// A short magma-like ramp (sRGB display values).
fn magma(t: f32) -> [f32; 3] {
    const STOPS: [[f32; 3]; 6] = [
        [0.0, 0.0, 0.016],
        [0.23, 0.06, 0.44],
        [0.55, 0.16, 0.51],
        [0.87, 0.29, 0.41],
        [0.99, 0.62, 0.42],
        [0.99, 0.99, 0.75],
    ];
    let t = t.clamp(0.0, 1.0) * 5.0;
    let i = (t as usize).min(4);
    let f = t - i as f32;
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    [a[0] + (b[0] - a[0]) * f, a[1] + (b[1] - a[1]) * f, a[2] + (b[2] - a[2]) * f]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn img(v: f32) -> Image {
        let mut i = Image::new(32, 32);
        i.pixels.iter_mut().enumerate().for_each(|(k, p)| *p = [v * (k % 7) as f32; 3]);
        i
    }

    #[test]
    fn identical_images() {
        let a = img(0.3);
        let r = compare(&a, &a, None).unwrap();
        assert_eq!(r.rmse, 0.0);
        assert_eq!(r.rel_mse, 0.0);
        assert!(r.psnr.is_infinite());
        assert!(r.flip.mean < 1e-6, "{}", r.flip.mean);
        assert!((r.energy_ratio - 1.0).abs() < 1e-12);
    }

    #[test]
    fn different_images() {
        let a = img(0.3);
        let b = img(0.33);
        let r = compare(&a, &b, None).unwrap();
        assert!(r.rmse > 0.0 && r.flip.mean > 0.0);
        assert!((r.energy_ratio - 0.3 / 0.33).abs() < 1e-6);
        let m = Mask { width: 32, height: 32, include: (0..1024).map(|k| k % 7 == 0).collect() };
        // Only black pixels selected: no difference.
        assert_eq!(rmse(&a, &b, Some(&m)).unwrap(), 0.0);
        assert!(compare(&a, &Image::new(3, 3), None).is_err());
    }
}

/// Agreement of two caustic maps of the same light-view face (e.g. the GPU's and the CPU
/// reference's), texel by texel. Both are box-filtered over 3×3 texels first, so that photon
/// noise and the difference between a Gaussian splat and a box deposit do not dominate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapAgreement {
    /// Sum of `a` over sum of `b` (luminance; the texel areas are the same in both maps).
    pub energy_ratio: f64,
    /// RMSE over the texels where either filtered map exceeds 1 % of `b`'s filtered maximum,
    /// relative to `b`'s mean over those texels.
    pub rel_rmse: f64,
    /// Texels compared.
    pub texels: usize,
    /// Brightest filtered texel (x, y) of `a` and of `b`.
    pub peak_a: (u32, u32),
    pub peak_b: (u32, u32),
}

impl std::fmt::Display for MapAgreement {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "energy ratio {:.4}, relative RMSE {:.4} over {} texels, peak {:?} vs {:?}",
            self.energy_ratio, self.rel_rmse, self.texels, self.peak_a, self.peak_b
        )
    }
}

/// See [`MapAgreement`]. The maps must have the same size.
pub fn map_agreement(a: &Image, b: &Image) -> MapAgreement {
    assert_eq!((a.width, a.height), (b.width, b.height), "caustic maps of different sizes");
    let blur = |img: &Image| -> Vec<f64> {
        let (w, h) = (img.width as i64, img.height as i64);
        let lum = img.luminance();
        let mut out = vec![0.0; lum.len()];
        for y in 0..h {
            for x in 0..w {
                let mut s = 0.0;
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        let (xx, yy) = (x + dx, y + dy);
                        if xx >= 0 && yy >= 0 && xx < w && yy < h {
                            s += lum[(yy * w + xx) as usize] as f64;
                        }
                    }
                }
                out[(y * w + x) as usize] = s / 9.0;
            }
        }
        out
    };
    let (fa, fb) = (blur(a), blur(b));
    let peak = |v: &[f64]| {
        let i = v.iter().enumerate().fold(0, |best, (i, x)| if *x > v[best] { i } else { best });
        (i as u32 % a.width, i as u32 / a.width)
    };
    let max_b = fb.iter().cloned().fold(0.0, f64::max);
    let sel: Vec<usize> = (0..fa.len()).filter(|&i| fa[i] > 0.01 * max_b || fb[i] > 0.01 * max_b).collect();
    let mse = sel.iter().map(|&i| (fa[i] - fb[i]).powi(2)).sum::<f64>() / sel.len().max(1) as f64;
    let mean = sel.iter().map(|&i| fb[i]).sum::<f64>() / sel.len().max(1) as f64;
    let sum = |img: &Image| img.luminance().iter().map(|&x| x as f64).sum::<f64>();
    MapAgreement {
        energy_ratio: sum(a) / sum(b).max(1e-30),
        rel_rmse: mse.sqrt() / mean.max(1e-30),
        texels: sel.len(),
        peak_a: peak(&fa),
        peak_b: peak(&fb),
    }
}
