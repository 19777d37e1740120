//! The reference's passes: the caustic photons (camera image and light-space maps), the photon
//! beams' and view deposits' own photons, and the camera paths; the photon emitters and the
//! Morton-ordered photon ranges they trace.

use super::emit::Emitter;
use super::sampling::{PathRng, hash, sobol_2d};
use super::trace::{PhotonOut, PhotonTargets, Tracer};
use super::{CAUSTIC_BATCHES, Progress, ReferenceSettings, photon_beams, view_photons};
use caustics::error::Result;
use caustics::image_io::Image;
use caustics::lightspace::LightView;
use caustics::scene::Scene;
use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;

pub(super) const CHUNK: u64 = 8192;
const WAVE: u64 = 64;

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
pub(super) fn caustic_emitter(scene: &Scene, li: usize) -> Option<Emitter> {
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
pub(super) fn trace_range(
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
pub(super) fn wants_beams(scene: &Scene, settings: &ReferenceSettings) -> bool {
    scene.medium.is_some()
        && settings.medium_beam_photons > 0
        && settings.caustic_paths.keeps(false)
        && specular_sphere(scene).is_some()
}

/// Trace [`ReferenceSettings::medium_beam_photons`] photons per light (their own stratified
/// samples and seed, the same emission as the caustic photons) and keep their flights through
/// the medium as photon beams. Returns the indexed beams and the rays traced.
pub(super) fn beam_pass(
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
/// specular objects, and that light in the image's class of caustic paths and its diffuse
/// orders (order 1 and up: the deposits are first diffuse hits, gathered at a camera path's
/// k-th diffuse vertex as order k).
pub(super) fn wants_view_photons(scene: &Scene, settings: &ReferenceSettings) -> bool {
    settings.specular_view_photons > 0
        && settings.caustic_paths.keeps(false)
        && settings.diffuse_orders.max.is_none_or(|m| m >= 1)
        && specular_sphere(scene).is_some()
}

/// Trace [`ReferenceSettings::specular_view_photons`] photons per light (their own samples and
/// seed) and keep their first diffuse hits. Returns the indexed deposits and the rays traced.
pub(super) fn view_pass(
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

pub(super) struct PhotonResult {
    pub(super) caustic: Image,
    pub(super) variance: Image,
    pub(super) maps: Vec<Vec<Image>>,
    pub(super) paths: u64,
    pub(super) rays: u64,
    pub(super) seconds: f64,
}

pub(super) fn photon_pass(
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
pub(super) struct CameraResult {
    /// The non-caustic image and its per-pixel variance.
    pub(super) image: Image,
    pub(super) variance: Image,
    /// The caustic light gathered from the photon beams and deposits and its variance (with
    /// either only).
    pub(super) caustic: Option<(Image, Image)>,
    pub(super) rays: u64,
}

/// The non-caustic image: `camera_spp` camera paths per pixel, stratified in the pixel; and
/// the variance of each pixel's value; with photon beams or deposits, the caustic light the
/// same paths gather from them.
pub(super) fn camera_pass(
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
