//! Precomputed caustic spheres (Tandianus, Johan & Seah 2010, sections 3, 4 and 6): per caustic
//! object, the caustic it casts under a set of directional lights, tabulated on `s` concentric
//! spheres around it, blended at run time for any light direction.
//!
//! **Stored quantity.** Per light direction ω (the direction the light travels, in the
//! object's frame: the scene file's pose), per sphere, per latitude-longitude cell: the
//! *concentration* C (r, g, b; dimensionless) and the flux-weighted mean direction `d` of the
//! caustic light crossing the cell, not normalized (|d| ≤ 1: C d is the vector irradiance). C is the caustic flux per unit area perpendicular to its
//! direction of travel, per unit irradiance of the light (W/m² per W/m²). A receiver at `p`
//! with unit normal `n` under a directional light of irradiance `E` (W/m², r g b) travelling
//! along `L` gets the caustic irradiance `E ⊙ C(p) · max(0, −d(p)·n)` W/m² (exact when all
//! the light at `p` comes from the receiver's front). C does not change
//! when the object is scaled uniformly (the flux and the areas scale alike), so the table is
//! kept in the object's frame and looked up at `T⁻¹ p` for an object moved by `T`.
//!
//! **Light directions**: the vertices of an N×N grid on the octahedral map (N odd) centred on
//! straight down (−Y), deduplicated along the folded border. Why: the octahedral grid comes
//! with its triangulation (each grid cell split along the octahedron's edges), so the spherical
//! triangle holding a direction and its barycentric weights are found in O(1) with no search
//! or Delaunay step, the cells are close to equal in solid angle (within a factor ≈ 2, against
//! the poles' collapse of a latitude-longitude layout), and a Fibonacci layout, more uniform,
//! would need a stored triangulation and a point location search at run time.
//!
//! **Spheres**: radii by equation (1), `r_i = r_min + (r_max − r_min)((i − 1)/(s − 1))²`,
//! `r_max = 4d` (d the largest extent of the object's bounding box), `r_min` 0.1 % beyond the
//! nearest surface point from the centre (the bounding box centre): a receiver touching the
//! object lies between spheres, not inside the innermost one. **Cells**: W longitudes ×
//! H latitudes in a frame whose pole is ω; the latitude is warped, θ = π t² (t ∈ [0, 1]), so
//! that rows are dense where the caustic forms, downstream of the object along ω.

pub mod build;
pub mod cache;
mod feature;
pub(crate) mod frame;
pub mod gpu;
pub(crate) mod visibility;

pub use build::{build, build_with};

pub(crate) use feature::SpheresFeature;

use glam::{Quat, Vec3};
use std::f32::consts::PI;

/// Settings of a precomputation (part of the cache key).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct SphereSettings {
    /// Side N of the octahedral grid of light directions (odd, ≥ 3).
    pub directions: u32,
    /// Number of concentric spheres s (≥ 2).
    pub spheres: u32,
    /// Longitudes W per sphere.
    pub width: u32,
    /// Latitudes H per sphere.
    pub height: u32,
    /// Photons traced per direction.
    pub photons: u64,
    /// Maximal number of specular interactions per photon path.
    pub max_depth: u32,
}

impl Default for SphereSettings {
    fn default() -> Self {
        SphereSettings { directions: 7, spheres: 16, width: 64, height: 48, photons: 1 << 19, max_depth: 16 }
    }
}

impl SphereSettings {
    /// Checks the settings; the message names the setting.
    pub fn validate(&self) -> crate::Result<()> {
        let bad = |f: &str, m: &str| Err(crate::Error::input("<command line>", f, m));
        if self.directions < 3 || self.directions.is_multiple_of(2) || self.directions > 33 {
            return bad("--directions", "the octahedral grid side must be odd, from 3 to 33");
        }
        if self.spheres < 2 || self.spheres > 64 {
            return bad("--spheres", "from 2 to 64 spheres");
        }
        if !(4..=1024).contains(&self.width) || !(2..=512).contains(&self.height) {
            return bad("--sphere-size", "longitudes 4..1024, latitudes 2..512");
        }
        if self.photons == 0 {
            return bad("--sphere-photons", "at least one photon per direction");
        }
        Ok(())
    }
}

/// The frame of the octahedral map: its centre is straight down (−Y), the map's u along +X.
fn octa_frame() -> (Vec3, Vec3, Vec3) {
    (Vec3::X, Vec3::Z, Vec3::NEG_Y)
}

fn sign_nz(x: f32) -> f32 {
    if x < 0.0 { -1.0 } else { 1.0 }
}

/// Unit direction → octahedral map coordinates in [−1, 1]².
pub fn octa_encode(d: Vec3) -> (f32, f32) {
    let (a, b, c) = octa_frame();
    let (x, y, z) = (d.dot(a), d.dot(b), d.dot(c));
    let l1 = x.abs() + y.abs() + z.abs();
    let (x, y, z) = (x / l1, y / l1, z / l1);
    if z >= 0.0 { (x, y) } else { ((1.0 - y.abs()) * sign_nz(x), (1.0 - x.abs()) * sign_nz(y)) }
}

/// Octahedral map coordinates → unit direction.
pub fn octa_decode(u: f32, v: f32) -> Vec3 {
    let (a, b, c) = octa_frame();
    let z = 1.0 - u.abs() - v.abs();
    let (x, y) = if z >= 0.0 { (u, v) } else { ((1.0 - v.abs()) * sign_nz(u), (1.0 - u.abs()) * sign_nz(v)) };
    (a * x + b * y + c * z).normalize()
}

/// How the stored directions around a light direction are blended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Blend {
    /// The spherical triangle of 3 (a grid cell split along the octahedron's edges),
    /// barycentric weights. The default.
    Triangle,
    /// The paper's 4 nearest: the grid cell's corners, bilinear weights.
    Quad,
}

/// How a stored pattern (precomputed for light direction ω_k) is carried onto another light
/// direction l before the blend.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Warp {
    /// The paper's: the whole pattern rotated about the spheres' centre by R (ω_k → l), which
    /// is the caustic of the object rotated by R: exact for a rotationally symmetric object.
    Rotate,
    /// The object stays put: each caustic ray keeps where it leaves the object (its point of
    /// closest approach to the centre) and its deviation, its direction turned by R about
    /// there. The lookup point moves along the ray back to that point and out along the stored
    /// direction: p_k = p + t (d − R d), t = (p − c)·R d, d the stored mean direction at p_k,
    /// found by fixed-point iteration from d = ω_k (0 iterations: a shear along the light).
    Exit(u32),
}

/// The layout of light directions: an N×N octahedral grid, deduplicated.
#[derive(Debug, Clone)]
pub struct DirectionLayout {
    /// Grid side N (odd).
    pub n: u32,
    /// Unique directions (travel directions, unit).
    pub dirs: Vec<Vec3>,
    /// Per grid vertex (row-major, j·N + i), its index in `dirs`.
    pub vertex: Vec<u32>,
}

impl DirectionLayout {
    /// The layout of an N × N grid.
    pub fn new(n: u32) -> DirectionLayout {
        let mut dirs: Vec<Vec3> = Vec::new();
        let mut vertex = Vec::with_capacity((n * n) as usize);
        for j in 0..n {
            for i in 0..n {
                let d = octa_decode(grid_coord(i, n), grid_coord(j, n));
                let k = match dirs.iter().position(|e| e.dot(d) > 1.0 - 1e-6) {
                    Some(k) => k,
                    None => {
                        dirs.push(d);
                        dirs.len() - 1
                    }
                };
                vertex.push(k as u32);
            }
        }
        DirectionLayout { n, dirs, vertex }
    }

    /// The stored directions and weights (summing to 1) to blend for light direction `l`.
    pub fn weights(&self, l: Vec3, blend: Blend) -> [(u32, f32); 4] {
        let n = self.n;
        let (u, v) = octa_encode(l.normalize());
        let g = (n - 1) as f32;
        let fu = ((u + 1.0) * 0.5 * g).clamp(0.0, g);
        let fv = ((v + 1.0) * 0.5 * g).clamp(0.0, g);
        let i = (fu.floor() as u32).min(n - 2);
        let j = (fv.floor() as u32).min(n - 2);
        let (x, y) = (fu - i as f32, fv - j as f32);
        let vtx = |di: u32, dj: u32| self.vertex[((j + dj) * n + i + di) as usize];
        match blend {
            Blend::Quad => [
                (vtx(0, 0), (1.0 - x) * (1.0 - y)),
                (vtx(1, 0), x * (1.0 - y)),
                (vtx(0, 1), (1.0 - x) * y),
                (vtx(1, 1), x * y),
            ],
            Blend::Triangle => {
                // The octahedron's edges run along the cell's anti-diagonal where u·v > 0
                // (cell centre), along its diagonal elsewhere; split the cell along them.
                let cu = grid_coord(i, n) + 1.0 / g;
                let cv = grid_coord(j, n) + 1.0 / g;
                if cu * cv > 0.0 {
                    if x + y <= 1.0 {
                        [(vtx(0, 0), 1.0 - x - y), (vtx(1, 0), x), (vtx(0, 1), y), (vtx(1, 1), 0.0)]
                    } else {
                        [(vtx(1, 1), x + y - 1.0), (vtx(0, 1), 1.0 - x), (vtx(1, 0), 1.0 - y), (vtx(0, 0), 0.0)]
                    }
                } else if x >= y {
                    [(vtx(0, 0), 1.0 - x), (vtx(1, 0), x - y), (vtx(1, 1), y), (vtx(0, 1), 0.0)]
                } else {
                    [(vtx(0, 0), 1.0 - y), (vtx(0, 1), y - x), (vtx(1, 1), x), (vtx(1, 0), 0.0)]
                }
            }
        }
    }
}

/// The angle between unit `q` and the pole `w`, accurate near the pole (where acos of the dot
/// product loses most of its digits in f32, and the warped rows are finest).
pub fn polar_angle(q: Vec3, w: Vec3) -> f32 {
    q.cross(w).length().atan2(q.dot(w))
}

fn grid_coord(i: u32, n: u32) -> f32 {
    -1.0 + 2.0 * i as f32 / (n - 1) as f32
}

/// Equation (1): the radii of `s` spheres from `r_min` to `r_max`, quadratically spaced.
pub fn radii(r_min: f32, r_max: f32, s: u32) -> Vec<f32> {
    (0..s).map(|i| r_min + (r_max - r_min) * (i as f32 / (s - 1) as f32).powi(2)).collect()
}

/// A basis (a, b) perpendicular to unit `w`, the same for the same `w` (Frisvad / Duff et al.).
pub fn basis(w: Vec3) -> (Vec3, Vec3) {
    let s = if w.z >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (s + w.z);
    let b = w.x * w.y * a;
    (Vec3::new(1.0 + s * w.x * w.x * a, s * b, -s * w.x), Vec3::new(b, s + w.y * w.y * a, -w.y))
}

/// The geometry of one object's spheres (no data).
#[derive(Debug, Clone, PartialEq)]
pub struct SphereGeometry {
    /// Centre, in the object's frame (the scene file's pose).
    pub center: Vec3,
    /// The spheres' radii (m), innermost first.
    pub radii: Vec<f32>,
    /// Cells per sphere: columns (longitude) and rows (warped latitude).
    pub width: u32,
    /// Rows per sphere (latitude, θ = π t²).
    pub height: u32,
}

impl SphereGeometry {
    /// Cells per sphere.
    pub fn cells(&self) -> usize {
        (self.width * self.height) as usize
    }

    /// The cell (row, column) holding unit direction `q` in the frame of pole `w`.
    pub fn cell_of(&self, q: Vec3, w: Vec3) -> (u32, u32) {
        let (a, b) = basis(w);
        let th = polar_angle(q, w);
        let t = (th / PI).sqrt();
        let mut ph = q.dot(b).atan2(q.dot(a));
        if ph < 0.0 {
            ph += 2.0 * PI;
        }
        let row = ((t * self.height as f32) as u32).min(self.height - 1);
        let col = ((ph / (2.0 * PI) * self.width as f32) as u32).min(self.width - 1);
        (row, col)
    }

    /// Area of a cell of row `row` on a sphere of radius `r`.
    pub fn cell_area(&self, row: u32, r: f32) -> f32 {
        let t0 = row as f32 / self.height as f32;
        let t1 = (row + 1) as f32 / self.height as f32;
        let (th0, th1) = (PI * t0 * t0, PI * t1 * t1);
        r * r * (th0.cos() - th1.cos()) * (2.0 * PI / self.width as f32)
    }
}

/// One caustic object's precomputed spheres.
#[derive(Debug, Clone, PartialEq)]
pub struct CausticSpheres {
    /// What the table was precomputed with.
    pub settings: SphereSettings,
    /// Its spheres and cells.
    pub geometry: SphereGeometry,
    /// The stored light directions (travel directions, unit), in the order of `data`.
    pub layout_dirs: Vec<Vec3>,
    /// Per direction, per sphere, per row, per column: [C.r, C.g, C.b, 0, d.x, d.y, d.z, 0].
    pub data: Vec<[f32; 8]>,
}

/// A photon leaving the object for good: origin, unit direction, flux per unit light
/// irradiance (m², r g b).
#[derive(Debug, Clone, Copy)]
pub struct Escaped {
    /// Where it leaves the object (m, the object's frame).
    pub origin: Vec3,
    /// Its unit direction.
    pub dir: Vec3,
    /// Its flux per unit light irradiance (m², r g b).
    pub flux: Vec3,
}

/// Smallest |cos| between a photon and a sphere's normal used to turn the flux through a cell
/// into flux per perpendicular area (grazing crossings would blow up 1/cos).
const MIN_COS: f32 = 0.1;

impl CausticSpheres {
    /// Bytes of the table in f32 (half storage: half of it).
    pub fn bytes(&self) -> u64 {
        (self.data.len() * 32) as u64
    }

    fn index(&self, dir: usize, sphere: usize, row: u32, col: u32) -> usize {
        let g = &self.geometry;
        ((dir * g.radii.len() + sphere) * g.height as usize + row as usize) * g.width as usize + col as usize
    }

    /// Tabulates direction `dir` (index into `layout_dirs`) from its escaping photons, in
    /// their order (the sum is deterministic for a given order).
    pub fn deposit(&mut self, dir: usize, photons: &[Escaped]) {
        let g = self.geometry.clone();
        let w = self.layout_dirs[dir];
        let mut acc = vec![[0f64; 6]; g.radii.len() * g.cells()];
        for p in photons {
            let oc = p.origin - g.center;
            let bq = oc.dot(p.dir);
            let c0 = oc.length_squared();
            for (si, &r) in g.radii.iter().enumerate() {
                let disc = bq * bq - (c0 - r * r);
                if disc < 0.0 {
                    continue;
                }
                let sq = disc.sqrt();
                for t in [-bq - sq, -bq + sq] {
                    if t <= 0.0 {
                        continue;
                    }
                    let q = (oc + p.dir * t) / r;
                    let (row, col) = g.cell_of(q, w);
                    let cos = p.dir.dot(q).abs().max(MIN_COS);
                    let c = p.flux / (g.cell_area(row, r) * cos);
                    let lum = c.x + c.y + c.z;
                    let a = &mut acc[si * g.cells() + (row * g.width + col) as usize];
                    a[0] += c.x as f64;
                    a[1] += c.y as f64;
                    a[2] += c.z as f64;
                    a[3] += (lum * p.dir.x) as f64;
                    a[4] += (lum * p.dir.y) as f64;
                    a[5] += (lum * p.dir.z) as f64;
                }
            }
        }
        let base = self.index(dir, 0, 0, 0);
        for (k, a) in acc.iter().enumerate() {
            // The mean direction keeps its length (|d| ≤ 1, 1 when all the cell's light
            // travels one way): C d is the cell's vector irradiance (net flux per area), so that
            // a receiver gets C max(0, −d·n), not the larger C max(0, −d̂·n) (near a focus the
            // light crosses a cell from a wide cone: the normalized mean overstated it by
            // 1/|d|, 5–25 % on the floor under a resting ball).
            let lum = a[0] + a[1] + a[2];
            let d = if lum > 0.0 {
                Vec3::new((a[3] / lum) as f32, (a[4] / lum) as f32, (a[5] / lum) as f32)
            } else {
                Vec3::ZERO
            };
            self.data[base + k] = [a[0] as f32, a[1] as f32, a[2] as f32, 0.0, d.x, d.y, d.z, 0.0];
        }
    }

    /// An empty table for `geometry` and `dirs`.
    pub fn empty(settings: SphereSettings, geometry: SphereGeometry, layout_dirs: Vec<Vec3>) -> CausticSpheres {
        let len = layout_dirs.len() * geometry.radii.len() * geometry.cells();
        CausticSpheres { settings, geometry, layout_dirs, data: vec![[0.0; 8]; len] }
    }

    /// (C, d) of stored direction `dir` at object-frame point `p` (d the luminance-weighted
    /// mean direction, of length ≤ 1: C d is the vector irradiance): bilinear on the spheres,
    /// linear between them in the eq. (1) parameter; outside the spheres C falls off as 1/r²
    /// from the nearest sphere (the caustic's flux spreads out from the object).
    pub fn sample(&self, dir: usize, p: Vec3) -> (Vec3, Vec3) {
        let g = &self.geometry;
        let q = p - g.center;
        let r = q.length();
        if r <= 0.0 {
            return (Vec3::ZERO, Vec3::ZERO);
        }
        let s = g.radii.len();
        let (r_min, r_max) = (g.radii[0], g.radii[s - 1]);
        let (rr, fall) = if r < r_min {
            (r_min, (r_min / r).powi(2))
        } else if r > r_max {
            (r_max, (r_max / r).powi(2))
        } else {
            (r, 1.0)
        };
        let fs = ((rr - r_min) / (r_max - r_min)).max(0.0).sqrt() * (s - 1) as f32;
        let s0 = (fs.floor() as usize).min(s - 2);
        let ws = (fs - s0 as f32).clamp(0.0, 1.0);
        let w = self.layout_dirs[dir];
        let (a, b) = basis(w);
        let u = q / r;
        let th = polar_angle(u, w);
        let ft = (th / PI).sqrt() * g.height as f32 - 0.5;
        let mut ph = u.dot(b).atan2(u.dot(a));
        if ph < 0.0 {
            ph += 2.0 * PI;
        }
        let fp = ph / (2.0 * PI) * g.width as f32 - 0.5;
        let r0 = ft.floor();
        let wr = ft - r0;
        let c0 = fp.floor();
        let wc = fp - c0;
        let rows =
            [(r0 as i64).clamp(0, g.height as i64 - 1) as u32, (r0 as i64 + 1).clamp(0, g.height as i64 - 1) as u32];
        let cols = [(c0 as i64).rem_euclid(g.width as i64) as u32, (c0 as i64 + 1).rem_euclid(g.width as i64) as u32];
        let mut c = Vec3::ZERO;
        let mut d = Vec3::ZERO;
        let mut lum = 0.0;
        for (si, wsph) in [(s0, 1.0 - ws), (s0 + 1, ws)] {
            for (ri, wrow) in [(0, 1.0 - wr), (1, wr)] {
                for (ci, wcol) in [(0, 1.0 - wc), (1, wc)] {
                    let wt = wsph * wrow * wcol;
                    if wt == 0.0 {
                        continue;
                    }
                    let e = self.data[self.index(dir, si, rows[ri], cols[ci])];
                    let ce = Vec3::new(e[0], e[1], e[2]);
                    c += ce * wt;
                    d += Vec3::new(e[4], e[5], e[6]) * (wt * (ce.x + ce.y + ce.z));
                    lum += wt * (ce.x + ce.y + ce.z);
                }
            }
        }
        if lum <= 0.0 {
            return (Vec3::ZERO, Vec3::ZERO);
        }
        (c * fall, d / lum)
    }

    /// Caustic irradiance factor (W/m² per W/m² of light, r g b) at object-frame point `p` on a
    /// receiver of unit normal `n` (object frame) under a directional light travelling along
    /// `l` (object frame): the stored directions around `l` rotated onto it and blended.
    pub fn irradiance(&self, p: Vec3, n: Vec3, l: Vec3, layout: &DirectionLayout, blend: Blend) -> Vec3 {
        let l = l.normalize();
        let mut e = Vec3::ZERO;
        for (k, w) in layout.weights(l, blend) {
            if w <= 0.0 {
                continue;
            }
            let e_k = self.irradiance_of(k as usize, p, n, l);
            e += e_k * w;
        }
        e
    }

    /// Stored direction `k` rotated onto light direction `l`, at point `p`, normal `n`.
    pub fn irradiance_of(&self, k: usize, p: Vec3, n: Vec3, l: Vec3) -> Vec3 {
        self.irradiance_of_warped(k, p, n, l, Warp::Rotate)
    }

    /// [`Self::irradiance`] with the stored patterns carried onto `l` by `warp`.
    pub fn irradiance_warped(
        &self,
        p: Vec3,
        n: Vec3,
        l: Vec3,
        layout: &DirectionLayout,
        blend: Blend,
        warp: Warp,
    ) -> Vec3 {
        let l = l.normalize();
        let mut e = Vec3::ZERO;
        for (k, w) in layout.weights(l, blend) {
            if w > 0.0 {
                e += self.irradiance_of_warped(k as usize, p, n, l, warp) * w;
            }
        }
        e
    }

    /// Where stored pattern `k` is looked up for light direction `l` at object-frame point
    /// `p` under `warp`, and the rotation R (ω_k → l) its mean directions are carried by.
    pub fn warped_point(&self, k: usize, p: Vec3, l: Vec3, warp: Warp) -> (Vec3, Quat) {
        let w = self.layout_dirs[k];
        let rot = Quat::from_rotation_arc(w, l);
        let c = self.geometry.center;
        let q = p - c;
        match warp {
            Warp::Rotate => (rot.inverse() * q + c, rot),
            Warp::Exit(iterations) => {
                // The ray through p along D (its direction under l) passes closest to the
                // centre at p − t·D, t = (p − c)·D; under ω_k it left there along R⁻¹D.
                let t = q.dot(l);
                let mut pk = p + (w - l) * t;
                for _ in 0..iterations {
                    let (_, d) = self.sample(k, pk);
                    if d == Vec3::ZERO {
                        break;
                    }
                    let d = d.normalize();
                    let dl = rot * d;
                    pk = p + (d - dl) * q.dot(dl);
                }
                (pk, rot)
            }
        }
    }

    /// [`Self::irradiance_of`] with the pattern carried onto `l` by `warp`.
    pub fn irradiance_of_warped(&self, k: usize, p: Vec3, n: Vec3, l: Vec3, warp: Warp) -> Vec3 {
        let (pk, rot) = self.warped_point(k, p, l, warp);
        let (c, d) = self.sample(k, pk);
        let cos = (-(rot * d).dot(n)).max(0.0);
        c * cos
    }
}

/// Relative gap between the object's nearest surface point and the innermost sphere.
pub const R_MIN_GAP: f32 = 1e-3;

/// The distance from `center` to the nearest point of `shape`'s surface (the scene file's
/// pose): the analytic sphere's radius less the offset of its centre, else the nearest point
/// of the triangles (of the mesh, or of the shape's default tessellation).
pub fn nearest_surface(shape: &crate::scene::Shape, center: Vec3) -> f32 {
    use crate::scene::Shape;
    let tris = |pos: &[Vec3], idx: &[[u32; 3]]| {
        idx.iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| pos[i as usize]);
                (closest_on_triangle(center, a, b, c) - center).length()
            })
            .fold(f32::INFINITY, f32::min)
    };
    match shape {
        Shape::Sphere { center: c, radius } => (*radius - (*c - center).length()).abs(),
        Shape::Mesh(m) => tris(&m.positions, &m.indices),
        other => {
            let t = other.tessellate(&crate::scene::Tessellation::default());
            tris(&t.positions, &t.indices)
        }
    }
}

/// The point of triangle (a, b, c) nearest `p` (Ericson, Real-Time Collision Detection 5.1.5).
fn closest_on_triangle(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> Vec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let den = 1.0 / (va + vb + vc);
    a + ab * (vb * den) + ac * (vc * den)
}

impl SphereGeometry {
    /// The spheres of `shape` (the scene file's pose): centred on its bounding box, radii by
    /// equation (1) from r_min to r_max = 4 × the box's largest extent. r_min lies just beyond
    /// the object's nearest surface point ([`nearest_surface`] × (1 + [`R_MIN_GAP`]), plus a
    /// margin over the tracer's spawn offset), so that a receiver touching the object (a ball
    /// resting on the floor: the floor around the contact point) lies between spheres, not
    /// inside the innermost one, where the lookup only extrapolates. (It was 1.02 × the
    /// nearest vertex's distance: the floor within 0.2 R of a resting ball's contact point
    /// was inside it, where a high sun's light lands.)
    pub fn for_shape(shape: &crate::scene::Shape, settings: &SphereSettings) -> SphereGeometry {
        let (lo, hi) = shape.bounds();
        let center = (lo + hi) * 0.5;
        let d = (hi - lo).max_element();
        let nearest = nearest_surface(shape, center);
        let r_max = 4.0 * d;
        // The reference's tracer spawns a ray 2e-5 (1 + |p|max) off the surface: stay beyond.
        let margin = 1e-4 * (1.0 + center.abs().max_element() + nearest);
        let r_min = (nearest * (1.0 + R_MIN_GAP) + margin).clamp(1e-3 * r_max, 0.5 * r_max);
        SphereGeometry {
            center,
            radii: radii(r_min, r_max, settings.spheres),
            width: settings.width,
            height: settings.height,
        }
    }
}
