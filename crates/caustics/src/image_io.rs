//! HDR images: linear RGB float32, and the tone mapping of `docs/scene-format.md`. Reading and
//! writing files (EXR, PNG) is `caustics_reference::io`'s: the renderer needs no file format.

/// A linear RGB image, row-major, pixel (0,0) top-left.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width × height` linear RGB pixels, row-major, top row first.
    pub pixels: Vec<[f32; 3]>,
}

impl Image {
    /// A black image.
    pub fn new(width: u32, height: u32) -> Image {
        Image { width, height, pixels: vec![[0.0; 3]; (width * height) as usize] }
    }
    /// Pixel (x, y), (0,0) top-left.
    pub fn get(&self, x: u32, y: u32) -> [f32; 3] {
        self.pixels[(y * self.width + x) as usize]
    }
    /// Set pixel (x, y), (0,0) top-left.
    pub fn set(&mut self, x: u32, y: u32, c: [f32; 3]) {
        let w = self.width;
        self.pixels[(y * w + x) as usize] = c;
    }
    /// Sum over all pixels and channels (the references' `energy.sum_*`).
    pub fn sum(&self) -> f64 {
        self.pixels.iter().map(|p| p.iter().map(|&c| c as f64).sum::<f64>()).sum()
    }
    /// Luminance (Rec. 709) of each pixel.
    pub fn luminance(&self) -> Vec<f32> {
        self.pixels.iter().map(|p| luminance(*p)).collect()
    }
}

/// Luminance (Rec. 709) of a linear RGB colour.
pub fn luminance(c: [f32; 3]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// The PNG tone mapping of `docs/scene-format.md`: exposure, ACES fit (Narkowicz 2015), sRGB.
pub fn tonemap(c: [f32; 3], exposure: f32) -> [u8; 3] {
    c.map(|v| {
        let x = (v * exposure).max(0.0);
        let y = ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0);
        let y = if y.is_finite() { y } else { 1.0 };
        (255.0 * srgb_encode(y)).round() as u8
    })
}

/// The sRGB transfer function: linear `y` in [0, 1] to the encoded value in [0, 1].
pub fn srgb_encode(y: f32) -> f32 {
    if y <= 0.0031308 { 12.92 * y } else { 1.055 * y.powf(1.0 / 2.4) - 0.055 }
}

/// The inverse of [`srgb_encode`]: encoded `v` in [0, 1] to linear.
pub fn srgb_decode(v: f32) -> f32 {
    if v <= 0.04045 { v / 12.92 } else { ((v + 0.055) / 1.055).powf(2.4) }
}
