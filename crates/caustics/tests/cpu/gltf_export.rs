//! `caustics convert`: every catalogue scene written as glTF (`.glb` and `.gltf`) and read back
//! is the same scene bit for bit, and renders the same bits on the CPU reference; the files
//! pass the `gltf` crate's validation and require no extension; the glTF rendition alone (our
//! extension removed) is the same scene in glTF's own terms; errors name the file.

use caustics::scene::{Shape, TriMesh};
use caustics::{Error, Scene};
use caustics_reference::reference::{self, ReferenceSettings};
use glam::Vec3;
use rayon::prelude::*;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU32, Ordering};

fn scenes_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes")
}

/// Every `scenes/*.json`, sorted, and `scenes/gltf/glass_ball.json` (a spot with glTF's falloff).
fn catalogue() -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(scenes_dir())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect();
    v.sort();
    v.push(scenes_dir().join("gltf/glass_ball.json"));
    assert!(v.len() >= 20, "the catalogue: {v:?}");
    v
}

fn temp_dir(tag: &str) -> PathBuf {
    static CALLS: AtomicU32 = AtomicU32::new(0);
    let call = CALLS.fetch_add(1, Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("caustics_gltf_export_{tag}_{}_{call}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn load(p: &Path) -> Scene {
    Scene::load(p).unwrap_or_else(|e| panic!("{e}"))
}

/// `scene` written to `dir/name` and read back.
fn round_trip(scene: &Scene, dir: &Path, name: &str) -> Scene {
    let out = dir.join(name);
    caustics::scene::write_gltf(scene, &out).unwrap_or_else(|e| panic!("{e}"));
    load(&out)
}

fn bits(v: Vec3) -> [u32; 3] {
    v.to_array().map(f32::to_bits)
}

/// Positions and normals as f32 bits, and the indices.
type MeshBits<'a> = (Vec<[u32; 3]>, Vec<[u32; 3]>, &'a [[u32; 3]]);

fn mesh_bits(m: &TriMesh) -> MeshBits<'_> {
    (m.positions.iter().map(|p| bits(*p)).collect(), m.normals.iter().map(|p| bits(*p)).collect(), &m.indices)
}

/// Field by field, every float by its bits (`{:?}` of an f32 is its shortest round-trip form:
/// two floats print alike exactly when their bits are equal, NaN aside, which a scene has none
/// of). `source` and `warnings` are not compared.
fn assert_same(a: &Scene, b: &Scene, what: &str) {
    assert_eq!(a.name, b.name, "{what}: name");
    assert_eq!(a.description, b.description, "{what}: description");
    assert_eq!(format!("{:?}", a.camera), format!("{:?}", b.camera), "{what}: camera");
    assert_eq!(a.exposure.to_bits(), b.exposure.to_bits(), "{what}: exposure");
    assert_eq!(format!("{:?}", a.lights), format!("{:?}", b.lights), "{what}: lights");
    assert_eq!(format!("{:?}", a.materials), format!("{:?}", b.materials), "{what}: materials");
    assert_eq!(a.material_names, b.material_names, "{what}: material names");
    assert_eq!(a.objects.len(), b.objects.len(), "{what}: objects");
    for (k, (x, y)) in a.objects.iter().zip(&b.objects).enumerate() {
        assert_eq!((x.material, x.caustic_caster), (y.material, y.caustic_caster), "{what}: objects[{k}]");
        assert_eq!(format!("{:?}", x.waves), format!("{:?}", y.waves), "{what}: objects[{k}].waves");
        match (&x.shape, &y.shape) {
            (Shape::Mesh(m), Shape::Mesh(n)) => assert!(mesh_bits(m) == mesh_bits(n), "{what}: objects[{k}] mesh"),
            (s, t) => assert_eq!(format!("{s:?}"), format!("{t:?}"), "{what}: objects[{k}].shape"),
        }
    }
    assert_eq!(format!("{:?}", a.medium), format!("{:?}", b.medium), "{what}: medium");
    match (&a.environment, &b.environment) {
        (None, None) => {}
        (Some(e), Some(f)) => {
            assert_eq!((e.width, e.height, e.clamped_negative), (f.width, f.height, f.clamped_negative), "{what}");
            assert_eq!((bits(e.scale), e.rotate_y.to_bits()), (bits(f.scale), f.rotate_y.to_bits()), "{what}");
            assert_eq!(e.path, f.path, "{what}: environment path");
            assert!(e.texels.iter().map(|t| bits(*t)).eq(f.texels.iter().map(|t| bits(*t))), "{what}: texels");
            for d in [Vec3::Y, Vec3::new(0.3, 0.2, -0.9).normalize(), Vec3::new(-0.5, -0.1, 0.4).normalize()] {
                assert_eq!(e.pdf(d).to_bits(), f.pdf(d).to_bits(), "{what}: environment pdf toward {d}");
            }
        }
        _ => panic!("{what}: environment present in one scene only"),
    }
}

#[test]
fn gltf_export_every_catalogue_scene_round_trips_bit_for_bit() {
    let dir = temp_dir("all");
    catalogue().par_iter().for_each(|p| {
        let stem = p.file_stem().unwrap().to_string_lossy().into_owned();
        let a = load(p);
        let b = round_trip(&a, &dir, &format!("{stem}.glb"));
        assert_same(&a, &b, &format!("{stem}.glb"));
        // The .gltf form (base64 buffer) and a second round trip, of the smaller scenes.
        if std::fs::metadata(dir.join(format!("{stem}.glb"))).unwrap().len() < 8 << 20 {
            let c = round_trip(&b, &dir, &format!("{stem}.gltf"));
            assert_same(&a, &c, &format!("{stem}.gltf"));
        }
    });
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn gltf_export_every_catalogue_scene_renders_the_same_bits_on_the_cpu() {
    let dir = temp_dir("render");
    let s = ReferenceSettings {
        photons_per_light: 3_000,
        camera_spp: 1,
        max_depth: 6,
        seed: 7,
        caustic_map_size: 8,
        medium_single_scattering_only: true,
        ..Default::default()
    };
    catalogue().par_iter().for_each(|p| {
        let stem = p.file_stem().unwrap().to_string_lossy().into_owned();
        let mut a = load(p);
        let mut b = round_trip(&a, &dir, &format!("{stem}.glb"));
        for x in [&mut a, &mut b] {
            x.camera.width = 12;
            x.camera.height = 8;
        }
        let (ia, ib) = (reference::render(&a, &s).unwrap(), reference::render(&b, &s).unwrap());
        assert!(ia.image.pixels.iter().flatten().any(|x| *x > 0.0), "{stem}: a black image proves nothing");
        let same =
            ia.image.pixels.iter().zip(&ib.image.pixels).all(|(p, q)| p.map(f32::to_bits) == q.map(f32::to_bits));
        assert!(same, "{stem}: the converted scene renders other bits");
    });
    std::fs::remove_dir_all(&dir).ok();
}

/// The exported JSON document of `scene` (a `.gltf`).
fn gltf_json(scene: &Scene) -> Value {
    serde_json::from_slice(&caustics::scene::to_gltf(scene).unwrap()).unwrap()
}

#[test]
fn gltf_export_files_pass_the_gltf_crates_validation_and_require_nothing() {
    for name in ["glass_sphere.json", "glass_sphere_sky.json", "smoke_puff.json", "pool_sun.json", "mirror_ring.json"] {
        let scene = load(&scenes_dir().join(name));
        let glb = caustics::scene::to_glb(&scene).unwrap();
        let g = gltf::Gltf::from_slice(&glb).unwrap_or_else(|e| panic!("{name}: .glb: {e:?}"));
        assert!(
            g.extensions_required().next().is_none(),
            "{name}: requires {:?}",
            g.extensions_required().collect::<Vec<_>>()
        );
        assert!(g.extensions_used().any(|e| e == "CAUSTICS_scene"), "{name}");
        assert_eq!(g.cameras().count(), 1, "{name}");
        assert_eq!(g.meshes().count(), scene.objects.len(), "{name}");
        let text = caustics::scene::to_gltf(&scene).unwrap();
        let g = gltf::Gltf::from_slice(&text).unwrap_or_else(|e| panic!("{name}: .gltf: {e:?}"));
        assert!(g.extensions_required().next().is_none(), "{name}");
        let doc: Value = serde_json::from_slice(&text).unwrap();
        assert!(doc.get("extensionsRequired").is_none(), "{name}");
    }
}

/// A program that ignores `CAUSTICS_scene` sees the same scene in glTF's terms: our loader with
/// the extension removed gets the same triangles, materials, light power and camera.
#[test]
fn gltf_export_without_our_extension_is_the_same_scene_in_gltf_terms() {
    let dir = temp_dir("plain");
    let a = load(&scenes_dir().join("glass_bunny.json"));
    let mut doc = gltf_json(&a);
    doc["extensions"].as_object_mut().unwrap().remove("CAUSTICS_scene");
    doc["extensionsUsed"].as_array_mut().unwrap().retain(|e| e != "CAUSTICS_scene");
    let path = dir.join("plain.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let b = load(&path);
    std::fs::remove_dir_all(&dir).ok();
    assert_eq!(a.objects.len(), b.objects.len());
    for (k, (x, y)) in a.objects.iter().zip(&b.objects).enumerate() {
        let (Shape::Mesh(m), Shape::Mesh(n)) = (&x.shape, &y.shape) else { continue };
        assert_eq!(m.positions, n.positions, "objects[{k}]: world-space positions, identity nodes");
        assert_eq!(m.indices, n.indices, "objects[{k}]");
        let names = (&a.material_names[x.material], &b.material_names[y.material]);
        assert_eq!(names.0, names.1, "objects[{k}]: material");
    }
    assert_eq!(a.lights.len(), b.lights.len());
    for (l, m) in a.lights.iter().zip(&b.lights) {
        assert_eq!(l.kind(), m.kind());
        let p = |l: &caustics::scene::Light| match *l {
            caustics::scene::Light::Spot { intensity, .. } | caustics::scene::Light::Point { intensity, .. } => {
                intensity
            }
            caustics::scene::Light::Directional { irradiance, .. } => irradiance,
        };
        assert!((p(l) - p(m)).abs().max_element() <= 1e-5 * p(l).max_element(), "{l:?} vs {m:?}");
        if let (Some(x), Some(y)) = (l.position(), m.position()) {
            assert_eq!(x, y);
        }
    }
    let (c, d) = (&a.camera, &b.camera);
    assert_eq!(c.position, d.position);
    assert!(c.forward().dot(d.forward()) > 1.0 - 1e-6 && c.true_up().dot(d.true_up()) > 1.0 - 1e-6);
    assert!((c.fov_y_deg - d.fov_y_deg).abs() < 1e-4);
}

#[test]
fn gltf_export_errors_name_the_file() {
    let scene = Scene::default_scene();
    let dir = temp_dir("errors");
    let e = caustics::scene::write_gltf(&scene, &dir.join("out.obj")).unwrap_err();
    assert!(matches!(e, Error::Input { .. }) && e.to_string().contains("out.obj"), "{e}");
    let missing = dir.join("no such folder").join("out.glb");
    let e = caustics::scene::write_gltf(&scene, &missing).unwrap_err();
    assert!(e.is_input() && e.to_string().contains("out.glb"), "{e}");
    // A failed write leaves nothing behind, and an existing file is replaced whole.
    let out = dir.join("out.glb");
    std::fs::write(&out, b"old").unwrap();
    caustics::scene::write_gltf(&scene, &out).unwrap();
    assert!(std::fs::read(&out).unwrap().starts_with(b"glTF"));
    let left: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(left, vec![std::ffi::OsString::from("out.glb")]);

    // A bad extension value is an input error at its JSON pointer.
    let mut doc = gltf_json(&scene);
    doc["extensions"]["CAUSTICS_scene"]["objects"][0]["material"] = 99.into();
    let path = dir.join("bad.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    match Scene::load(&path) {
        Err(Error::Input { file, field, message, .. }) => {
            assert!(file.ends_with("bad.gltf"), "{file}");
            assert_eq!(field, "/extensions/CAUSTICS_scene/objects/0/material", "{message}");
        }
        r => panic!("{:?}", r.map(|s| s.name)),
    }
    doc["extensions"]["CAUSTICS_scene"]["objects"][0]["material"] = 0.into();
    doc["extensions"]["CAUSTICS_scene"]["exposure"] = "bright".into();
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let e = Scene::load(&path).unwrap_err();
    let Error::Input { field, .. } = &e else { panic!("{e}") };
    assert_eq!(field, "/extensions/CAUSTICS_scene/exposure", "{e}");
    std::fs::remove_dir_all(&dir).ok();
}
