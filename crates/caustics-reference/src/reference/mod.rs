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
pub mod photon_beams;
pub mod sampling;
pub mod spheres;
pub mod trace;
pub mod view_photons;

use caustics::error::{Error, Result};
use caustics::image_io::Image;
use caustics::lightspace::LightView;
use caustics::scene::Scene;
use emit::Emitter;
use geometry::Accel;
use glam::Vec3;
use rayon::prelude::*;
use sampling::{PathRng, hash, sobol_2d};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Instant;
pub use trace::{CausticPaths, Deposit};
use trace::{PhotonOut, PhotonTargets, Tracer};

/// The most photons per light the reference accepts (2^40).
pub const MAX_PHOTONS: u64 = 1 << 40;

/// How much work the reference does.
#[derive(Debug, Clone, PartialEq)]
pub struct ReferenceSettings {
    /// Photons emitted per light (toward the specular objects; see [`emit`]).
    pub photons_per_light: u64,
    /// Camera paths per pixel for the non-caustic image.
    pub camera_spp: u32,
    /// Most interactions per path (specular and diffuse surfaces, medium scatterings).
    pub max_depth: u32,
    /// Seed of every random number.
    pub seed: u64,
    /// Texels per side of each light-space caustic map face.
    pub caustic_map_size: u32,
    /// Participating medium: single scattering only (every path from a light to the camera
    /// scatters in the medium at most once, with any number of surface bounces before and
    /// after) instead of multiple scattering.
    pub medium_single_scattering_only: bool,
    /// Which caustic paths the camera image `caustic` (and so `image`) holds: all of them
    /// (the default), or only light → specular chain → the first diffuse surface → camera,
    /// the part the GPU's caustic maps render, or the rest (for measurements). The caustic
    /// maps and the `nocaustic` image do not depend on it. See [`CausticPaths`].
    pub caustic_paths: CausticPaths,
    /// Give spot lights (cone up to 75°) a spill face in their caustic maps
    /// (`LightView::with_spill`), as the GPU does where `RenderSettings::uses_spill_face`; off
    /// by default, so every map keeps one face per spot light. The camera images do not depend
    /// on it.
    pub spill_faces: bool,
    /// Caustic photons reflect partially at dielectric interfaces (the default). Off, every
    /// dielectric interface transmits them with weight 1 − F, reflecting only totally: the light
    /// the GPU's transmitted branches carry (the beams' and photon maps' first branch; with
    /// `--no-glass-reflection` on the GPU the like-for-like comparison of docs/benchmarks.md).
    /// The camera paths (the `nocaustic` image) do not depend on it.
    pub partial_reflections: bool,
    /// Scenes with a medium and specular objects: photons per light traced as photon beams
    /// ([`photon_beams`]) for the caustic light the camera sees in the medium through specular
    /// surfaces (light → specular → medium → specular → camera); 0 leaves those paths out.
    pub medium_beam_photons: u64,
    /// The photon beams' kernel radius (m); 0: half a pixel's footprint at the specular objects
    /// ([`photon_beams::auto_radius`]).
    pub medium_beam_radius: f32,
    /// Scenes with specular objects: photons per light whose first diffuse hits are kept
    /// ([`view_photons`]) for the caustic the camera sees on surfaces through specular surfaces
    /// (light → glass → floor → glass → camera); 0 leaves that light out.
    pub specular_view_photons: u64,
    /// Their kernel radius (m); 0: a pixel's footprint at the specular objects.
    pub specular_view_radius: f32,
    /// For the tests of the photon beams and the deposits: the camera sees the caustic light
    /// directly through them too, instead of through the photons' camera connections from
    /// medium scattering points and first diffuse hits (both estimate the same light).
    #[doc(hidden)]
    pub gather_direct: bool,
}

/// The most photon beams per light the reference accepts (memory: about 100 bytes a beam).
pub const MAX_BEAM_PHOTONS: u64 = 1 << 24;

impl Default for ReferenceSettings {
    fn default() -> Self {
        ReferenceSettings {
            photons_per_light: 4_000_000,
            camera_spp: 16,
            max_depth: 16,
            seed: 0,
            caustic_map_size: 512,
            medium_single_scattering_only: false,
            caustic_paths: CausticPaths::All,
            spill_faces: false,
            partial_reflections: true,
            medium_beam_photons: 1 << 18,
            medium_beam_radius: 0.0,
            specular_view_photons: 1 << 18,
            specular_view_radius: 0.0,
            gather_direct: false,
        }
    }
}

impl ReferenceSettings {
    /// Check the settings; errors name the command-line option.
    pub fn validate(&self) -> Result<()> {
        let e = |field: &str, m: String| Err(Error::input("<command line>", field, m));
        if self.photons_per_light == 0 || self.photons_per_light > MAX_PHOTONS {
            return e("--photons", format!("must be between 1 and 2^40 per light (got {})", self.photons_per_light));
        }
        if self.camera_spp == 0 || self.camera_spp > 1 << 20 {
            return e("--spp", format!("must be between 1 and 1048576 (got {})", self.camera_spp));
        }
        if self.max_depth == 0 || self.max_depth > 1024 {
            return e("--max-depth", format!("must be between 1 and 1024 (got {})", self.max_depth));
        }
        if self.medium_beam_photons > MAX_BEAM_PHOTONS {
            return e(
                "--medium-beams",
                format!("must be between 0 and 2^24 per light (got {})", self.medium_beam_photons),
            );
        }
        if self.specular_view_photons > MAX_BEAM_PHOTONS {
            return e(
                "--specular-view-photons",
                format!("must be between 0 and 2^24 per light (got {})", self.specular_view_photons),
            );
        }
        if !(self.specular_view_radius >= 0.0 && self.specular_view_radius.is_finite()) {
            return e(
                "--specular-view-radius",
                format!("must be 0 (automatic) or a positive length in metres (got {})", self.specular_view_radius),
            );
        }
        if !(self.medium_beam_radius >= 0.0 && self.medium_beam_radius.is_finite()) {
            return e(
                "--medium-beam-radius",
                format!("must be 0 (automatic) or a positive length in metres (got {})", self.medium_beam_radius),
            );
        }
        if self.caustic_map_size == 0 || self.caustic_map_size > 16384 {
            return e(
                "--caustic-map-size",
                format!("must be between 1 and 16384 texels (got {})", self.caustic_map_size),
            );
        }
        Ok(())
    }
}

/// Work done and speed.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReferenceStats {
    /// Photon paths traced (all lights).
    pub photon_paths: u64,
    /// Camera paths traced.
    pub camera_paths: u64,
    /// Rays cast (closest-hit and shadow/visibility rays) in photon and camera passes.
    pub rays: u64,
    /// Rays of the photon pass alone.
    pub photon_rays: u64,
    pub threads: usize,
    pub triangles: usize,
    pub bvh_seconds: f64,
    pub photon_seconds: f64,
    pub camera_seconds: f64,
    /// Wall-clock seconds, everything included.
    pub seconds: f64,
    /// Rays per second over the photon and camera passes.
    pub rays_per_second: f64,
    /// Photon paths per second in the photon pass.
    pub photon_paths_per_second: f64,
    /// Photon beams kept for the medium seen through specular surfaces and their kernel radius
    /// (m) (0, 0: none).
    pub medium_beams: u64,
    pub medium_beam_radius: f32,
    /// Deposits kept for the surfaces seen through specular surfaces and their kernel radius
    /// (m) (0, 0: none).
    pub view_deposits: u64,
    pub view_radius: f32,
    /// Seconds the beams' and the deposits' own photons took to trace and index.
    pub gather_photon_seconds: f64,
}

impl std::fmt::Display for ReferenceStats {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let t = self.threads.max(1) as f64;
        write!(
            f,
            "CPU reference: {} photon paths in {:.2} s ({:.2} M paths/s, {:.2} M/s per thread), {} camera paths in {:.2} s; \
             {} rays ({:.2} M rays/s, {:.2} M/s per thread); {} threads, {} triangles (BVH {:.3} s); {:.2} s in all",
            self.photon_paths,
            self.photon_seconds,
            self.photon_paths_per_second / 1e6,
            self.photon_paths_per_second / 1e6 / t,
            self.camera_paths,
            self.camera_seconds,
            self.rays,
            self.rays_per_second / 1e6,
            self.rays_per_second / 1e6 / t,
            self.threads,
            self.triangles,
            self.bvh_seconds,
            self.seconds
        )?;
        if self.medium_beams > 0 {
            write!(f, "; {} photon beams (radius {:.4} m)", self.medium_beams, self.medium_beam_radius)?;
        }
        if self.view_deposits > 0 {
            write!(
                f,
                "; {} deposits for the surfaces seen through glass (radius {:.4} m)",
                self.view_deposits, self.view_radius
            )?;
        }
        if self.medium_beams > 0 || self.view_deposits > 0 {
            write!(f, " in {:.2} s", self.gather_photon_seconds)?;
        }
        Ok(())
    }
}

/// A complete reference rendering.
#[derive(Debug, Clone)]
pub struct ReferenceOutput {
    /// `caustic + nocaustic`, radiance W/(m² sr) (the whole rendering with the default
    /// [`CausticPaths::All`]).
    pub image: Image,
    /// Caustic light only (light tracing), W/(m² sr): the path classes of
    /// [`ReferenceSettings::caustic_paths`] (all of them by default).
    pub caustic: Image,
    /// Everything else (camera paths), W/(m² sr).
    pub nocaustic: Image,
    /// Per pixel and channel: the estimated variance of `caustic`'s value (the variance of the
    /// mean over [`CAUSTIC_BATCHES`] independent batches of photons), (W/(m² sr))²; where the
    /// camera sees caustic light through glass (gathered from the deposits and photon beams),
    /// plus the camera samples' variance of that part, not the noise of the deposits and beams
    /// themselves.
    pub caustic_variance: Image,
    /// Per pixel and channel: the estimated variance of `nocaustic`'s value (sample variance
    /// of the camera paths / spp; an over-estimate, since the paths are stratified).
    pub nocaustic_variance: Image,
    /// Per light, per light-view face: N×N caustic irradiance (W/m²).
    pub caustic_maps: Vec<Vec<Image>>,
    pub stats: ReferenceStats,
}

/// The photons of each light are traced in this many batches (consecutive index ranges); the
/// spread between batches gives the caustic variance estimate.
pub const CAUSTIC_BATCHES: u64 = 16;
const CHUNK: u64 = 8192;
const WAVE: u64 = 64;

fn check_scene(scene: &Scene) -> Result<()> {
    // The loader refuses these; scenes built in code are checked here. A directional light
    // with a medium is rendered here (its light enters the box from the vacuum outside it; the
    // GPU's volume caustics from caustic spheres are compared with it), though the loader
    // refuses it for the GPU's direct light in media.
    if scene.medium.is_some() && scene.environment.is_some() {
        return Err(Error::input(&scene.source, "medium", "a medium cannot be combined with an environment light"));
    }
    Ok(())
}

fn tracer<'a>(scene: &'a Scene, accel: &'a Accel, settings: &ReferenceSettings) -> Tracer<'a> {
    let mut t = Tracer::new(scene, accel, settings.max_depth);
    t.single_scattering = settings.medium_single_scattering_only;
    t.caustic_paths = settings.caustic_paths;
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

/// Bounding sphere of the specular objects (those that can start a caustic path).
fn specular_sphere(scene: &Scene) -> Option<(Vec3, f32)> {
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    let mut any = false;
    for o in &scene.objects {
        if scene.material_of(o).is_specular() {
            let (a, b) = o.shape.bounds();
            lo = lo.min(a);
            hi = hi.max(b);
            any = true;
        }
    }
    any.then(|| ((lo + hi) * 0.5, (hi - lo).length() * 0.5 * 1.001 + 1e-6))
}

/// The emitter of caustic photons of light `li`: toward the specular objects only. Light
/// `scene.lights.len()` is the environment light, if the scene has one.
fn caustic_emitter(scene: &Scene, li: usize) -> Option<Emitter> {
    let (c, r) = specular_sphere(scene)?;
    let (lo, hi) = scene.bounds();
    let sc = (lo + hi) * 0.5;
    let sr = (hi - lo).length() * 0.5 * 1.001 + 1e-6;
    match scene.lights.get(li) {
        Some(light) => Some(Emitter::toward(light, c, r, sc, sr)),
        None => {
            let env = scene.environment.as_ref().filter(|e| li == scene.lights.len() && !e.is_black())?;
            Some(Emitter::environment(env.clone(), c, r, sc, sr))
        }
    }
}

/// Trace photons `range` of light `li`.
fn trace_range(
    tracer: &Tracer,
    emitter: &Emitter,
    settings: &ReferenceSettings,
    li: usize,
    range: std::ops::Range<u64>,
    targets: &PhotonTargets,
) -> PhotonOut {
    let mut out = PhotonOut::default();
    let scramble = hash(&[settings.seed, li as u64, 0x5048_4f54_4f4e]);
    let inv_n = 1.0 / settings.photons_per_light as f64;
    // Trace the chunk's photons in Morton order of their emission samples: neighbouring
    // photons then take neighbouring paths, which keeps the BVH in cache. The order is fixed
    // by the samples alone, so results still do not depend on the thread count.
    let mut todo: Vec<(u32, u64, glam::Vec2)> = range
        .map(|i| {
            let u = sobol_2d(i, scramble);
            (morton(u), i, u)
        })
        .collect();
    todo.sort_unstable_by_key(|&(m, i, _)| (m, i));
    for (_, i, u) in todo {
        let aux = || PathRng::new(hash(&[settings.seed, li as u64, i, 0x656e_7669])).next_2d();
        let Some(e) = emitter.sample_with(u, aux) else { continue };
        let mut rng = PathRng::new(hash(&[settings.seed, li as u64, i, 0x7061_7468]));
        let flux = (e.flux_n.as_dvec3() * inv_n).as_vec3();
        tracer.trace_photon(e.origin, e.dir, flux, &mut rng, targets, &mut out);
    }
    out
}

/// Trace `n` caustic photons per light, a set of their own (the same emission as the caustic
/// photons, stratified samples of their own under the seed `settings.seed ^ salt`), into
/// `targets` (beams or deposits, no camera connections). Their beams, deposits and rays, in
/// chunk order: they do not depend on the thread count.
fn extra_photons(
    scene: &Scene,
    tracer: &Tracer,
    settings: &ReferenceSettings,
    n: u64,
    salt: u64,
    targets: &PhotonTargets,
    progress: &Progress,
) -> Result<PhotonOut> {
    let es = ReferenceSettings { photons_per_light: n, seed: settings.seed ^ salt, ..settings.clone() };
    let mut all = PhotonOut::default();
    for li in 0..=scene.lights.len() {
        let Some(em) = caustic_emitter(scene, li) else { continue };
        let nchunks = n.div_ceil(CHUNK);
        let mut c0 = 0;
        while c0 < nchunks {
            progress.check()?;
            let c1 = (c0 + WAVE).min(nchunks);
            let outs: Vec<PhotonOut> = (c0..c1)
                .into_par_iter()
                .map(|c| trace_range(tracer, &em, &es, li, c * CHUNK..((c + 1) * CHUNK).min(n), targets))
                .collect();
            for o in outs {
                all.rays += o.rays;
                all.beams.extend(o.beams);
                all.deposits.extend(o.deposits);
            }
            progress.add((c1 * CHUNK).min(n) - c0 * CHUNK);
            c0 = c1;
        }
    }
    Ok(all)
}

/// A kernel radius setting: the given length, or `auto` where it is 0.
fn or_auto(set: f32, auto: f32) -> f32 {
    if set > 0.0 { set } else { auto }
}

/// Whether a rendering traces photon beams: a medium, specular objects, and the light they
/// carry in the image's class of caustic paths.
fn wants_beams(scene: &Scene, settings: &ReferenceSettings) -> bool {
    scene.medium.is_some()
        && settings.medium_beam_photons > 0
        && settings.caustic_paths.keeps(false)
        && specular_sphere(scene).is_some()
}

/// Trace [`ReferenceSettings::medium_beam_photons`] photons per light (their own stratified
/// samples and seed, the same emission as the caustic photons) and keep their flights through
/// the medium as photon beams. Returns the indexed beams and the rays traced.
fn beam_pass(
    scene: &Scene,
    tracer: &Tracer,
    settings: &ReferenceSettings,
    progress: &Progress,
) -> Result<(Option<photon_beams::PhotonBeams>, u64)> {
    let (Some(medium), Some((focus, _))) = (&scene.medium, specular_sphere(scene)) else { return Ok((None, 0)) };
    let targets = PhotonTargets { camera: false, map: None, record_deposits: false, record_beams: true };
    let out =
        extra_photons(scene, tracer, settings, settings.medium_beam_photons, 0x6265_616d_7300, &targets, progress)?;
    let (beams, rays) = (out.beams, out.rays);
    let radius = or_auto(settings.medium_beam_radius, photon_beams::auto_radius(&scene.camera, focus));
    // Boxes of at most a sixteenth of the medium's diagonal.
    let piece = (medium.bounds_max - medium.bounds_min).length() / 16.0;
    Ok((Some(photon_beams::PhotonBeams::new(beams, radius, piece)), rays))
}

/// Whether a rendering keeps deposits for the surfaces seen through specular surfaces:
/// specular objects, and that light in the image's class of caustic paths.
fn wants_view_photons(scene: &Scene, settings: &ReferenceSettings) -> bool {
    settings.specular_view_photons > 0 && settings.caustic_paths.keeps(false) && specular_sphere(scene).is_some()
}

/// Trace [`ReferenceSettings::specular_view_photons`] photons per light (their own samples and
/// seed) and keep their first diffuse hits. Returns the indexed deposits and the rays traced.
fn view_pass(
    scene: &Scene,
    tracer: &Tracer,
    settings: &ReferenceSettings,
    progress: &Progress,
) -> Result<(Option<view_photons::ViewPhotons>, u64)> {
    let Some((focus, _)) = specular_sphere(scene) else { return Ok((None, 0)) };
    let targets = PhotonTargets { camera: false, map: None, record_deposits: true, record_beams: false };
    let out =
        extra_photons(scene, tracer, settings, settings.specular_view_photons, 0x7669_6577_0000, &targets, progress)?;
    let (deposits, rays) = (out.deposits, out.rays);
    let radius = or_auto(settings.specular_view_radius, 2.0 * photon_beams::auto_radius(&scene.camera, focus));
    Ok((Some(view_photons::ViewPhotons::new(deposits, radius)), rays))
}

struct PhotonResult {
    caustic: Image,
    variance: Image,
    maps: Vec<Vec<Image>>,
    paths: u64,
    rays: u64,
    seconds: f64,
}

fn photon_pass(
    scene: &Scene,
    tracer: &Tracer,
    settings: &ReferenceSettings,
    camera: bool,
    maps: bool,
    progress: &Progress,
) -> Result<PhotonResult> {
    let t0 = Instant::now();
    let (w, h) = (scene.camera.width, scene.camera.height);
    let npix = (w * h) as usize;
    let size = settings.caustic_map_size;
    let views: Vec<LightView> = scene
        .lights
        .iter()
        .map(|l| if settings.spill_faces { LightView::with_spill(scene, l) } else { LightView::new(scene, l) })
        .collect();
    let mut map_acc: Vec<Vec<Vec<Vec3>>> = views
        .iter()
        .map(|v| if maps { vec![vec![Vec3::ZERO; (size * size) as usize]; v.faces.len()] } else { Vec::new() })
        .collect();
    // The lights, then the environment (no light-space maps).
    let emitters: Vec<Option<Emitter>> = (0..=scene.lights.len()).map(|li| caustic_emitter(scene, li)).collect();
    let n = settings.photons_per_light;
    let batches = CAUSTIC_BATCHES.min(n);
    let mut sum = vec![glam::DVec3::ZERO; if camera { npix } else { 0 }];
    let mut sumsq = sum.clone();
    let mut batch_img = vec![Vec3::ZERO; sum.len()];
    let (mut paths, mut rays) = (0u64, 0u64);
    for b in 0..batches {
        batch_img.iter_mut().for_each(|p| *p = Vec3::ZERO);
        for (li, em) in emitters.iter().enumerate() {
            let Some(em) = em else { continue };
            let map = if maps && li < views.len() { Some((&views[li], size)) } else { None };
            let targets = PhotonTargets { camera, map, record_deposits: false, record_beams: false };
            let (start, end) = (n * b / batches, n * (b + 1) / batches);
            paths += end - start;
            let nchunks = (end - start).div_ceil(CHUNK);
            let mut c0 = 0;
            while c0 < nchunks {
                progress.check()?;
                let c1 = (c0 + WAVE).min(nchunks);
                let outs: Vec<PhotonOut> = (c0..c1)
                    .into_par_iter()
                    .map(|c| {
                        let r = start + c * CHUNK..(start + (c + 1) * CHUNK).min(end);
                        trace_range(tracer, em, settings, li, r, &targets)
                    })
                    .collect();
                // Applied in chunk order: the sums do not depend on the thread count.
                for o in outs {
                    rays += o.rays;
                    for (pix, v) in o.cam {
                        batch_img[pix as usize] += v;
                    }
                    for (f, t, v) in o.map {
                        map_acc[li][f as usize][t as usize] += v;
                    }
                }
                progress.add((c1 * CHUNK).min(end - start) - c0 * CHUNK);
                c0 = c1;
            }
        }
        // A batch is 1/B of the photons: B × its sum estimates the image.
        let bf = batches as f64;
        for ((s, q), v) in sum.iter_mut().zip(sumsq.iter_mut()).zip(&batch_img) {
            let x = v.as_dvec3() * bf;
            *s += x;
            *q += x * x;
        }
    }
    let bf = batches as f64;
    let mut caustic = Image::new(w, h);
    let mut variance = Image::new(w, h);
    if camera {
        for i in 0..npix {
            let mean = sum[i] / bf;
            let var = if batches > 1 {
                ((sumsq[i] - sum[i] * mean) / (bf * (bf - 1.0))).max(glam::DVec3::ZERO)
            } else {
                glam::DVec3::ZERO
            };
            caustic.pixels[i] = mean.as_vec3().to_array();
            variance.pixels[i] = var.as_vec3().to_array();
        }
    }
    let maps = map_acc
        .into_iter()
        .map(|faces| {
            faces
                .into_iter()
                .map(|f| Image { width: size, height: size, pixels: f.into_iter().map(|v| v.to_array()).collect() })
                .collect()
        })
        .collect();
    Ok(PhotonResult { caustic, variance, maps, paths, rays, seconds: t0.elapsed().as_secs_f64() })
}

/// What the camera paths render.
struct CameraResult {
    /// The non-caustic image and its per-pixel variance.
    image: Image,
    variance: Image,
    /// The caustic light gathered from the photon beams and deposits and its variance (with
    /// either only).
    caustic: Option<(Image, Image)>,
    rays: u64,
}

/// The non-caustic image: `camera_spp` camera paths per pixel, stratified in the pixel; and
/// the variance of each pixel's value; with photon beams or deposits, the caustic light the
/// same paths gather from them.
fn camera_pass(
    scene: &Scene,
    tracer: &Tracer,
    settings: &ReferenceSettings,
    progress: &Progress,
) -> Result<CameraResult> {
    let (w, h) = (scene.camera.width, scene.camera.height);
    let spp = settings.camera_spp;
    // Per pixel: mean and variance of the mean, of both parts.
    type Px = ([f32; 3], [f32; 3], [f32; 3], [f32; 3]);
    type Row = (Vec<Px>, u64);
    let stats = |acc: glam::DVec3, acc2: glam::DVec3| {
        let n = spp as f64;
        let mean = acc / n;
        let v =
            if spp > 1 { ((acc2 - acc * mean) / (n * (n - 1.0))).max(glam::DVec3::ZERO) } else { glam::DVec3::ZERO };
        (mean.as_vec3().to_array(), v.as_vec3().to_array())
    };
    let rows: Vec<Row> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut row = Vec::with_capacity(w as usize);
            let mut rays = 0;
            if progress.is_cancelled() {
                return (row, rays);
            }
            for x in 0..w {
                let pix = (y * w + x) as u64;
                let scramble = hash(&[settings.seed, 0xCA3E, pix]);
                let (mut acc, mut acc2) = (glam::DVec3::ZERO, glam::DVec3::ZERO);
                let (mut cacc, mut cacc2) = (glam::DVec3::ZERO, glam::DVec3::ZERO);
                for s in 0..spp as u64 {
                    let u = sobol_2d(s, scramble);
                    let mut rng = PathRng::new(hash(&[settings.seed, 0xCA3F, pix, s]));
                    let (l, lc, r) = tracer.trace_camera(x as f32 + u.x, y as f32 + u.y, &mut rng);
                    rays += r;
                    let (l, lc) = (l.as_dvec3(), lc.as_dvec3());
                    acc += l;
                    acc2 += l * l;
                    cacc += lc;
                    cacc2 += lc * lc;
                }
                let (m, v) = stats(acc, acc2);
                let (cm, cv) = stats(cacc, cacc2);
                row.push((m, v, cm, cv));
            }
            progress.add(w as u64 * spp as u64);
            (row, rays)
        })
        .collect();
    progress.check()?;
    let mut img = Image::new(w, h);
    let mut vimg = Image::new(w, h);
    let mut cimg = Image::new(w, h);
    let mut cvimg = Image::new(w, h);
    let mut rays = 0;
    for (y, (row, r)) in rows.into_iter().enumerate() {
        rays += r;
        for (x, (m, v, cm, cv)) in row.into_iter().enumerate() {
            let i = y * w as usize + x;
            (img.pixels[i], vimg.pixels[i], cimg.pixels[i], cvimg.pixels[i]) = (m, v, cm, cv);
        }
    }
    let caustic = (tracer.beams.is_some() || tracer.view_photons.is_some()).then_some((cimg, cvimg));
    Ok(CameraResult { image: img, variance: vimg, caustic, rays })
}

/// Morton code of a point of the unit square (16 bits per axis).
fn morton(u: glam::Vec2) -> u32 {
    fn spread(x: u32) -> u32 {
        let mut x = x & 0xffff;
        x = (x | (x << 8)) & 0x00ff_00ff;
        x = (x | (x << 4)) & 0x0f0f_0f0f;
        x = (x | (x << 2)) & 0x3333_3333;
        (x | (x << 1)) & 0x5555_5555
    }
    let q = |v: f32| ((v * 65536.0) as u32).min(65535);
    spread(q(u.x)) | (spread(q(u.y)) << 1)
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
