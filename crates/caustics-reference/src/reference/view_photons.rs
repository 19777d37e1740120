//! A surface photon map for the caustic the camera sees through a specular chain: light →
//! specular → diffuse surface → specular → camera (L S+ D S+ E: the floor caustic seen through a
//! glass ball, in a mirror).
//!
//! The photon tracer connects each caustic photon's diffuse hits to the camera with a shadow ray
//! (`Tracer::connect_camera`), which glass and mirrors stop, so this light had no estimate. Here
//! a separate set of caustic photons keeps its first diffuse hits ([`Deposit`]s: the flux that
//! arrives there, attenuated by any medium on the way), indexed in a uniform grid of cells of the
//! kernel's radius, and a camera path whose vertices so far are all specular (at least one)
//! gathers the deposits around its first diffuse vertex, and around every later one (light
//! that bounced before the surface seen through glass: a pool floor lit by the caustic on the
//! floor beside it, which no photon connection reaches either): the irradiance
//! `E = Σ Φ k_r(|x − p|)` with the 2D Epanechnikov kernel `k_r(d) = 2 / (π r²) (1 − d²/r²)`
//! (integrating to 1 over the disk), deposits on the same object and side only (normals within
//! 60°), and the vertex's radiance `albedo / π · E`. Density estimation: consistent, not
//! unbiased (a caustic sharper than r is blurred by r).
//!
//! Why by hand: a uniform grid of fixed cells is a few lines; the crates that index points
//! (kd-trees) would add a dependency for a radius search the grid does exactly.

use super::trace::Deposit;
use glam::Vec3;
use std::collections::HashMap;

/// The first diffuse hits of a set of caustic photons, indexed for radius searches.
pub struct ViewPhotons {
    deposits: Vec<Deposit>,
    /// Cell → range of `deposits` (sorted by cell).
    cells: HashMap<[i32; 3], (u32, u32)>,
    radius: f32,
}

impl ViewPhotons {
    /// Index `deposits` (flux in W) for gathering with kernel radius `radius` (m, > 0).
    pub fn new(mut deposits: Vec<Deposit>, radius: f32) -> ViewPhotons {
        let cell = |p: Vec3| (p / radius).floor().as_ivec3().to_array();
        deposits.retain(|d| d.position.is_finite() && d.flux.max_element() > 0.0);
        // Sorted by cell, then by their order (stable): the sums run in a fixed order.
        deposits.sort_by_key(|d| cell(d.position));
        let mut cells = HashMap::new();
        let mut i = 0;
        while i < deposits.len() {
            let c = cell(deposits[i].position);
            let mut j = i + 1;
            while j < deposits.len() && cell(deposits[j].position) == c {
                j += 1;
            }
            cells.insert(c, (i as u32, j as u32));
            i = j;
        }
        ViewPhotons { deposits, cells, radius }
    }

    pub fn len(&self) -> usize {
        self.deposits.len()
    }

    pub fn is_empty(&self) -> bool {
        self.deposits.is_empty()
    }

    pub fn radius(&self) -> f32 {
        self.radius
    }

    /// The caustic irradiance (W/m²) at `p` on object `object`, on the side of unit normal `n`.
    pub fn irradiance(&self, p: Vec3, n: Vec3, object: u32) -> Vec3 {
        let r = self.radius;
        let c = (p / r).floor().as_ivec3();
        let mut e = Vec3::ZERO;
        // The 27 cells around p's, in a fixed order.
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let Some(&(a, b)) = self.cells.get(&(c + glam::IVec3::new(dx, dy, dz)).to_array()) else {
                        continue;
                    };
                    for d in &self.deposits[a as usize..b as usize] {
                        let q = (d.position - p).length_squared() / (r * r);
                        if q >= 1.0 || d.object != object || d.normal.dot(n) < 0.5 {
                            continue;
                        }
                        e += d.flux * (1.0 - q);
                    }
                }
            }
        }
        e * (2.0 / (std::f32::consts::PI * r * r))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn deposit(position: Vec3, flux: f32, object: u32) -> Deposit {
        Deposit { position, normal: Vec3::Y, dir: Vec3::NEG_Y, flux: Vec3::splat(flux), specular_bounces: 1, object }
    }

    #[test]
    fn deposits_spread_evenly_give_their_irradiance() {
        // 400² deposits of total flux 2 W over a 1 m square: E = 2 W/m² inside it, at any radius
        // that fits; the other side of the surface and other objects get none.
        let n = 400;
        let mut deps = Vec::new();
        for i in 0..n {
            for j in 0..n {
                let x = (i as f32 + 0.5) / n as f32 - 0.5;
                let z = (j as f32 + 0.5) / n as f32 - 0.5;
                deps.push(deposit(Vec3::new(x, 0.0, z), 2.0 / (n * n) as f32, 3));
            }
        }
        for r in [0.01f32, 0.05] {
            let vp = ViewPhotons::new(deps.clone(), r);
            for p in [Vec3::ZERO, Vec3::new(0.3, 0.0, -0.2), Vec3::new(-0.1, 0.0, 0.37)] {
                let e = vp.irradiance(p, Vec3::Y, 3);
                assert!((e.x / 2.0 - 1.0).abs() < 0.01, "r {r}, {p}: {e}");
            }
            assert_eq!(vp.irradiance(Vec3::ZERO, Vec3::NEG_Y, 3), Vec3::ZERO);
            assert_eq!(vp.irradiance(Vec3::ZERO, Vec3::Y, 4), Vec3::ZERO);
            // Half the kernel off the square's edge: half the light.
            let e = vp.irradiance(Vec3::new(0.5, 0.0, 0.0), Vec3::Y, 3);
            assert!((e.x / 1.0 - 1.0).abs() < 0.02, "r {r}, at the edge: {e}");
        }
    }
}
