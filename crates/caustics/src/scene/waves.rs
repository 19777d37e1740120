//! Animated water (`{"type": "waves"}` in the scene format, `docs/scene-format.md`): a closed
//! water body whose top is a heightfield of Gerstner waves (Tessendorf 2001, "Simulating Ocean
//! Water", eq. 9: each wave also moves the surface points horizontally, which sharpens crests and
//! so the caustics under them), its sides and bottom flat. [`Waves::mesh`] poses it at a time;
//! `Scene::at_time` and `Renderer::set_time` re-pose every such object.
//!
//! The same surface as `tools/make_pool.py` (which writes it as OBJ; a test holds the two to the
//! digits the OBJ prints). Written here rather than taken from a crate: the ocean crates we know
//! of make FFT spectra for engines' vertex shaders; we need a few deterministic waves as a closed
//! triangle mesh in metres, which is forty lines.

use super::TriMesh;
use glam::{Vec2, Vec3};

/// Gravity (m/s²): the waves' dispersion ω = √(g k) of deep water.
pub const GRAVITY: f64 = 9.81;

/// One Gerstner wave.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wave {
    /// Height of the crest above the rest level (m).
    pub amplitude: f32,
    /// Crest to crest (m).
    pub wavelength: f32,
    /// Direction of travel in the xz-plane, degrees from +x toward +z.
    pub direction_deg: f32,
    /// Steepness in [0, 1]: 0 is a sine wave, 1 the sharpest crest without loops (shared between
    /// the waves: each moves points by at most `steepness / (k · waves)` sideways).
    pub steepness: f32,
    /// Phase at time 0 (radians).
    pub phase: f32,
}

/// A water body with a wavy top, in metres, in world space (no transform).
#[derive(Debug, Clone, PartialEq)]
pub struct Waves {
    /// Centre of the body in x and z (m).
    pub center: Vec2,
    /// Extent in x and z (m).
    pub size: Vec2,
    /// Rest height of the surface (m).
    pub surface: f32,
    /// Height of the flat bottom (m), below the lowest trough.
    pub bottom: f32,
    /// Quads per side of the surface grid.
    pub grid: u32,
    /// Smooth shading normals on the surface (averaged over its faces); flat otherwise.
    pub smooth_normals: bool,
    /// The waves, summed.
    pub waves: Vec<Wave>,
}

impl Waves {
    /// The displacement of the rest point (x, z) at time `t` (s): (dx, dy, dz), in f64 as the
    /// script computes it.
    pub fn displacement(&self, x: f64, z: f64, t: f64) -> [f64; 3] {
        let mut d = [0.0f64; 3];
        let n = self.waves.len() as f64;
        for w in &self.waves {
            let k = std::f64::consts::TAU / w.wavelength as f64;
            let omega = (GRAVITY * k).sqrt();
            let dir = (w.direction_deg as f64).to_radians();
            let (kx, kz) = (dir.cos(), dir.sin());
            let th = k * (kx * x + kz * z) - omega * t + w.phase as f64;
            let q = w.steepness as f64 / (k * n);
            d[0] += q * kx * th.cos();
            d[2] += q * kz * th.cos();
            d[1] += w.amplitude as f64 * th.sin();
        }
        d
    }

    /// The closed body at time `t` (s), normals out: with smooth normals the surface grid's
    /// `(grid + 1)²` vertices first (row by row along +x, rows along +z, as the script writes
    /// them), then the sides and the bottom, flat shaded; flat shaded throughout without. Border points move only along their side, so the body stays
    /// closed at every time.
    pub fn mesh(&self, t: f32) -> TriMesh {
        let n = self.grid as usize;
        let (h, c) = (self.size.as_dvec2() * 0.5, self.center.as_dvec2());
        let mut top = TriMesh::default();
        for j in 0..=n {
            for i in 0..=n {
                let x = -h.x + 2.0 * h.x * i as f64 / n as f64;
                let z = -h.y + 2.0 * h.y * j as f64 / n as f64;
                let [mut dx, dy, mut dz] = self.displacement(x, z, t as f64);
                if i == 0 || i == n {
                    dx = 0.0;
                }
                if j == 0 || j == n {
                    dz = 0.0;
                }
                let p = [c.x + x + dx, self.surface as f64 + dy, c.y + z + dz];
                top.positions.push(Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32));
            }
        }
        let idx = |i: usize, j: usize| (j * (n + 1) + i) as u32;
        for j in 0..n {
            for i in 0..n {
                // Counter-clockwise seen from above: the face normals point up (out).
                top.indices.push([idx(i, j), idx(i, j + 1), idx(i + 1, j + 1)]);
                top.indices.push([idx(i, j), idx(i + 1, j + 1), idx(i + 1, j)]);
            }
        }
        // The sides and the bottom: under the border, walked +x along the -z side first.
        let border: Vec<(usize, usize)> = (0..n)
            .map(|i| (i, 0))
            .chain((0..n).map(|j| (n, j)))
            .chain((1..=n).rev().map(|i| (i, n)))
            .chain((1..=n).rev().map(|j| (0, j)))
            .collect();
        let mut rest = TriMesh { positions: top.positions.clone(), ..TriMesh::default() };
        let base = rest.positions.len() as u32;
        for &(i, j) in &border {
            let p = top.positions[idx(i, j) as usize];
            rest.positions.push(Vec3::new(p.x, self.bottom, p.z));
        }
        let m = border.len() as u32;
        for k in 0..m {
            let (i0, j0) = border[k as usize];
            let (i1, j1) = border[((k + 1) % m) as usize];
            let (t0, t1) = (idx(i0, j0), idx(i1, j1));
            let (b0, b1) = (base + k, base + (k + 1) % m);
            rest.indices.push([t0, t1, b1]);
            rest.indices.push([t0, b1, b0]);
        }
        rest.positions.push(Vec3::new(self.center.x, self.bottom, self.center.y));
        let centre = rest.positions.len() as u32 - 1;
        for k in 0..m {
            rest.indices.push([centre, base + k, base + (k + 1) % m]);
        }
        rest.normals = vec![Vec3::ZERO; rest.positions.len()];
        rest.use_face_normals();
        top.normals = vec![Vec3::ZERO; top.positions.len()];
        if self.smooth_normals {
            top.fix_normals();
        } else {
            top.use_face_normals();
        }
        let first = top.positions.len() as u32;
        top.positions.extend(rest.positions);
        top.normals.extend(rest.normals);
        top.indices.extend(rest.indices.iter().map(|t| t.map(|x| x + first)));
        top
    }

    /// The bounds the body keeps at every time: its box, with the surface's largest rise.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let rise: f32 = self.waves.iter().map(|w| w.amplitude).sum();
        let h = self.size * 0.5;
        (
            Vec3::new(self.center.x - h.x, self.bottom, self.center.y - h.y),
            Vec3::new(self.center.x + h.x, self.surface + rise, self.center.y + h.y),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pool of `scenes/pool.json` as `tools/make_pool.py` makes it (its WAVES table).
    fn pool() -> Waves {
        let w = |amplitude, wavelength, direction_deg, steepness, phase| Wave {
            amplitude,
            wavelength,
            direction_deg,
            steepness,
            phase,
        };
        Waves {
            center: Vec2::ZERO,
            size: Vec2::splat(2.0),
            surface: 0.42,
            bottom: -0.02,
            grid: 48,
            smooth_normals: false,
            waves: vec![
                w(0.012, 0.9, 20.0, 0.6, 0.0),
                w(0.008, 0.55, 75.0, 0.5, 1.3),
                w(0.006, 0.37, -40.0, 0.5, 2.1),
                w(0.004, 0.23, 130.0, 0.4, 0.7),
            ],
        }
    }

    #[test]
    fn the_surface_is_the_scripts() {
        // scenes/meshes/pool_water.obj was written by the script (6 decimals) at time 0.
        let obj = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/meshes/pool_water.obj");
        let text = std::fs::read_to_string(obj).unwrap();
        let script: Vec<Vec3> = text
            .lines()
            .filter_map(|l| l.strip_prefix("v "))
            .map(|l| {
                let v: Vec<f32> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
                Vec3::new(v[0], v[1], v[2])
            })
            .collect();
        // Smooth normals keep the grid's vertices first, in the script's order.
        let m = Waves { smooth_normals: true, ..pool() }.mesh(0.0);
        let top = 49 * 49;
        let worst = (0..top).map(|i| (m.positions[i] - script[i]).abs().max_element()).fold(0.0f32, f32::max);
        // The OBJ prints 6 decimals (5e-7) and f32 keeps 7 digits of 0.4 m (3e-8).
        assert!(worst < 1e-6, "surface differs from the script's by {worst} m");
        // Same faces: 2 per quad, 2 per border segment, 1 per bottom fan segment.
        let faces = text.lines().filter(|l| l.starts_with("f ")).count();
        assert_eq!(m.indices.len(), faces);
    }

    #[test]
    fn the_body_is_closed_and_faces_out_at_every_time() {
        let mut w = pool();
        w.grid = 12;
        for smooth in [false, true] {
            w.smooth_normals = smooth;
            for t in [0.0, 0.37, 5.0] {
                let m = w.mesh(t);
                assert_eq!(m.boundary_edges(), 0, "open at t = {t}");
                // Divergence theorem: the signed volume is the body's (positive: faces out), close
                // to the box's at rest height (waves move as much water up as down, to ~10 %).
                let vol: f32 = m
                    .indices
                    .iter()
                    .map(|t| {
                        let [a, b, c] = t.map(|i| m.positions[i as usize]);
                        a.dot(b.cross(c)) / 6.0
                    })
                    .sum();
                let rest = 4.0 * (0.42 + 0.02);
                assert!((vol / rest - 1.0).abs() < 0.1, "volume {vol} against {rest} at t = {t}");
                let (lo, hi) = w.bounds();
                let (mlo, mhi) = m.bounds();
                assert!(mlo.cmpge(lo - 1e-6).all() && mhi.cmple(hi + 1e-6).all(), "outside its bounds at t = {t}");
                // The surface's normals point up.
                let up = m.indices[..2 * 12 * 12].iter().flatten().all(|&i| m.normals[i as usize].y > 0.5);
                assert!(up, "a surface normal points down");
            }
        }
        // Time moves the surface, not the sides' corners.
        let (a, b) = (w.mesh(0.0), w.mesh(0.5));
        assert_ne!(a.positions[5], b.positions[5]);
        assert_eq!(a.positions[0].x, b.positions[0].x);
    }
}
