//! Deformed meshes (`Renderer::set_mesh_vertices`): the next frame rewrites the mesh's vertices
//! and BVH triangles and refits its BVH on the GPU (`bvh_refit`): the GPU's boxes are the CPU
//! refit's bit for bit and contain what they hold, and the image and caustic maps are those of a
//! fresh renderer of the deformed scene (whose BVH is built anew: another topology, the same
//! closest hits).

use crate::common;
use caustics::Scene;
use caustics::render::RenderSettings;
use caustics::renderer::{FrameRequest, FrameStats, Renderer};
use caustics::scene::{Shape, Tessellation, TriMesh};
use common::gpu;
use glam::{Affine3A, Vec3};
use std::sync::Arc;

/// The catalogue's glass ball as a tessellated mesh, over the diffuse floor under the spot
/// light, 64 × 64; and the mesh.
fn glass_mesh() -> (Scene, TriMesh) {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let mut scene = Scene::load(&dir.join("glass_sphere.json")).unwrap();
    scene.camera.width = 64;
    scene.camera.height = 64;
    let t = Tessellation { sphere_segments: 24, ..Default::default() };
    let mesh = scene.objects[0].shape.tessellate(&t);
    scene.objects[0].shape = Shape::Mesh(Arc::new(mesh.clone()));
    (scene, mesh)
}

/// The ball squashed and rippled (every vertex moves; normals tilted and renormalised).
fn deformed(m: &TriMesh) -> (Vec<Vec3>, Vec<Vec3>) {
    let c = Vec3::new(0.0, 0.9, 0.0);
    let positions = m
        .positions
        .iter()
        .map(|&p| {
            let d = p - c;
            let r = 1.0 + 0.12 * (5.0 * d.x + 1.0).sin() * (4.0 * d.z + 0.5).cos();
            c + Vec3::new(d.x * r * 1.1, d.y * r * 0.8 + 0.01, d.z * r)
        })
        .collect();
    let normals = m.normals.iter().map(|&n| (n + Vec3::new(0.1 * n.y, 0.05, -0.1 * n.x)).normalize()).collect();
    (positions, normals)
}

fn settings() -> RenderSettings {
    RenderSettings {
        photons: caustics::settings::PhotonSettings { count: 64, caustic_map_size: 64, ..Default::default() },
        shading: caustics::settings::ShadingSettings { shadow_map_size: 256, ..Default::default() },
        ..Default::default()
    }
}

fn frame(r: &mut Renderer) -> FrameStats {
    let ctx = r.context().clone();
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    r.encode(&mut enc, FrameRequest { stats: true }).unwrap();
    ctx.queue.submit([enc.finish()]);
    r.wait_stats().unwrap().expect("the frame asked for statistics")
}

fn bits_of(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| x.to_bits()).collect()
}

#[test]
fn the_gpu_refit_is_the_cpu_refit_and_its_boxes_nest() {
    let Some(ctx) = gpu() else { return };
    let (scene, mesh) = glass_mesh();
    let mut r = Renderer::with_context(ctx, scene, settings()).unwrap();
    let first = frame(&mut r);
    assert!(first.timings.iter().all(|(n, _)| n != "bvh_refit"), "nothing to refit in the first frame");
    let built = r.read_bvh().unwrap();
    let (p, n) = deformed(&mesh);
    r.set_mesh_vertices(0, &p, &n).unwrap();
    let stats = frame(&mut r);
    assert_eq!(stats.lights_redone, [true], "the light sees the mesh");
    if !stats.timings.is_empty() {
        let ms = stats.timings.iter().find(|(n, _)| n == "bvh_refit").expect("the refit is timed").1;
        eprintln!("bvh_refit: {ms:.3} ms for {} triangles", mesh.indices.len());
    }
    let b = r.read_bvh().unwrap();
    let (_, nodes, tris) = b.ranges[0].clone();
    assert_eq!(b.ranges[0].0, 0);
    // The CPU refit moved every box of the mesh, the topology stayed.
    let node = |v: &[caustics::gpu::types::BvhNode]| -> Vec<(u32, u32)> { v.iter().map(|n| (n.a, n.count)).collect() };
    assert_eq!(node(&b.cpu_nodes), node(&built.cpu_nodes));
    assert_ne!(b.cpu_nodes, built.cpu_nodes);
    // The GPU holds the CPU's triangles and nodes, bit for bit.
    let tri_bits = |v: &[caustics::gpu::types::BvhTri]| -> Vec<u32> {
        v.iter().flat_map(|t| [t.p0, t.p1, t.p2, t.n0, t.n1, t.n2]).flat_map(|x| bits_of(&x)).collect()
    };
    assert!(tri_bits(&b.gpu_tris[tris.clone()]) == tri_bits(&b.cpu_tris[tris.clone()]));
    let node_bits = |v: &[caustics::gpu::types::BvhNode]| -> Vec<u32> {
        v.iter().flat_map(|n| [bits_of(&n.lo), vec![n.a], bits_of(&n.hi), vec![n.count]]).flatten().collect()
    };
    let differ = (nodes.clone()).filter(|&i| node_bits(&b.gpu_nodes[i..=i]) != node_bits(&b.cpu_nodes[i..=i])).count();
    assert_eq!(differ, 0, "{differ} of {} nodes differ between the GPU refit and the CPU's", nodes.len());
    // Every box holds its children or its triangles (the deformed positions).
    let inside = |n: &caustics::gpu::types::BvhNode, p: &[f32]| (0..3).all(|ax| p[ax] >= n.lo[ax] && p[ax] <= n.hi[ax]);
    for i in nodes.clone() {
        let n = b.gpu_nodes[i];
        if n.count == 0 {
            for c in [b.gpu_nodes[n.a as usize], b.gpu_nodes[n.a as usize + 1]] {
                assert!(inside(&n, &c.lo) && inside(&n, &c.hi), "node {i}: a child outside");
            }
        } else {
            for t in &b.gpu_tris[n.a as usize..(n.a + n.count) as usize] {
                let idx = mesh.indices[t.p0[3].to_bits() as usize];
                for (k, v) in [t.p0, t.p1, t.p2].iter().enumerate() {
                    assert_eq!(v[..3], p[idx[k] as usize].to_array(), "the triangle's deformed vertex");
                    assert!(inside(&n, v), "node {i}: a triangle outside");
                }
            }
        }
    }
    // The instance's bounds are the root's box (min and max of the positions), as the GPU has it.
    let root = b.gpu_nodes[nodes.start];
    let lo = p.iter().fold(Vec3::splat(f32::MAX), |a, q| a.min(*q));
    let hi = p.iter().fold(Vec3::splat(f32::MIN), |a, q| a.max(*q));
    assert_eq!((root.lo, root.hi), (lo.to_array(), hi.to_array()));
    assert!(b.gpu_instances == b.cpu_instances);
    assert_eq!(
        (b.gpu_instances[0].lo[..3].to_vec(), b.gpu_instances[0].hi[..3].to_vec()),
        (lo.to_array().to_vec(), hi.to_array().to_vec())
    );
    // Deformed again: the frame creates no GPU object (the refit's levels, bind groups and
    // pipeline are kept).
    let (p2, n2) = deformed(&TriMesh { positions: p.clone(), normals: n.clone(), indices: mesh.indices.clone() });
    r.set_mesh_vertices(0, &p2, &n2).unwrap();
    let before = r.created();
    frame(&mut r);
    assert_eq!((r.created() - before).total(), 0, "a second deformation created GPU objects");
    let again = r.read_bvh().unwrap();
    assert!(node_bits(&again.gpu_nodes) == node_bits(&again.cpu_nodes));
    // A camera-only frame refits nothing.
    let mut cam = r.scene().camera.clone();
    cam.position.x += 0.1;
    r.set_camera(cam).unwrap();
    let camera = frame(&mut r);
    assert!(camera.timings.iter().all(|(n, _)| n != "bvh_refit"));
    assert_eq!(camera.lights_redone, [false]);
}

/// The image's and the light's fixed-point caustic flux, as bits.
fn bits(r: &Renderer) -> (Vec<u32>, Vec<u64>) {
    let img = r.read_image().unwrap();
    (img.pixels.iter().flat_map(|p| p.map(f32::to_bits)).collect(), r.read_caustic_flux_bits(0).unwrap())
}

/// A renderer that deformed the mesh (refit BVH) against a fresh one of the deformed scene
/// (rebuilt BVH): the same bits. Moved too, so that the transform applies on top of the
/// deformation.
#[test]
fn a_deformed_mesh_renders_as_a_fresh_renderer_of_the_deformed_scene() {
    let Some(ctx) = gpu() else { return };
    let (scene, mesh) = glass_mesh();
    let (p, n) = deformed(&mesh);
    let t = Affine3A::from_translation(Vec3::new(0.1, 0.0, -0.05));
    let mut r = Renderer::with_context(ctx.clone(), scene.clone(), settings()).unwrap();
    frame(&mut r);
    let before = bits(&r);
    r.set_object_transform(0, t).unwrap();
    r.set_mesh_vertices(0, &p, &n).unwrap();
    frame(&mut r);
    let kept = bits(&r);

    let mut changed = scene.clone();
    changed.objects[0].shape =
        Shape::Mesh(Arc::new(TriMesh { positions: p, normals: n, indices: mesh.indices.clone() }));
    let mut fresh = Renderer::with_context(ctx, changed, settings()).unwrap();
    fresh.set_object_transform(0, t).unwrap();
    frame(&mut fresh);
    let want = bits(&fresh);
    assert!(want.1.iter().any(|&b| b != 0), "the caustic map is empty");
    assert!(before.1 != want.1, "the deformation changed nothing");
    let img = (r.read_image().unwrap(), fresh.read_image().unwrap());
    let differ: Vec<f32> = img
        .0
        .pixels
        .iter()
        .zip(&img.1.pixels)
        .filter(|(a, b)| a != b)
        .map(|(a, b)| (0..3).map(|c| (a[c] - b[c]).abs()).fold(0.0, f32::max))
        .collect();
    if !differ.is_empty() {
        eprintln!("{} pixels differ, by up to {}", differ.len(), differ.iter().fold(0.0f32, |a, &b| a.max(b)));
    }
    assert!(kept.0 == want.0, "the image differs from a fresh renderer's ({} pixels)", differ.len());
    assert!(kept.1 == want.1, "the caustic map differs from a fresh renderer's");
}

#[test]
fn bad_vertices_are_input_errors() {
    let Some(ctx) = gpu() else { return };
    let (scene, mesh) = glass_mesh();
    let mut r = Renderer::with_context(ctx, scene, settings()).unwrap();
    let (p, n) = (mesh.positions.clone(), mesh.normals.clone());
    let err = |r: &mut Renderer, i: usize, p: &[Vec3], n: &[Vec3]| {
        let e = r.set_mesh_vertices(i, p, n).unwrap_err();
        assert!(e.is_input(), "{e}");
        e.to_string()
    };
    let e = err(&mut r, 7, &p, &n);
    assert!(e.contains("objects[7]") && e.contains("no such object"), "{e}");
    let e = err(&mut r, 1, &p, &n);
    assert!(e.contains("objects[1]") && e.contains("not a mesh"), "{e}");
    let e = err(&mut r, 0, &p[1..], &n);
    assert!(e.contains("objects[0].positions") && e.contains(&format!("{} vertices", p.len())), "{e}");
    let e = err(&mut r, 0, &p, &n[..3]);
    assert!(e.contains("objects[0].normals"), "{e}");
    let mut bad = p.clone();
    bad[5].y = f32::NAN;
    let e = err(&mut r, 0, &bad, &n);
    assert!(e.contains("objects[0].positions[5]") && e.contains("finite"), "{e}");
    let mut bad = n.clone();
    bad[2].x = f32::INFINITY;
    let e = err(&mut r, 0, &p, &bad);
    assert!(e.contains("objects[0].normals[2]"), "{e}");
    // Nothing changed: the frame refits nothing and the mesh is as loaded.
    let s = frame(&mut r);
    assert!(s.timings.iter().all(|(n, _)| n != "bvh_refit"));
    let Shape::Mesh(m) = &r.scene().objects[0].shape else { panic!("a mesh") };
    assert!(m.positions == mesh.positions);
    // The same vertices again: no change, nothing redone.
    r.set_mesh_vertices(0, &p, &n).unwrap();
    assert_eq!(frame(&mut r).lights_redone, [false]);
}

/// The refit's cost on the Stanford bunny (glass, 64 × 64), deformed every frame: prints the
/// `bvh_refit` pass's median and the frame's passes summed (a measurement, not a check; run it
/// by name).
#[test]
#[ignore = "a measurement: run by name"]
fn refit_cost_on_the_bunny() {
    let Some(ctx) = gpu() else { return };
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let mut scene = Scene::load(&dir.join("glass_bunny.json")).unwrap();
    scene.camera.width = 64;
    scene.camera.height = 64;
    let object = scene.objects.iter().position(|o| matches!(o.shape, Shape::Mesh(_))).unwrap();
    let Shape::Mesh(mesh) = scene.objects[object].shape.clone() else { unreachable!() };
    let mut r = Renderer::with_context(ctx, scene, settings()).unwrap();
    frame(&mut r);
    let (mut refit, mut total) = (Vec::new(), Vec::new());
    for i in 0..8 {
        let a = 0.002 * (i + 1) as f32;
        let p: Vec<Vec3> = mesh.positions.iter().map(|&q| q + Vec3::new(a * (40.0 * q.y).sin(), 0.0, 0.0)).collect();
        r.set_mesh_vertices(object, &p, &mesh.normals).unwrap();
        let s = frame(&mut r);
        if s.timings.is_empty() {
            eprintln!("no timestamp queries on this adapter");
            return;
        }
        refit.push(s.timings.iter().find(|(n, _)| n == "bvh_refit").unwrap().1);
        total.push(s.timings.iter().map(|(_, ms)| ms).sum::<f64>());
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    eprintln!(
        "bunny ({} triangles): bvh_refit median {:.3} ms, the frame's passes {:.1} ms",
        mesh.indices.len(),
        median(&mut refit),
        median(&mut total)
    );
}
