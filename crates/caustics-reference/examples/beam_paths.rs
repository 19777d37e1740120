//! The light of a spot light's transmitted beam branch, traced on the CPU (diagnostic for the
//! beams on mesh casters: docs/benchmarks.md, "Beams on a mesh caster: the deficit found").
//! `cargo run --release -p caustics-reference --example beam_paths -- SCENE [N] [MAX_DEPTH] [GRID]`
//! prints, for the scene's first light (a spot), the flux (W, first channel) over N² stratified
//! directions of its cone that meets a specular object, that leaves on the transmitted branch
//! (every dielectric interface transmitting with weight 1 − F, total internal reflection
//! followed, as `beam_refine`'s branch 0) to a diffuse surface or out of the scene, that passes
//! MAX_DEPTH interactions, and that ends inside a dielectric; then, over a GRID² grid of the
//! spot's light face, the light in triangles whose three corners take one path (the
//! `beam_refine` signature) or not, and in those whose corners take three paths.
use caustics::scene::{Light, Scene};
use caustics_reference::reference::branch::{Fate, trace};
use caustics_reference::reference::emit::Emitter;
use caustics_reference::reference::geometry::Accel;
use glam::{Vec2, Vec3};
use rayon::prelude::*;

fn main() {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let scene = Scene::load(std::path::Path::new(&a[0])).unwrap_or_else(|e| panic!("{e}"));
    let arg = |k: usize, default: u32| a.get(k).map_or(default, |s| s.parse().unwrap());
    let (n, max_depth, g) = (arg(1, 1000), arg(2, 16), arg(3, 128) as usize);
    let accel = Accel::new(&scene);
    let light = &scene.lights[0];
    let em = Emitter::full(light, Vec3::ZERO, 10.0);
    // Flux by fate: onto a caster, caustic, of it with a second layer, deep, inside.
    let t = (0..n)
        .into_par_iter()
        .map(|j| {
            let mut acc = [0.0f64; 5];
            for i in 0..n {
                let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                let Some(e) = em.sample(u) else { continue };
                let p = trace(&scene, &accel, e.origin, e.dir, max_depth);
                let w = f64::from(e.flux_n.x) / f64::from(n * n);
                if p.fate != Fate::Missed {
                    acc[0] += w;
                }
                match p.fate {
                    Fate::Caustic => {
                        acc[1] += w * f64::from(p.weight);
                        if p.layer1 {
                            acc[2] += w * f64::from(p.weight);
                        }
                    }
                    Fate::Deep => acc[3] += w * f64::from(p.weight),
                    Fate::Inside => acc[4] += w * f64::from(p.weight),
                    Fate::Missed => {}
                }
            }
            acc
        })
        .reduce(|| [0.0; 5], |x, y| std::array::from_fn(|k| x[k] + y[k]));
    println!(
        "onto specular objects {:.4} W; transmitted branch on caustic paths {:.4} W (of it after a second layer {:.4} W); past {max_depth} interactions {:.4} W; ended inside {:.4} W",
        t[0], t[1], t[2], t[3], t[4]
    );
    let Light::Spot { position, direction, cone_angle, .. } = light else { return };
    // The light face of a spot (lightspace.rs: a square frustum around the cone).
    let tan = cone_angle.tan();
    let axis = direction.normalize();
    let right = axis.any_orthonormal_vector();
    let up = axis.cross(right);
    let dir = |x: f32, y: f32| (axis + right * (x * tan) + up * (y * tan)).normalize();
    let corner = |i: usize, j: usize| {
        let p = trace(
            &scene,
            &accel,
            *position,
            dir(-1.0 + 2.0 * i as f32 / g as f32, -1.0 + 2.0 * j as f32 / g as f32),
            max_depth,
        );
        (p.fate == Fate::Caustic, p.fate != Fate::Missed, p.sig, p.land)
    };
    let pts: Vec<_> = (0..=g).into_par_iter().flat_map_iter(|j| (0..=g).map(move |i| corner(i, j))).collect();
    let at = |i: usize, j: usize| pts[j * (g + 1) + i];
    let same = |a: (bool, bool, u32, u32), b: (bool, bool, u32, u32)| a.0 && b.0 && a.2 == b.2 && a.3 == b.3;
    let cell = (2.0 * tan / g as f32).powi(2) / 2.0;
    let (mut one, mut other, mut three) = (0.0f64, 0.0f64, 0.0f64);
    for j in 0..g {
        for i in 0..g {
            for tri in [[at(i, j), at(i + 1, j), at(i + 1, j + 1)], [at(i, j), at(i + 1, j + 1), at(i, j + 1)]] {
                if !tri.iter().any(|p| p.1) {
                    continue;
                }
                let d = dir(-1.0 + 2.0 * (i as f32 + 0.5) / g as f32, -1.0 + 2.0 * (j as f32 + 0.5) / g as f32);
                // (the triangle's solid angle: its area on the face times cos³ of its angle)
                let w = f64::from(light.intensity_toward(d).x * cell * d.dot(axis).powi(3));
                if same(tri[0], tri[1]) && same(tri[1], tri[2]) {
                    one += w;
                } else {
                    other += w;
                    let all = tri.iter().all(|p| p.0);
                    if all && !same(tri[0], tri[1]) && !same(tri[1], tri[2]) && !same(tri[0], tri[2]) {
                        three += w;
                    }
                }
            }
        }
    }
    println!(
        "grid {g}²: light toward triangles meeting a specular object whose corners take one caustic path {one:.4} W, not {other:.4} W, three paths {three:.4} W"
    );
}
