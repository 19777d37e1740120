//! The GPU beams' transmitted branch traced on the CPU: a light ray through the specular
//! objects with every dielectric interface transmitting with weight 1 − F (total internal
//! reflection followed) and mirrors and conductors reflecting with their reflectance, as `beam_refine`'s branch 0 (`shaders/shared/beam_trace.wgsl`,
//! `trace_edge`), with its path signature. Ground truth for the flux the transmitted beams carry
//! (`tests/gpu/beams/`) and for where their paths change (the retired `beam_paths` example: docs/benchmarks.md, "Retired measurement programs").

use super::geometry::{Accel, spawn};
use super::optics::{fresnel_conductor, fresnel_dielectric, reflect, refract};
use caustics::scene::{Material, Scene};
use glam::Vec3;

/// Where a light ray's transmitted branch ends.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fate {
    /// It meets no specular object that casts caustics first.
    Missed,
    /// On a diffuse surface or out of the scene, outside dielectrics: a caustic path.
    Caustic,
    /// Past the interactions allowed.
    Deep,
    /// On a diffuse surface or out of the scene while "inside" a dielectric.
    Inside,
}

/// One ray's transmitted branch (from `o0` along unit `d0`, at most `max_depth` specular
/// interactions): its fate, weight (the Fresnel and mirror factors, first channel),
/// `beam_refine`'s signature (objects, reflected or refracted, side) and landing object
/// (`u32::MAX`: out of the scene), and whether it crossed the medium from one specular
/// interaction to another (a second caster layer).
#[derive(Clone, Copy, Debug)]
pub struct Path {
    pub fate: Fate,
    pub weight: f32,
    pub sig: u32,
    pub land: u32,
    pub layer1: bool,
}

/// A dielectric interface met along unit `d` (shading normal `ns` and geometric normal `ng` on
/// the incident side, `eta` the ratio of the indices): its Fresnel reflectance (1: total
/// internal reflection) and the refracted direction, `None` where the light reflects totally
/// (also where refraction about `ns` would cross the geometric surface and about `ng` reflects
/// totally).
fn interface(d: Vec3, ns: Vec3, ng: Vec3, eta: f32) -> (f32, Option<Vec3>) {
    let (f, cos_t) = fresnel_dielectric(-d.dot(ns), eta);
    if f >= 1.0 {
        return (f, None);
    }
    let td = refract(d, ns, eta, cos_t);
    if td.dot(ng) < 0.0 {
        return (f, Some(td));
    }
    let (f2, c2) = fresnel_dielectric(-d.dot(ng), eta);
    (f, (f2 < 1.0).then(|| refract(d, ng, eta, c2)))
}

/// The transmitted branch of the ray from `o0` along unit `d0` (`Path`).
pub fn trace(scene: &Scene, accel: &Accel, o0: Vec3, d0: Vec3, max_depth: u32) -> Path {
    trace_segments(scene, accel, o0, d0, max_depth, &mut Vec::new())
}

/// A straight piece of a traced branch: from `o` along unit `d` for `len` (to the next surface;
/// `f32::INFINITY`: out of the scene), carrying `weight` of the light (first channel), inside a
/// dielectric or not.
#[derive(Clone, Copy, Debug)]
pub struct Segment {
    pub o: Vec3,
    pub d: Vec3,
    pub len: f32,
    pub weight: f32,
    pub inside: bool,
}

/// [`trace`], also appending the branch's segments (from `o0` on) to `segments`.
pub fn trace_segments(
    scene: &Scene,
    accel: &Accel,
    o0: Vec3,
    d0: Vec3,
    max_depth: u32,
    segments: &mut Vec<Segment>,
) -> Path {
    let (mut o, mut d) = (o0, d0);
    let mut p = Path { fate: Fate::Missed, weight: 1.0, sig: 0, land: u32::MAX, layer1: false };
    let mut inside = false;
    let mut depth = 0;
    loop {
        let hit = accel.intersect(o, d, 1e30);
        segments.push(Segment { o, d, len: hit.map_or(f32::INFINITY, |h| h.t), weight: p.weight, inside });
        let specular = hit.filter(|h| scene.materials[scene.objects[h.object as usize].material].is_specular());
        let Some(h) = specular else {
            if depth > 0 {
                p.fate = if inside { Fate::Inside } else { Fate::Caustic };
                p.land = hit.map_or(u32::MAX, |h| h.object);
            }
            return p;
        };
        if depth == 0 && !scene.objects[h.object as usize].caustic_caster {
            // (the light meets a specular object that casts no caustics first)
            return p;
        }
        if depth >= max_depth {
            p.fate = Fate::Deep;
            return p;
        }
        p.layer1 |= depth > 0 && !inside;
        let front = d.dot(h.ng) < 0.0;
        let ng = if front { h.ng } else { -h.ng };
        let mut ns = if front { h.ns } else { -h.ns };
        if -d.dot(ns) <= 0.0 {
            ns = ng;
        }
        let mut refl = true;
        let mut nd = Vec3::ZERO;
        match scene.materials[scene.objects[h.object as usize].material] {
            Material::Dielectric { ior, ext_ior, .. } => {
                let eta = if front { ior / ext_ior } else { ext_ior / ior };
                let (f, td) = interface(d, ns, ng, eta);
                if let Some(td) = td {
                    refl = false;
                    nd = td;
                }
                if f < 1.0 {
                    p.weight *= 1.0 - f;
                }
            }
            Material::Mirror { reflectance } => p.weight *= reflectance.x,
            Material::Conductor { eta, k } => p.weight *= fresnel_conductor((-d.dot(ns)).clamp(0.0, 1.0), eta, k).x,
            Material::Diffuse { .. } => {} // (not specular: ended above)
        }
        if refl {
            nd = reflect(d, ns);
            if nd.dot(ng) <= 0.0 {
                nd = reflect(d, ng);
            }
        } else {
            inside = front;
        }
        p.sig = (p.sig.wrapping_mul(31).wrapping_add(h.object * 8 + (refl as u32) * 2 + front as u32 + 1)) & 0xffffff;
        o = spawn(h.p, h.ng, nd);
        d = nd;
        depth += 1;
    }
}

/// A leaf of a light ray's full path tree ([`tree`]): a caustic path (it ends on a diffuse
/// surface or leaves the scene, outside dielectrics), where it reflected partially (`chosen`,
/// bit k: at interaction k; `count` times in all, interactions past 31 counted but without a
/// bit), its weight (the Fresnel and mirror factors, first channel) and the object it lands on
/// (`u32::MAX`: out of the scene).
#[derive(Clone, Copy, Debug)]
pub struct Leaf {
    pub chosen: u32,
    pub count: u32,
    pub weight: f64,
    pub land: u32,
}

/// Every caustic path of the ray from `o0` along unit `d0` with at most `max_depth` specular
/// interactions, each partial reflection at a dielectric followed as well as the transmission
/// (total internal reflection followed, mirrors and conductors reflecting with their
/// reflectance, as [`trace`]); branches whose weight falls below `min_weight` are dropped.
/// `leaf` gets each path's [`Leaf`]. Ground truth for the beams' branches together, the
/// residual branch's light (`tests/gpu/beams/`).
pub fn tree(
    scene: &Scene,
    accel: &Accel,
    o0: Vec3,
    d0: Vec3,
    max_depth: u32,
    min_weight: f64,
    leaf: &mut impl FnMut(Leaf),
) {
    struct Walk<'a, F> {
        scene: &'a Scene,
        accel: &'a Accel,
        max_depth: u32,
        min_weight: f64,
        leaf: &'a mut F,
    }
    /// A branch's state: its weight, interactions so far, whether it is inside glass, and its
    /// partial reflections (bit k: at interaction k; their count).
    #[derive(Clone, Copy)]
    struct Branch {
        w: f64,
        depth: u32,
        inside: bool,
        chosen: u32,
        count: u32,
    }
    impl<F: FnMut(Leaf)> Walk<'_, F> {
        fn step(&mut self, o: Vec3, d: Vec3, b: Branch) {
            let Branch { w, depth, inside, chosen, count } = b;
            if w < self.min_weight {
                return;
            }
            let sc = self.scene;
            let hit = self.accel.intersect(o, d, 1e30);
            let specular = hit.filter(|h| sc.materials[sc.objects[h.object as usize].material].is_specular());
            let Some(h) = specular else {
                if depth > 0 && !inside {
                    (self.leaf)(Leaf { chosen, count, weight: w, land: hit.map_or(u32::MAX, |h| h.object) });
                }
                return;
            };
            if (depth == 0 && !sc.objects[h.object as usize].caustic_caster) || depth >= self.max_depth {
                return;
            }
            let front = d.dot(h.ng) < 0.0;
            let ng = if front { h.ng } else { -h.ng };
            let mut ns = if front { h.ns } else { -h.ns };
            if -d.dot(ns) <= 0.0 {
                ns = ng;
            }
            let mut rd = reflect(d, ns);
            if rd.dot(ng) <= 0.0 {
                rd = reflect(d, ng);
            }
            let (ro, next) = (spawn(h.p, h.ng, rd), depth + 1);
            let after = |w: f64| Branch { w, depth: next, ..b };
            match sc.materials[sc.objects[h.object as usize].material] {
                Material::Dielectric { ior, ext_ior, .. } => {
                    let eta = if front { ior / ext_ior } else { ext_ior / ior };
                    let (f, td) = interface(d, ns, ng, eta);
                    if let Some(td) = td {
                        let f = f64::from(f);
                        self.step(spawn(h.p, h.ng, td), td, Branch { inside: front, ..after(w * (1.0 - f)) });
                        let bit = if depth < 32 { 1 << depth } else { 0 };
                        self.step(ro, rd, Branch { chosen: chosen | bit, count: count + 1, ..after(w * f) });
                    } else {
                        self.step(ro, rd, after(w));
                    }
                }
                Material::Mirror { reflectance } => self.step(ro, rd, after(w * f64::from(reflectance.x))),
                Material::Conductor { eta, k } => {
                    let r = fresnel_conductor((-d.dot(ns)).clamp(0.0, 1.0), eta, k).x;
                    self.step(ro, rd, after(w * f64::from(r)));
                }
                Material::Diffuse { .. } => {} // (not specular: ended above)
            }
        }
    }
    let start = Branch { w: 1.0, depth: 0, inside: false, chosen: 0, count: 0 };
    Walk { scene, accel, max_depth, min_weight, leaf }.step(o0, d0, start);
}

/// Whether a path that reflected partially `count` times (bit k of `chosen`: at interaction
/// k) is the beams' residual branch's: no branch with fixed reflections follows it, of the
/// `fixed` traced (the transmitted branch none; branch k + 1 one reflection at interaction k).
/// As `residual_owns` in `shaders/shared/beam_trace.wgsl`.
pub fn residual_owns(chosen: u32, count: u32, fixed: u32) -> bool {
    count >= 2 || (count == 1 && (chosen == 0 || chosen.trailing_zeros() + 1 >= fixed))
}
