//! Environment segmentation into directional lights: the cube-map median cut of Tandianus,
//! Johan and Seah 2010, section 5 ("Environment Map Segmentation"), after Debevec's median cut.
//!
//! Every texel of the equirectangular map is a point on the cube of directions (the face of its
//! centre's major axis, at the face coordinates of its centre) carrying its radiance times its
//! exact solid angle, `L · Ω` (W/m²: the irradiance that texel alone gives a surface facing
//! it). The segmentation starts from the six cube faces and repeatedly takes a region and
//! splits it, across its longer side, into two regions of (as nearly as the texels allow) equal
//! total, until `D` regions remain. Each region becomes a directional light travelling from its
//! `L · Ω`-weighted centre direction.
//!
//! **Which region is split** ([`SplitRule`]). The paper splits the region of largest total. On
//! a map with a sun that wastes lights: the sun's region stays the largest however small it
//! gets, so it is cut again and again into slivers around a few texels (on `sky.exr`, 5 of 24
//! lights within 3° of the sun; on `studio.exr` 11 of 24 within 3° of the brightest texel). We
//! split by default ([`SplitRule::Radius`]) the region of largest `total × angular radius`,
//! `sqrt(2 Σ w · Σ w (1 − ω·ĉ))` (w the texel's `L · Ω`, ω its direction, ĉ the region's
//! weighted centre): the flux-weighted direction error of standing for the region by one
//! direction, linear in the angle as a caustic's displacement is (4 of 24 on both maps, the
//! sun's light within 0.4° of it; the retired `env_segments` example, table in
//! `docs/benchmarks.md`). A region of one texel (a one-texel sun) has no spread and is never
//! split; a black region neither. When no region has any spread left (a map black but for a
//! few texels), the remaining splits go to the region of largest solid angle, so that `D`
//! regions still come back (black ones: the renderer skips lights of zero irradiance).
//!
//! **What a light carries.** `irradiance` is the region's total `Σ L · Ω` (the paper's light
//! power; the regions sum to the map's total). The light itself
//! ([`EnvironmentLight::to_light`]) carries `facing`, the irradiance the region gives a surface
//! facing its centre, `Σ L · Ω · max(0, ω·ĉ)`: with it a diffuse surface that sees the whole
//! region gets exactly the region's irradiance (`E (n·ĉ) = n · Σ L Ω ω` when ĉ is the direction
//! of `Σ L Ω ω`), so a floor under a uniform sky gets π L up to the regions cut by the horizon.
//! It is lower than the total by the region's spread (4 % for a 24-region uniform sky): what a
//! caustic object of constant cross-section (a sphere) receives from a broad region is
//! underestimated by as much. The sun's compact region loses nothing measurable.
//!
//! **Rotation.** The segmentation is made in the map's own frame ([`segment_map`]); the scene's
//! `rotate_y_deg` (or a live rotation) only rotates the lights' centres ([`rotate`]): exact, and
//! no re-segmentation, so no flicker while the environment turns.
//!
//! **Occlusion** (section 5: per caustic object, each region's unoccluded part):
//! [`region_visibility`](crate::raycast::region_visibility).
//!
//! With `D < 6`, the `6 - D + 1` faces of least total are merged into one region.

use super::Light;
use super::environment::Environment;
use glam::{DVec3, Mat3, Vec2, Vec3};
use std::f32::consts::PI;

/// One region of the segmentation and the directional light that stands for it.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvironmentLight {
    /// Unit direction toward the region's `L · Ω`-weighted centre (toward the sky).
    pub centre: Vec3,
    /// Total `Σ L · Ω` of the region's texels, W/m² (per channel).
    pub irradiance: Vec3,
    /// Irradiance (W/m², per channel) the region gives a surface facing `centre`:
    /// `Σ L · Ω · max(0, ω·centre)`; what the directional light carries.
    pub facing: Vec3,
    /// Solid angle of the region's texels, sr.
    pub solid_angle: f32,
    /// Texels in the region.
    pub texels: usize,
    /// The region's texels (indices `y · width + x` into the map), in no particular order.
    pub members: Vec<u32>,
    /// Cube face (0..6: +X, -X, +Y, -Y, +Z, -Z) and rectangle `[s0, t0, s1, t1]` in its face
    /// coordinates (of the map's own frame); `None` for the merged region of several faces
    /// (`D < 6`).
    pub face: Option<(u8, [f32; 4])>,
}

impl EnvironmentLight {
    /// The directional light: travelling away from the centre, with the irradiance the region
    /// gives a surface facing it.
    pub fn to_light(&self) -> Light {
        Light::Directional { direction: -self.centre, irradiance: self.facing }
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
    index: u32,
}

struct Region {
    face: Option<(u8, [f32; 4])>,
    points: Vec<Point>,
    total: f64,
    /// Weighted angular spread `Σ w − |Σ w ω|` (= `Σ w (1 − ω·ĉ)`): the split criterion.
    spread: f64,
    solid_angle: f64,
}

impl Region {
    fn new(face: Option<(u8, [f32; 4])>, points: Vec<Point>) -> Region {
        let total: f64 = points.iter().map(|p| p.weight).sum();
        let sum = points.iter().fold(DVec3::ZERO, |a, p| a + p.dir.as_dvec3() * p.weight);
        // Relative rounding of the f64 sums is ~1e-16 per texel: below 1e-9 of the total is
        // no spread (one texel, or a black region).
        let spread = (total - sum.length()).max(0.0);
        let spread = if spread <= 1e-9 * total { 0.0 } else { spread };
        let solid_angle = points.iter().map(|p| p.solid_angle as f64).sum();
        Region { face, points, total, spread, solid_angle }
    }
}

/// Face (0..6) and face coordinates in [-1, 1]² of unit direction `d`. The side faces (±X, ±Z)
/// have the height (y) as their first coordinate, so their first cut (across the first
/// coordinate of a square) runs along the horizon's side of the map: on a map symmetric about
/// the horizon, on the horizon itself, and no region straddles it.
fn cube_face(d: Vec3) -> (u8, Vec2) {
    let a = d.abs();
    if a.x >= a.y && a.x >= a.z {
        (if d.x >= 0.0 { 0 } else { 1 }, Vec2::new(d.y, d.z) / a.x)
    } else if a.y >= a.z {
        (if d.y >= 0.0 { 2 } else { 3 }, Vec2::new(d.x, d.z) / a.y)
    } else {
        (if d.z >= 0.0 { 4 } else { 5 }, Vec2::new(d.y, d.x) / a.z)
    }
}

/// Unit direction, in the map's own frame (no rotation), of map coordinates (u, v): the
/// orientation of `docs/scene-format.md`.
pub fn map_direction(uv: Vec2) -> Vec3 {
    let phi = (uv.x - 0.5) * 2.0 * PI;
    let theta = uv.y * PI;
    let (st, ct) = theta.sin_cos();
    Vec3::new(st * phi.sin(), ct, -st * phi.cos())
}

/// The map-to-world rotation of an environment turned by `rotate_y` radians about +Y (the
/// scene format's `rotate_y_deg`): `R_y(rotate_y)`.
pub fn rotation(rotate_y: f32) -> Mat3 {
    Mat3::from_rotation_y(rotate_y)
}

/// Lights of [`segment_map`] turned into the world by `rotate_y` radians about +Y.
pub fn rotate(lights: &[EnvironmentLight], rotate_y: f32) -> Vec<EnvironmentLight> {
    let r = rotation(rotate_y);
    lights.iter().map(|l| EnvironmentLight { centre: (r * l.centre).normalize(), ..l.clone() }).collect()
}

/// Segment `env` into `d` regions (`d >= 1`), centres in world space (the map's
/// `rotate_y` applied): [`segment_map`] then [`rotate`].
pub fn segment(env: &Environment, d: usize) -> Vec<EnvironmentLight> {
    rotate(&segment_map(env, d), env.rotate_y)
}

/// Which region the median cut splits next.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SplitRule {
    /// The paper's: the region of largest total `Σ L · Ω`, among those with any angular spread
    /// (so a one-texel sun is never cut into slivers).
    Total,
    /// The region of largest weighted angular spread `Σ w (1 − ω·ĉ)` (variance minimisation).
    Spread,
    /// The region of largest `total × angular radius`, `sqrt(2 Σ w · Σ w (1 − ω·ĉ))`: the
    /// flux-weighted direction error, linear in the angle (the caustic's displacement).
    #[default]
    Radius,
}

/// Segment `env` into `d` regions (`d >= 1`) in the map's own frame (its rotation ignored):
/// the six faces (or fewer, merged, for `d < 6`), then the halves of each split, each in the
/// place of the region it was cut from. The default [`SplitRule`].
pub fn segment_map(env: &Environment, d: usize) -> Vec<EnvironmentLight> {
    segment_map_with(env, d, SplitRule::default())
}

/// [`segment_map`] with a given split rule.
pub fn segment_map_with(env: &Environment, d: usize, rule: SplitRule) -> Vec<EnvironmentLight> {
    let d = d.max(1);
    let mut faces: Vec<Vec<Point>> = vec![Vec::new(); 6];
    for index in 0..env.width * env.height {
        let (f, p) = point(env, index);
        faces[f as usize].push(p);
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
    cut(&mut regions, d, rule);
    regions.into_iter().map(to_light).collect()
}

/// Texel `index` (`y · width + x`) of `env` as a point of the cube, and its face.
fn point(env: &Environment, index: u32) -> (u8, Point) {
    let (x, y) = (index % env.width, index / env.width);
    let omega = env.texel_solid_angle(y);
    let uv = Vec2::new((x as f32 + 0.5) / env.width as f32, (y as f32 + 0.5) / env.height as f32);
    let dir = map_direction(uv);
    let value = env.texels[index as usize] * omega;
    let (f, st) = cube_face(dir);
    let weight = (value.x as f64 + value.y as f64 + value.z as f64) / 3.0;
    (f, Point { st, dir, value, weight, solid_angle: omega, index })
}

/// Split `region` (one of [`segment_map`]'s, in the map's own frame) further into up to `k`
/// sub-regions by the same median cut (rule [`SplitRule::Radius`]), the sub-regions as lights
/// (their `centre`, `irradiance` and `facing` their own). A region that cannot be split (one
/// texel, no spread, the merged region of `D < 6`) comes back alone.
pub fn subdivide(env: &Environment, region: &EnvironmentLight, k: usize) -> Vec<EnvironmentLight> {
    let Some(face) = region.face else {
        return vec![region.clone()];
    };
    let points = region.members.iter().map(|&i| point(env, i).1).collect();
    let mut regions = vec![Region::new(Some(face), points)];
    cut(&mut regions, k.max(1), SplitRule::Radius);
    regions.into_iter().filter(|r| r.total > 0.0).map(to_light).collect()
}

/// The median cut proper: split regions of `regions` until `d` remain.
fn cut(regions: &mut Vec<Region>, d: usize, rule: SplitRule) {
    while regions.len() < d {
        let splittable = |i: &usize| regions[*i].points.len() >= 2 && regions[*i].face.is_some();
        // The region of largest spread (the first on ties); with no spread anywhere, the one
        // of largest solid angle.
        let key = |r: &Region| match rule {
            SplitRule::Total => r.total,
            SplitRule::Spread => r.spread,
            SplitRule::Radius => (2.0 * r.spread * r.total).sqrt(),
        };
        let by_spread = (0..regions.len())
            .filter(splittable)
            .filter(|&i| regions[i].spread > 0.0)
            .max_by(|&a, &b| key(&regions[a]).total_cmp(&key(&regions[b])).then(b.cmp(&a)));
        let pick = by_spread.or_else(|| {
            (0..regions.len())
                .filter(splittable)
                .max_by(|&a, &b| regions[a].solid_angle.total_cmp(&regions[b].solid_angle).then(b.cmp(&a)))
        });
        let Some(i) = pick else {
            break; // fewer texels than regions asked for
        };
        let r = regions.remove(i);
        let (a, b) = split(r);
        regions.insert(i, b);
        regions.insert(i, a);
    }
}

/// Split a face region across its longer side into two of (nearly) equal total.
fn split(r: Region) -> (Region, Region) {
    let (face, rect) = r.face.expect("only face regions are split");
    let axis = if rect[2] - rect[0] >= rect[3] - rect[1] { 0 } else { 1 };
    let mut pts = r.points;
    pts.sort_by(|a, b| a.st[axis].total_cmp(&b.st[axis]).then(a.index.cmp(&b.index)));
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
    let facing =
        r.points.iter().fold(DVec3::ZERO, |a, p| a + p.value.as_dvec3() * p.dir.as_dvec3().dot(centre).max(0.0));
    EnvironmentLight {
        centre: centre.as_vec3(),
        irradiance: value.as_vec3(),
        facing: facing.as_vec3(),
        solid_angle: omega as f32,
        texels: r.points.len(),
        members: r.points.iter().map(|p| p.index).collect(),
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
                    assert_eq!(irradiance, lit[0].facing);
                    assert!((lit[0].facing - expected).abs().max_element() <= 1e-6 * expected.max_element());
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

    #[test]
    fn a_uniform_sky_gives_a_floor_pi_l() {
        // Irradiance on an upward floor from the lights, Σ E max(0, n·ĉ), against π L: exact but
        // for regions cut by the horizon (none from D = 12 on: the map is symmetric about it,
        // so every side face's first cut falls on it) and the texels' own extent. With D = 6
        // the four side faces straddle the horizon and light the floor from it: only the top
        // face counts.
        let env = map(128, 64, |_, _| Vec3::ONE);
        for d in [6, 12, 24, 48] {
            let lights = segment(&env, d);
            let e: f32 = lights.iter().map(|l| l.facing.x * l.centre.y.max(0.0)).sum();
            eprintln!("D = {d}: floor irradiance {e} = π L × {}", e / PI);
            if d >= 12 {
                assert!((e / PI - 1.0).abs() < 0.005, "D = {d}: {e} vs π");
            }
        }
    }

    #[test]
    fn a_sun_of_one_texel_over_a_sky_gets_one_light() {
        // A dim sky and a one-texel sun of 10⁵ times its radiance (half the map's L·Ω, as in
        // sky.exr's brightest region): exactly one light near the sun (no slivers of sky around
        // it, which the paper's largest-total rule makes), holding the sun, aimed at it.
        let (bx, by) = (300u32, 40u32);
        let env = map(512, 256, |x, y| if (x, y) == (bx, by) { Vec3::splat(1e5) } else { Vec3::splat(0.5) });
        let sun = env.direction(Vec2::new((bx as f32 + 0.5) / 512.0, (by as f32 + 0.5) / 256.0));
        let sun_e = 1e5 * env.texel_solid_angle(by);
        for d in [12, 24, 48] {
            let lights = segment(&env, d);
            let near: Vec<_> = lights.iter().filter(|l| l.centre.dot(sun) > (5f32).to_radians().cos()).collect();
            let holder = lights.iter().find(|l| l.members.contains(&(by * 512 + bx))).unwrap();
            eprintln!(
                "D = {d}: {} lights within 5° of the sun; its region: {:.4} sr, {:.2}° from it, {:.3} of its L·Ω is sun",
                near.len(),
                holder.solid_angle,
                holder.centre.dot(sun).clamp(-1.0, 1.0).acos().to_degrees(),
                sun_e / holder.irradiance.x
            );
            assert_eq!(near.len(), 1, "D = {d}: {} lights within 5° of the sun", near.len());
            assert!(near[0].irradiance.x >= sun_e, "D = {d}");
            assert!(near[0].centre.dot(sun) > 1f32.to_radians().cos(), "D = {d}");
            assert!(near[0].members.contains(&(by * 512 + bx)));
        }
    }

    #[test]
    fn subdivide_partitions_a_region() {
        // A region cut again into K sub-regions: they partition its texels and its L·Ω, each
        // centre lies within the region's extent; a region lit by one texel gives one lit
        // sub-region (so `env_taps` gives it no taps).
        let env = map(128, 64, |x, y| Vec3::new(0.5 + (x as f32 * 0.1).sin().abs(), 0.7, 1.0 + y as f32 * 0.01));
        let lights = segment_map(&env, 24);
        for l in &lights {
            let subs = subdivide(&env, l, 16);
            assert!(!subs.is_empty() && subs.len() <= 16);
            let mut members: Vec<u32> = subs.iter().flat_map(|s| s.members.clone()).collect();
            members.sort();
            let mut want = l.members.clone();
            want.sort();
            assert_eq!(members, want);
            let e = subs.iter().fold(Vec3::ZERO, |a, s| a + s.irradiance);
            assert!(((e - l.irradiance) / l.irradiance).abs().max_element() < 1e-4, "{e} vs {}", l.irradiance);
            let spread = l.members.iter().map(|&i| point(&env, i).1.dir.dot(l.centre)).fold(1.0f32, f32::min);
            assert!(subs.iter().all(|s| s.centre.dot(l.centre) >= spread - 1e-4));
        }
        let one = map(64, 32, |x, y| if (x, y) == (10, 10) { Vec3::ONE } else { Vec3::ZERO });
        let lit: Vec<_> = segment_map(&one, 6).into_iter().filter(|l| l.facing.max_element() > 0.0).collect();
        let subs = subdivide(&one, &lit[0], 16);
        assert_eq!(subs.len(), 1, "one lit sub-region (the black ones are dropped)");
        assert!(subs[0].members.contains(&(10 * 64 + 10)));
        assert_eq!(subs[0].irradiance, lit[0].irradiance);
    }

    #[test]
    fn rotation_turns_the_lights_without_resegmenting() {
        let texels: Vec<Vec3> = (0..64 * 32).map(|i| Vec3::splat(1.0 + (i % 7) as f32 + (i / 64) as f32)).collect();
        let a = Environment::from_texels(64, 32, texels.clone(), 0.0).unwrap();
        let b = Environment::from_texels(64, 32, texels, 70.0).unwrap();
        let la = segment(&a, 24);
        let lb = segment(&b, 24);
        for (x, y) in la.iter().zip(&lb) {
            assert_eq!(x.members, y.members);
            assert_eq!(x.irradiance, y.irradiance);
            // The rotated light points where the rotated map shows the region's centre.
            let uv = a.uv(x.centre);
            assert!((b.direction(uv) - y.centre).length() < 1e-5);
        }
    }
}
