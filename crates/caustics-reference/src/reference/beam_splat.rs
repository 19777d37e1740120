//! The single scattering of given beams (the GPU's [`caustics::beams::Beam`]s) or light-path
//! segments toward the camera, integrated on the CPU by quadrature: the check of `beam_raster`'s
//! per-pixel integral (`shaders/shared/beam_scatter.wgsl`) independent of its code, and with the
//! light paths themselves (`super::branch::trace_segments`) of the beams' construction
//! (the retired `beam_splat` example, `tests/gpu/beams/`; docs/benchmarks.md, "Beams: the GPU's beams
//! integrated on the CPU").
//!
//! Each point's light goes to the pixel it projects into (the box pixel filter, as the CPU
//! reference's and the line integral's) where it lies on the camera's side of the first
//! surface, found by 4 × 4 rays per pixel (not the GPU's eye buffers): of the tangent plane of
//! the surface the ray through its quarter of a pixel meets (a depth test against the ray's hit
//! distance cut the fog above a floor seen at a grazing angle as the GPU's camera-facing plane
//! once did, 2 % at a quarter pixel). Homogeneous media only (analytic transmittance); the first
//! channel.

use super::geometry::Accel;
use super::medium::Media;
use caustics::beams::Beam;
use caustics::error::{Error, Result};
use caustics::scene::Scene;
use glam::Vec3;
use rayon::prelude::*;

/// Depth rays per pixel side.
const SUB: u32 = 4;

/// The camera, first surfaces and medium of a scene, for splatting.
pub struct BeamSplat {
    pub width: u32,
    pub height: u32,
    cam: Vec3,
    axes: [Vec3; 3],
    tan: (f32, f32),
    pix_area: f32,
    /// The first surface along SUB × SUB rays per pixel: its point and unit normal toward the
    /// camera.
    surface: Vec<Option<(Vec3, Vec3)>>,
    /// The medium (the reference's: box, coefficients, phase function) and its box.
    media: Media,
    lo: Vec3,
    hi: Vec3,
}

/// The heights of line o + y s on the beam's side of the plane through q (normal along
/// `along`): `beyond` keeps the heights past the plane, else those before it; cuts `r`.
fn plane_cut(q: [Vec3; 3], along: Vec3, o: Vec3, s: Vec3, beyond: bool, r: &mut (f32, f32)) {
    let mut n = (q[1] - q[0]).cross(q[2] - q[0]);
    if n.length_squared() < 1e-30 {
        return;
    }
    if n.dot(along) < 0.0 {
        n = -n;
    }
    let (f0, f1) = (n.dot(o - q[0]), n.dot(s));
    let (f0, f1) = if beyond { (f0, f1) } else { (-f0, -f1) };
    if f1 > 0.0 {
        r.0 = r.0.max(-f0 / f1);
    } else if f1 < 0.0 {
        r.1 = r.1.min(-f0 / f1);
    } else if f0 < 0.0 {
        *r = (1.0, 0.0);
    }
}

/// Barycentrics (the first two) of the centroids of a triangle's midpoint subdivision into n²
/// triangles: a beam's lines.
pub fn lines(n: usize) -> Vec<[f32; 2]> {
    let mut bary = Vec::with_capacity(n * n);
    let nf = n as f32;
    for i in 0..n {
        for j in 0..n - i {
            let (a, b) = (i as f32, j as f32);
            bary.push([(a + 1.0 / 3.0) / nf, (b + 1.0 / 3.0) / nf]);
            if i + j + 1 < n {
                bary.push([(a + 2.0 / 3.0) / nf, (b + 2.0 / 3.0) / nf]);
            }
        }
    }
    bary
}

impl BeamSplat {
    /// The scene's camera and first surfaces; an error where it has no medium or a density grid.
    pub fn new(scene: &Scene) -> Result<BeamSplat> {
        let m = scene.medium.as_ref().ok_or_else(|| Error::input("<beam_splat>", "medium", "the scene has none"))?;
        if m.density.is_some() {
            return Err(Error::input("<beam_splat>", "medium.density", "homogeneous media only"));
        }
        let cam = &scene.camera;
        let (w, h) = (cam.width, cam.height);
        let accel = Accel::new(scene);
        let surface = (0..w * h * SUB * SUB)
            .into_par_iter()
            .map(|i| {
                let (sx, sy) = (i % (w * SUB), i / (w * SUB));
                let d = cam.ray_dir((sx as f32 + 0.5) / SUB as f32, (sy as f32 + 0.5) / SUB as f32);
                accel
                    .intersect(cam.position, d, f32::MAX)
                    .map(|hit| (hit.p, if hit.ng.dot(d) < 0.0 { hit.ng } else { -hit.ng }))
            })
            .collect();
        let tan_y = (cam.fov_y_deg.to_radians() * 0.5).tan();
        let tan_x = tan_y * cam.aspect();
        Ok(BeamSplat {
            media: Media::new(m),
            width: w,
            height: h,
            cam: cam.position,
            axes: [cam.forward(), cam.right(), cam.true_up()],
            tan: (tan_x, tan_y),
            pix_area: (2.0 * tan_x / w as f32) * (2.0 * tan_y / h as f32),
            surface,
            lo: m.bounds_min,
            hi: m.bounds_max,
        })
    }

    /// The length of segment a → b inside the medium's box.
    pub fn in_medium(&self, a: Vec3, b: Vec3) -> f32 {
        let len = a.distance(b);
        if len <= 0.0 {
            return 0.0;
        }
        self.media.length_in(a, (b - a) / len, len)
    }

    /// Adds to `img` (first channel, row-major) the light of a point x of the medium that
    /// carries `power` (W) along unit `dl` over a length `ds` (m) after `pre` m of medium: its
    /// single scattering toward the camera, in the pixel it projects into if nothing hides it.
    fn point(&self, x: Vec3, dl: Vec3, power: f32, pre_from: (Vec3, f32), img: &mut [f64]) {
        if x.cmplt(self.lo).any() || x.cmpgt(self.hi).any() {
            return;
        }
        let [fwd, right, up] = self.axes;
        let tv = x - self.cam;
        let dist = tv.length();
        let vd = tv / dist;
        let z = vd.dot(fwd);
        if z <= 1e-6 {
            return;
        }
        let (w, h) = (self.width as f32, self.height as f32);
        let px = (vd.dot(right) / z / self.tan.0 + 1.0) * 0.5 * w;
        let py = (1.0 - vd.dot(up) / z / self.tan.1) * 0.5 * h;
        if !(px >= 0.0 && py >= 0.0 && px < w && py < h) {
            return;
        }
        let (qx, qy) = ((px * SUB as f32) as u32, (py * SUB as f32) as u32);
        if let Some((p, n)) = self.surface[(qy * self.width * SUB + qx) as usize]
            && n.dot(x - p) < 0.0
        {
            return;
        }
        let (o, pre) = pre_from;
        let tr = (-self.media.sigma_t.x * (pre + self.in_medium(o, x) + self.in_medium(self.cam, x))).exp();
        let v =
            self.media.sigma_s.x * power * self.media.phase(dl, -vd) * tr / (dist * dist * z * z * z * self.pix_area);
        img[py as usize * self.width as usize + px as usize] += f64::from(v);
    }

    /// The single scattering of `beams` (first channel, row-major): per beam the lines of
    /// constant barycentrics `bary` ([`lines`]) between its clip and end planes (`end_at_box`:
    /// a last segment leaving the scene ends at the medium's box instead), each in `steps`
    /// stratified points.
    pub fn beams(&self, beams: &[Beam], bary: &[[f32; 2]], steps: usize, end_at_box: bool) -> Vec<f64> {
        let n = (self.width * self.height) as usize;
        beams
            .par_chunks(64)
            .map(|chunk| {
                let mut img = vec![0.0f64; n];
                for b in chunk {
                    self.beam(b, bary, steps, end_at_box, &mut img);
                }
                img
            })
            .reduce(
                || vec![0.0; n],
                |mut x, y| {
                    x.iter_mut().zip(&y).for_each(|(a, b)| *a += b);
                    x
                },
            )
    }

    fn beam(&self, b: &Beam, bary: &[[f32; 2]], steps: usize, end_at_box: bool, img: &mut [f64]) {
        let nrm = b.normal();
        let sc: [Vec3; 3] = b.dirs.map(|d| d / nrm.dot(d));
        let mean = (b.dirs[0] + b.dirs[1] + b.dirs[2]).normalize();
        let clip_q = [0, 1, 2].map(|i| b.vertices[i] + sc[i] * b.clip[i]);
        let end_q = [0, 1, 2].map(|i| b.vertices[i] + sc[i] * (b.ends[i] * nrm.dot(b.dirs[i])));
        for (li, wb) in bary.iter().enumerate() {
            let wv = [wb[0], wb[1], 1.0 - wb[0] - wb[1]];
            let o: Vec3 = (0..3).map(|i| b.vertices[i] * wv[i]).sum();
            let sd: Vec3 = (0..3).map(|i| sc[i] * wv[i]).sum();
            let pre: f32 = (0..3).map(|i| b.pre[i] * wv[i]).sum();
            let mut r = (0.0f32, f32::INFINITY);
            plane_cut(clip_q, mean, o, sd, true, &mut r);
            if end_at_box && b.land == u32::MAX && b.layer == 0 {
                r.1 = r.1.min(4.0 * (self.hi - self.lo).length());
            } else {
                plane_cut(end_q, mean, o, sd, false, &mut r);
            }
            if r.1 <= r.0 || r.0.is_nan() || !r.1.is_finite() {
                continue;
            }
            let dl = sd.normalize();
            let cos_t = nrm.dot(dl).max(1e-4);
            let dy = (r.1 - r.0) / steps as f32;
            // (the line's share of the flux per unit height, over the path length per height)
            let power = b.flux.x / bary.len() as f32 / cos_t * dy;
            for si in 0..steps {
                // (stratified, jittered by a hash of the beam, line and step)
                let hsh = ((li * 7919 + si * 104729) as u32 ^ b.vertices[0].x.to_bits()).wrapping_mul(2654435761);
                let y = r.0 + dy * (si as f32 + (hsh >> 8) as f32 / (1u32 << 24) as f32);
                self.point(o + sd * y, dl, power, (o, pre), img);
            }
        }
    }

    /// Adds to `img` the single scattering of a light-path segment from `o` along unit `d` for
    /// `len` m carrying `power` W after `pre` m of medium, in points `ds` apart (offset by
    /// `jitter` in [0, 1) of a step).
    pub fn segment(
        &self,
        (o, d, len): (Vec3, Vec3, f32),
        power: f32,
        pre: f32,
        (ds, jitter): (f32, f32),
        img: &mut [f64],
    ) {
        let len = len.min(4.0 * (self.hi - self.lo).length());
        let steps = (len / ds).ceil().max(1.0) as usize;
        let dt = len / steps as f32;
        for si in 0..steps {
            self.point(o + d * (dt * (si as f32 + jitter)), d, power * dt, (o, pre), img);
        }
    }

    /// The medium's box.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        (self.lo, self.hi)
    }
}
