//! glTF 2.0 scenes (`scenes/gltf/`, written by `tools/make_gltf_assets.py`): light units, node
//! transforms, generated normals, the warnings, error pointers, a mutation fuzz test, and the
//! glass-ball scene rendering the same image bits as its hand-written JSON twin.

use caustics::scene::{Light, Material, Shape, TriMesh};
use caustics::{Error, Scene};
use caustics_reference::reference::{self, ReferenceSettings};
use glam::Vec3;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU32, Ordering};

fn asset(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/gltf").join(name)
}

fn load(name: &str) -> Scene {
    Scene::load(&asset(name)).unwrap_or_else(|e| panic!("{e}"))
}

fn mesh(scene: &Scene, k: usize) -> &TriMesh {
    match &scene.objects[k].shape {
        Shape::Mesh(m) => m,
        s => panic!("object {k} is not a mesh: {s:?}"),
    }
}

/// A fresh temporary folder (the tests of the binary run in parallel).
fn temp_dir(tag: &str) -> PathBuf {
    static CALLS: AtomicU32 = AtomicU32::new(0);
    let call = CALLS.fetch_add(1, Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("caustics_gltf_{tag}_{}_{call}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// glass_ball.gltf edited by `edit`, loaded from a temporary file.
fn try_edited(edit: impl Fn(&mut Value)) -> caustics::Result<Scene> {
    let mut doc: Value = serde_json::from_slice(&std::fs::read(asset("glass_ball.gltf")).unwrap()).unwrap();
    edit(&mut doc);
    let dir = temp_dir("edit");
    let path = dir.join("edited.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let r = Scene::load(&path);
    std::fs::remove_dir_all(&dir).ok();
    r
}

/// The error's field and text of glass_ball.gltf edited by `edit`.
fn load_edited(edit: impl Fn(&mut Value)) -> (String, String) {
    match try_edited(edit) {
        Err(e @ Error::Input { .. }) => {
            let text = e.to_string();
            let Error::Input { field, .. } = e else { unreachable!() };
            assert!(text.contains("edited.gltf"), "{text}");
            (field, text)
        }
        Err(e) => panic!("not an input error: {e}"),
        Ok(_) => panic!("the edited file loaded"),
    }
}

#[test]
fn every_asset_loads() {
    for name in ["glass_ball.glb", "glass_ball.gltf", "nested.gltf", "instanced.glb", "unsupported.gltf"] {
        let s = load(name);
        assert!(!s.objects.is_empty() && !s.lights.is_empty(), "{name}");
        assert!(s.material_names.windows(2).all(|w| w[0] < w[1]), "{name}: {:?}", s.material_names);
        assert_eq!(s.materials.len(), s.material_names.len());
        for o in &s.objects {
            assert!(o.material < s.materials.len());
            let m = match &o.shape {
                Shape::Mesh(m) => m,
                _ => panic!("{name}: not a mesh"),
            };
            assert!(m.positions.iter().all(|p| p.is_finite()));
            assert!(m.normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-4), "{name}");
        }
    }
}

#[test]
fn same_file_gives_the_same_scene() {
    let (a, b) = (load("glass_ball.glb"), load("glass_ball.glb"));
    assert_eq!(format!("{a:?}"), format!("{b:?}"));
    // The GLB and the .gltf with a data: URI hold the same scene.
    let c = load("glass_ball.gltf");
    assert_eq!(a.camera, c.camera);
    assert_eq!(a.lights, c.lights);
    assert_eq!(a.materials, c.materials);
    assert_eq!(a.warnings.len(), c.warnings.len());
    for k in 0..a.objects.len() {
        assert_eq!(mesh(&a, k), mesh(&c, k));
    }
}

#[test]
fn light_units_divide_by_683_lumens_per_watt() {
    assert_eq!(caustics::scene::LUMENS_PER_WATT, 683.0);
    // glass_ball: a white spot of 40 × 683 cd → 40 W/sr, at (0, 4, 0) shining down.
    let s = load("glass_ball.glb");
    let Light::Spot { position, direction, cone_angle, falloff_start, intensity, profile } = &s.lights[0] else {
        panic!("{:?}", s.lights)
    };
    assert_eq!(*intensity, Vec3::splat(40.0));
    assert_eq!((*position, *direction), (Vec3::new(0.0, 4.0, 0.0), Vec3::NEG_Y));
    assert_eq!((*cone_angle, *falloff_start), (30f32.to_radians(), 22f32.to_radians()));
    assert_eq!(*profile, caustics::scene::SpotProfile::Gltf);
    // nested: a directional sun of 2 × 683 lx, colour (1, 0.5, 0.25) → (2, 1, 0.5) W/m², its
    // node turned -60° about x: it travels along -Z turned, (0, -sin 60°, -cos 60°).
    let s = load("nested.gltf");
    let Light::Directional { direction, irradiance } = &s.lights[0] else { panic!("{:?}", s.lights) };
    assert!((*irradiance - Vec3::new(2.0, 1.0, 0.5)).abs().max_element() < 1e-6, "{irradiance}");
    let want = Vec3::new(0.0, -(60f32.to_radians().sin()), -(60f32.to_radians().cos()));
    assert!((*direction - want).length() < 1e-5, "{direction}");
    // instanced: a point light of 10 × 683 cd → 10 W/sr.
    let s = load("instanced.glb");
    assert_eq!(s.lights, vec![Light::Point { position: Vec3::new(0.0, 2.0, 0.5), intensity: Vec3::splat(10.0) }]);
}

/// Every triangle of a convex mesh faces away from its centre, and each vertex normal is its
/// triangle's (flat normals).
fn assert_flat_and_outward(m: &TriMesh, what: &str) {
    let (lo, hi) = m.bounds();
    let c = (lo + hi) * 0.5;
    for t in &m.indices {
        let n = m.face_cross(*t).normalize();
        let centroid = t.iter().map(|&i| m.positions[i as usize]).sum::<Vec3>() / 3.0;
        assert!(n.dot(centroid - c) > 0.0, "{what}: a triangle faces in");
        for &i in t {
            assert!((m.normals[i as usize] - n).length() < 1e-5, "{what}: not the flat normal");
        }
    }
    assert_eq!(m.positions.len(), 3 * m.indices.len(), "{what}: flat shading has a vertex per corner");
}

#[test]
fn node_transforms_nest_and_matrix_equals_trs() {
    let s = load("nested.gltf");
    // Objects in scene order: trs_cube, matrix_cube, mirrored_cube, chain_cube, shapes.
    assert_eq!(s.objects.len(), 5, "{:?}", s.warnings);
    let (trs, mat) = (mesh(&s, 0), mesh(&s, 1));
    assert_eq!(trs.indices, mat.indices);
    for (a, b) in trs.positions.iter().zip(&mat.positions) {
        assert!((a - b).length() < 1e-5, "{a} vs {b}");
    }
    // The TRS cube's first corner (-0.2, -0.2, -0.2) through child then parent, by hand.
    let parent = glam::Mat4::from_scale_rotation_translation(
        Vec3::splat(0.5),
        glam::Quat::from_rotation_x(20f32.to_radians()),
        Vec3::new(0.0, 1.0, 0.0),
    );
    let child = glam::Mat4::from_scale_rotation_translation(
        Vec3::new(1.0, 2.0, 1.0),
        glam::Quat::from_rotation_y(30f32.to_radians()),
        Vec3::new(0.5, 0.25, -0.5),
    );
    let corner = (parent * child).transform_point3(Vec3::splat(-0.2));
    assert!(
        trs.positions.iter().any(|p| (*p - corner).length() < 1e-5),
        "{corner} not among {:?}",
        &trs.positions[..3]
    );
    // The grandchild of a matrix node: translate (0.25, 0, 0), then turn 45° about z and move
    // to z = 1, then the parent's TRS.
    let chain = glam::Mat4::from_rotation_translation(glam::Quat::from_rotation_z(45f32.to_radians()), Vec3::Z);
    let corner =
        (parent * chain * glam::Mat4::from_translation(Vec3::new(0.25, 0.0, 0.0))).transform_point3(Vec3::splat(0.2));
    assert!(mesh(&s, 3).positions.iter().any(|p| (*p - corner).length() < 1e-5), "{corner}");
    // Generated normals are flat and, with the mirrored cube's flipped winding, face out.
    for (k, what) in [(0, "trs_cube"), (1, "matrix_cube"), (2, "mirrored_cube"), (3, "chain_cube")] {
        assert_flat_and_outward(mesh(&s, k), what);
    }
    let m = mesh(&s, 2);
    let (lo, hi) = m.bounds();
    assert!(((lo + hi) * 0.5 - parent.transform_point3(Vec3::new(-0.5, 0.0, 0.0))).length() < 1e-5);
}

#[test]
fn strips_and_fans_become_triangles_and_points_are_skipped() {
    let s = load("nested.gltf");
    let m = mesh(&s, 4);
    assert_eq!(m.indices.len(), 4, "a 4-vertex strip and a 4-vertex fan: 2 triangles each");
    for t in &m.indices {
        assert!(m.face_cross(*t).normalize().dot(Vec3::Y) > 0.999, "counter-clockwise from above");
    }
    let points: Vec<_> = s.warnings.iter().filter(|w| w.contains("points or lines")).collect();
    assert_eq!(points.len(), 1, "{:?}", s.warnings);
    assert!(points[0].contains("/meshes/1/primitives/2/mode") && points[0].contains("strip_fan_points"), "{points:?}");
}

#[test]
fn instancing_draws_the_mesh_once_per_node() {
    let s = load("instanced.glb");
    assert_eq!(s.objects.len(), 4);
    let a = mesh(&s, 0);
    for (k, dx) in [(1, 0.8), (2, 1.6)] {
        let b = mesh(&s, k);
        assert_eq!(a.indices, b.indices);
        for (p, q) in a.positions.iter().zip(&b.positions) {
            assert!((*q - *p - Vec3::new(dx, 0.0, 0.0)).length() < 1e-5);
        }
    }
    assert!(matches!(s.materials[s.objects[0].material], Material::Mirror { .. }), "smooth metal is a mirror");
    assert!(s.objects[0].caustic_caster && !s.objects[3].caustic_caster);
    // No camera: the view frames the scene, every corner of its bounds in front of it.
    assert!(s.warnings.iter().any(|w| w.contains("no camera")), "{:?}", s.warnings);
    let (lo, hi) = s.bounds();
    let cam = &s.camera;
    for corner in [lo, hi, Vec3::new(lo.x, hi.y, lo.z), Vec3::new(hi.x, lo.y, hi.z)] {
        let d = (corner - cam.position).normalize();
        let (x, y) = (d.dot(cam.right()) / d.dot(cam.forward()), d.dot(cam.true_up()) / d.dot(cam.forward()));
        let t = (cam.fov_y_deg.to_radians() * 0.5).tan();
        assert!(x.abs() <= t * cam.aspect() && y.abs() <= t, "{corner} is out of view");
    }
}

#[test]
fn unsupported_features_are_named_once_each() {
    let s = load("unsupported.gltf");
    let features = [
        ("textures are not read (with its KHR_texture_transform)", "painted"),
        ("normal map ignored", "painted"),
        ("emission ignored", "painted"),
        ("alpha mode Blend", "painted"),
        ("skinning ignored", "blob"),
        ("morph targets ignored", "blob"),
        ("animation(s) ignored", "/animations"),
        ("KHR_materials_dispersion not read", "tinted"),
        ("rough metal", "brushed"),
        ("thin-walled", "window_glass"),
        ("range ignored", "lamp"),
        ("not closed", "window"),
        ("no camera", "/cameras"),
    ];
    for (feature, who) in features {
        let hits: Vec<_> = s.warnings.iter().filter(|w| w.contains(feature)).collect();
        assert_eq!(hits.len(), 1, "{feature}: {:#?}", s.warnings);
        assert!(hits[0].contains(who) && hits[0].contains("unsupported.gltf"), "{feature}: {}", hits[0]);
    }
    assert_eq!(s.warnings.len(), features.len(), "{:#?}", s.warnings);
    let tinted = s.material_names.iter().position(|n| n == "tinted").unwrap();
    // KHR_materials_volume: attenuationColor [1, 0.5, 0.5] after 0.5 m, σa = −ln(c) / d.
    let sigma = Vec3::new(0.0, -(0.5f32.ln()) / 0.5, -(0.5f32.ln()) / 0.5);
    assert_eq!(s.materials[tinted], Material::Dielectric { ior: 1.5, ext_ior: 1.0, absorption: sigma });
    let brushed = s.material_names.iter().position(|n| n == "brushed").unwrap();
    assert!(matches!(s.materials[brushed], Material::Diffuse { .. }));
}

#[test]
fn missing_lights_and_orthographic_cameras_are_warnings() {
    let s = try_edited(|d| {
        d["nodes"][2].as_object_mut().unwrap().remove("extensions");
        d["cameras"][0] = serde_json::json!({"type": "orthographic", "orthographic": {"xmag": 1, "ymag": 1, "znear": 0.1, "zfar": 10}});
    })
    .unwrap();
    assert!(matches!(s.lights[..], [Light::Directional { .. }]), "{:?}", s.lights);
    let hit = |t: &str| s.warnings.iter().filter(|w| w.contains(t)).count();
    assert_eq!((hit("no light"), hit("only perspective cameras")), (1, 1), "{:#?}", s.warnings);
    assert_eq!(s.camera.look_at, (s.bounds().0 + s.bounds().1) * 0.5, "the framing view");
}

/// A change to a glTF document.
type Edit = Box<dyn Fn(&mut Value)>;

#[test]
fn errors_name_the_file_and_the_json_pointer() {
    let cases: Vec<(&str, Edit)> = vec![
        (
            "/meshes/0/primitives/0/attributes/POSITION",
            Box::new(|d| d["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = 99.into()),
        ),
        ("/accessors/0/count", Box::new(|d| d["accessors"][0]["count"] = 1_000_000_000_000u64.into())),
        ("/bufferViews/0", Box::new(|d| d["bufferViews"][0]["byteOffset"] = 1_000_000.into())),
        ("/buffers/0/byteLength", Box::new(|d| d["buffers"][0]["byteLength"] = 1_000_000.into())),
        ("/buffers/0/uri", Box::new(|d| d["buffers"][0]["uri"] = "data:application/octet-stream;base64,@@@@".into())),
        ("/buffers/0/uri", Box::new(|d| d["buffers"][0]["uri"] = "no_such_file.bin".into())),
        ("/nodes/3/translation", Box::new(|d| d["nodes"][3]["translation"] = serde_json::json!([0.0, 1e39, 0.0]))),
        ("/meshes/0/primitives/0/mode", Box::new(|d| d["meshes"][0]["primitives"][0]["mode"] = 9.into())),
        ("/meshes/1/primitives/0/indices", Box::new(|d| d["meshes"][1]["primitives"][0]["indices"] = 2.into())),
        ("/nodes/0/mesh", Box::new(|d| d["nodes"][0]["mesh"] = 7.into())),
        ("/accessors/2", Box::new(|d| d["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = 2.into())),
        ("/bufferViews/0/byteStride", Box::new(|d| d["bufferViews"][0]["byteStride"] = 2.into())),
        (
            "/extensionsRequired/0",
            Box::new(|d| d["extensionsRequired"] = serde_json::json!(["KHR_draco_mesh_compression"])),
        ),
        (
            "/extensions/KHR_lights_punctual/lights/0/spot/innerConeAngle",
            Box::new(|d| d["extensions"]["KHR_lights_punctual"]["lights"][0]["spot"]["innerConeAngle"] = 1.0.into()),
        ),
        ("/cameras/0/perspective/yfov", Box::new(|d| d["cameras"][0]["perspective"]["yfov"] = 0.into())),
        (
            "/materials/0/pbrMetallicRoughness/baseColorFactor",
            Box::new(|d| {
                d["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] = serde_json::json!([2, 0, 0, 1])
            }),
        ),
        ("/nodes/1/children/0", Box::new(|d| d["nodes"][1]["children"] = serde_json::json!([1]))),
        (
            "/meshes/0/primitives/0/attributes",
            Box::new(|d| d["meshes"][0]["primitives"][0]["attributes"] = serde_json::json!({"NORMAL": 1})),
        ),
        ("/accessors/0/count", Box::new(|d| d["accessors"][0]["count"] = (-1).into())),
        ("/meshes/0/primitives/0/material", Box::new(|d| d["meshes"][0]["primitives"][0]["material"] = 5.into())),
        (
            "/nodes/2/extensions/KHR_lights_punctual/light",
            Box::new(|d| d["nodes"][2]["extensions"]["KHR_lights_punctual"]["light"] = 3.into()),
        ),
        ("/nodes/3/camera", Box::new(|d| d["nodes"][3]["camera"] = 3.into())),
        ("/scene", Box::new(|d| d["scene"] = 4.into())),
    ];
    for (want, edit) in cases {
        let (field, text) = load_edited(edit);
        assert_eq!(field, want, "{text}");
    }
}

#[test]
fn broken_glb_files_are_errors() {
    let good = std::fs::read(asset("glass_ball.glb")).unwrap();
    let dir = temp_dir("glb");
    let path = dir.join("broken.glb");
    let mut cases: Vec<Vec<u8>> =
        vec![Vec::new(), good[..3].to_vec(), good[..11].to_vec(), good[..good.len() / 2].to_vec()];
    let mut magic = good.clone();
    magic[0] = b'X';
    cases.push(magic);
    let mut version = good.clone();
    version[4] = 1;
    cases.push(version);
    let mut chunk = good.clone();
    chunk[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
    cases.push(chunk);
    let mut length = good.clone();
    length[8..12].copy_from_slice(&3u32.to_le_bytes());
    cases.push(length);
    for bytes in cases {
        std::fs::write(&path, &bytes).unwrap();
        let e = Scene::load(&path).err().unwrap_or_else(|| panic!("{} bytes loaded", bytes.len()));
        assert!(e.is_input() && e.to_string().contains("broken.glb"), "{e}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn camera_choice_by_name_and_index() {
    let path = asset("glass_ball.glb");
    let default = load("glass_ball.glb").camera;
    assert_eq!(default.fov_y_deg, 38f32.to_radians().to_degrees());
    assert_eq!((default.position, default.look_at), (Vec3::new(0.0, 1.0, 4.0), Vec3::new(0.0, 1.0, 3.0)));
    for choice in ["main", "camera", "0"] {
        assert_eq!(Scene::load_with_camera(&path, Some(choice)).unwrap().camera, default, "{choice}");
    }
    let e = Scene::load_with_camera(&path, Some("nope")).unwrap_err().to_string();
    assert!(e.contains("--camera") && e.contains("0 main"), "{e}");
    let json = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/glass_sphere.json");
    assert!(Scene::load_with_camera(&json, Some("0")).unwrap_err().is_input());
}

/// A small deterministic generator (splitmix64).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Every leaf of a JSON value, as a path of keys and indices.
fn leaves(v: &Value, path: &mut Vec<Value>, out: &mut Vec<Vec<Value>>) {
    match v {
        Value::Object(m) => m.iter().for_each(|(k, x)| {
            path.push(Value::from(k.clone()));
            leaves(x, path, out);
            path.pop();
        }),
        Value::Array(a) if !a.is_empty() => a.iter().enumerate().for_each(|(i, x)| {
            path.push(Value::from(i));
            leaves(x, path, out);
            path.pop();
        }),
        _ => out.push(path.clone()),
    }
}

fn at_path<'a>(v: &'a mut Value, path: &[Value]) -> &'a mut Value {
    path.iter().fold(v, |v, k| match k {
        Value::String(s) => &mut v[s.as_str()],
        k => &mut v[k.as_u64().unwrap() as usize],
    })
}

/// Load `bytes` as `name` in `dir`; a panic or an error that does not name the file fails.
fn must_not_panic(dir: &Path, name: &str, bytes: &[u8], case: &str) {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    let r = std::panic::catch_unwind(|| Scene::load(&path));
    match r {
        Err(_) => panic!("{name}: {case}: the loader panicked"),
        Ok(Err(e)) => assert!(e.is_input() && e.to_string().contains(name), "{case}: {e}"),
        Ok(Ok(s)) => assert!(!s.objects.is_empty() && !s.lights.is_empty(), "{case}"),
    }
}

#[test]
fn mutation_fuzz_never_panics() {
    let start = std::time::Instant::now();
    let dir = temp_dir("fuzz");
    std::fs::copy(asset("nested.bin"), dir.join("nested.bin")).unwrap();
    let mut rng = Rng(42);
    let mut cases = 0;
    let bad_values = [
        Value::from(-1),
        Value::from(0),
        Value::from(1),
        Value::from(3),
        Value::from(4_294_967_295u64),
        Value::from(1e39),
        Value::from(-1e39),
        Value::from(2.5),
        Value::from("x"),
        Value::Null,
        serde_json::json!([]),
        serde_json::json!({}),
        serde_json::json!([1e30, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0]),
    ];
    for name in ["glass_ball.glb", "glass_ball.gltf", "nested.gltf", "instanced.glb", "unsupported.gltf"] {
        let good = std::fs::read(asset(name)).unwrap();
        for k in 0..600 {
            let mut b = good.clone();
            for _ in 0..1 + rng.below(4) {
                let i = if k % 2 == 0 { rng.below(b.len().min(2048)) } else { rng.below(b.len()) };
                b[i] ^= 1 << rng.below(8);
            }
            must_not_panic(&dir, name, &b, &format!("flip case {k}"));
            cases += 1;
        }
        for k in 0..150 {
            let cut = rng.below(good.len());
            must_not_panic(&dir, name, &good[..cut], &format!("truncated to {cut} (case {k})"));
            cases += 1;
        }
        if name.ends_with(".gltf") {
            let doc: Value = serde_json::from_slice(&good).unwrap();
            let mut all = Vec::new();
            leaves(&doc, &mut Vec::new(), &mut all);
            for k in 0..600 {
                let mut d = doc.clone();
                let path = &all[rng.below(all.len())];
                let v = bad_values[rng.below(bad_values.len())].clone();
                *at_path(&mut d, path) = v.clone();
                let case = format!("{path:?} = {v} (case {k})");
                must_not_panic(&dir, name, &serde_json::to_vec(&d).unwrap(), &case);
                cases += 1;
            }
        }
    }
    std::fs::remove_dir_all(&dir).ok();
    let secs = start.elapsed().as_secs_f64();
    println!("glTF mutation fuzz: {cases} cases in {secs:.2} s");
    assert!(cases >= 5000);
}

#[test]
fn gltf_and_json_glass_ball_render_the_same_bits() {
    let mut g = load("glass_ball.glb");
    let mut j = Scene::load(&asset("glass_ball.json")).unwrap();
    for s in [&mut g, &mut j] {
        s.camera.width = 24;
        s.camera.height = 24;
    }
    assert_eq!(g.camera, j.camera);
    assert_eq!(g.lights, j.lights);
    assert_eq!((&g.materials, &g.material_names), (&j.materials, &j.material_names));
    assert_eq!(g.objects.len(), j.objects.len());
    for k in 0..g.objects.len() {
        assert_eq!(g.objects[k].material, j.objects[k].material);
        let (a, b) = (mesh(&g, k), mesh(&j, k));
        let tris =
            |m: &TriMesh| -> Vec<[Vec3; 3]> { m.indices.iter().map(|t| t.map(|i| m.positions[i as usize])).collect() };
        assert_eq!(tris(a), tris(b), "object {k}: the same triangles");
    }
    let s = ReferenceSettings {
        photons_per_light: 20_000,
        camera_spp: 2,
        max_depth: 8,
        seed: 3,
        caustic_map_size: 16,
        medium_single_scattering_only: false,
        ..Default::default()
    };
    let (a, b) = (reference::render(&g, &s).unwrap(), reference::render(&j, &s).unwrap());
    assert!(a.image.pixels.iter().flatten().any(|x| *x > 0.0));
    for (p, q) in a.image.pixels.iter().zip(&b.image.pixels) {
        assert_eq!((*p).map(f32::to_bits), (*q).map(f32::to_bits));
    }
}
