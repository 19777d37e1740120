//! The exact photon tracer (`shaders/shared/raytrace.wgsl` over `caustics::accel`): closest
//! hits against brute force (watertight at shared edges and vertices, degenerate triangles),
//! stack overflow detection, a mesh sphere against the analytic sphere, total internal
//! reflection in a mesh prism with its flux in closed form, light through two meshes in a row
//! against the CPU reference, and the camera's caustic image of two stacked balls against the
//! CPU reference restricted to the GPU's path classes.

use crate::common;

use caustics::raycast::{CastOptions, Ray, cast_rays};
use caustics::render::{Emission, RenderSettings, Tracer};
use caustics::scene::{Scene, Shape, Tessellation, TriMesh};
use common::gpu;
use glam::{Affine3A, Vec3};
use std::sync::Arc;

fn scene(json: &str) -> Scene {
    Scene::from_json(json, "<test>", std::path::Path::new(".")).unwrap()
}

fn base_scene() -> Scene {
    scene(include_str!("../../../../scenes/glass_sphere.json"))
}

/// Deterministic uniform numbers in [0, 1).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
    fn dir(&mut self) -> Vec3 {
        let z = 2.0 * self.next() - 1.0;
        let a = std::f32::consts::TAU * self.next();
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * a.cos(), r * a.sin(), z)
    }
}

/// Closest distance of the ray to any triangle (f64 Möller-Trumbore, edges inclusive), and
/// the distance to the next-nearest triangle (to tell ties apart).
fn brute(m: &TriMesh, o: Vec3, d: Vec3) -> Option<f64> {
    let (o, d) = (o.as_dvec3(), d.as_dvec3());
    let mut best: Option<f64> = None;
    for t in &m.indices {
        let [a, b, c] = t.map(|i| m.positions[i as usize].as_dvec3());
        let (e1, e2) = (b - a, c - a);
        let p = d.cross(e2);
        let det = e1.dot(p);
        if det.abs() < 1e-18 {
            continue;
        }
        let s = o - a;
        let u = s.dot(p) / det;
        let q = s.cross(e1);
        let v = d.dot(q) / det;
        let tt = e2.dot(q) / det;
        let eps = 1e-9;
        if u >= -eps && v >= -eps && u + v <= 1.0 + eps && tt > 1e-9 && best.is_none_or(|x| tt < x) {
            best = Some(tt);
        }
    }
    best
}

/// A closed mesh sphere (shared vertices) plus degenerate triangles (zero area: repeated
/// vertices, collinear vertices) that must never be hit.
fn test_mesh() -> TriMesh {
    let mut m = Shape::Sphere { center: Vec3::new(0.0, 0.9, 0.0), radius: 0.5 }
        .tessellate(&Tessellation { sphere_segments: 24, cylinder_segments: 24 });
    let base = m.positions.len() as u32;
    for p in [Vec3::new(0.0, 0.9, 0.0), Vec3::new(0.1, 0.9, 0.0), Vec3::new(0.2, 0.9, 0.0)] {
        m.positions.push(p);
        m.normals.push(Vec3::Y);
    }
    m.indices.push([base, base, base + 1]);
    m.indices.push([base, base + 1, base + 2]);
    m
}

fn mesh_scene(m: TriMesh) -> Scene {
    let mut s = base_scene();
    s.objects[0].shape = Shape::Mesh(Arc::new(m));
    s.objects.truncate(1);
    s
}

#[test]
fn closest_hits_match_brute_force_and_no_ray_leaks_through_an_edge() {
    let Some(ctx) = gpu() else { return };
    let m = test_mesh();
    let sc = mesh_scene(m.clone());
    let c = Vec3::new(0.0, 0.9, 0.0);
    let mut rng = Lcg(7);
    let mut rays = Vec::new();
    // Random rays from a sphere of radius 2 around the mesh toward random points near it.
    for _ in 0..4000 {
        let o = c + 2.0 * rng.dir();
        let target = c + 0.6 * rng.dir() * rng.next();
        rays.push(Ray { origin: o, dir: (target - o).normalize(), t_max: 1e30 });
    }
    // Rays aimed exactly at vertices and edge midpoints from outside: a closed mesh must be hit.
    let aimed_from = rays.len();
    for t in m.indices.iter().take(m.indices.len() - 2) {
        for (i, j) in [(0, 1), (1, 2), (0, 0)] {
            let p = 0.5 * (m.positions[t[i] as usize] + m.positions[t[j] as usize]);
            let o = c + (p - c) * 3.0 + 0.01 * rng.dir();
            rays.push(Ray { origin: o, dir: (p - o).normalize(), t_max: 1e30 });
        }
    }
    let out = cast_rays(&ctx, &sc, &[], &rays, CastOptions::default()).unwrap();
    assert_eq!(out.stack_overflows, 0);
    let mut checked = 0;
    for (k, (r, h)) in rays.iter().zip(&out.hits).enumerate() {
        let want = brute(&m, r.origin, r.dir);
        match (want, h) {
            (None, None) => {}
            (Some(w), Some(h)) => {
                assert!((h.t as f64 - w).abs() <= 1e-4 * w.max(1.0), "ray {k}: GPU t {} brute {w}", h.t);
                assert!(h.triangle.is_some_and(|t| (t as usize) < m.indices.len() - 2), "ray {k}: degenerate hit");
                checked += 1;
            }
            (w, h) => {
                // A disagreement is allowed only for a ray grazing the silhouette (within
                // rounding of an edge seen edge-on): not for the aimed rays, which hit the mesh
                // head-on.
                assert!(k < aimed_from, "aimed ray {k} leaked: GPU {h:?}, brute force {w:?}");
                let d = r.dir;
                let closest = (c - r.origin) - d * (c - r.origin).dot(d);
                assert!((closest.length() - 0.5).abs() < 0.02, "ray {k}: GPU {h:?}, brute force {w:?}");
            }
        }
    }
    assert!(checked > 3000, "only {checked} hits compared");
}

#[test]
fn moved_instances_hit_where_the_baked_mesh_is_and_overflows_are_counted() {
    let Some(ctx) = gpu() else { return };
    let m = test_mesh();
    let sc = mesh_scene(m.clone());
    let t = Affine3A::from_scale_rotation_translation(
        Vec3::splat(1.3),
        glam::Quat::from_rotation_y(0.7) * glam::Quat::from_rotation_x(-0.3),
        Vec3::new(0.3, -0.2, 0.1),
    );
    let baked = mesh_scene(match sc.objects[0].shape.transformed(&t).unwrap() {
        Shape::Mesh(m) => (*m).clone(),
        _ => unreachable!(),
    });
    let mut rng = Lcg(3);
    let c = t.transform_point3(Vec3::new(0.0, 0.9, 0.0));
    let rays: Vec<Ray> = (0..2000)
        .map(|_| {
            let o = c + 3.0 * rng.dir();
            Ray { origin: o, dir: (c + 0.7 * rng.dir() - o).normalize(), t_max: 1e30 }
        })
        .collect();
    let a = cast_rays(&ctx, &sc, &[t], &rays, CastOptions::default()).unwrap();
    let b = cast_rays(&ctx, &baked, &[], &rays, CastOptions::default()).unwrap();
    let mut hits = 0;
    for (x, y) in a.hits.iter().zip(&b.hits) {
        match (x, y) {
            (Some(x), Some(y)) => {
                assert!((x.t - y.t).abs() < 1e-4, "moved instance t {} baked {}", x.t, y.t);
                assert!(x.normal.dot(y.normal) > 0.9999);
                hits += 1;
            }
            (None, None) => {}
            _ => {}
        }
    }
    let agree = a.hits.iter().zip(&b.hits).filter(|(x, y)| x.is_some() == y.is_some()).count();
    assert!(agree >= rays.len() - 4, "{agree} of {} rays agree on hit or miss", rays.len());
    assert!(hits > 1000);
    // A one-entry stack cannot hold the far child of a two-level tree: overflows are counted.
    let small = CastOptions { stack_limit: 1, ..Default::default() };
    let o = cast_rays(&ctx, &sc, &[t], &rays, small).unwrap();
    assert!(o.stack_overflows > 0, "no overflow counted with a one-entry stack");
    assert_eq!(a.stack_overflows, 0);
    // Any-hit agrees with closest-hit on whether something is there.
    let any = cast_rays(&ctx, &sc, &[t], &rays, CastOptions { any_hit: true, ..Default::default() }).unwrap();
    assert!(any.hits.iter().zip(&a.hits).all(|(x, y)| x.is_some() == y.is_some()));
}

fn settings(tracer: Tracer) -> RenderSettings {
    RenderSettings {
        photons: caustics::settings::PhotonSettings {
            count: 256,
            caustic_map_size: 128,
            tracer,
            emission: Emission::Basic,
            ..Default::default()
        },
        shading: caustics::settings::ShadingSettings { shadow_map_size: 512, ..Default::default() },
        ..Default::default()
    }
}

fn small(mut s: Scene) -> Scene {
    s.camera.width = 96;
    s.camera.height = 96;
    s
}

#[test]
fn a_mesh_sphere_focuses_as_the_analytic_sphere() {
    let Some(ctx) = gpu() else { return };
    let analytic = small(base_scene());
    let mut mesh = analytic.clone();
    mesh.objects[0].shape = Shape::Mesh(Arc::new(
        analytic.objects[0].shape.tessellate(&Tessellation { sphere_segments: 256, cylinder_segments: 256 }),
    ));
    let a = caustics::render::render(&ctx, &analytic, &settings(Tracer::Exact)).unwrap();
    let b = caustics::render::render(&ctx, &mesh, &settings(Tracer::Exact)).unwrap();
    let m = caustics_reference::metrics::map_agreement(&b.caustic_maps[0][0], &a.caustic_maps[0][0]);
    eprintln!("mesh sphere vs analytic sphere: {m}");
    assert!((m.energy_ratio - 1.0).abs() < 0.01, "{m}");
    assert!(m.rel_rmse < 0.05, "{m}");
    let (pa, pb) = (m.peak_a, m.peak_b);
    assert!(pa.0.abs_diff(pb.0) <= 1 && pa.1.abs_diff(pb.1) <= 1, "the focus moved: {m}");
}

/// A right-angle glass prism (flat faces) under a spot light straight above: light enters the
/// top leg face head-on, is totally reflected at the hypotenuse (45° > the critical 41.8°) and
/// leaves through the other leg face head-on onto a wall beside it. All of it lands on the wall,
/// carrying (1 - F0)² of the flux onto the prism, F0 = ((n - 1)/(n + 1))², none below it.
#[test]
fn total_internal_reflection_in_a_mesh_prism() {
    let Some(ctx) = gpu() else { return };
    // Prism along z: legs on y = 1 (top, normal +y) and x = 0.5 (side, normal +x), hypotenuse
    // from (-0.5, 1) to (0.5, 0): the light going down turns to +x.
    let (x0, x1, y0, y1, z0, z1) = (-0.5f32, 0.5f32, 0.0f32, 1.0f32, -0.5f32, 0.5f32);
    let corners = [Vec3::new(x0, y1, 0.0), Vec3::new(x1, y1, 0.0), Vec3::new(x1, y0, 0.0)];
    let mut m = TriMesh { positions: Vec::new(), normals: Vec::new(), indices: Vec::new() };
    let mut quad = |p: [Vec3; 4]| {
        let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
        let b = m.positions.len() as u32;
        m.positions.extend(p);
        m.normals.extend([n; 4]);
        m.indices.push([b, b + 1, b + 2]);
        m.indices.push([b, b + 2, b + 3]);
    };
    let at = |p: Vec3, z: f32| Vec3::new(p.x, p.y + 0.5, z);
    // Side faces (counter-clockwise seen from outside).
    for (i, j) in [(0usize, 1usize), (1, 2), (2, 0)] {
        let (a, b) = (corners[i], corners[j]);
        quad([at(a, z0), at(a, z1), at(b, z1), at(b, z0)]);
    }
    let mut tri = |p: [Vec3; 3]| {
        let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
        let b = m.positions.len() as u32;
        m.positions.extend(p);
        m.normals.extend([n; 3]);
        m.indices.push([b, b + 1, b + 2]);
    };
    tri([at(corners[0], z1), at(corners[2], z1), at(corners[1], z1)]);
    tri([at(corners[0], z0), at(corners[1], z0), at(corners[2], z0)]);
    // Outward normals: the top face's must point up.
    let top = m
        .indices
        .iter()
        .position(|t| {
            m.positions[t[0] as usize].y > 1.49
                && m.positions[t[1] as usize].y > 1.49
                && m.positions[t[2] as usize].y > 1.49
        })
        .unwrap();
    assert!(m.normals[m.indices[top][0] as usize].y > 0.99, "prism winding");
    let json = r#"{ "schema_version": 1, "name": "prism",
      "camera": { "position": [0, 2, 6], "look_at": [0.5, 0.5, 0], "fov_y_deg": 45, "width": 64, "height": 64 },
      "lights": [ { "type": "spot", "position": [-0.1, 5, 0], "direction": [0, -1, 0], "cone_angle_deg": 4, "falloff_start_deg": 4, "intensity": [100, 100, 100] } ],
      "materials": { "white": { "type": "diffuse", "albedo": 0.8 }, "glass": { "type": "dielectric", "ior": 1.5 } },
      "objects": [
        { "type": "sphere", "center": [0, -50, 0], "radius": 0.01, "material": "glass" },
        { "type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [6, 6], "material": "white" },
        { "type": "rectangle", "center": [2.5, 1, 0], "normal": [-1, 0, 0], "size": [3, 6], "material": "white" } ] }"#;
    let mut sc = scene(json);
    sc.objects[0].shape = Shape::Mesh(Arc::new(m));
    let s = RenderSettings {
        photons: caustics::settings::PhotonSettings { reflection: false, ..settings(Tracer::Exact).photons },
        ..settings(Tracer::Exact)
    };
    let out = caustics::render::render(&ctx, &sc, &s).unwrap();
    let f = &out.flux[0];
    let f0 = (0.5f64 / 2.5).powi(2);
    let want = f.emitted * (1.0 - f0) * (1.0 - f0);
    eprintln!("prism: {f:?}, expected landed {want}");
    assert!(f.emitted > 0.0);
    assert!(
        (f.landed + f.lost_outside - want).abs() < 0.01 * want,
        "landed {} + outside {} vs {want}",
        f.landed,
        f.lost_outside
    );
    // On the wall, not the floor: the caustic map's texels with flux all project onto x > 2.4.
    let deposits = caustics_reference::reference::caustic_deposits(
        &sc,
        &caustics_reference::reference::ReferenceSettings { photons_per_light: 20000, ..Default::default() },
        0,
    )
    .unwrap();
    let on_wall = deposits.iter().filter(|d| d.position.x > 2.49).map(|d| d.flux.element_sum() as f64).sum::<f64>();
    let all = deposits.iter().map(|d| d.flux.element_sum() as f64).sum::<f64>();
    assert!(on_wall > 0.9 * all, "the CPU reference puts {on_wall} of {all} W on the wall");
    assert_eq!(out.flux[0].stack_overflows, 0);
}

/// Two glass mesh balls stacked along the spot light's axis, the upper focusing into the lower
/// (the case the image-space tracer gets wrong): the exact tracer's caustic map against the CPU
/// reference's.
#[test]
fn light_through_two_meshes_in_a_row_matches_the_cpu_reference() {
    let Some(ctx) = gpu() else { return };
    let json = r#"{ "schema_version": 1, "name": "stacked",
      "camera": { "position": [0, 2, 3.8], "look_at": [0, 0.7, 0], "fov_y_deg": 40, "width": 64, "height": 64 },
      "lights": [ { "type": "spot", "position": [0, 4, 0], "direction": [0, -1, 0], "cone_angle_deg": 25, "falloff_start_deg": 18, "intensity": [40, 40, 40] } ],
      "materials": { "floor": { "type": "diffuse", "albedo": 0.8 }, "glass": { "type": "dielectric", "ior": 1.5 } },
      "objects": [
        { "type": "sphere", "center": [0, 2.2, 0], "radius": 0.4, "material": "glass" },
        { "type": "sphere", "center": [0, 0.7, 0], "radius": 0.4, "material": "glass" },
        { "type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [8, 8], "material": "floor" } ] }"#;
    let analytic = scene(json);
    let mut sc = analytic.clone();
    for i in 0..2 {
        sc.objects[i].shape = Shape::Mesh(Arc::new(
            sc.objects[i].shape.tessellate(&Tessellation { sphere_segments: 128, cylinder_segments: 128 }),
        ));
    }
    let rs = caustics_reference::reference::ReferenceSettings {
        photons_per_light: 1_000_000,
        caustic_map_size: 128,
        ..Default::default()
    };
    let s = RenderSettings {
        photons: caustics::settings::PhotonSettings { count: 512, ..settings(Tracer::Exact).photons },
        ..settings(Tracer::Exact)
    };
    // Measured on lavapipe with every pass: meshes, energy 0.9993, relative RMSE 0.013; analytic
    // balls 0.9988, 0.0135 (the CPU reference's noise at 1M photons). The bound on the energy is
    // the issue's target for stacked refractors.
    for (name, sc) in [("meshes", &sc), ("analytic", &analytic)] {
        let gpu_out = caustics::render::render(&ctx, sc, &s).unwrap();
        let cpu = caustics_reference::reference::caustic_maps(sc, &rs).unwrap();
        let m = caustics_reference::metrics::map_agreement(&gpu_out.caustic_maps[0][0], &cpu[0][0]);
        eprintln!("two balls ({name}), exact tracer vs CPU reference: {m}");
        assert!((m.energy_ratio - 1.0).abs() < 0.03, "{name}: {m}");
        assert!(m.rel_rmse < 0.05, "{name}: {m}");
        assert_eq!(gpu_out.flux[0].stack_overflows, 0);
        if name == "analytic" {
            // The image-space tracer marches the lower ball through the upper one's buffers
            // and misses the focus (what the exact tracer fixes).
            let img = caustics::render::render(
                &ctx,
                sc,
                &RenderSettings {
                    photons: caustics::settings::PhotonSettings { tracer: Tracer::ImageSpace, ..s.photons },
                    ..s.clone()
                },
            )
            .unwrap();
            let mi = caustics_reference::metrics::map_agreement(&img.caustic_maps[0][0], &cpu[0][0]);
            eprintln!("two balls ({name}), image-space tracer vs CPU reference: {mi}");
            assert!(mi.rel_rmse > 3.0 * m.rel_rmse, "image-space {mi} vs exact {m}");
        }
    }
}

/// The caustic region of a camera image: pixels where the reference's or the GPU's caustic
/// exceeds 2 % of the reference's 99.5th-percentile luminance (as the retired `tracers` example).
fn caustic_region(
    cpu: &caustics::image_io::Image,
    gpu: &caustics::image_io::Image,
) -> caustics_reference::metrics::Mask {
    let mut l: Vec<f32> = cpu.luminance().into_iter().filter(|&x| x > 0.0).collect();
    l.sort_by(f32::total_cmp);
    let t = 0.02 * l.get((l.len() as f64 * 0.995) as usize).copied().unwrap_or(0.0);
    let mut img = caustics::image_io::Image::new(cpu.width, cpu.height);
    for ((px, a), b) in img.pixels.iter_mut().zip(cpu.luminance()).zip(gpu.luminance()) {
        *px = if a > t || b > t { [1.0; 3] } else { [0.0; 3] };
    }
    caustics_reference::metrics::Mask::from_image(&img, false)
}

/// The camera's caustic image of two glass balls stacked along the spot light (the upper one
/// focusing into the lower one, `scenes/stacked_balls.json` at 64 × 64) with the exact tracer
/// against the CPU reference restricted to the paths the GPU renders (light → specular chain →
/// first diffuse surface → camera, `CausticPaths::FirstDiffuse`): the issue's target for
/// stacked refractors, caustic-region HDR-FLIP within 0.1 and energy within 3 % (the bounds
/// are the issue's, not set from the measurement). Measured on lavapipe: HDR-FLIP 0.023, energy
/// 1.0031; the reference's own noise (seed 1 against 0) 0.007, 0.9983. With a 128² map (one
/// texel 0.6 pixel) the bilinear lookups blur the rim of the focused disc: HDR-FLIP 0.095.
#[test]
fn stacked_balls_camera_caustic_matches_the_restricted_cpu_reference() {
    use caustics_reference::reference::{self, CausticPaths, ReferenceSettings};
    let Some(ctx) = gpu() else { return };
    let mut sc =
        Scene::load(std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/stacked_balls.json")))
            .unwrap();
    sc.camera.width = 64;
    sc.camera.height = 64;
    let rs = |seed: u64| ReferenceSettings {
        photons_per_light: 2_000_000,
        camera_spp: 1,
        caustic_map_size: 128,
        seed,
        caustic_paths: CausticPaths::FirstDiffuse,
        ..Default::default()
    };
    let cpu = reference::render(&sc, &rs(0)).unwrap();
    let s = RenderSettings {
        photons: caustics::settings::PhotonSettings {
            count: 512,
            caustic_map_size: 256,
            ..settings(Tracer::Exact).photons
        },
        ..settings(Tracer::Exact)
    };
    let gpu_out = caustics::render::render(&ctx, &sc, &s).unwrap();
    let mask = caustic_region(&cpu.caustic, &gpu_out.caustic);
    let flip = caustics_reference::metrics::hdr_flip(&gpu_out.caustic, &cpu.caustic, Some(&mask)).unwrap().mean;
    let energy = caustics_reference::metrics::energy_ratio(&gpu_out.caustic, &cpu.caustic, Some(&mask)).unwrap();
    // The reference's own noise in the same figures (another seed against it).
    let cpu1 = reference::render(&sc, &rs(1)).unwrap();
    let m1 = caustic_region(&cpu.caustic, &cpu1.caustic);
    let noise = caustics_reference::metrics::hdr_flip(&cpu1.caustic, &cpu.caustic, Some(&m1)).unwrap().mean;
    let noise_e = caustics_reference::metrics::energy_ratio(&cpu1.caustic, &cpu.caustic, Some(&m1)).unwrap();
    eprintln!(
        "stacked balls, camera caustic, exact tracer vs restricted CPU reference: region HDR-FLIP {flip:.3}, energy {energy:.4}; reference seed 1 vs 0: {noise:.3}, {noise_e:.4}"
    );
    assert!(flip <= 0.1, "region HDR-FLIP {flip}");
    assert!((energy - 1.0).abs() <= 0.03, "region energy {energy}");
    assert!(noise < 0.5 * flip.max(0.05), "the reference's noise {noise} is not well below the figure");
}

/// The adaptive hierarchy at its maximal level traces the dense grid's photons with the exact
/// tracer too (its coverage is dilated by a texel: the exact shapes reach beyond their
/// rasterized silhouettes), for every branch: the maps and the bookkeeping are identical.
#[test]
fn adaptive_maximal_level_equals_the_dense_grid_with_the_exact_tracer() {
    let Some(ctx) = gpu() else { return };
    let sc = small(base_scene());
    let set = |t: Emission| RenderSettings {
        photons: caustics::settings::PhotonSettings {
            emission: t,
            splat: caustics::splat::SplatMode::Fixed,
            ..settings(Tracer::Exact).photons
        },
        adaptive: caustics::settings::AdaptiveSettings { base_grid: 32, ..settings(Tracer::Exact).adaptive },
        ..settings(Tracer::Exact)
    };
    // The deterministic passes: the bookkeeping closes exactly.
    let det = |t: Emission| RenderSettings {
        photons: caustics::settings::PhotonSettings { residual: false, ..set(t).photons },
        ..set(t)
    };
    let basic = caustics::render::render(&ctx, &sc, &det(Emission::Basic)).unwrap();
    let adaptive = caustics::render::render(&ctx, &sc, &det(Emission::AdaptiveLevel)).unwrap();
    assert!(adaptive.caustic_flux_bits == basic.caustic_flux_bits, "adaptive: caustic map differs from basic");
    assert_eq!(adaptive.flux, basic.flux, "adaptive: flux bookkeeping differs from basic");
    // The bookkeeping closes: what reached the casters landed, was lost, or is in a branch not
    // traced (fixed-point rounding per booking aside).
    let f = &basic.flux[0];
    let sum = f.landed + f.lost_no_exit + f.lost_tir + f.lost_no_receiver + f.lost_outside + f.untraced_branches;
    eprintln!("{f:?}: sum {sum}");
    assert!((sum / f.emitted - 1.0).abs() < 1e-4, "{f:?}: sum {sum}");
    assert!(f.untraced_branches < 0.02 * f.emitted, "{f:?}");
    // With the residual pass (random choices, the same per photon in every technique): the
    // same photons again, and the bookkeeping closes in expectation (the residual pass stands
    // for the untraced branches).
    let basic = caustics::render::render(&ctx, &sc, &set(Emission::Basic)).unwrap();
    let adaptive = caustics::render::render(&ctx, &sc, &set(Emission::AdaptiveLevel)).unwrap();
    assert!(adaptive.caustic_flux_bits == basic.caustic_flux_bits, "residual: adaptive differs from basic");
    let g = &basic.flux[0];
    let sum = g.landed + g.lost_no_exit + g.lost_tir + g.lost_no_receiver + g.lost_outside;
    eprintln!("with the residual pass {g:?}: sum {sum}");
    assert_eq!(g.untraced_branches, 0.0);
    assert!((sum / g.emitted - 1.0).abs() < 0.2 * f.untraced_branches / f.emitted, "{g:?}: sum {sum}");
}

/// The first hit taken from the light's caster buffer (deferred emission) instead of the BVH:
/// the same caustic up to the rasterized silhouette (measured on lavapipe: energy 0.98 of the
/// BVH's on the stacked balls, the same focus).
#[test]
fn first_hit_from_the_light_buffer_gives_the_same_caustic() {
    let Some(ctx) = gpu() else { return };
    let sc = small(base_scene());
    let bvh = caustics::render::render(&ctx, &sc, &settings(Tracer::Exact)).unwrap();
    let buf = caustics::render::render(
        &ctx,
        &sc,
        &RenderSettings {
            testing: caustics::settings::TestingSettings {
                first_hit_from_buffer: true,
                ..settings(Tracer::Exact).testing
            },
            ..settings(Tracer::Exact)
        },
    )
    .unwrap();
    let m = caustics_reference::metrics::map_agreement(&buf.caustic_maps[0][0], &bvh.caustic_maps[0][0]);
    eprintln!("first hit from the buffer vs the BVH: {m}\n{:?}\n{:?}", buf.flux[0], bvh.flux[0]);
    assert!((m.energy_ratio - 1.0).abs() < 0.03, "{m}");
    assert!(m.rel_rmse < 0.1, "{m}");
    assert!(buf.caustic_flux_bits != bvh.caustic_flux_bits, "the setting changed nothing");
}
