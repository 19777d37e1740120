//! Ray casting against a scene: exact analytic spheres, rectangles and open cylinders (solved in
//! double precision), and one triangle BVH over every mesh.

use super::bvh::Bvh;
use caustics::scene::{Scene, Shape, TriMesh};
use glam::{DVec3, Vec2, Vec3};
use std::sync::Arc;

/// A surface hit.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub t: f32,
    pub p: Vec3,
    /// Unit geometric normal, outward for closed shapes (sphere, cylinder, meshes wound
    /// counter-clockwise seen from outside); the rectangle's `normal`.
    pub ng: Vec3,
    /// Unit shading normal, on the same side as `ng`.
    pub ns: Vec3,
    pub object: u32,
}

enum Analytic {
    Sphere { c: DVec3, r: f64 },
    Rect { c: Vec3, n: Vec3, u: Vec3, v: Vec3, half: Vec2 },
    Cyl { base: DVec3, axis: DVec3, r: f64, h: f64 },
}

/// Everything a ray can hit.
pub struct Accel {
    analytic: Vec<(u32, Analytic)>,
    bvh: Bvh,
    /// Per stored triangle id: (object, mesh, triangle index within the mesh).
    tri_ref: Vec<(u32, u32, u32)>,
    meshes: Vec<Arc<TriMesh>>,
}

impl Accel {
    pub fn new(scene: &Scene) -> Accel {
        let mut analytic = Vec::new();
        let mut tris = Vec::new();
        let mut tri_ref = Vec::new();
        let mut meshes = Vec::new();
        for (oi, o) in scene.objects.iter().enumerate() {
            let oi = oi as u32;
            match &o.shape {
                Shape::Sphere { center, radius } => {
                    analytic.push((oi, Analytic::Sphere { c: center.as_dvec3(), r: *radius as f64 }))
                }
                Shape::Rectangle { center, normal, u, v, size } => {
                    analytic.push((oi, Analytic::Rect { c: *center, n: *normal, u: *u, v: *v, half: *size * 0.5 }))
                }
                Shape::Cylinder { base_center, axis, radius, height } => analytic.push((
                    oi,
                    Analytic::Cyl {
                        base: base_center.as_dvec3(),
                        axis: axis.as_dvec3().normalize(),
                        r: *radius as f64,
                        h: *height as f64,
                    },
                )),
                Shape::Mesh(m) => {
                    let mi = meshes.len() as u32;
                    for (ti, t) in m.indices.iter().enumerate() {
                        tris.push(t.map(|i| m.positions[i as usize]));
                        tri_ref.push((oi, mi, ti as u32));
                    }
                    meshes.push(m.clone());
                }
            }
        }
        Accel { analytic, bvh: Bvh::build(tris), tri_ref, meshes }
    }

    pub fn triangle_count(&self) -> usize {
        self.tri_ref.len()
    }

    /// Nearest hit along unit `d` from `o` with t in (0, tmax).
    pub fn intersect(&self, o: Vec3, d: Vec3, tmax: f32) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        let mut tmax = tmax;
        if let Some(h) = self.bvh.intersect(o, d, tmax) {
            let (oi, mi, ti) = self.tri_ref[h.id as usize];
            let m = &self.meshes[mi as usize];
            let idx = m.indices[ti as usize];
            let [a, b, c] = idx.map(|i| m.positions[i as usize]);
            let b0 = 1.0 - h.b1 - h.b2;
            let p = a * b0 + b * h.b1 + c * h.b2;
            let ng = (b - a).cross(c - a).normalize_or_zero();
            let ns = (m.normals[idx[0] as usize] * b0
                + m.normals[idx[1] as usize] * h.b1
                + m.normals[idx[2] as usize] * h.b2)
                .normalize_or_zero();
            let ns = if ns.dot(ng) > 0.0 { ns } else { ng };
            tmax = h.t;
            best = Some(Hit { t: h.t, p, ng, ns, object: oi });
        }
        for (oi, a) in &self.analytic {
            if let Some((t, p, n)) = a.intersect(o, d, tmax) {
                tmax = t;
                best = Some(Hit { t, p, ng: n, ns: n, object: *oi });
            }
        }
        best
    }

    /// Whether anything lies along unit `d` from `o` with t in (0, tmax).
    pub fn occluded(&self, o: Vec3, d: Vec3, tmax: f32) -> bool {
        self.analytic.iter().any(|(_, a)| a.intersect(o, d, tmax).is_some()) || self.bvh.occluded(o, d, tmax)
    }
}

impl Analytic {
    fn intersect(&self, o: Vec3, d: Vec3, tmax: f32) -> Option<(f32, Vec3, Vec3)> {
        match self {
            Analytic::Sphere { c, r } => {
                let od = o.as_dvec3();
                let dd = d.as_dvec3();
                let oc = od - *c;
                let b = oc.dot(dd);
                // r² - |oc - b d|²: no cancellation for distant spheres.
                let h = oc - b * dd;
                let disc = r * r - h.dot(h);
                if disc < 0.0 {
                    return None;
                }
                let s = disc.sqrt();
                let q = if b > 0.0 { -b - s } else { -b + s };
                let (t0, t1) = {
                    let c2 = oc.dot(oc) - r * r;
                    let (x, y) = (q, if q != 0.0 { c2 / q } else { 0.0 });
                    if x < y { (x, y) } else { (y, x) }
                };
                let t = if t0 > 0.0 { t0 } else { t1 };
                if t <= 0.0 || t >= tmax as f64 {
                    return None;
                }
                let n = (od + dd * t - *c).normalize();
                Some((t as f32, (*c + n * *r).as_vec3(), n.as_vec3()))
            }
            Analytic::Rect { c, n, u, v, half } => {
                let dn = d.dot(*n);
                if dn.abs() < 1e-12 {
                    return None;
                }
                let t = (*c - o).dot(*n) / dn;
                if !(t > 0.0 && t < tmax) {
                    return None;
                }
                let p = o + d * t;
                let q = p - *c;
                if q.dot(*u).abs() > half.x || q.dot(*v).abs() > half.y {
                    return None;
                }
                Some((t, p - *n * q.dot(*n), *n))
            }
            Analytic::Cyl { base, axis, r, h } => {
                let od = o.as_dvec3();
                let dd = d.as_dvec3();
                let oc = od - *base;
                let dp = dd - *axis * dd.dot(*axis);
                let op = oc - *axis * oc.dot(*axis);
                let a = dp.dot(dp);
                if a < 1e-24 {
                    return None;
                }
                let b = op.dot(dp);
                // disc/a² with the |op - (b/a) dp| form to limit cancellation.
                let closest = op - dp * (b / a);
                let disc = (r * r - closest.dot(closest)) * a;
                if disc < 0.0 {
                    return None;
                }
                let s = disc.sqrt();
                for t in [(-b - s) / a, (-b + s) / a] {
                    if t <= 0.0 || t >= tmax as f64 {
                        continue;
                    }
                    let y = (oc + dd * t).dot(*axis);
                    if y < 0.0 || y > *h {
                        continue;
                    }
                    let radial = (op + dp * t).normalize();
                    let p = *base + *axis * y + radial * *r;
                    return Some((t as f32, p.as_vec3(), radial.as_vec3()));
                }
                None
            }
        }
    }
}

/// Origin for a ray leaving surface point `p` (geometric normal `ng`) in direction `d`: moved
/// off the surface to the side `d` goes, by a distance relative to the coordinates' magnitude.
#[inline]
pub fn spawn(p: Vec3, ng: Vec3, d: Vec3) -> Vec3 {
    let eps = 2e-5 * (1.0 + p.abs().max_element());
    if d.dot(ng) >= 0.0 { p + ng * eps } else { p - ng * eps }
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn analytic_shapes() {
        let s = Analytic::Sphere { c: DVec3::new(0.0, 0.0, 0.0), r: 1.0 };
        let (t, p, n) = s.intersect(Vec3::new(0.0, 0.0, 5.0), Vec3::NEG_Z, 100.0).unwrap();
        assert!((t - 4.0).abs() < 1e-6 && (p.z - 1.0).abs() < 1e-6 && (n.z - 1.0).abs() < 1e-6);
        let (t, _, n) = s.intersect(Vec3::new(0.0, 0.0, 0.0), Vec3::NEG_Z, 100.0).unwrap();
        assert!((t - 1.0).abs() < 1e-6 && (n.z + 1.0).abs() < 1e-6);
        let c = Analytic::Cyl { base: DVec3::ZERO, axis: DVec3::Y, r: 0.5, h: 1.0 };
        let (t, _, n) = c.intersect(Vec3::new(-2.0, 0.5, 0.0), Vec3::X, 100.0).unwrap();
        assert!((t - 1.5).abs() < 1e-6 && (n.x + 1.0).abs() < 1e-6);
        let (t, _, n) = c.intersect(Vec3::new(0.0, 0.5, 0.0), Vec3::X, 100.0).unwrap();
        assert!((t - 0.5).abs() < 1e-6 && (n.x - 1.0).abs() < 1e-6);
        assert!(c.intersect(Vec3::new(-2.0, 1.5, 0.0), Vec3::X, 100.0).is_none());
    }
}
