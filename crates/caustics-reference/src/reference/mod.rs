//! The exact CPU reference renderer.
//!
//! Independent of the GPU code (its own BVH, intersection, sampling and tracers); it shares
//! only the scene loading and the light-space parameterization ([`caustics::lightspace`]) so that
//! its caustic maps compare texel by texel with the GPU's.
//!
//! - [`bvh`], [`geometry`]: binned-SAH triangle BVH with watertight intersection, exact
//!   analytic spheres, rectangles and open cylinders.
//! - [`emit`]: photon emission with exact flux per photon.
//! - [`medium`]: homogeneous participating media (transmittance, free flight, phase functions).
//! - [`trace`]: photon tracing (caustic light: deposits in light-space maps, and light tracing
//!   to the camera) and camera path tracing (everything else).
//! - [`sampling`]: counter-based random numbers and scrambled Sobol points: the same seed gives
//!   the same image whatever the thread count.
//!
//! See `docs/reference-renderer.md`.

pub mod beam_splat;
pub mod branch;
pub mod bvh;
pub mod emit;
pub mod geometry;
pub mod medium;
pub mod optics;
mod passes;
pub mod photon_beams;
pub mod sampling;
mod settings;
pub mod spheres;
pub mod trace;
pub mod view_photons;

use caustics::error::{Error, Result};
use caustics::image_io::Image;
use caustics::scene::Scene;
use geometry::Accel;
use passes::{
    CHUNK, beam_pass, camera_pass, caustic_emitter, photon_pass, trace_range, view_pass, wants_beams,
    wants_view_photons,
};
use rayon::prelude::*;
pub use settings::{
    CAUSTIC_BATCHES, MAX_BEAM_PHOTONS, MAX_PHOTONS, ReferenceOutput, ReferenceSettings, ReferenceStats,
};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Instant;
pub use trace::{CausticPaths, Deposit, DiffuseOrders};
use trace::{PhotonOut, PhotonTargets, Tracer};

fn check_scene(scene: &Scene) -> Result<()> {
    // The loader refuses what the renderer cannot draw; scenes built in code are checked here.
    // (A directional or environment light with a medium: their light enters the box from the
    // vacuum outside it.)
    let _ = scene;
    Ok(())
}

fn tracer<'a>(scene: &'a Scene, accel: &'a Accel, settings: &ReferenceSettings) -> Tracer<'a> {
    let mut t = Tracer::new(scene, accel, settings.max_depth);
    t.single_scattering = settings.medium_single_scattering_only;
    t.caustic_paths = settings.caustic_paths;
    t.diffuse_orders = settings.diffuse_orders;
    t.partial_reflections = settings.partial_reflections;
    t.gather_direct = settings.gather_direct;
    t
}

/// Progress of a reference rendering, shared with another thread (a progress bar, a viewer),
/// and the way to cancel it. Work is counted in units of one photon path or one camera path;
/// `total` is set when the rendering starts.
#[derive(Debug, Default)]
pub struct Progress {
    done: AtomicU64,
    total: AtomicU64,
    cancel: AtomicBool,
}

impl Progress {
    pub fn new() -> Progress {
        Progress::default()
    }
    /// Ask the rendering to stop: it returns [`Error::Cancelled`] soon after (within one wave
    /// of photon chunks or one image row per thread).
    pub fn cancel(&self) {
        self.cancel.store(true, Ordering::Relaxed);
    }
    pub fn is_cancelled(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }
    /// Units of work done so far.
    pub fn done(&self) -> u64 {
        self.done.load(Ordering::Relaxed)
    }
    /// Units of work in all (0 until the rendering has started).
    pub fn total(&self) -> u64 {
        self.total.load(Ordering::Relaxed)
    }
    /// Done / total, in [0, 1] (0 before the start).
    pub fn fraction(&self) -> f64 {
        let t = self.total();
        if t == 0 { 0.0 } else { (self.done() as f64 / t as f64).min(1.0) }
    }
    /// Report `done` of `total` units (work counted outside this crate, such as the GPU's
    /// caustic-sphere precomputation).
    pub fn report(&self, done: u64, total: u64) {
        self.total.store(total, Ordering::Relaxed);
        self.done.store(done, Ordering::Relaxed);
    }
    fn add(&self, n: u64) {
        self.done.fetch_add(n, Ordering::Relaxed);
    }
    fn check(&self) -> Result<()> {
        if self.is_cancelled() { Err(Error::Cancelled) } else { Ok(()) }
    }
}

/// Render the full reference image, its caustic and non-caustic parts, and the light-space
/// caustic maps.
pub fn render(scene: &Scene, settings: &ReferenceSettings) -> Result<ReferenceOutput> {
    render_with_progress(scene, settings, &Progress::new())
}

/// [`render`], reporting its progress to `progress` and stopping with [`Error::Cancelled`]
/// when it is cancelled. The result does not depend on the progress reporting.
pub fn render_with_progress(
    scene: &Scene,
    settings: &ReferenceSettings,
    progress: &Progress,
) -> Result<ReferenceOutput> {
    settings.validate()?;
    check_scene(scene)?;
    let (w, h) = (scene.camera.width as u64, scene.camera.height as u64);
    let lights_with_photons =
        (0..=scene.lights.len()).filter(|&li| caustic_emitter(scene, li).is_some()).count() as u64;
    let beam_photons = if wants_beams(scene, settings) { settings.medium_beam_photons } else { 0 };
    let view_photons = if wants_view_photons(scene, settings) { settings.specular_view_photons } else { 0 };
    progress.total.store(
        lights_with_photons * (settings.photons_per_light + beam_photons + view_photons)
            + w * h * settings.camera_spp as u64,
        Ordering::Relaxed,
    );
    progress.done.store(0, Ordering::Relaxed);
    progress.check()?;
    let t0 = Instant::now();
    let accel = Accel::new(scene);
    let bvh_seconds = t0.elapsed().as_secs_f64();
    let mut tracer = tracer(scene, &accel, settings);
    let mut photons = photon_pass(scene, &tracer, settings, true, true, progress)?;
    let tb = Instant::now();
    let (beams, beam_rays) = if beam_photons > 0 { beam_pass(scene, &tracer, settings, progress)? } else { (None, 0) };
    let (view, view_rays) = if view_photons > 0 { view_pass(scene, &tracer, settings, progress)? } else { (None, 0) };
    let gather_photon_seconds = tb.elapsed().as_secs_f64();
    let (medium_beams, medium_beam_radius) = beams.as_ref().map_or((0, 0.0), |b| (b.beams().len() as u64, b.radius()));
    let (view_deposits, view_radius) = view.as_ref().map_or((0, 0.0), |v| (v.len() as u64, v.radius()));
    tracer.beams = beams;
    tracer.view_photons = view;
    let t1 = Instant::now();
    let cam = camera_pass(scene, &tracer, settings, progress)?;
    let camera_seconds = t1.elapsed().as_secs_f64();
    let (nocaustic, nocaustic_variance, camera_rays) = (cam.image, cam.variance, cam.rays);
    // The light the camera gathers through specular surfaces (beams, deposits) is caustic light
    // (its first surface is specular); its variance is independent of the photons'.
    if let Some((c, v)) = cam.caustic {
        for (p, q) in photons.caustic.pixels.iter_mut().zip(&c.pixels) {
            (0..3).for_each(|k| p[k] += q[k]);
        }
        for (p, q) in photons.variance.pixels.iter_mut().zip(&v.pixels) {
            (0..3).for_each(|k| p[k] += q[k]);
        }
    }
    let mut image = nocaustic.clone();
    for (p, c) in image.pixels.iter_mut().zip(&photons.caustic.pixels) {
        for k in 0..3 {
            p[k] += c[k];
        }
    }
    let rays = photons.rays + beam_rays + view_rays + camera_rays;
    let busy = photons.seconds + camera_seconds;
    let stats = ReferenceStats {
        photon_paths: photons.paths,
        camera_paths: w * h * settings.camera_spp as u64,
        rays,
        photon_rays: photons.rays,
        threads: rayon::current_num_threads(),
        triangles: accel.triangle_count(),
        bvh_seconds,
        photon_seconds: photons.seconds,
        camera_seconds,
        seconds: t0.elapsed().as_secs_f64(),
        rays_per_second: rays as f64 / busy.max(1e-9),
        photon_paths_per_second: photons.paths as f64 / photons.seconds.max(1e-9),
        medium_beams,
        medium_beam_radius,
        view_deposits,
        view_radius,
        gather_photon_seconds,
    };
    Ok(ReferenceOutput {
        image,
        caustic: photons.caustic,
        nocaustic,
        caustic_variance: photons.variance,
        nocaustic_variance,
        caustic_maps: photons.maps,
        stats,
    })
}

/// Only the light-space caustic maps (no camera image): per light, per face, N×N W/m².
pub fn caustic_maps(scene: &Scene, settings: &ReferenceSettings) -> Result<Vec<Vec<Image>>> {
    settings.validate()?;
    check_scene(scene)?;
    let accel = Accel::new(scene);
    let tracer = tracer(scene, &accel, settings);
    Ok(photon_pass(scene, &tracer, settings, false, true, &Progress::new())?.maps)
}

/// The first diffuse hit of every caustic photon of light `light` (tests and tools; memory
/// grows with the photon count). Light `scene.lights.len()` is the environment light.
pub fn caustic_deposits(scene: &Scene, settings: &ReferenceSettings, light: usize) -> Result<Vec<Deposit>> {
    settings.validate()?;
    check_scene(scene)?;
    if light > scene.lights.len() || (light == scene.lights.len() && scene.environment.is_none()) {
        return Err(Error::input(
            &scene.source,
            "lights",
            format!("no light {light} (the scene has {})", scene.lights.len()),
        ));
    }
    let accel = Accel::new(scene);
    let tracer = tracer(scene, &accel, settings);
    let Some(emitter) = caustic_emitter(scene, light) else { return Ok(Vec::new()) };
    let targets = PhotonTargets { camera: false, map: None, record_deposits: true, record_beams: false };
    let n = settings.photons_per_light;
    let chunks: Vec<u64> = (0..n.div_ceil(CHUNK)).collect();
    let outs: Vec<PhotonOut> = chunks
        .par_iter()
        .map(|&c| trace_range(&tracer, &emitter, settings, light, c * CHUNK..((c + 1) * CHUNK).min(n), &targets))
        .collect();
    Ok(outs.into_iter().flat_map(|o| o.deposits).collect())
}

#[cfg(test)]
mod progress_tests {
    use super::*;

    fn small(photons: u64) -> (Scene, ReferenceSettings) {
        let mut s = Scene::default_scene();
        s.camera.width = 24;
        s.camera.height = 16;
        let rs =
            ReferenceSettings { photons_per_light: photons, camera_spp: 2, caustic_map_size: 32, ..Default::default() };
        (s, rs)
    }

    #[test]
    fn progress_counts_all_the_work_and_changes_nothing() {
        let (s, rs) = small(1 << 14);
        let p = Progress::new();
        let a = render_with_progress(&s, &rs, &p).expect("render");
        // The caustic photons, the deposits' own photons (the ball: specular objects) and the
        // camera paths.
        assert_eq!(p.total(), (1 << 14) + rs.specular_view_photons + 24 * 16 * 2);
        assert_eq!(p.done(), p.total());
        assert_eq!(p.fraction(), 1.0);
        let b = render(&s, &rs).expect("render");
        assert_eq!(a.image.pixels, b.image.pixels);
        assert_eq!(a.caustic_maps[0][0].pixels, b.caustic_maps[0][0].pixels);
    }

    #[test]
    fn a_cancelled_render_returns_cancelled() {
        let (s, rs) = small(1 << 14);
        let p = Progress::new();
        p.cancel();
        assert!(matches!(render_with_progress(&s, &rs, &p), Err(Error::Cancelled)));
    }

    #[test]
    fn cancelling_from_another_thread_stops_soon() {
        let (s, rs) = small(1 << 28);
        let p = Progress::new();
        let t0 = Instant::now();
        let r = std::thread::scope(|sc| {
            sc.spawn(|| {
                std::thread::sleep(std::time::Duration::from_millis(200));
                p.cancel();
            });
            render_with_progress(&s, &rs, &p)
        });
        assert!(matches!(r, Err(Error::Cancelled)));
        assert!(p.done() < p.total());
        assert!(t0.elapsed().as_secs_f64() < 15.0, "{:?}", t0.elapsed());
    }
}
