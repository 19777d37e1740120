//! The GPU beams' transmitted branch traced on the CPU: a light ray through the specular
//! objects with every dielectric interface transmitting with weight 1 − F (total internal
//! reflection followed) and mirrors and conductors reflecting with their reflectance, as `beam_refine`'s branch 0 (`shaders/shared/beam_trace.wgsl`,
//! `trace_edge`), with its path signature. Ground truth for the flux the transmitted beams carry
//! (`tests/gpu_beams.rs`) and for where their paths change (`examples/beam_paths.rs`).

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

/// The transmitted branch of the ray from `o0` along unit `d0` (`Path`).
pub fn trace(scene: &Scene, accel: &Accel, o0: Vec3, d0: Vec3, max_depth: u32) -> Path {
    let (mut o, mut d) = (o0, d0);
    let mut p = Path { fate: Fate::Missed, weight: 1.0, sig: 0, land: u32::MAX, layer1: false };
    let mut inside = false;
    let mut depth = 0;
    loop {
        let hit = accel.intersect(o, d, 1e30);
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
            Material::Dielectric { ior, ext_ior } => {
                let eta = if front { ior / ext_ior } else { ext_ior / ior };
                let (f, cos_t) = fresnel_dielectric(-d.dot(ns), eta);
                refl = f >= 1.0;
                if !refl {
                    nd = refract(d, ns, eta, cos_t);
                    if nd.dot(ng) >= 0.0 {
                        let (f2, c2) = fresnel_dielectric(-d.dot(ng), eta);
                        if f2 >= 1.0 {
                            refl = true;
                        } else {
                            nd = refract(d, ng, eta, c2);
                        }
                    }
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
