//! The two tracers: photons from the lights (caustic light) and paths from the camera
//! (everything else).
//!
//! Split of the light transport, as in the references: a photon whose first surface after the
//! light is specular is caustic light; the camera paths add up direct lighting (next-event
//! estimation to the delta lights, with shadow rays that stop at any surface, glass included)
//! at every diffuse vertex, which is exactly the light whose first bounce is diffuse. So the
//! two parts never overlap and together are the whole image. Caustics seen through a specular
//! chain from the camera, which no light-tracing connection reaches (glass stops it), are
//! gathered by the camera paths: on surfaces (specular → diffuse → specular → camera) from the
//! deposits of [`super::view_photons`], in a medium (specular → medium → specular → camera) from
//! the photon beams of [`super::photon_beams`]. (The Mitsuba references lack the first: their
//! specular mask marks those pixels.)
//! [`CausticPaths`] restricts the photons' camera connections to one class of paths (the
//! GPU's: the first diffuse hit only) or to the rest.
//! [`DiffuseOrders`] keeps chosen diffuse bounce orders (the number of diffuse vertices on a path)
//! on both sides.
//!
//! The environment light follows the same split: photons from it (`emit`) whose first surface
//! is specular are caustic light; the camera paths see it directly or through specular
//! surfaces before any diffuse vertex, and sample it at diffuse vertices (`trace_camera`).
//!
//! A participating medium ([`super::medium`]) follows the split with "first interaction"
//! (surface or medium scattering) for "first surface": a photon reaches its first surface
//! unscattered (its flux times the transmittance; light that scatters first is the camera
//! paths'), and after its first specular interaction it scatters in the medium and is
//! connected to the camera at every scattering point (the volume caustic). Camera paths
//! sample scattering points too and estimate the light's direct contribution there with the
//! phase function and a shadow ray (light shafts, multiple scattering). Shadow rays and camera
//! connections are attenuated by the transmittance. With `single_scattering`, every path
//! scatters in the medium at most once and goes on after it with the medium only attenuating:
//! light a surface reflects into the medium (light → floor → fog → camera) and light the medium
//! scatters onto a surface (light → fog → floor → camera) both count, caustic or not.

use super::geometry::{Accel, Hit, spawn};
use super::medium::{Flight, Media};
use super::optics::{fresnel_conductor, fresnel_dielectric, reflect, refract};
use super::photon_beams::{PhotonBeam, PhotonBeams};
use super::sampling::{PathRng, cosine_hemisphere};
use super::view_photons::ViewPhotons;
use caustics::lightspace::LightView;
use caustics::scene::{Camera, Light, Material, Scene};
use glam::Vec3;
use std::f32::consts::PI;

/// Pinhole projection of world points to pixels.
#[derive(Clone, Debug)]
pub struct CamProj {
    pub pos: Vec3,
    fwd: Vec3,
    right: Vec3,
    up: Vec3,
    tan_x: f32,
    tan_y: f32,
    w: u32,
    h: u32,
    /// Area of one pixel on the image plane at distance 1.
    pix_area: f32,
}

impl CamProj {
    pub fn new(c: &Camera) -> Self {
        let tan_y = (c.fov_y_deg.to_radians() * 0.5).tan();
        let tan_x = tan_y * c.aspect();
        CamProj {
            pos: c.position,
            fwd: c.forward(),
            right: c.right(),
            up: c.true_up(),
            tan_x,
            tan_y,
            w: c.width,
            h: c.height,
            pix_area: (2.0 * tan_x / c.width as f32) * (2.0 * tan_y / c.height as f32),
        }
    }

    /// Pixel index and cos θ (to the optical axis) of the ray from the camera along unit `d`.
    #[inline]
    pub fn project(&self, d: Vec3) -> Option<(u32, f32)> {
        let z = d.dot(self.fwd);
        if z <= 1e-6 {
            return None;
        }
        let sx = d.dot(self.right) / z / self.tan_x;
        let sy = d.dot(self.up) / z / self.tan_y;
        let x = (sx + 1.0) * 0.5 * self.w as f32;
        let y = (1.0 - sy) * 0.5 * self.h as f32;
        if !(x >= 0.0 && y >= 0.0 && x < self.w as f32 && y < self.h as f32) {
            return None;
        }
        let (xi, yi) = ((x as u32).min(self.w - 1), (y as u32).min(self.h - 1));
        Some((yi * self.w + xi, z))
    }
}

/// A caustic photon's first diffuse hit (for tests and tools).
#[derive(Clone, Copy, Debug)]
pub struct Deposit {
    pub position: Vec3,
    /// Geometric normal, facing the side the photon came from.
    pub normal: Vec3,
    /// Direction the photon travelled.
    pub dir: Vec3,
    /// Flux (W) the photon carries.
    pub flux: Vec3,
    /// Specular interactions before it.
    pub specular_bounces: u32,
    pub object: u32,
}

/// Which light-traced (caustic) paths reach the camera image: the classes of paths a caustic
/// photon (first surface specular) makes before it is connected to the camera.
///
/// The GPU renders caustic light as its caustic maps hold it: the irradiance at each photon's
/// first diffuse hit, shaded where the camera sees that surface directly (`shade_receivers`);
/// its caustic-only image has no surface caustic where the camera sees a specular surface first
/// (`composite.wgsl`), as this reference's has none (a camera connection stops at glass). So
/// [`CausticPaths::FirstDiffuse`] is its like-for-like class, L S+ D E. The rest, which the
/// GPU's caustic maps do not hold: light that leaves the first diffuse surface again (diffuse
/// interreflection, floor → glass → floor, ...: L S+ D (S|D)* D E) and, in a medium, light
/// scattered in the medium after the specular chain (volume caustics, which the GPU renders
/// with beams, also seen through glass: the photon beams here; and surfaces lit by
/// them). `All` = `FirstDiffuse` + `Rest`, photon by photon: the photons take the same random
/// choices in every mode (a connection outside the class is made and dropped).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CausticPaths {
    /// Every caustic path (the default): a photon is connected to the camera at every
    /// diffuse hit and every medium scattering point after its first specular interaction.
    #[default]
    All,
    /// Only L S+ D E: the connection at the photon's first diffuse hit, reached through
    /// specular interactions alone (no medium scattering before it); the photon stops there.
    FirstDiffuse,
    /// Every connection that `FirstDiffuse` leaves out.
    Rest,
}

impl CausticPaths {
    /// Parse `all`, `first-diffuse` or `rest`.
    pub fn parse(s: &str) -> Option<CausticPaths> {
        match s {
            "all" => Some(CausticPaths::All),
            "first-diffuse" => Some(CausticPaths::FirstDiffuse),
            "rest" => Some(CausticPaths::Rest),
            _ => None,
        }
    }

    /// Whether a connection to the camera belongs to the class; `first` says whether it is
    /// the one at the photon's first diffuse hit through a purely specular chain.
    #[inline]
    pub(crate) fn keeps(self, first: bool) -> bool {
        match self {
            CausticPaths::All => true,
            CausticPaths::FirstDiffuse => first,
            CausticPaths::Rest => !first,
        }
    }
}

/// Which diffuse bounce orders of the light reach the camera images
/// ([`ReferenceSettings::diffuse_orders`](super::ReferenceSettings::diffuse_orders)).
///
/// The order of a path's contribution is the number of diffuse surface vertices on the whole
/// path from the light to the camera; specular interactions (glass, water, mirrors) and medium
/// scattering do not count. So order 0 is light that reaches the camera without a diffuse
/// vertex (the environment seen directly or through specular surfaces, light scattered in the
/// medium: shafts, volume caustics); order 1 is direct light and the caustics on their first
/// diffuse surface (what the GPU renders, with order 0); order 2 is light that left one diffuse
/// surface before the one the camera sees (diffuse interreflection, a caustic lit by a caustic);
/// and so on. The estimators count it the same way on both sides: next-event estimation at a
/// camera path's k-th diffuse vertex (lights and environment) is order k, the environment met by
/// the cosine-sampled bounce from that vertex order k too, a medium scattering point after k
/// diffuse vertices order k; a caustic photon connected to the camera at its j-th diffuse hit is
/// order j, at a medium scattering point after j diffuse hits order j; the deposits the camera
/// gathers through glass at its k-th diffuse vertex order k, the photon beams the order of their
/// photon's diffuse hits.
/// Contributions outside the kept orders are computed and dropped (the random choices are the
/// same in every mode): the image of `all` is the sum of the images of disjoint ranges covering
/// every order, path by path, to float rounding.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DiffuseOrders {
    /// Lowest kept order.
    pub min: u32,
    /// Highest kept order; `None`: no limit.
    pub max: Option<u32>,
}

impl Default for DiffuseOrders {
    fn default() -> Self {
        DiffuseOrders::ALL
    }
}

impl DiffuseOrders {
    /// Every order (the default).
    pub const ALL: DiffuseOrders = DiffuseOrders { min: 0, max: None };

    /// Parse `all`, `N` (that order alone), `A-B` (A to B) or `A-` (A and up).
    pub fn parse(s: &str) -> Option<DiffuseOrders> {
        let s = s.trim();
        if s == "all" {
            return Some(DiffuseOrders::ALL);
        }
        let num = |t: &str| if t.bytes().all(|b| b.is_ascii_digit()) { t.parse::<u32>().ok() } else { None };
        let o = match s.split_once('-') {
            None => {
                let n = num(s)?;
                DiffuseOrders { min: n, max: Some(n) }
            }
            Some((a, "")) => DiffuseOrders { min: num(a)?, max: None },
            Some((a, b)) => DiffuseOrders { min: num(a)?, max: Some(num(b)?) },
        };
        o.is_valid().then_some(o)
    }

    /// Whether `min ≤ max`.
    pub fn is_valid(self) -> bool {
        self.max.is_none_or(|m| self.min <= m)
    }

    /// Whether every order is kept.
    pub fn is_all(self) -> bool {
        self == DiffuseOrders::ALL
    }

    /// Whether contributions of order `k` are kept.
    #[inline]
    pub fn keeps(self, k: u32) -> bool {
        k >= self.min && self.max.is_none_or(|m| k <= m)
    }

    /// Whether every order from `k` up is dropped (a path may stop there).
    #[inline]
    pub(crate) fn none_from(self, k: u32) -> bool {
        self.max.is_some_and(|m| k > m)
    }
}

impl std::fmt::Display for DiffuseOrders {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match (self.min, self.max) {
            (0, None) => write!(f, "all"),
            (a, None) => write!(f, "{a}-"),
            (a, Some(b)) if a == b => write!(f, "{a}"),
            (a, Some(b)) => write!(f, "{a}-{b}"),
        }
    }
}

/// What tracing a batch of photons produces.
#[derive(Default)]
pub struct PhotonOut {
    /// (pixel, radiance contribution).
    pub cam: Vec<(u32, Vec3)>,
    /// (face, texel, irradiance contribution).
    pub map: Vec<(u32, u32, Vec3)>,
    pub deposits: Vec<Deposit>,
    /// The photons' flights through the medium after their first specular interaction
    /// (`PhotonTargets::record_beams`).
    pub beams: Vec<PhotonBeam>,
    pub rays: u64,
}

/// Where photon results go.
pub struct PhotonTargets<'a> {
    pub camera: bool,
    pub map: Option<(&'a LightView, u32)>,
    pub record_deposits: bool,
    /// Keep the photons' flights through the medium as photon beams ([`super::photon_beams`]).
    pub record_beams: bool,
}

pub struct Tracer<'a> {
    pub scene: &'a Scene,
    pub accel: &'a Accel,
    mats: Vec<Material>,
    pub max_depth: u32,
    pub cam: CamProj,
    /// The scene's participating medium, if any.
    pub media: Option<Media>,
    /// Every path (light to camera) scatters in the medium at most once.
    pub single_scattering: bool,
    /// Which caustic paths are connected to the camera.
    pub caustic_paths: CausticPaths,
    /// Which diffuse bounce orders reach the camera images.
    pub diffuse_orders: DiffuseOrders,
    /// Caustic photons reflect partially at dielectric interfaces (with probability F); off,
    /// they transmit with weight 1 − F (`ReferenceSettings::partial_reflections`).
    pub partial_reflections: bool,
    /// The caustic photons' beams, gathered by camera paths that reach the medium through
    /// specular surfaces (light → specular → medium → specular → camera); `None`: those paths
    /// are not rendered.
    pub beams: Option<PhotonBeams>,
    /// The caustic photons' first diffuse hits, gathered by camera paths that reach a diffuse
    /// surface through specular surfaces (light → specular → surface → specular → camera);
    /// `None`: those paths are not rendered.
    pub view_photons: Option<ViewPhotons>,
    /// The beams and the deposits also give the caustic light the camera sees directly, and
    /// the photons' connections from medium scattering points and first diffuse hits are
    /// dropped (for the tests of the two estimates against light tracing).
    pub gather_direct: bool,
}

impl<'a> Tracer<'a> {
    pub fn new(scene: &'a Scene, accel: &'a Accel, max_depth: u32) -> Self {
        let mats = scene.objects.iter().map(|o| scene.materials[o.material]).collect();
        Tracer {
            scene,
            accel,
            mats,
            max_depth,
            cam: CamProj::new(&scene.camera),
            media: scene.medium.as_ref().map(Media::new),
            single_scattering: false,
            caustic_paths: CausticPaths::All,
            diffuse_orders: DiffuseOrders::ALL,
            partial_reflections: true,
            beams: None,
            view_photons: None,
            gather_direct: false,
        }
    }

    /// Whether the ray segment that ends at `hit` (or escapes) lies inside a dielectric: it
    /// does exactly when it ends on a dielectric's back face (closed, non-nested dielectrics).
    #[inline]
    fn in_dielectric(&self, d: Vec3, hit: Option<&Hit>) -> bool {
        hit.is_some_and(|h| matches!(self.mats[h.object as usize], Material::Dielectric { .. }) && d.dot(h.ng) >= 0.0)
    }

    /// Transmittance of the medium (if any) along the segment [0, t] of a ray outside
    /// dielectrics.
    #[inline]
    fn transmittance(&self, o: Vec3, d: Vec3, t: f32, rng: &mut PathRng) -> Vec3 {
        self.media.as_ref().map_or(Vec3::ONE, |m| m.transmittance(o, d, t, rng))
    }

    /// Trace one photon with flux `flux` (W) from `o` along `d`.
    pub fn trace_photon(
        &self,
        o: Vec3,
        d: Vec3,
        flux: Vec3,
        rng: &mut PathRng,
        t: &PhotonTargets,
        out: &mut PhotonOut,
    ) {
        let (mut o, mut d, mut flux) = (o, d, flux);
        let mut spec = 0u32;
        let mut diffuse_seen = 0u32;
        // Whether the photon has scattered in the medium (its path is not L S+ D then).
        let mut scattered = false;
        let paths = self.caustic_paths;
        let orders = self.diffuse_orders;
        // Whether the photon may stop once no later connection can be kept (photon beams keep
        // every flight, marked with whether its order is kept: the same beams in every mode).
        let may_stop = !t.record_beams;
        // Absorption coefficient (1/m) of the dielectric the photon travels in (zero: clear),
        // and where its segment starts (the surface point, not the offset origin).
        let mut sigma = Vec3::ZERO;
        let mut from = o;
        for depth in 0..self.max_depth {
            out.rays += 1;
            let hit = self.accel.intersect(o, d, f32::INFINITY);
            if let Some(m) = &self.media
                && !self.in_dielectric(d, hit.as_ref())
            {
                let t_hit = hit.as_ref().map_or(f32::INFINITY, |h| h.t);
                if depth == 0 || (scattered && self.single_scattering) {
                    // Before the first surface: caustic light reaches it unscattered. With
                    // single scattering, after its one scattering event: it only attenuates.
                    flux *= m.transmittance(o, d, t_hit, rng);
                } else {
                    if t.record_beams
                        && let Some((t0, t1)) = m.clip(o, d, t_hit)
                    {
                        // The camera gathers the beam through specular surfaces alone: its
                        // order is the photon's diffuse hits so far.
                        let kept = orders.keeps(diffuse_seen);
                        out.beams.push(PhotonBeam { o: o + d * t0, d, len: t1 - t0, flux, kept });
                    }
                    match m.sample(o, d, t_hit, rng) {
                        Flight::Pass { weight } => flux *= weight,
                        Flight::Scatter { t: ts, weight } => {
                            // In-medium caustic light (a volume caustic).
                            flux *= weight * absorbed(sigma, ts);
                            let x = o + d * ts;
                            from = x;
                            if t.camera {
                                let n0 = out.cam.len();
                                self.connect_camera_medium(m, x, d, flux, rng, out);
                                if !paths.keeps(false) || self.gather_direct || !orders.keeps(diffuse_seen) {
                                    out.cam.truncate(n0);
                                }
                            }
                            scattered = true;
                            if depth + 1 >= self.max_depth {
                                break;
                            }
                            let q = weight.max_element().min(1.0);
                            if q <= 0.0 || rng.next_f32() >= q {
                                break;
                            }
                            flux /= q;
                            d = m.sample_phase(d, rng);
                            o = x;
                            continue;
                        }
                    }
                }
            }
            let Some(h) = hit else { break };
            flux *= absorbed(sigma, h.p.distance(from));
            from = h.p;
            let front = d.dot(h.ng) < 0.0;
            let (ng, ns) = if front { (h.ng, h.ns) } else { (-h.ng, -h.ns) };
            match self.mats[h.object as usize] {
                Material::Diffuse { albedo } => {
                    if depth == 0 {
                        break; // direct light: not caustic
                    }
                    if diffuse_seen == 0 {
                        if t.record_deposits {
                            out.deposits.push(Deposit {
                                position: h.p,
                                normal: ng,
                                dir: d,
                                flux,
                                specular_bounces: spec,
                                object: h.object,
                            });
                        }
                        if let Some((view, size)) = t.map
                            && let Some((f, x, y)) = view.project(h.p, size)
                        {
                            let (xi, yi) = ((x as u32).min(size - 1), (y as u32).min(size - 1));
                            let area = view.texel_area(f, h.p, ng, size);
                            if area > 0.0 && area.is_finite() {
                                out.map.push((f as u32, yi * size + xi, flux / area));
                            }
                        }
                    }
                    let first = diffuse_seen == 0 && !scattered;
                    if t.camera {
                        // Made and, outside the class, dropped: the photon's random numbers
                        // are the same in every mode.
                        let n0 = out.cam.len();
                        self.connect_camera(DiffusePoint { p: h.p, ng, ns, albedo }, flux, rng, out);
                        if !paths.keeps(first)
                            || (self.gather_direct && diffuse_seen == 0)
                            || !orders.keeps(diffuse_seen + 1)
                        {
                            out.cam.truncate(n0);
                        }
                    }
                    diffuse_seen += 1;
                    if depth + 1 >= self.max_depth {
                        break;
                    }
                    // Later connections: order `diffuse_seen` in the medium, one more on surfaces.
                    if may_stop && orders.none_from(diffuse_seen + u32::from(self.media.is_none())) {
                        break;
                    }
                    if paths == CausticPaths::FirstDiffuse || !(t.camera || t.record_beams) {
                        // Nothing later is kept (the maps and deposits take the first diffuse
                        // hit only).
                        break;
                    }
                    let q = albedo.max_element().min(1.0);
                    if q <= 0.0 || rng.next_f32() >= q {
                        break;
                    }
                    flux *= albedo / q;
                    d = cosine_hemisphere(rng.next_2d(), ng);
                    o = spawn(h.p, h.ng, d);
                    continue;
                }
                m => {
                    let Some((nd, w)) = scatter_specular(m, d, ng, ns, front, rng, self.partial_reflections) else {
                        break;
                    };
                    spec += 1;
                    flux *= w;
                    sigma = medium_after(m, sigma, nd, h.ng);
                    d = nd;
                    o = spawn(h.p, h.ng, d);
                }
            }
            if flux.max_element() <= 0.0 {
                break;
            }
        }
    }

    /// Light tracing: splat the radiance that the diffuse point `at` sends to the camera.
    fn connect_camera(&self, at: DiffusePoint, flux: Vec3, rng: &mut PathRng, out: &mut PhotonOut) {
        let DiffusePoint { p, ng, ns, albedo } = at;
        let to = self.cam.pos - p;
        let dist2 = to.length_squared();
        let dist = dist2.sqrt();
        let dir = to / dist;
        if dir.dot(ng) <= 0.0 {
            return; // camera on the other side: a Lambertian reflector sends nothing there
        }
        let cos_x = dir.dot(ns).max(0.0);
        let Some((pix, cos_c)) = self.cam.project(-dir) else { return };
        out.rays += 1;
        if self.accel.occluded(spawn(p, ng, dir), dir, dist * (1.0 - 1e-5)) {
            return;
        }
        let g = cos_x / (dist2 * self.cam.pix_area * cos_c * cos_c * cos_c);
        let mut v = flux * albedo * (g / PI);
        if self.media.is_some() {
            v *= self.transmittance(p, dir, dist, rng);
        }
        out.cam.push((pix, v));
    }

    /// Light tracing from a medium scattering point `x` (photon travelling along `wi` with
    /// weighted flux `flux`, the scattering coefficient already in it): splat the radiance it
    /// sends to the camera, `flux · phase · T / (d² · A_pix · cos³ θc)`.
    fn connect_camera_medium(&self, m: &Media, x: Vec3, wi: Vec3, flux: Vec3, rng: &mut PathRng, out: &mut PhotonOut) {
        let to = self.cam.pos - x;
        let dist2 = to.length_squared();
        let dist = dist2.sqrt();
        if dist <= 0.0 {
            return;
        }
        let dir = to / dist;
        let Some((pix, cos_c)) = self.cam.project(-dir) else { return };
        out.rays += 1;
        if self.accel.occluded(x, dir, dist * (1.0 - 1e-5)) {
            return;
        }
        let g = m.phase(wi, dir) / (dist2 * self.cam.pix_area * cos_c * cos_c * cos_c);
        out.cam.push((pix, flux * m.transmittance(x, dir, dist, rng) * g));
    }

    /// Radiance (W/(m² sr) per unit σs, the weight has σs) scattered at the medium point `x`
    /// toward `-wi` straight from the lights, with shadow rays that any surface stops and the
    /// medium attenuates. Returns (radiance, rays).
    fn medium_direct(&self, m: &Media, x: Vec3, wi: Vec3, rng: &mut PathRng) -> (Vec3, u64) {
        let mut l = Vec3::ZERO;
        let mut rays = 0;
        for light in &self.scene.lights {
            let (dir, dist, incident) = match light {
                Light::Spot { position, .. } | Light::Point { position, .. } => {
                    let to = *position - x;
                    let d2 = to.length_squared();
                    let dist = d2.sqrt();
                    if dist <= 0.0 {
                        continue;
                    }
                    let dir = to / dist;
                    (dir, dist, light.intensity_toward(-dir) / d2)
                }
                // From outside the box (vacuum there): the medium attenuates the part inside.
                Light::Directional { direction, irradiance } => (-*direction, f32::INFINITY, *irradiance),
            };
            if incident.max_element() <= 0.0 {
                continue;
            }
            rays += 1;
            if self.accel.occluded(x, dir, if dist.is_finite() { dist * (1.0 - 1e-5) } else { dist }) {
                continue;
            }
            l += incident * m.transmittance(x, dir, dist, rng) * m.phase(wi, dir);
        }
        // The environment: one sample from its distribution (the phase-sampled ray that escapes
        // adds nothing: `trace_camera`), attenuated by the medium on its way out of the box.
        if let Some(env) = self.scene.environment.as_deref()
            && let Some(s) = env.sample(rng.next_2d())
            && s.radiance.max_element() > 0.0
        {
            rays += 1;
            if !self.accel.occluded(x, s.dir, f32::INFINITY) {
                l += s.radiance * m.transmittance(x, s.dir, f32::INFINITY, rng) * (m.phase(wi, s.dir) / s.pdf);
            }
        }
        (l, rays)
    }

    /// Radiance along the camera ray through image point (x, y), without caustic light, and the
    /// caustic light it gathers where it has met specular surfaces alone (at least one), which
    /// the photons' camera connections cannot render: from the photon beams ([`Self::beams`])
    /// along its flights through the medium, from the deposits ([`Self::view_photons`]) at its
    /// first diffuse vertex. Returns (radiance, gathered caustic radiance, rays traced).
    ///
    /// The environment light: a ray that escapes before any diffuse vertex sees it (background,
    /// reflections, refractions); at a diffuse vertex it is sampled by next-event estimation
    /// from its distribution and, by the cosine-sampled bounce when that ray escapes straight
    /// away, combined by multiple importance sampling (power heuristic). A ray that escapes
    /// after specular bounces that follow a diffuse vertex carries environment light whose
    /// first surface is specular: caustic light, which the photons render.
    pub fn trace_camera(&self, x: f32, y: f32, rng: &mut PathRng) -> (Vec3, Vec3, u64) {
        let mut o = self.cam.pos;
        let mut d = self.scene.camera.ray_dir(x, y);
        let mut beta = Vec3::ONE;
        let mut l = Vec3::ZERO;
        let mut rays = 0u64;
        let env = self.scene.environment.as_deref();
        // Diffuse vertices so far: the order of the light sampled at a medium point or met by
        // the bounce from the last one, and one less than that of the next one's.
        let mut diffuse = 0u32;
        let orders = self.diffuse_orders;
        // Density of the cosine sampling that made `d`, when `d` leaves a diffuse vertex.
        let mut bsdf_pdf: Option<f32> = None;
        // Whether the path has scattered in the medium (with single scattering, later flights
        // only attenuate).
        let mut scattered = false;
        // Caustic light from the photon beams and deposits, and whether the path has met
        // specular surfaces only (at least one) so far.
        let mut lc = Vec3::ZERO;
        let mut specular_only = false;
        // Whether the camera sees this path's first diffuse vertex (or medium point) through
        // specular surfaces: then no photon connection reaches any of its vertices (they need
        // the camera in direct view of the photon's last vertex), so the deposits (L S+ D) are
        // gathered at every diffuse vertex, not only the first; next-event estimation adds the
        // light that arrives there directly (L D).
        let mut eye_specular = false;
        let beams = self.beams.as_ref().filter(|_| self.caustic_paths.keeps(false));
        // (the deposits are first diffuse hits: gathered at the k-th diffuse vertex, order k)
        let view_photons = self.view_photons.as_ref().filter(|_| self.caustic_paths.keeps(false));
        // Absorption coefficient (1/m) of the dielectric the ray travels in (zero: clear), and
        // where its segment starts (the surface point, not the offset origin).
        let mut sigma = Vec3::ZERO;
        let mut from = o;
        for depth in 0..self.max_depth {
            rays += 1;
            // Whether this vertex gathers (the tests' `gather_direct`: also the camera's own).
            let gathers = specular_only || (self.gather_direct && depth == 0);
            let hit = self.accel.intersect(o, d, f32::INFINITY);
            if let Some(m) = &self.media
                && !self.in_dielectric(d, hit.as_ref())
            {
                let t_hit = hit.as_ref().map_or(f32::INFINITY, |h| h.t);
                if gathers && let Some(b) = beams {
                    // From a fork: the path's own numbers stay those of a rendering without
                    // beams (heterogeneous media draw for the transmittances).
                    let mut g = rng.fork(0x6265_616d);
                    lc += beta * b.gather(m, o, d, t_hit, &mut g).0;
                }
                let flight = if scattered && self.single_scattering {
                    Flight::Pass { weight: m.transmittance(o, d, t_hit, rng) }
                } else {
                    m.sample(o, d, t_hit, rng)
                };
                match flight {
                    Flight::Pass { weight } => beta *= weight,
                    Flight::Scatter { t, weight } => {
                        beta *= weight * absorbed(sigma, t);
                        let x = o + d * t;
                        from = x;
                        let (ls, r) = self.medium_direct(m, x, d, rng);
                        rays += r;
                        if orders.keeps(diffuse) {
                            l += beta * ls;
                        }
                        scattered = true;
                        specular_only = false;
                        if depth + 1 >= self.max_depth {
                            break;
                        }
                        let q = weight.max_element().min(1.0);
                        if q <= 0.0 || rng.next_f32() >= q {
                            break;
                        }
                        beta /= q;
                        d = m.sample_phase(d, rng);
                        o = x;
                        bsdf_pdf = None;
                        continue;
                    }
                }
            }
            let Some(h) = hit else {
                if let Some(env) = env {
                    // (after a scattering event in the medium the environment was sampled there:
                    // `medium_direct`; this ray, sampled by the phase function, adds nothing)
                    if diffuse == 0 && !scattered {
                        if orders.keeps(0) {
                            l += beta * env.lookup(d);
                        }
                    } else if let Some(pb) = bsdf_pdf
                        && orders.keeps(diffuse)
                    {
                        let pl = env.pdf(d);
                        l += beta * env.lookup(d) * (pb * pb / (pb * pb + pl * pl));
                    }
                }
                break;
            };
            beta *= absorbed(sigma, h.p.distance(from));
            from = h.p;
            let front = d.dot(h.ng) < 0.0;
            let (ng, ns) = if front { (h.ng, h.ns) } else { (-h.ng, -h.ns) };
            match self.mats[h.object as usize] {
                Material::Diffuse { albedo } => {
                    if (gathers || eye_specular)
                        && orders.keeps(diffuse + 1)
                        && let Some(v) = view_photons
                    {
                        lc += beta * albedo / PI * v.irradiance(h.p, ng, h.object);
                    }
                    let last = depth + 1 >= self.max_depth;
                    let (e, r) = self.direct_irradiance(h.p, h.ng, ng, ns, last, rng);
                    rays += r;
                    diffuse += 1;
                    if orders.keeps(diffuse) {
                        l += beta * albedo * e / PI;
                    }
                    specular_only = false;
                    if last {
                        break;
                    }
                    // Later light: order `diffuse` (the environment met by this bounce, the
                    // medium), one more at the next diffuse vertex.
                    let same = self.media.is_some() || self.scene.environment.is_some();
                    if orders.none_from(diffuse + u32::from(!same)) {
                        break;
                    }
                    let q = albedo.max_element().min(1.0);
                    if q <= 0.0 || rng.next_f32() >= q {
                        break;
                    }
                    beta *= albedo / q;
                    d = cosine_hemisphere(rng.next_2d(), ng);
                    bsdf_pdf = Some(d.dot(ng).max(0.0) / PI);
                    o = spawn(h.p, h.ng, d);
                }
                m => {
                    let Some((nd, w)) = scatter_specular(m, d, ng, ns, front, rng, true) else { break };
                    beta *= w;
                    sigma = medium_after(m, sigma, nd, h.ng);
                    specular_only = diffuse == 0 && !scattered;
                    eye_specular |= specular_only;
                    d = nd;
                    bsdf_pdf = None;
                    o = spawn(h.p, h.ng, d);
                    if beta.max_element() <= 0.0 {
                        break;
                    }
                }
            }
        }
        (l, lc, rays)
    }

    /// Irradiance (W/m²) at `p` straight from the lights, on the side of `ng` (shading cosine
    /// with `ns`), with shadow rays. Returns (irradiance, rays). The environment light is
    /// sampled once from its distribution, weighted for multiple importance sampling with the
    /// cosine-sampled bounce of [`Self::trace_camera`], or not weighted at the `last` vertex
    /// (no bounce follows); `rng` is drawn from only then.
    fn direct_irradiance(
        &self,
        p: Vec3,
        ng_raw: Vec3,
        ng: Vec3,
        ns: Vec3,
        last: bool,
        rng: &mut PathRng,
    ) -> (Vec3, u64) {
        let mut e = Vec3::ZERO;
        let mut rays = 0;
        for light in &self.scene.lights {
            let (dir, dist, incident) = match light {
                Light::Spot { position, .. } | Light::Point { position, .. } => {
                    let to = *position - p;
                    let d2 = to.length_squared();
                    let dist = d2.sqrt();
                    let dir = to / dist;
                    (dir, dist * (1.0 - 1e-5), light.intensity_toward(-dir) / d2)
                }
                Light::Directional { direction, irradiance } => (-*direction, f32::INFINITY, *irradiance),
            };
            if dir.dot(ng) <= 0.0 || incident.max_element() <= 0.0 {
                continue;
            }
            let cos = dir.dot(ns).max(0.0);
            rays += 1;
            if self.accel.occluded(spawn(p, ng_raw, dir), dir, dist) {
                continue;
            }
            if self.media.is_some() {
                e += incident * cos * self.transmittance(p, dir, dist, rng);
            } else {
                e += incident * cos;
            }
        }
        if let Some(env) = self.scene.environment.as_deref() {
            let u = rng.next_2d();
            if let Some(s) = env.sample(u)
                && s.dir.dot(ng) > 0.0
                && s.radiance.max_element() > 0.0
            {
                rays += 1;
                if !self.accel.occluded(spawn(p, ng_raw, s.dir), s.dir, f32::INFINITY) {
                    let pb = s.dir.dot(ng) / PI;
                    let w = if last { 1.0 } else { s.pdf * s.pdf / (s.pdf * s.pdf + pb * pb) };
                    let t =
                        if self.media.is_some() { self.transmittance(p, s.dir, f32::INFINITY, rng) } else { Vec3::ONE };
                    e += s.radiance * t * (s.dir.dot(ns).max(0.0) * w / s.pdf);
                }
            }
        }
        (e, rays)
    }
}

/// Beer–Lambert transmittance exp(−σ·s) along a distance `s` in a dielectric with absorption
/// coefficient `sigma` (exactly 1 where `sigma` is zero: clear paths keep their bits).
#[inline]
pub(crate) fn absorbed(sigma: Vec3, s: f32) -> Vec3 {
    if sigma == Vec3::ZERO { Vec3::ONE } else { (-sigma * s).exp() }
}

/// The absorption coefficient of what a ray travels in after leaving specular surface `m` along
/// `nd` (`ng_out` the surface's outward geometric normal), `sigma` before: a dielectric's inside
/// when the ray goes into it (refracted in or reflected inside), clear when it goes out (the
/// `ext_ior` side is taken as clear); mirrors and conductors keep it.
#[inline]
pub(crate) fn medium_after(m: Material, sigma: Vec3, nd: Vec3, ng_out: Vec3) -> Vec3 {
    match m {
        Material::Dielectric { absorption, .. } => {
            if nd.dot(ng_out) < 0.0 {
                absorption
            } else {
                Vec3::ZERO
            }
        }
        _ => sigma,
    }
}

/// Scatter off a specular surface: new direction and throughput weight. `ng`, `ns` face the
/// incoming side; `front` says whether the ray arrived from the side the normal points to
/// (outside, for a dielectric). Dielectrics choose reflection with probability F (unbiased,
/// weight 1); without `partial` they reflect only totally and otherwise transmit with weight
/// 1 − F (the light of the GPU's transmitted branches: `beam_refine`'s branch 0).
#[inline]
pub(crate) fn scatter_specular(
    m: Material,
    d: Vec3,
    ng: Vec3,
    ns: Vec3,
    front: bool,
    rng: &mut PathRng,
    partial: bool,
) -> Option<(Vec3, Vec3)> {
    let reflect_checked = |n: Vec3| {
        let r = reflect(d, n);
        if r.dot(ng) > 0.0 { r } else { reflect(d, ng) }
    };
    match m {
        Material::Mirror { reflectance } => Some((reflect_checked(ns), reflectance)),
        Material::Conductor { eta, k } => {
            let cos_i = (-d.dot(ns)).clamp(0.0, 1.0);
            Some((reflect_checked(ns), fresnel_conductor(cos_i, eta, k)))
        }
        Material::Dielectric { ior, ext_ior, .. } => {
            let eta = if front { ior / ext_ior } else { ext_ior / ior };
            let mut n = ns;
            let mut cos_i = -d.dot(n);
            if cos_i <= 0.0 {
                n = ng;
                cos_i = -d.dot(n);
            }
            let (f, cos_t) = fresnel_dielectric(cos_i, eta);
            if f >= 1.0 || (partial && rng.next_f32() < f) {
                Some((reflect_checked(n), Vec3::ONE))
            } else {
                let w = if partial { Vec3::ONE } else { Vec3::splat(1.0 - f) };
                let t = refract(d, n, eta, cos_t);
                if t.dot(ng) < 0.0 {
                    Some((t, w))
                } else {
                    // Shading normal sent the refracted ray back out: refract about the
                    // geometric normal instead.
                    let (_, ct) = fresnel_dielectric(-d.dot(ng), eta);
                    Some((refract(d, ng, eta, ct), w))
                }
            }
        }
        Material::Diffuse { .. } => None,
    }
}

#[cfg(test)]
mod scatter_tests {
    use super::*;

    const GLASS: Material = Material::Dielectric { ior: 1.5, ext_ior: 1.0, absorption: Vec3::ZERO };

    /// Without partial reflections a dielectric transmits with weight 1 − F every time and
    /// reflects only totally; with them, it reflects with probability F at weight 1: the same
    /// transmitted light on average (the like-for-like class of `--no-partial-reflections`).
    #[test]
    fn without_partial_reflections_glass_transmits_with_one_minus_fresnel() {
        let n = Vec3::Y;
        let d = Vec3::new(0.8, -0.6, 0.0);
        let (f, _) = fresnel_dielectric(0.6, 1.5);
        assert!(f > 0.02 && f < 0.2, "F = {f}");
        let mut rng = PathRng::new(7);
        let draws = 200_000;
        let mut transmitted = 0.0f64;
        for _ in 0..draws {
            let (t, w) = scatter_specular(GLASS, d, n, n, true, &mut rng, false).expect("a dielectric scatters");
            assert!(t.dot(n) < 0.0, "refracted into the glass");
            assert_eq!(w, Vec3::splat(1.0 - f));
            let (t, w) = scatter_specular(GLASS, d, n, n, true, &mut rng, true).expect("a dielectric scatters");
            assert_eq!(w, Vec3::ONE);
            if t.dot(n) < 0.0 {
                transmitted += 1.0;
            }
        }
        let p = transmitted / f64::from(draws);
        let sigma = (f64::from(f) * (1.0 - f64::from(f)) / f64::from(draws)).sqrt();
        assert!((p - (1.0 - f64::from(f))).abs() < 4.0 * sigma, "transmitted {p} against {}", 1.0 - f);
        // Past the critical angle inside the glass: total internal reflection either way.
        let inside = Vec3::new(0.9, 0.1f32.sqrt(), 0.0).normalize();
        let (r, w) = scatter_specular(GLASS, inside, -n, -n, false, &mut rng, false).expect("a dielectric scatters");
        assert!(r.dot(n) < 0.0, "reflected back into the glass");
        assert_eq!(w, Vec3::ONE);
    }
}

/// A point on a diffuse surface a photon lit: position, geometric and shading normals (on the
/// side the photon came from) and albedo.
#[derive(Clone, Copy)]
struct DiffusePoint {
    p: Vec3,
    ng: Vec3,
    ns: Vec3,
    albedo: Vec3,
}
