//! Heterogeneous media in scenes (`medium.density`, a `.vol` grid): the shipped example loads,
//! and bad grids and boxes get an input error naming the scene file, the field and the grid
//! file, never a panic.

use caustics::Scene;
use caustics::scene::DensityGrid;
use glam::Vec3;
use std::path::{Path, PathBuf};

fn scene_with(medium_extra: &str, bounds: &str) -> String {
    format!(
        r#"{{ "schema_version": 1, "name": "t",
  "camera": {{ "position": [0, 2, 4], "look_at": [0, 0, 0], "fov_y_deg": 40, "width": 64, "height": 64 }},
  "lights": [ {{ "type": "spot", "position": [0, 4, 0], "direction": [0, -1, 0], "cone_angle_deg": 30, "intensity": 10 }} ],
  "materials": {{ "floor": {{ "type": "diffuse", "albedo": 0.5 }} }},
  "objects": [ {{ "type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [4, 4], "material": "floor" }} ],
  "medium": {{ "sigma_s": 0.2, "sigma_a": 0.05, "bounds": {bounds} {medium_extra} }} }}"#
    )
}

const BOUNDS: &str = r#"{ "min": [-5, -1, -5], "max": [5, 5, 5] }"#;

fn dir() -> PathBuf {
    let d = std::env::temp_dir().join(format!("caustics-density-test-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn write(name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir().join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

fn with_grid(path: &Path) -> String {
    scene_with(&format!(r#", "density": {{ "path": "{}" }}"#, path.display()), BOUNDS)
}

fn err(json: &str) -> String {
    match Scene::from_json(json, "bad.json", Path::new(".")) {
        Ok(_) => panic!("accepted: {json}"),
        Err(e) => {
            assert!(e.is_input(), "not an input error: {e}");
            let s = e.to_string();
            assert!(s.starts_with("bad.json: "), "error does not name the file: {s}");
            s
        }
    }
}

fn good_bytes() -> Vec<u8> {
    DensityGrid::new([2, 3, 4], (0..24).map(|i| i as f32 * 0.1).collect()).unwrap().to_vol_bytes(Vec3::ZERO, Vec3::ONE)
}

#[test]
fn the_shipped_grid_and_a_written_one_load() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let s = Scene::load(&root.join("smoke_puff.json")).unwrap();
    let m = s.medium.as_ref().unwrap();
    let g = m.density.as_ref().unwrap();
    assert_eq!(g.dims, [48, 40, 48]);
    assert!(g.max > 1.0 && g.data.iter().all(|&v| v >= 0.0));
    // The density at the box's corners is the corner voxels' value (clamped trilinear).
    assert_eq!(m.density_at(m.bounds_min), g.data[0]);

    let p = write("good.vol", &good_bytes());
    let s = Scene::from_json(&with_grid(&p), "good.json", Path::new(".")).unwrap();
    let g = s.medium.as_ref().unwrap().density.as_ref().unwrap();
    assert_eq!((g.dims, g.max), ([2, 3, 4], 2.3));
    // A relative path is relative to the scene file's folder.
    let s =
        Scene::from_json(&scene_with(r#", "density": { "path": "good.vol" }"#, BOUNDS), "good.json", &dir()).unwrap();
    assert!(s.medium.unwrap().density.is_some());
}

#[test]
fn bad_grids_name_the_field_and_the_file() {
    let good = good_bytes();
    let mut cases: Vec<(&str, Vec<u8>, &str)> = vec![
        ("empty.vol", vec![], "does not start with \"VOL\""),
        ("magic.vol", b"VOX\x03".to_vec(), "does not start with \"VOL\""),
        ("header.vol", good[..30].to_vec(), "truncated .vol header"),
        ("truncated.vol", good[..good.len() - 3].to_vec(), "truncated"),
        ("trailing.vol", [good.as_slice(), &[0u8; 4]].concat(), "bytes after"),
    ];
    let patch = |at: usize, v: &[u8]| {
        let mut b = good.clone();
        b[at..at + v.len()].copy_from_slice(v);
        b
    };
    cases.push(("version.vol", patch(3, &[2]), "version 2"));
    cases.push(("encoding.vol", patch(4, &2i32.to_le_bytes()), "encoding 2"));
    cases.push(("zero_x.vol", patch(8, &0i32.to_le_bytes()), "dimension x is 0"));
    cases.push(("negative_z.vol", patch(16, &(-4i32).to_le_bytes()), "dimension z is -4"));
    cases.push(("huge_y.vol", patch(12, &100_000i32.to_le_bytes()), "dimension y is 100000"));
    cases.push(("channels.vol", patch(20, &3i32.to_le_bytes()), "3 channels"));
    cases.push(("negative.vol", patch(48 + 4 * 7, &(-1.0f32).to_le_bytes()), "voxel (1, 0, 1) is -1"));
    cases.push(("nan.vol", patch(48 + 4 * 23, &f32::NAN.to_le_bytes()), "voxel (1, 2, 3) is NaN"));
    for (name, bytes, what) in cases {
        let p = write(name, &bytes);
        let e = err(&with_grid(&p));
        assert!(e.contains("medium.density.path"), "{name}: error does not name the field: {e}");
        assert!(e.contains(name), "{name}: error does not name the grid file: {e}");
        assert!(e.contains(what), "{name}: error does not say \"{what}\": {e}");
    }
    // Unreadable: a missing file, a directory.
    let e = err(&with_grid(&dir().join("missing.vol")));
    assert!(e.contains("medium.density.path") && e.contains("missing.vol") && e.contains("cannot read"), "{e}");
    let e = err(&with_grid(&dir()));
    assert!(e.contains("medium.density.path") && e.contains("cannot read"), "{e}");
    // Malformed JSON for the grid: an unknown field, a missing path, a wrong type.
    for extra in [r#", "density": { "path": "a.vol", "scale": 2 }"#, r#", "density": {}"#, r#", "density": "a.vol""#] {
        let e = err(&scene_with(extra, BOUNDS));
        assert!(e.contains("density"), "{extra}: {e}");
    }
}

#[test]
fn empty_or_inverted_boxes_and_negative_sigma_are_refused() {
    for bounds in [
        r#"{ "min": [-5, 1, -5], "max": [5, 1, 5] }"#,
        r#"{ "min": [5, -1, -5], "max": [-5, 5, 5] }"#,
        r#"{ "min": [-5, -1, -5], "max": [5, 5, -5] }"#,
    ] {
        let e = err(&scene_with("", bounds));
        assert!(e.contains("medium.bounds") && e.contains("empty or inverted"), "{bounds}: {e}");
    }
    let json = scene_with("", BOUNDS).replace("\"sigma_s\": 0.2", "\"sigma_s\": -0.2");
    assert!(err(&json).contains("medium.sigma_s"));
    let json = scene_with("", BOUNDS).replace("\"sigma_a\": 0.05", "\"sigma_a\": [0.1, -1, 0]");
    assert!(err(&json).contains("medium.sigma_a"));
}
