//! Photon beams: the reference's caustic light scattered in the medium and seen through a
//! specular chain from the camera (light → specular → medium → specular → camera, L S+ M S+ E).
//!
//! The photon tracer connects every medium scattering point to the camera with a shadow ray
//! (`Tracer::connect_camera_medium`), which glass stops: a volume caustic seen through or
//! reflected in glass has no such connection (the delta interface cannot be hit by a
//! connection). These paths are rendered here the other way round: the caustic photons' flights
//! through the medium are kept as *photon beams* (each flight after the photon's first specular
//! interaction, from where it enters the medium's box to where it leaves it or meets a surface,
//! with the flux it carries there), and a camera path that reaches the medium through specular
//! surfaces only gathers the beams its flight passes near, with the beam × beam estimate of
//! Jarosz, Nowrouzezahrai, Sadeghi and Jensen (2011, "A comprehensive theory of volumetric
//! radiance estimation using photon points and beams", the 1D blur):
//!
//! `L = Σ_beams k_r(u) σs(x) f(θ) Φ T_beam(v) T_ray(w) / sin θ`
//!
//! where `u` is the distance between the two lines, `x` the beam's point nearest the ray, `v` and
//! `w` the distances of the closest points along the beam and the ray, `θ` the angle between
//! them and `k_r` a 1D kernel of radius `r` (Epanechnikov, integrating to 1). It is consistent
//! (exact as `r` → 0 and the beams grow in number), not unbiased: the kernel blurs the volume
//! caustic by `r` across the ray, a fraction of a pixel by default ([`auto_radius`]). Both
//! ends of the estimate are on segments that see each other (the beam stops at its first
//! surface, the ray at its first surface), so no shadow ray is needed.
//!
//! The split with the photon tracer's camera connections stays exact: those connect points the
//! camera sees directly, the beams are gathered only by camera paths with at least one
//! specular vertex and no diffuse or medium vertex before the flight (`Tracer::trace_camera`).
//! With multiple scattering the camera side gathers only on such flights (light scattered
//! again after a camera-side scattering is left out, as the GPU leaves it out).
//!
//! Why by hand: no crate of the Rust ecosystem gathers photon beams; the beams' pieces are
//! indexed with `obvhs` (the BVH crate the reference's triangle BVH is built with).

use super::medium::Media;
use super::sampling::PathRng;
use glam::{Vec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use obvhs::ray::Ray;

/// One photon's flight through the medium: from `o` (in the medium's box) along unit `d` for
/// `len`, carrying `flux` (W) at `o`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhotonBeam {
    pub o: Vec3,
    pub d: Vec3,
    pub len: f32,
    pub flux: Vec3,
    /// Whether the rendering keeps its light (`ReferenceSettings::diffuse_orders`); a beam
    /// outside the kept orders is indexed and met as the others, its light left out: the
    /// gathers draw the same random numbers in every mode.
    pub kept: bool,
}

/// A length of a beam, indexed by its box grown by the kernel's radius; a crossing is counted
/// by the piece whose range holds the beam's closest point, so each beam once.
#[derive(Clone, Copy, Debug)]
struct Piece {
    beam: u32,
    v0: f32,
    v1: f32,
    aabb: Aabb,
}

impl obvhs::Boundable for Piece {
    fn aabb(&self) -> Aabb {
        self.aabb
    }
}

/// Most pieces a beam is cut into (shorter boxes for the BVH).
const MAX_PIECES: usize = 16;

/// The smallest sin θ the estimate divides by: rays within about half a degree of a beam's
/// direction are weighted as if at that angle (the estimate's 1/sin θ has an infinite variance
/// at parallel lines; the bias is confined to those rays).
const MIN_SIN: f32 = 0.01;

/// The photon beams of a rendering, indexed for gathering.
pub struct PhotonBeams {
    beams: Vec<PhotonBeam>,
    pieces: Vec<Piece>,
    bvh: Option<Bvh2>,
    radius: f32,
}

/// The default kernel radius (m): half the angle one pixel subtends, times the camera's distance
/// to the centre of `focus` (the specular objects' bounding sphere): the blur of half a pixel
/// where the specular objects are.
pub fn auto_radius(camera: &caustics::scene::Camera, focus: Vec3) -> f32 {
    let pixel_angle = 2.0 * (camera.fov_y_deg.to_radians() * 0.5).tan() / camera.height.max(1) as f32;
    (0.5 * pixel_angle * (focus - camera.position).length()).max(1e-6)
}

impl PhotonBeams {
    /// Index `beams` for gathering with kernel radius `radius` (m, > 0); `piece_len` (m) is the
    /// length of beam one box of the index covers at most.
    pub fn new(beams: Vec<PhotonBeam>, radius: f32, piece_len: f32) -> PhotonBeams {
        let mut pieces = Vec::new();
        let grow = Vec3A::splat(radius);
        for (i, b) in beams.iter().enumerate() {
            if b.len.is_nan() || b.len <= 0.0 || b.flux.max_element() <= 0.0 {
                continue;
            }
            let k = ((b.len / piece_len.max(1e-6)).ceil() as usize).clamp(1, MAX_PIECES);
            for j in 0..k {
                let (v0, v1) = (b.len * j as f32 / k as f32, b.len * (j + 1) as f32 / k as f32);
                let (a, c) = (Vec3A::from(b.o + b.d * v0), Vec3A::from(b.o + b.d * v1));
                let aabb = Aabb::new(a.min(c) - grow, a.max(c) + grow);
                // The last piece reaches past the beam's end (floating point): the closest
                // point is checked against the beam's length too.
                let v1 = if j + 1 == k { f32::INFINITY } else { v1 };
                pieces.push(Piece { beam: i as u32, v0: if j == 0 { f32::NEG_INFINITY } else { v0 }, v1, aabb });
            }
        }
        let bvh = (!pieces.is_empty()).then(|| {
            let params = obvhs::BvhBuildParams { pre_split: false, ..obvhs::BvhBuildParams::fast_build() };
            let mut build_time = std::time::Duration::ZERO;
            let bvh = obvhs::bvh2::builder::build_bvh2(&pieces, params, &mut build_time);
            // Store the pieces in the tree's order (no indirection when gathering).
            pieces = bvh.primitive_indices.iter().map(|&i| pieces[i as usize]).collect();
            bvh
        });
        PhotonBeams { beams, pieces, bvh, radius }
    }

    /// The beams (in the order they were traced).
    pub fn beams(&self) -> &[PhotonBeam] {
        &self.beams
    }

    pub fn radius(&self) -> f32 {
        self.radius
    }

    /// Radiance (W/(m² sr)) the beams scatter toward the ray's origin along its segment
    /// `o + w d`, 0 ≤ w ≤ `t_max` (unit `d`, outside dielectrics), attenuated along both the
    /// beam and the ray: the estimate of the module documentation. Returns (radiance, beams
    /// counted).
    pub fn gather(&self, m: &Media, o: Vec3, d: Vec3, t_max: f32, rng: &mut PathRng) -> (Vec3, u32) {
        let Some(bvh) = &self.bvh else { return (Vec3::ZERO, 0) };
        let r = self.radius;
        let mut sum = Vec3::ZERO;
        let mut count = 0;
        let ray = Ray::new(o.into(), d.into(), 0.0, t_max.min(1e30));
        bvh.ray_traverse_anyhit(ray, |_, id| {
            let p = &self.pieces[id];
            let b = &self.beams[p.beam as usize];
            let n = d.cross(b.d);
            let s2 = n.length_squared();
            let sin = s2.sqrt();
            if sin < 1e-6 {
                return; // parallel: no closest point (the clamp below covers nearly parallel)
            }
            let ob = b.o - o;
            let u = ob.dot(n) / sin;
            if u.abs() >= r {
                return;
            }
            // Closest points: o + w d and b.o + v b.d.
            let w = ob.cross(b.d).dot(n) / s2;
            let v = ob.cross(d).dot(n) / s2;
            if !(w >= 0.0 && w <= t_max && v >= p.v0 && v < p.v1 && v >= 0.0 && v <= b.len) {
                return;
            }
            let x = b.o + b.d * v;
            let q = u / r;
            let k = 0.75 / r * (1.0 - q * q);
            let sigma_s = m.sigma_s * m.density(x);
            let t_beam = m.transmittance(b.o, b.d, v, rng);
            let t_ray = m.transmittance(o, d, w, rng);
            if b.kept {
                sum += b.flux * sigma_s * t_beam * t_ray * (m.phase(b.d, -d) * k / sin.max(MIN_SIN));
            }
            count += 1;
        });
        (sum, count)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use caustics::scene::{Medium, Phase};

    fn fog(sigma_s: f32, sigma_a: f32) -> Media {
        Media::new(&Medium {
            sigma_s: Vec3::splat(sigma_s),
            sigma_a: Vec3::splat(sigma_a),
            phase: Phase::Isotropic,
            bounds_min: Vec3::splat(-10.0),
            bounds_max: Vec3::splat(10.0),
            density: None,
        })
    }

    /// A bundle of parallel beams of total flux Φ spread uniformly over a square of side `a`
    /// crossing a ray: the ray sees the flux density Φ/a² over the path length through the
    /// bundle (a / sin θ), radiance σs f Φ / (a sin θ) without attenuation, whatever the radius;
    /// with it, the mean of T_beam T_ray over that path.
    #[test]
    fn a_bundle_of_beams_gives_the_radiance_of_its_flux_density() {
        let m = fog(0.2, 0.1);
        let (a, n) = (0.5f32, 200usize);
        let phi = 3.0f32;
        let mut beams = Vec::new();
        for i in 0..n {
            for j in 0..n {
                // The bundle along +z from z = -2, spread over x, y ∈ [-a/2, a/2].
                let x = ((i as f32 + 0.5) / n as f32 - 0.5) * a;
                let y = ((j as f32 + 0.5) / n as f32 - 0.5) * a;
                beams.push(PhotonBeam {
                    o: Vec3::new(x, y, -2.0),
                    d: Vec3::Z,
                    len: 4.0,
                    flux: Vec3::splat(phi / (n * n) as f32),
                    kept: true,
                });
            }
        }
        let unattenuated = 0.2 * 0.25 / std::f32::consts::PI * phi / a;
        // Rays from (-3, y, z0) along (1, 0, c)/|.|: at x they are at w = (x + 3)|(1, 0, c)| and
        // at the beam's v = z0 + c (x + 3) + 2.
        let attenuation = |z0: f32, c: f32| {
            let k = 1000;
            let len = (1.0 + c * c).sqrt();
            (0..k)
                .map(|i| {
                    let x = ((i as f32 + 0.5) / k as f32 - 0.5) * a;
                    (-0.3 * ((x + 3.0) * len + z0 + c * (x + 3.0) + 2.0)).exp()
                })
                .sum::<f32>()
                / k as f32
        };
        for radius in [0.01f32, 0.05] {
            let pb = PhotonBeams::new(beams.clone(), radius, 0.5);
            let mut rng = PathRng::new(1);
            for (z0, c) in [(0.3f32, 0.0f32), (-2.7, 1.0)] {
                let d = Vec3::new(1.0, 0.0, c).normalize();
                let k = 64;
                let got = (0..k)
                    .map(|t| {
                        let y = ((t as f32 + 0.5) / k as f32 - 0.5) * a * 0.8;
                        pb.gather(&m, Vec3::new(-3.0, y, z0), d, 8.0, &mut rng).0.x
                    })
                    .sum::<f32>()
                    / k as f32;
                let sin = 1.0 / (1.0 + c * c).sqrt();
                let expect = unattenuated / sin * attenuation(z0, c);
                assert!((got / expect - 1.0).abs() < 0.01, "radius {radius}, slope {c}: {got} vs {expect}");
            }
            // A ray that stops before the bundle sees nothing of it.
            let (l, count) = pb.gather(&m, Vec3::new(-3.0, 0.0, 0.3), Vec3::X, 2.0, &mut rng);
            assert_eq!((l, count), (Vec3::ZERO, 0));
        }
    }

    #[test]
    fn the_medium_attenuates_along_the_beam_and_the_ray() {
        let m = fog(0.2, 0.3);
        let b = PhotonBeam { o: Vec3::new(0.0, 0.0, -2.0), d: Vec3::Z, len: 4.0, flux: Vec3::ONE, kept: true };
        let pb = PhotonBeams::new(vec![b], 0.1, 1.0);
        let mut rng = PathRng::new(1);
        // Straight through the beam's line at v = 2 (z = 0), w = 3.
        let (l, c) = pb.gather(&m, Vec3::new(-3.0, 0.0, 0.0), Vec3::X, 6.0, &mut rng);
        assert_eq!(c, 1);
        let k = 0.75 / 0.1;
        let expect = 0.2 * 0.25 / std::f32::consts::PI * k * (-0.5f32 * 2.0).exp() * (-0.5f32 * 3.0).exp();
        assert!((l.x / expect - 1.0).abs() < 1e-4, "{} vs {expect}", l.x);
    }
}
