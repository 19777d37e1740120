//! Tessellated analytic shapes: outward counter-clockwise winding, exact normals, closed where
//! the shape is closed.

use caustics::scene::mesh;
use glam::{Vec2, Vec3};

fn assert_outward(m: &caustics::scene::TriMesh, what: &str) {
    for t in &m.indices {
        let n = m.face_cross(*t);
        let sn: Vec3 = t.iter().map(|&i| m.normals[i as usize]).sum();
        assert!(n.dot(sn) > 0.0, "{what}: triangle {t:?} winds against its normals");
    }
}

#[test]
fn sphere_winds_outward_and_is_closed() {
    let m = mesh::sphere(Vec3::new(1.0, 2.0, 3.0), 0.5, 64);
    assert_outward(&m, "sphere");
    assert_eq!(m.boundary_edges(), 0);
    for (p, n) in m.positions.iter().zip(&m.normals) {
        assert!(((*p - Vec3::new(1.0, 2.0, 3.0)).length() - 0.5).abs() < 1e-5);
        assert!((n.length() - 1.0).abs() < 1e-5);
    }
}

#[test]
fn cylinder_and_rectangle_wind_outward() {
    let c = mesh::cylinder(Vec3::ZERO, Vec3::Y, 0.6, 0.5, 128);
    assert_outward(&c, "cylinder");
    let r = mesh::rectangle(Vec3::ZERO, Vec3::Y, Vec3::X, Vec3::Y.cross(Vec3::X), Vec2::new(2.0, 3.0));
    assert_outward(&r, "rectangle");
    let area: f32 = r.indices.iter().map(|t| r.face_cross(*t).length() * 0.5).sum();
    assert!((area - 6.0).abs() < 1e-5);
}
