//! Bad scene input gets a clear error naming the file and the field (and the line for syntax
//! errors), never a panic. Every scene in the catalogue loads.

use caustics::{Error, Scene};
use std::path::Path;

const GOOD: &str = r#"{
  "schema_version": 1, "name": "t",
  "camera": { "position": [0, 2, 4], "look_at": [0, 0, 0], "fov_y_deg": 40, "width": 64, "height": 64 },
  "lights": [ { "type": "spot", "position": [0, 4, 0], "direction": [0, -1, 0], "cone_angle_deg": 30, "intensity": 10 } ],
  "materials": { "floor": { "type": "diffuse", "albedo": 0.5 }, "glass": { "type": "dielectric", "ior": 1.5 } },
  "objects": [ { "type": "sphere", "center": [0, 1, 0], "radius": 0.5, "material": "glass" },
               { "type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [4, 4], "material": "floor" } ]
}"#;

fn err(json: &str) -> String {
    match Scene::from_json(json, "bad.json", Path::new(env!("CARGO_MANIFEST_DIR"))) {
        Ok(_) => panic!("accepted: {json}"),
        Err(e) => {
            assert!(e.is_input(), "not an input error: {e}");
            let s = e.to_string();
            assert!(s.starts_with("bad.json: "), "error does not name the file: {s}");
            s
        }
    }
}

fn with(from: &str, to: &str) -> String {
    assert!(GOOD.contains(from), "{from}");
    GOOD.replacen(from, to, 1)
}

#[test]
fn good_scene_loads() {
    let s = Scene::from_json(GOOD, "good.json", Path::new(".")).unwrap();
    assert_eq!(s.objects.len(), 2);
    assert!(s.objects[0].caustic_caster && !s.objects[1].caustic_caster);
}

#[test]
fn catalogue_and_default_scene_load() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let mut n = 0;
    for e in std::fs::read_dir(&dir).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "json") {
            let s = Scene::load(&p).unwrap_or_else(|e| panic!("{e}"));
            assert!(!s.lights.is_empty() || s.environment.is_some());
            n += 1;
        }
    }
    assert!(n >= 6);
    Scene::default_scene();
}

#[test]
fn syntax_error_names_line_and_column() {
    let e = err("{\n  \"schema_version\": 1,\n  \"name\": \"x\",,\n}");
    assert!(e.contains("line 3"), "{e}");
}

#[test]
fn field_errors_name_the_field() {
    let cases = [
        (with("\"fov_y_deg\": 40", "\"fov_y_deg\": 40, \"zoom\": 2"), "zoom"),
        // Inside tagged elements too the error names the key, not just the element.
        (with("\"radius\": 0.5", "\"radius\": \"big\""), "objects[0].radius"),
        (with("\"material\": \"glass\"", "\"material\": \"crystal\""), "objects[0].material"),
        (with("\"ior\": 1.5", "\"ior\": 0"), "materials.glass.ior"),
        (with("\"ior\": 1.5", "\"ior\": -1.5"), "materials.glass.ior"),
        (with("\"intensity\": 10", "\"intensity\": -10"), "lights[0].intensity"),
        (with("\"intensity\": 10", "\"intensity\": [1, 2]"), "lights[0].intensity"),
        (with("\"width\": 64", "\"width\": 0"), "camera.width"),
        (with("\"albedo\": 0.5", "\"albedo\": 1.5"), "materials.floor.albedo"),
        (with("\"type\": \"spot\"", "\"type\": \"laser\""), "lights[0]"),
        (with("\"radius\": 0.5", "\"radius\": 0.5, \"spin\": 1"), "objects[0].spin"),
        (with("\"ior\": 1.5", "\"ior\": [1.5]"), "materials.glass.ior"),
        (with("\"type\": \"sphere\", ", ""), "objects[0]"),
        (with("\"schema_version\": 1", "\"schema_version\": 2"), "schema_version"),
        (with("\"direction\": [0, -1, 0]", "\"direction\": [0, 0, 0]"), "lights[0].direction"),
        (
            with("\"cone_angle_deg\": 30", "\"cone_angle_deg\": 30, \"falloff_start_deg\": 40"),
            "lights[0].falloff_start_deg",
        ),
        (with("\"cone_angle_deg\": 30", "\"cone_angle_deg\": 30, \"falloff\": \"smooth\""), "lights[0].falloff"),
        (with("\"size\": [4, 4]", "\"size\": [4, -4]"), "objects[1].size[1]"),
        (GOOD.replace("\"fov_y_deg\": 40, ", ""), "fov_y_deg"),
    ];
    for (json, field) in cases {
        let e = err(&json);
        assert!(e.contains(field), "error does not name {field}: {e}");
    }
}

fn write_obj(name: &str, text: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("caustics-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn mesh_scene(path: &Path, material: &str) -> String {
    with(
        "{ \"type\": \"sphere\", \"center\": [0, 1, 0], \"radius\": 0.5, \"material\": \"glass\" }",
        &format!("{{ \"type\": \"mesh\", \"path\": {:?}, \"material\": \"{material}\" }}", path.display().to_string()),
    )
}

#[test]
fn broken_meshes_are_named_errors_or_warnings() {
    let missing = Path::new("/nonexistent/bunny.obj");
    let e = err(&mesh_scene(missing, "glass"));
    assert!(e.contains("objects[0].path") && e.contains("bunny.obj"), "{e}");

    let nan = write_obj("nan.obj", "v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n");
    let e = err(&mesh_scene(&nan, "glass"));
    assert!(e.contains("not finite") || e.contains("OBJ"), "{e}");

    let oob = write_obj("oob.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n");
    let e = err(&mesh_scene(&oob, "glass"));
    assert!(e.contains("out of range") && e.contains("line 4"), "{e}");

    // A degenerate triangle is dropped with a warning; an open dielectric mesh warns.
    let open = write_obj("open.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\n");
    let s = Scene::from_json(&mesh_scene(&open, "glass"), "m.json", Path::new(".")).unwrap();
    assert!(s.warnings.iter().any(|w| w.contains("degenerate")), "{:?}", s.warnings);
    assert!(s.warnings.iter().any(|w| w.contains("not closed")), "{:?}", s.warnings);
}

#[test]
fn error_type_is_input() {
    let e = Scene::load(Path::new("/nonexistent/scene.json")).unwrap_err();
    assert!(matches!(e, Error::Input { .. }));
    assert!(e.to_string().contains("/nonexistent/scene.json"));
}

#[test]
fn bad_media_name_the_field() {
    let medium = r#""medium": { "sigma_s": [0.1, 0.2, 0.3], "sigma_a": 0.05, "phase": { "type": "hg", "g": 0.4 },
                   "bounds": { "min": [-5, -1, -5], "max": [5, 5, 5] } },
  "objects""#;
    let good = GOOD.replacen("\"objects\"", medium, 1);
    let s = Scene::from_json(&good, "good.json", Path::new(".")).unwrap();
    assert!(s.medium.is_some());
    let bad = |from: &str, to: &str| {
        assert!(good.contains(from), "{from}");
        good.replacen(from, to, 1)
    };
    let cases = [
        (bad("\"sigma_s\": [0.1, 0.2, 0.3]", "\"sigma_s\": [0.1, -0.2, 0.3]"), "medium.sigma_s"),
        (bad("\"sigma_a\": 0.05", "\"sigma_a\": -0.05"), "medium.sigma_a"),
        (bad("\"sigma_a\": 0.05", "\"sigma_a\": \"thick\""), "medium.sigma_a"),
        (bad("\"max\": [5, 5, 5]", "\"max\": [5, -1, 5]"), "medium.bounds"),
        (bad("\"max\": [5, 5, 5]", "\"max\": [-6, 5, 5]"), "medium.bounds"),
        (bad("\"g\": 0.4", "\"g\": 1"), "medium.phase.g"),
        (bad("\"type\": \"hg\"", "\"type\": \"rayleigh\""), "medium"),
        (bad("\"bounds\"", "\"density\": 2, \"bounds\""), "density"),
    ];
    for (json, field) in cases {
        let e = err(&json);
        assert!(e.contains(field), "error does not name {field}: {e}");
    }
}

/// A `waves` object (animated water): it loads as a closed mesh posed at time 0 and again at any
/// time; bad fields are named.
#[test]
fn waves_load_pose_in_time_and_name_bad_fields() {
    let waves = r#"{ "type": "waves", "size": [2, 2], "surface": 0.4, "bottom": 0.0, "grid": 8,
        "waves": [ { "amplitude": 0.02, "wavelength": 0.5, "direction_deg": 30, "steepness": 0.5 } ],
        "material": "glass" }"#;
    let json = with(r#"{ "type": "sphere", "center": [0, 1, 0], "radius": 0.5, "material": "glass" }"#, waves);
    let s = Scene::from_json(&json, "w.json", Path::new(".")).unwrap();
    assert!(s.is_animated() && s.objects[0].caustic_caster);
    let caustics::scene::Shape::Mesh(m0) = &s.objects[0].shape else { panic!("not a mesh") };
    assert_eq!(m0.boundary_edges(), 0);
    let later = s.at_time(0.3);
    let caustics::scene::Shape::Mesh(m1) = &later.objects[0].shape else { panic!("not a mesh") };
    assert_eq!((m0.positions.len(), m0.indices.len()), (m1.positions.len(), m1.indices.len()));
    assert_ne!(m0.positions, m1.positions, "time moved nothing");
    assert_eq!(s.at_time(0.0).objects[0].shape.bounds(), s.objects[0].shape.bounds());
    let bad = |from: &str, to: &str| err(&json.replacen(from, to, 1));
    let cases = [
        (bad("\"grid\": 8", "\"grid\": 1"), "objects[0].grid"),
        (bad("\"steepness\": 0.5", "\"steepness\": 1.5"), "objects[0].waves[0].steepness"),
        (bad("\"amplitude\": 0.02", "\"amplitude\": -0.02"), "objects[0].waves[0].amplitude"),
        (bad("\"wavelength\": 0.5", "\"wavelength\": 0"), "objects[0].waves[0].wavelength"),
        (bad("\"bottom\": 0.0", "\"bottom\": 0.39"), "objects[0].bottom"),
        (bad("\"size\": [2, 2]", "\"size\": [2, -2]"), "objects[0].size[1]"),
        (bad("\"waves\": [", "\"waves\": [], \"w\": ["), "objects[0]"),
    ];
    for (e, field) in cases {
        assert!(e.contains(field), "{field}: {e}");
    }
}
