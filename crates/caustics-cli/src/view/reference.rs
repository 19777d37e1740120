//! The CPU reference of the current view, computed on a background thread (A/B and difference
//! views): progress from [`caustics_reference::reference::Progress`], cancelled when the view changes.

use caustics::Scene;
use caustics::image_io::{Image, tonemap};
use caustics_reference::reference::{Progress, ReferenceOutput, ReferenceSettings};
use std::sync::Arc;
use std::thread::JoinHandle;

/// A reference rendering in flight.
pub struct Job {
    pub progress: Arc<Progress>,
    /// The view generation it renders (see [`super::session::Session::generation`]).
    pub generation: u64,
    handle: Option<JoinHandle<caustics::Result<ReferenceOutput>>>,
}

impl Job {
    /// Start rendering `scene` (its camera is the view) on a new thread.
    pub fn start(scene: Scene, settings: ReferenceSettings, generation: u64) -> Job {
        let progress = Arc::new(Progress::new());
        let p = progress.clone();
        let handle = std::thread::Builder::new()
            .name("cpu-reference".into())
            .spawn(move || caustics_reference::reference::render_with_progress(&scene, &settings, &p))
            .ok();
        Job { progress, generation, handle }
    }

    pub fn is_finished(&self) -> bool {
        self.handle.as_ref().is_none_or(JoinHandle::is_finished)
    }

    /// The result, once finished (blocks otherwise).
    pub fn join(mut self) -> caustics::Result<ReferenceOutput> {
        match self.handle.take() {
            Some(h) => h.join().unwrap_or_else(|_| Err(caustics::Error::Device("the CPU reference panicked".into()))),
            None => Err(caustics::Error::Device("cannot start a thread for the CPU reference".into())),
        }
    }

    /// Ask it to stop; the thread ends soon and its result is dropped.
    pub fn cancel(&self) {
        self.progress.cancel();
    }
}

impl Drop for Job {
    fn drop(&mut self) {
        self.progress.cancel();
    }
}

/// An 8-bit RGBA image for display.
#[derive(Debug, Clone, PartialEq)]
pub struct Rgba {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<u8>,
}

impl Rgba {
    /// `img` tone-mapped as the renderer's display image is.
    pub fn tonemapped(img: &Image, exposure: f32) -> Rgba {
        let pixels = img
            .pixels
            .iter()
            .flat_map(|p| {
                let [r, g, b] = tonemap(*p, exposure);
                [r, g, b, 255]
            })
            .collect();
        Rgba { width: img.width, height: img.height, pixels }
    }
}

/// Difference view of `a` (GPU) against `b` (reference): per pixel the absolute difference of
/// the tone-mapped values, amplified 4×, as a heat map (black = equal, red = a brighter,
/// blue = b brighter). Also the mean absolute tone-mapped difference (0..1).
pub fn difference(a: &Image, b: &Image, exposure: f32) -> Option<(Rgba, f64)> {
    if a.width != b.width || a.height != b.height {
        return None;
    }
    let mut pixels = Vec::with_capacity(a.pixels.len() * 4);
    let mut sum = 0.0f64;
    for (pa, pb) in a.pixels.iter().zip(&b.pixels) {
        let ta = tonemap(*pa, exposure);
        let tb = tonemap(*pb, exposure);
        let la = (ta[0] as f32 + ta[1] as f32 + ta[2] as f32) / 3.0;
        let lb = (tb[0] as f32 + tb[1] as f32 + tb[2] as f32) / 3.0;
        let d = la - lb;
        sum += d.abs() as f64 / 255.0;
        let v = (d.abs() * 4.0).min(255.0) as u8;
        if d >= 0.0 {
            pixels.extend_from_slice(&[v, v / 4, 0, 255]);
        } else {
            pixels.extend_from_slice(&[0, v / 4, v, 255]);
        }
    }
    let n = a.pixels.len().max(1) as f64;
    Some((Rgba { width: a.width, height: a.height, pixels }, sum / n))
}
