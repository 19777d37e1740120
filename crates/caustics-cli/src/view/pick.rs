//! Picking by ray casting the current scene (the CPU reference's exact intersection code), and
//! the geometry of dragging: points moved in the plane facing the camera, rotations about an
//! object's centre.

use super::camera::project;
use caustics::Scene;
use caustics::scene::{Camera, Light, Shape};
use caustics_reference::reference::geometry::Accel;
use glam::{Affine3A, Quat, Vec2, Vec3};

/// What the user selected.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Selection {
    Light(usize),
    Object(usize),
}

/// A light is picked when the click lands within this many pixels of its marker.
pub const LIGHT_PICK_PIXELS: f32 = 14.0;

/// The object or light under image pixel (x, y): lights first (their markers, within
/// [`LIGHT_PICK_PIXELS`]), then the nearest object the ray hits. Rectangles (floors and walls)
/// are not selectable: a click on them selects nothing. Returns the selection and the world
/// point grabbed.
pub fn pick(scene: &Scene, accel: &Accel, x: f32, y: f32) -> Option<(Selection, Vec3)> {
    let cam = &scene.camera;
    let mut best: Option<(f32, usize, Vec3)> = None;
    for (i, l) in scene.lights.iter().enumerate() {
        let Some(p) = l.position() else { continue };
        let Some((q, _)) = project(cam, p) else { continue };
        let d = q.distance(Vec2::new(x, y));
        if d <= LIGHT_PICK_PIXELS && best.is_none_or(|(bd, ..)| d < bd) {
            best = Some((d, i, p));
        }
    }
    if let Some((_, i, p)) = best {
        return Some((Selection::Light(i), p));
    }
    let dir = cam.ray_dir(x, y);
    let hit = accel.intersect(cam.position, dir, f32::INFINITY)?;
    let o = scene.objects.get(hit.object as usize)?;
    if matches!(o.shape, Shape::Rectangle { .. }) {
        return None;
    }
    Some((Selection::Object(hit.object as usize), hit.p))
}

/// The end of spot light `light`'s direction handle (drawn from the light along its axis,
/// 15 % of the scene's size long): dragging it aims the light.
pub fn spot_handle(scene: &Scene, light: usize) -> Option<Vec3> {
    match scene.lights.get(light)? {
        Light::Spot { position, direction, .. } => {
            let (lo, hi) = scene.bounds();
            Some(*position + direction.normalize_or_zero() * 0.15 * (hi - lo).length().max(1e-3))
        }
        _ => None,
    }
}

/// The spot light whose handle end is within [`LIGHT_PICK_PIXELS`] of pixel (x, y), unless a
/// light's marker is nearer.
pub fn pick_handle(scene: &Scene, x: f32, y: f32) -> Option<(usize, Vec3)> {
    let nearest_marker = scene
        .lights
        .iter()
        .filter_map(|l| project(&scene.camera, l.position()?))
        .map(|(q, _)| q.distance(Vec2::new(x, y)))
        .fold(f32::INFINITY, f32::min);
    (0..scene.lights.len())
        .filter_map(|i| {
            let h = spot_handle(scene, i)?;
            let (q, _) = project(&scene.camera, h)?;
            let d = q.distance(Vec2::new(x, y));
            (d <= LIGHT_PICK_PIXELS * 0.8 && d < nearest_marker).then_some((d, i, h))
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, i, h)| (i, h))
}

/// The nearest scene point under pixel (x, y), if any (for aiming a light).
pub fn scene_point(scene: &Scene, accel: &Accel, x: f32, y: f32) -> Option<Vec3> {
    let cam = &scene.camera;
    accel.intersect(cam.position, cam.ray_dir(x, y), f32::INFINITY).map(|h| h.p)
}

/// Where the ray through pixel (x, y) meets the plane through `anchor` facing the camera.
pub fn on_view_plane(cam: &Camera, anchor: Vec3, x: f32, y: f32) -> Option<Vec3> {
    let n = cam.forward();
    let d = cam.ray_dir(x, y);
    let denom = d.dot(n);
    if denom.abs() < 1e-6 {
        return None;
    }
    let t = (anchor - cam.position).dot(n) / denom;
    (t > 0.0).then(|| cam.position + d * t)
}

/// `t0` followed by a rotation about `centre`: `yaw` radians about `up`, then `pitch` about
/// `right`.
pub fn rotated_about(t0: Affine3A, centre: Vec3, up: Vec3, right: Vec3, yaw: f32, pitch: f32) -> Affine3A {
    let q = Quat::from_axis_angle(right.normalize(), pitch) * Quat::from_axis_angle(up.normalize(), yaw);
    Affine3A::from_translation(centre) * Affine3A::from_quat(q) * Affine3A::from_translation(-centre) * t0
}

/// `light` aimed at `point` (spot and directional lights; a point light has no direction).
pub fn aimed(light: &Light, point: Vec3) -> Light {
    let mut l = light.clone();
    match &mut l {
        Light::Spot { position, direction, .. } => {
            if let Some(d) = (point - *position).try_normalize() {
                *direction = d;
            }
        }
        Light::Directional { .. } | Light::Point { .. } => {}
    }
    l
}

/// `light` moved to `to` (spot and point lights).
pub fn moved(light: &Light, to: Vec3) -> Light {
    let mut l = light.clone();
    if let Light::Spot { position, .. } | Light::Point { position, .. } = &mut l {
        *position = to;
    }
    l
}

/// Azimuth and elevation (degrees) of a unit direction, about +Y.
pub fn direction_angles(d: Vec3) -> (f32, f32) {
    let d = d.try_normalize().unwrap_or(Vec3::NEG_Y);
    (d.x.atan2(d.z).to_degrees(), d.y.clamp(-1.0, 1.0).asin().to_degrees())
}

/// The unit direction of azimuth and elevation (degrees) about +Y.
pub fn direction_from_angles(azimuth: f32, elevation: f32) -> Vec3 {
    let (sa, ca) = azimuth.to_radians().sin_cos();
    let (se, ce) = elevation.to_radians().sin_cos();
    Vec3::new(ce * sa, se, ce * ca)
}

/// The centre of an object's bounds.
pub fn centre(shape: &Shape) -> Vec3 {
    let (lo, hi) = shape.bounds();
    (lo + hi) * 0.5
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn picks_the_glass_ball_and_the_light() {
        let scene = Scene::default_scene();
        let accel = Accel::new(&scene);
        let cam = &scene.camera;
        // The sphere's centre projects onto the sphere.
        let ball = scene
            .objects
            .iter()
            .position(|o| matches!(o.shape, Shape::Sphere { .. }))
            .expect("the built-in scene has a ball");
        let (q, _) = project(cam, centre(&scene.objects[ball].shape)).expect("in view");
        let (sel, p) = pick(&scene, &accel, q.x, q.y).expect("hit");
        assert_eq!(sel, Selection::Object(ball));
        assert!(p.is_finite());
        // A corner of the image sees the floor or a wall: nothing selectable.
        assert_eq!(pick(&scene, &accel, 1.0, cam.height as f32 - 1.0).map(|s| s.0), None);
        if let Some(lp) = scene.lights[0].position()
            && let Some((q, _)) = project(cam, lp)
            && q.x >= 0.0
            && q.y >= 0.0
            && q.x < cam.width as f32
            && q.y < cam.height as f32
        {
            assert_eq!(pick(&scene, &accel, q.x + 3.0, q.y).map(|s| s.0), Some(Selection::Light(0)));
        }
    }

    #[test]
    fn view_plane_drag_follows_the_mouse() {
        let scene = Scene::default_scene();
        let cam = &scene.camera;
        let anchor = cam.look_at;
        let (q, _) = project(cam, anchor).expect("in view");
        let p = on_view_plane(cam, anchor, q.x, q.y).expect("plane");
        assert!((p - anchor).length() < 1e-3);
        let p2 = on_view_plane(cam, anchor, q.x + 20.0, q.y).expect("plane");
        let (q2, _) = project(cam, p2).expect("in view");
        assert!((q2.x - q.x - 20.0).abs() < 1e-2);
        assert!((p2 - anchor).dot(cam.forward()).abs() < 1e-4);
    }

    #[test]
    fn rotation_keeps_the_centre_fixed() {
        let c = Vec3::new(1.0, 2.0, 3.0);
        let t = rotated_about(Affine3A::IDENTITY, c, Vec3::Y, Vec3::X, 0.7, 0.3);
        assert!((t.transform_point3(c) - c).length() < 1e-5);
        assert!(Shape::Sphere { center: c, radius: 1.0 }.transformed(&t).is_ok());
    }

    #[test]
    fn direction_angles_round_trip() {
        let d = Vec3::new(0.3, -0.8, 0.2).normalize();
        let (a, e) = direction_angles(d);
        assert!((direction_from_angles(a, e) - d).length() < 1e-5);
    }
}
