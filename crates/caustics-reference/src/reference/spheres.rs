//! The precomputation of caustic spheres (`caustics::caustic_spheres`) on the CPU: photons of
//! a unit-irradiance directional light traced exactly through one object alone (this module's
//! BVH and analytic shapes, every specular interaction up to `max_depth`, Fresnel choices made
//! at random from a hash of the photon as the reference renderer does, total internal
//! reflection), and the rays that leave it deposited on the spheres. All cores (rayon); the
//! result is the same bits in every run (photons are traced in chunks in parallel and deposited
//! in their index order).

use super::Progress;
use super::geometry::{Accel, spawn};
use super::sampling::{PathRng, basis, concentric_disc, hash, sobol_2d};
use super::trace::scatter_specular;
use caustics::caustic_spheres::{CausticSpheres, DirectionLayout, Escaped, SphereGeometry, SphereSettings};
use caustics::error::{Error, Result};
use caustics::scene::{Material, Scene};
use glam::Vec3;
use rayon::prelude::*;
use std::f32::consts::PI;
use std::sync::atomic::Ordering;

const CHUNK: u64 = 8192;

/// The object `object` of `scene` alone, as a scene the reference's tracer can intersect.
fn alone(scene: &Scene, object: usize) -> Scene {
    let mut s = scene.clone();
    s.objects = vec![scene.objects[object].clone()];
    s.lights.clear();
    s.environment = None;
    s.medium = None;
    s
}

/// The photons of a unit-irradiance directional light travelling along `dir` that leave
/// object `object` after at least one specular interaction (flux in m² per W/m² of light).
pub fn escaping(scene: &Scene, object: usize, dir: Vec3, settings: &SphereSettings, seed: u64) -> Vec<Escaped> {
    let s = alone(scene, object);
    let accel = Accel::new(&s);
    escaping_with(&s, &accel, dir, settings, seed, None)
}

fn escaping_with(
    s: &Scene,
    accel: &Accel,
    dir: Vec3,
    settings: &SphereSettings,
    seed: u64,
    progress: Option<&Progress>,
) -> Vec<Escaped> {
    let mat = s.materials[s.objects[0].material];
    let (lo, hi) = s.objects[0].shape.bounds();
    let c = (lo + hi) * 0.5;
    let radius = (hi - lo).length() * 0.5 * 1.0001 + 1e-6;
    let dir = dir.normalize();
    let (du, dv) = basis(dir);
    let back = 2.0 * radius + 1e-3;
    let n = settings.photons;
    let flux = Vec3::splat(PI * radius * radius / n as f32);
    let chunks: Vec<u64> = (0..n.div_ceil(CHUNK)).collect();
    let outs: Vec<Vec<Escaped>> = chunks
        .par_iter()
        .map(|&ch| {
            let mut out = Vec::new();
            for i in ch * CHUNK..((ch + 1) * CHUNK).min(n) {
                let p = concentric_disc(sobol_2d(i, seed)) * radius;
                let mut o = c + du * p.x + dv * p.y - dir * back;
                let mut d = dir;
                let mut f = flux;
                let mut rng = PathRng::new(hash(&[seed, i, 0x5350_4845_5245]));
                for depth in 0..settings.max_depth {
                    let Some(h) = accel.intersect(o, d, f32::INFINITY) else {
                        if depth > 0 {
                            out.push(Escaped { origin: o, dir: d, flux: f });
                        }
                        break;
                    };
                    if matches!(mat, Material::Diffuse { .. }) {
                        break;
                    }
                    let front = d.dot(h.ng) < 0.0;
                    let (ng, ns) = if front { (h.ng, h.ns) } else { (-h.ng, -h.ns) };
                    let Some((nd, w)) = scatter_specular(mat, d, ng, ns, front, &mut rng, true) else { break };
                    f *= w;
                    d = nd;
                    o = spawn(h.p, h.ng, d);
                    if f.max_element() <= 0.0 {
                        break;
                    }
                }
            }
            if let Some(pr) = progress {
                pr.done.fetch_add(((ch + 1) * CHUNK).min(n) - ch * CHUNK, Ordering::Relaxed);
            }
            out
        })
        .collect();
    outs.concat()
}

/// Precomputes the caustic spheres of object `object` of `scene` (the scene file's pose) for
/// the light directions `dirs` (by default the octahedral layout of `settings`). `progress`
/// counts photons; cancelling it returns [`Error::Cancelled`].
pub fn precompute(
    scene: &Scene,
    object: usize,
    settings: &SphereSettings,
    dirs: Option<Vec<Vec3>>,
    progress: &Progress,
) -> Result<CausticSpheres> {
    settings.validate()?;
    let Some(o) = scene.objects.get(object) else {
        return Err(Error::input(&scene.source, "objects", format!("no object {object}")));
    };
    if !scene.material_of(o).is_specular() {
        return Err(Error::input(&scene.source, format!("objects[{object}]"), "not a specular (caustic) object"));
    }
    let dirs = dirs.unwrap_or_else(|| DirectionLayout::new(settings.directions).dirs);
    let geometry = SphereGeometry::for_shape(&o.shape, settings);
    let mut sp = CausticSpheres::empty(*settings, geometry, dirs.clone());
    let s = alone(scene, object);
    let accel = Accel::new(&s);
    progress.total.store(settings.photons * dirs.len() as u64, Ordering::Relaxed);
    progress.done.store(0, Ordering::Relaxed);
    for (k, d) in dirs.iter().enumerate() {
        if progress.is_cancelled() {
            return Err(Error::Cancelled);
        }
        let photons = escaping_with(&s, &accel, *d, settings, k as u64 ^ 0x9e37_79b9, Some(progress));
        sp.deposit(k, &photons);
    }
    Ok(sp)
}

/// Where a [`load_or_precompute`] table came from.
#[derive(Debug, Clone, PartialEq)]
pub enum Origin {
    /// Read from the cache file.
    Cache,
    /// Precomputed (no usable cache; the reason why the file was not used).
    Built(String),
}

/// The caustic spheres of object `object`: read from the cache in `dir` when a file for the
/// same object, material and settings is there and intact, else precomputed and written there
/// (atomically). `storage` chooses f32 or half floats on disk.
pub fn load_or_precompute(
    scene: &Scene,
    object: usize,
    settings: &SphereSettings,
    storage: caustics::caustic_spheres::cache::Storage,
    dir: &std::path::Path,
    progress: &Progress,
) -> Result<(CausticSpheres, Origin)> {
    use caustics::caustic_spheres::cache;
    settings.validate()?;
    let Some(o) = scene.objects.get(object) else {
        return Err(Error::input(&scene.source, "objects", format!("no object {object}")));
    };
    let key = cache::key(scene, o, settings);
    let path = cache::path(dir, key, storage);
    let reason = match std::fs::read(&path) {
        Ok(bytes) => match cache::decode(&bytes, key, settings) {
            Ok((sp, _)) => return Ok((sp, Origin::Cache)),
            Err(e) => format!("{}: {e}", path.display()),
        },
        Err(e) => format!("{}: {e}", path.display()),
    };
    let sp = precompute(scene, object, settings, None, progress)?;
    let bytes = cache::encode(&sp, key, storage);
    cache::write(&path, &bytes)?;
    // What the renderer uses is what a later run reads back (half floats included).
    let (sp, _) = cache::decode(&bytes, key, settings)
        .map_err(|e| Error::Output { path: path.clone(), message: format!("cache does not read back: {e}") })?;
    Ok((sp, Origin::Built(reason)))
}

/// The caustic radiance (W/(m² sr)) the camera of `scene` sees on diffuse surfaces, from the
/// caustic spheres `spheres` (object index, table) under every directional light of the scene:
/// per pixel `ss × ss` camera rays, first hit by this module's exact ray casting; per
/// receiver point, per light, per caustic object `albedo/π · E ⊙ C · cos`, where the caustic
/// reaches the point only if the segment from the object's sphere centre to it meets no other
/// object (what the paper's caustic cube map decides by depth comparison). The CPU evaluation
/// of the technique (tests, measurements).
pub fn render_caustic(
    scene: &Scene,
    spheres: &[(usize, &CausticSpheres)],
    layout: &DirectionLayout,
    blend: caustics::caustic_spheres::Blend,
    ss: u32,
) -> caustics::image_io::Image {
    let identity = vec![glam::Affine3A::IDENTITY; spheres.len()];
    render_caustic_moved(scene, spheres, &identity, layout, blend, ss)
}

/// The caustic radiance of caustic object `object` under the scene's directional lights with
/// the object's caustic irradiance factor given by `factor(p, n, l)` (object frame = world,
/// W/m² per W/m²): [`render_caustic`] for one unmoved object with any evaluation of the
/// spheres (measurements of warps and blends).
pub fn render_caustic_with(
    scene: &Scene,
    object: usize,
    factor: &(dyn Fn(Vec3, Vec3, Vec3) -> Vec3 + Sync),
    ss: u32,
) -> caustics::image_io::Image {
    let accel = Accel::new(scene);
    let mut s = scene.clone();
    s.objects.remove(object);
    let occ = Accel::new(&s);
    let (lo, hi) = scene.objects[object].shape.bounds();
    let c = (lo + hi) * 0.5;
    diffuse_image(scene, &accel, ss, |p, n| {
        let to = p - c;
        let dist = to.length();
        if dist <= 0.0 || occ.occluded(c, to / dist, dist * (1.0 - 1e-4)) {
            return Vec3::ZERO;
        }
        let mut e = Vec3::ZERO;
        for light in &scene.lights {
            if let caustics::scene::Light::Directional { direction, irradiance } = light {
                e += *irradiance * factor(p, n, direction.normalize());
            }
        }
        e
    })
}

/// [`render_caustic`] with the caustic objects moved: `scene` holds them where they are now,
/// `moves[i]` is how `spheres[i]`'s object moved from the pose its table was made in (the
/// lookup is in the object's frame, as the renderer's).
pub fn render_caustic_moved(
    scene: &Scene,
    spheres: &[(usize, &CausticSpheres)],
    moves: &[glam::Affine3A],
    layout: &DirectionLayout,
    blend: caustics::caustic_spheres::Blend,
    ss: u32,
) -> caustics::image_io::Image {
    let accel = Accel::new(scene);
    // Per caustic object, the scene without it: the occlusion of its caustic.
    let others: Vec<Accel> = spheres
        .iter()
        .map(|(oi, _)| {
            let mut s = scene.clone();
            s.objects.remove(*oi);
            Accel::new(&s)
        })
        .collect();
    diffuse_image(scene, &accel, ss, |p, n| {
        let mut e = Vec3::ZERO;
        for (((_, sp), occ), mv) in spheres.iter().zip(&others).zip(moves) {
            let inv = mv.inverse();
            let rot = glam::Mat3::from(inv.matrix3);
            let (p_obj, n_obj) = (inv.transform_point3(p), (rot * n).normalize());
            let c = mv.transform_point3(sp.geometry.center);
            let to = p - c;
            let dist = to.length();
            if dist <= 0.0 || occ.occluded(c, to / dist, dist * (1.0 - 1e-4)) {
                continue;
            }
            for light in &scene.lights {
                if let caustics::scene::Light::Directional { direction, irradiance } = light {
                    let l = (rot * *direction).normalize();
                    // A table of one direction is that direction rotated onto any light.
                    let f = if sp.layout_dirs.len() == 1 {
                        sp.irradiance_of(0, p_obj, n_obj, l)
                    } else {
                        sp.irradiance(p_obj, n_obj, l, layout, blend)
                    };
                    e += *irradiance * f;
                }
            }
        }
        e
    })
}

/// The radiance `albedo/π · E` the camera of `scene` sees on diffuse surfaces, `E =
/// irradiance(p, n)` at each first hit (`n` faces the camera): per pixel `ss × ss` camera rays,
/// first hit by `accel`. The camera side shared by the CPU evaluations above.
fn diffuse_image(
    scene: &Scene,
    accel: &Accel,
    ss: u32,
    irradiance: impl Fn(Vec3, Vec3) -> Vec3 + Sync,
) -> caustics::image_io::Image {
    let cam = &scene.camera;
    let (w, h) = (cam.width, cam.height);
    let pixels: Vec<[f32; 3]> = (0..w * h)
        .into_par_iter()
        .map(|pix| {
            let (px, py) = (pix % w, pix / w);
            let mut sum = Vec3::ZERO;
            for sy in 0..ss {
                for sx in 0..ss {
                    let x = px as f32 + (sx as f32 + 0.5) / ss as f32;
                    let y = py as f32 + (sy as f32 + 0.5) / ss as f32;
                    let d = cam.ray_dir(x, y);
                    let Some(hit) = accel.intersect(cam.position, d, f32::INFINITY) else { continue };
                    let Material::Diffuse { albedo } = scene.materials[scene.objects[hit.object as usize].material]
                    else {
                        continue;
                    };
                    let n = if d.dot(hit.ng) < 0.0 { hit.ns } else { -hit.ns };
                    let e = irradiance(hit.p, n);
                    sum += albedo * e / PI;
                }
            }
            (sum / (ss * ss) as f32).to_array()
        })
        .collect();
    caustics::image_io::Image { width: w, height: h, pixels }
}
