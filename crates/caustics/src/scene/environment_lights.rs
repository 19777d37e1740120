//! Environment segmentation into directional lights: the cube-map median cut of Tandianus,
//! Johan and Seah 2010, section 5 ("Environment Map Segmentation"), after Debevec's median cut.
//!
//! Every texel of the equirectangular map is a point on the cube of directions (the face of its
//! centre's major axis, at the face coordinates of its centre) carrying its radiance times its
//! exact solid angle, `L · Ω` (W/m²: the irradiance that texel alone gives a surface facing
//! it). The segmentation starts from the six cube faces and repeatedly takes the region of
//! largest total `L · Ω` and splits it, across its longer side, into two regions of (as nearly
//! as the texels allow) equal total, until `D` regions remain. Each region becomes a
//! directional light travelling from its `L · Ω`-weighted centre direction, with the region's
//! total `Σ L · Ω` as irradiance: for a region small enough that `cos` to its centre is about 1,
//! that is the irradiance its directions give a surface facing the light, so the lights
//! together carry exactly the map's total. No occlusion yet (the paper renders the regions from
//! the caster's centre with the occluders in black; here every texel counts).
//!
//! With `D < 6`, the `6 - D + 1` faces of least total are merged into one region.

use super::Light;
use super::environment::Environment;
use glam::{DVec3, Vec2, Vec3};

/// One region of the segmentation and the directional light that stands for it.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvironmentLight {
    /// Unit direction toward the region's `L · Ω`-weighted centre (toward the sky).
    pub centre: Vec3,
    /// Total `Σ L · Ω` of the region's texels, W/m² (per channel).
    pub irradiance: Vec3,
    /// Solid angle of the region's texels, sr.
    pub solid_angle: f32,
    /// Texels in the region.
    pub texels: usize,
    /// Cube face (0..6: +X, -X, +Y, -Y, +Z, -Z) and rectangle `[s0, t0, s1, t1]` in its face
    /// coordinates; `None` for the merged region of several faces (`D < 6`).
    pub face: Option<(u8, [f32; 4])>,
}

impl EnvironmentLight {
    /// The directional light: travelling away from the centre, with the region's irradiance.
    pub fn to_light(&self) -> Light {
        Light::Directional { direction: -self.centre, irradiance: self.irradiance }
    }
}

/// A texel as a point of the cube.
#[derive(Clone, Copy)]
struct Point {
    st: Vec2,
    dir: Vec3,
    value: Vec3,
    weight: f64,
    solid_angle: f32,
}

struct Region {
    face: Option<(u8, [f32; 4])>,
    points: Vec<Point>,
    total: f64,
}

impl Region {
    fn new(face: Option<(u8, [f32; 4])>, points: Vec<Point>) -> Region {
        let total = points.iter().map(|p| p.weight).sum();
        Region { face, points, total }
    }
}

/// Face (0..6) and face coordinates in [-1, 1]² of unit direction `d`.
fn cube_face(d: Vec3) -> (u8, Vec2) {
    let a = d.abs();
    if a.x >= a.y && a.x >= a.z {
        (if d.x >= 0.0 { 0 } else { 1 }, Vec2::new(d.y, d.z) / a.x)
    } else if a.y >= a.z {
        (if d.y >= 0.0 { 2 } else { 3 }, Vec2::new(d.x, d.z) / a.y)
    } else {
        (if d.z >= 0.0 { 4 } else { 5 }, Vec2::new(d.x, d.y) / a.z)
    }
}

/// Segment `env` into `d` regions (`d >= 1`), largest first by construction order: the six
/// faces (or fewer, merged, for `d < 6`), then the halves of each split.
pub fn segment(env: &Environment, d: usize) -> Vec<EnvironmentLight> {
    let d = d.max(1);
    let mut faces: Vec<Vec<Point>> = vec![Vec::new(); 6];
    for y in 0..env.height {
        let omega = env.texel_solid_angle(y);
        for x in 0..env.width {
            let uv = Vec2::new((x as f32 + 0.5) / env.width as f32, (y as f32 + 0.5) / env.height as f32);
            let dir = env.direction(uv);
            let value = env.texels[(y * env.width + x) as usize] * omega;
            let (f, st) = cube_face(dir);
            faces[f as usize].push(Point {
                st,
                dir,
                value,
                weight: (value.x as f64 + value.y as f64 + value.z as f64) / 3.0,
                solid_angle: omega,
            });
        }
    }
    let mut regions: Vec<Region> =
        faces.into_iter().enumerate().map(|(f, p)| Region::new(Some((f as u8, [-1.0, -1.0, 1.0, 1.0])), p)).collect();
    if d < 6 {
        // Keep the d - 1 brightest faces; merge the rest.
        let mut order: Vec<usize> = (0..6).collect();
        order.sort_by(|&a, &b| regions[b].total.total_cmp(&regions[a].total).then(a.cmp(&b)));
        let mut keep = Vec::new();
        let mut merged = Vec::new();
        let mut taken: Vec<Option<Region>> = regions.into_iter().map(Some).collect();
        for (k, &i) in order.iter().enumerate() {
            let r = taken[i].take().expect("each face once");
            if k < d - 1 {
                keep.push(r);
            } else {
                merged.extend(r.points);
            }
        }
        keep.push(Region::new(None, merged));
        regions = keep;
    }
    while regions.len() < d {
        // The splittable region (two texels or more) of largest total; the first on ties.
        let Some(i) = (0..regions.len())
            .filter(|&i| regions[i].points.len() >= 2 && regions[i].face.is_some())
            .max_by(|&a, &b| regions[a].total.total_cmp(&regions[b].total).then(b.cmp(&a)))
        else {
            break; // fewer texels than regions asked for
        };
        let r = regions.remove(i);
        let (a, b) = split(r);
        regions.insert(i, b);
        regions.insert(i, a);
    }
    regions.into_iter().map(to_light).collect()
}

/// Split a face region across its longer side into two of (nearly) equal total.
fn split(r: Region) -> (Region, Region) {
    let (face, rect) = r.face.expect("only face regions are split");
    let axis = if rect[2] - rect[0] >= rect[3] - rect[1] { 0 } else { 1 };
    let mut pts = r.points;
    pts.sort_by(|a, b| a.st[axis].total_cmp(&b.st[axis]));
    let n = pts.len();
    // Split after index k (1 <= k + 1 <= n - 1): the most equal halves; by count when the
    // region is black.
    let mut best = (f64::INFINITY, n / 2 - 1);
    if r.total > 0.0 {
        let mut cum = 0.0;
        for (k, p) in pts.iter().enumerate().take(n - 1) {
            cum += p.weight;
            let imbalance = (2.0 * cum - r.total).abs();
            if imbalance < best.0 {
                best = (imbalance, k);
            }
        }
    }
    let k = best.1;
    let cut = 0.5 * (pts[k].st[axis] + pts[k + 1].st[axis]);
    let right = pts.split_off(k + 1);
    let (mut ra, mut rb) = (rect, rect);
    ra[axis + 2] = cut;
    rb[axis] = cut;
    (Region::new(Some((face, ra)), pts), Region::new(Some((face, rb)), right))
}

fn to_light(r: Region) -> EnvironmentLight {
    let mut sum = DVec3::ZERO;
    let mut value = DVec3::ZERO;
    let mut omega = 0.0f64;
    let mut geometric = DVec3::ZERO;
    for p in &r.points {
        sum += p.dir.as_dvec3() * p.weight;
        value += p.value.as_dvec3();
        omega += p.solid_angle as f64;
        geometric += p.dir.as_dvec3() * p.solid_angle as f64;
    }
    let centre = if sum.length() > 1e-30 {
        sum.normalize()
    } else if geometric.length() > 1e-30 {
        geometric.normalize()
    } else {
        DVec3::Y
    };
    EnvironmentLight {
        centre: centre.as_vec3(),
        irradiance: value.as_vec3(),
        solid_angle: omega as f32,
        texels: r.points.len(),
        face: r.face,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map(w: u32, h: u32, f: impl Fn(u32, u32) -> Vec3) -> Environment {
        let t = (0..w * h).map(|i| f(i % w, i / w)).collect();
        Environment::from_texels(w, h, t, 0.0).unwrap()
    }

    fn total(env: &Environment) -> DVec3 {
        let mut s = DVec3::ZERO;
        for y in 0..env.height {
            for x in 0..env.width {
                s += (env.texels[(y * env.width + x) as usize] * env.texel_solid_angle(y)).as_dvec3();
            }
        }
        s
    }

    #[test]
    fn one_bright_texel_gives_one_light_with_all_of_it() {
        let (bx, by) = (40u32, 9u32);
        let env = map(64, 32, |x, y| if (x, y) == (bx, by) { Vec3::new(100.0, 50.0, 25.0) } else { Vec3::ZERO });
        let expected = Vec3::new(100.0, 50.0, 25.0) * env.texel_solid_angle(by);
        let centre = env.direction(Vec2::new((bx as f32 + 0.5) / 64.0, (by as f32 + 0.5) / 32.0));
        for d in [1, 2, 5, 6, 7, 16, 64] {
            let lights = segment(&env, d);
            assert_eq!(lights.len(), d);
            let lit: Vec<_> = lights.iter().filter(|l| l.irradiance.max_element() > 0.0).collect();
            assert_eq!(lit.len(), 1, "D = {d}");
            assert!((lit[0].irradiance - expected).abs().max_element() <= 1e-6 * expected.max_element());
            assert!((lit[0].centre - centre).length() < 1e-5, "{} vs {centre}", lit[0].centre);
            match lit[0].to_light() {
                Light::Directional { direction, irradiance } => {
                    assert!((direction + centre).length() < 1e-5);
                    assert_eq!(irradiance, lit[0].irradiance);
                }
                l => panic!("{l:?}"),
            }
        }
    }

    #[test]
    fn regions_sum_to_the_map_and_d_regions_come_back() {
        let env = map(128, 64, |x, y| {
            let sun = if (70..73).contains(&x) && (18..20).contains(&y) { 500.0 } else { 0.0 };
            Vec3::new(0.5 + sun + (x as f32 * 0.1).sin().abs(), 0.7 + sun, 1.0 + (y as f32 * 0.2).cos().abs())
        });
        let t = total(&env);
        for d in 1..=64 {
            let lights = segment(&env, d);
            assert_eq!(lights.len(), d);
            let s = lights.iter().fold(DVec3::ZERO, |a, l| a + l.irradiance.as_dvec3());
            assert!(((s - t).abs() / t).max_element() < 1e-5, "D = {d}: {s} vs {t}");
            let n: usize = lights.iter().map(|l| l.texels).sum();
            assert_eq!(n, 128 * 64);
            let omega: f32 = lights.iter().map(|l| l.solid_angle).sum();
            assert!((omega - 4.0 * std::f32::consts::PI).abs() < 1e-3);
            assert!(lights.iter().all(|l| (l.centre.length() - 1.0).abs() < 1e-4));
        }
        // The sun ends up in a small region of its own once there are enough regions.
        let lights = segment(&env, 64);
        let brightest = lights.iter().max_by(|a, b| a.irradiance.y.total_cmp(&b.irradiance.y)).unwrap();
        assert!(brightest.solid_angle < 0.1, "{}", brightest.solid_angle);
    }
}
