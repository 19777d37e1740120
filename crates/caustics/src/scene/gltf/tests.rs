//! Unit tests of the glTF loader's pieces; whole files are tested in `tests/cpu/gltf.rs`.

use super::*;
use glam::Vec3;
use gltf::json::mesh::Mode;

#[test]
fn base64_decodes_rfc4648_vectors() {
    let d = |s: &str| container::base64_decode(s).unwrap();
    assert_eq!(d(""), b"");
    assert_eq!(d("Zg=="), b"f");
    assert_eq!(d("Zm8="), b"fo");
    assert_eq!(d("Zm9v"), b"foo");
    assert_eq!(d("Zm9vYmFy"), b"foobar");
    assert_eq!(d("+/+/"), [0xfb, 0xff, 0xbf]);
    assert!(container::base64_decode("Zm9v!").is_err());
    assert!(container::base64_decode("Z").is_err());
}

#[test]
fn strips_and_fans_follow_the_gltf_spec() {
    let v = [10, 11, 12, 13, 14];
    assert_eq!(geometry::triangles(&v, Mode::TriangleStrip).unwrap(), vec![[10, 11, 12], [12, 11, 13], [12, 13, 14]]);
    assert_eq!(geometry::triangles(&v, Mode::TriangleFan).unwrap(), vec![[11, 12, 10], [12, 13, 10], [13, 14, 10]]);
    assert_eq!(geometry::triangles(&v[..3], Mode::Triangles).unwrap(), vec![[10, 11, 12]]);
    assert!(geometry::triangles(&v[..4], Mode::Triangles).is_none());
    assert!(geometry::triangles(&v[..2], Mode::TriangleStrip).is_none());
}

#[test]
fn photometric_units_divide_by_the_efficacy() {
    assert_eq!(lights::radiometric([1.0, 0.5, 0.0], 683.0), Vec3::new(1.0, 0.5, 0.0));
    assert_eq!(lights::radiometric([1.0; 3], 27320.0), Vec3::splat(40.0));
}

#[test]
fn the_framing_camera_sees_the_bounds() {
    let (lo, hi) = (Vec3::new(-1.0, 0.0, -2.0), Vec3::new(3.0, 1.0, 0.5));
    for aspect in [0.5, 4.0 / 3.0, 3.0] {
        let c = camera::frame((lo, hi), aspect);
        let t = (c.fov_y_deg.to_radians() * 0.5).tan();
        for k in 0..8 {
            let p = Vec3::new([lo.x, hi.x][k & 1], [lo.y, hi.y][(k >> 1) & 1], [lo.z, hi.z][k >> 2]);
            let d = p - c.position;
            let z = d.dot(c.forward());
            assert!(z > 0.0);
            assert!((d.dot(c.right()) / z).abs() <= t * c.aspect() && (d.dot(c.true_up()) / z).abs() <= t);
        }
    }
}

#[test]
fn json_errors_point_into_the_document() {
    let cx = Ctx { file: "x.gltf", warnings: Vec::new() };
    let e = container::parse(
        &cx,
        br#"{"asset": {"version": "2.0"}, "meshes": [{"primitives": [{"attributes": {"POSITION": -1}}]}]}"#,
        Path::new("."),
    )
    .err()
    .unwrap();
    let Error::Input { field, .. } = e else { panic!("{e}") };
    assert_eq!(field, "/meshes/0/primitives/0/attributes/POSITION");
}
