//! Frames on demand, their statistics, the CPU reference of the view and its comparison, and
//! screenshots.

use super::{REFERENCE_DELAY, ReferenceView, Session, ViewMode};
use crate::view::reference::{self, Job, Rgba};
use caustics::renderer::{FrameRequest, FrameStats};
use caustics::{Error, Result};
use caustics_reference::ImageIo;
use std::path::{Path, PathBuf};
#[cfg(test)]
use std::time::Duration;
use std::time::Instant;

impl Session {
    /// Render a frame if anything changed; returns whether it did. Never waits for the GPU
    /// beyond what [`Renderer::encode`](caustics::renderer::Renderer::encode) does.
    pub fn render(&mut self) -> Result<bool> {
        if self.playing.is_some()
            && let Err(e) = self.advance()
        {
            self.playing = None;
            self.error = Some(e.to_string());
            return Err(e);
        }
        if !self.dirty {
            return Ok(false);
        }
        self.dirty = self.settle > 0;
        self.settle = self.settle.saturating_sub(1);
        if self.settings().caustic_spheres() && self.sphere_tables.is_none() {
            // Blocks while a table is precomputed (a progress bar on the terminal; cached).
            if let Err(e) =
                crate::spheres::attach(&mut self.renderer, &self.base, &self.sphere_args, &mut self.sphere_tables)
            {
                self.error = Some(e.to_string());
                return Err(e);
            }
        }
        let t0 = Instant::now();
        let mut enc =
            self.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("viewer frame") });
        let display = match self.renderer.encode(&mut enc, FrameRequest { stats: true }) {
            Ok(out) => out.display.clone(),
            Err(e) => {
                self.error = Some(e.to_string());
                return Err(e);
            }
        };
        self.queue.submit([enc.finish()]);
        // A progressive interreflection cache refines over the next frames.
        self.dirty |= self.renderer.refining();
        let done = self.frame_done.clone();
        if let Ok(mut d) = done.lock() {
            *d = None;
        }
        self.queue.on_submitted_work_done(move || {
            if let Ok(mut d) = done.lock() {
                *d = Some(Instant::now());
            }
        });
        self.frame_started = Some(t0);
        self.stats_pending = true;
        self.display = Some(display);
        self.frames += 1;
        if self.reference().is_some() {
            self.compare_with_reference();
        }
        Ok(true)
    }

    /// Collect what arrived: frame statistics, the frame's completion time, a finished
    /// reference; start the automatic reference when a comparison view waits for one. Call once
    /// per window frame.
    pub fn update(&mut self) {
        let _ = self.device.poll(wgpu::PollType::Poll);
        self.frame_time();
        match self.renderer.poll_stats() {
            Ok(Some(s)) => {
                self.arrived(s);
                self.stats_pending = false;
            }
            Ok(None) => {}
            Err(e) => {
                self.error = Some(e.to_string());
                self.stats_pending = false;
            }
        }
        if let Some(e) = self.renderer.last_error() {
            self.error = Some(e.to_string());
        }
        if self.job.as_ref().is_some_and(Job::is_finished)
            && let Some(job) = self.job.take()
        {
            let generation = job.generation;
            match job.join() {
                Ok(out) if generation == self.generation => {
                    self.reference_version += 1;
                    self.reference = Some(ReferenceView {
                        generation,
                        rgba: Rgba::tonemapped(&out.image, self.scene().exposure),
                        image: out.image,
                        diff: None,
                        rel_mse: None,
                        flip: None,
                        gpu: None,
                        seconds: out.stats.seconds,
                        version: self.reference_version,
                    });
                    self.compare_with_reference();
                }
                Ok(_) | Err(Error::Cancelled) => {}
                Err(e) => {
                    self.error = Some(format!("CPU reference: {e}"));
                    self.reference_failed = Some(generation);
                }
            }
        }
        if self.view_mode != ViewMode::Gpu
            && self.job.is_none()
            && self.reference().is_none()
            && self.reference_failed != Some(self.generation)
            && self.drag.is_none()
            && self.changed_at.elapsed() >= REFERENCE_DELAY
        {
            self.start_reference();
        }
    }

    /// The latest frame's host time, once the GPU finished it.
    fn frame_time(&mut self) {
        if let (Some(t0), Ok(mut d)) = (self.frame_started, self.frame_done.lock())
            && let Some(t1) = d.take()
        {
            self.frame_ms = Some(t1.duration_since(t0).as_secs_f64() * 1e3);
            self.frame_started = None;
        }
    }

    /// A frame's statistics arrived. The time budget learns from frames that did photon work
    /// (a camera-only frame costs the same whatever the grid).
    fn arrived(&mut self, s: FrameStats) {
        if let (Some(b), Some(ms)) = (&mut self.budget, self.frame_ms)
            && s.lights_redone.iter().any(|&r| r)
        {
            let mut next = self.renderer.settings().clone();
            if b.update(ms, &mut next)
                && let Err(e) = self.renderer.set_settings(next)
            {
                self.error = Some(e.to_string());
            }
        }
        self.stats = Some(s);
    }

    /// Whether the latest frame's statistics or completion time are still to come (the window
    /// keeps polling).
    pub fn awaiting_gpu(&self) -> bool {
        self.stats_pending || self.frame_started.is_some()
    }

    /// Wait for the statistics of the frames rendered so far (tests).
    #[cfg(test)]
    pub fn wait_stats(&mut self) {
        match self.renderer.wait_stats() {
            Ok(Some(s)) => {
                self.frame_time();
                self.arrived(s);
            }
            Ok(None) => {}
            Err(e) => self.error = Some(e.to_string()),
        }
        self.stats_pending = false;
        self.update();
    }

    /// Start the CPU reference of the current view (cancelling one in flight).
    pub fn start_reference(&mut self) {
        self.job = Some(Job::start(self.scene().clone(), self.reference_settings.clone(), self.generation));
    }

    /// Wait for the reference in flight (tests).
    #[cfg(test)]
    pub fn wait_reference(&mut self) {
        while self.job.as_ref().is_some_and(|j| !j.is_finished()) {
            std::thread::sleep(Duration::from_millis(20));
        }
        self.update();
    }

    fn compare_with_reference(&mut self) {
        let exposure = self.scene().exposure;
        let gpu = match self.renderer.read_image() {
            Ok(i) => i,
            Err(e) => {
                self.error = Some(e.to_string());
                return;
            }
        };
        self.reference_version += 1;
        let version = self.reference_version;
        if let Some(r) = self.reference.as_mut() {
            r.diff = reference::difference(&gpu, &r.image, exposure);
            r.rel_mse = caustics_reference::metrics::rel_mse(&gpu, &r.image, None).ok();
            r.flip = None;
            r.gpu = Some(gpu);
            r.version = version;
        }
    }

    /// Write the current image to `path` (.png tone-mapped, .exr linear radiance), atomically.
    pub fn screenshot(&mut self, path: &Path) -> Result<()> {
        self.render()?; // (if the view changed since the last frame)
        let img = self.renderer.read_image()?;
        img.write(path, self.scene().exposure)?;
        self.status = format!("wrote {}", path.display());
        Ok(())
    }

    /// The next free numbered screenshot name (no extension) in the screenshot folder.
    pub fn next_screenshot_stem(&mut self) -> PathBuf {
        loop {
            self.screenshots += 1;
            let s = self.screenshot_dir.join(format!("caustics-view-{:03}", self.screenshots));
            if !s.with_extension("png").exists() && !s.with_extension("exr").exists() {
                return s;
            }
        }
    }

    /// Write the current image as the next numbered PNG and EXR pair in the screenshot folder.
    pub fn screenshot_pair(&mut self) -> Result<Vec<PathBuf>> {
        self.render()?;
        let img = self.renderer.read_image()?;
        let stem = self.next_screenshot_stem();
        let paths = vec![stem.with_extension("png"), stem.with_extension("exr")];
        for p in &paths {
            img.write(p, self.scene().exposure)?;
        }
        self.status = format!("wrote {} and .exr", paths[0].display());
        Ok(paths)
    }
}
