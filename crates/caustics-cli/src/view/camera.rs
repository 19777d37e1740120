//! The orbit camera controller: orbit about a target, pan, zoom. Pure math on
//! [`caustics::scene::Camera`], no window.

use caustics::scene::Camera;
use glam::Vec3;

/// Radians of orbit per pixel of mouse motion.
pub const ORBIT_RAD_PER_PIXEL: f32 = 0.008;
/// Distance factor per wheel step (one notch = 1.0).
pub const ZOOM_PER_STEP: f32 = 0.9;
/// Pitch stays this far from the poles (radians), so the view never flips.
const POLE_MARGIN: f32 = 0.02;

/// Orbit state derived from a camera: the target (its `look_at`), the distance to it, and the
/// yaw and pitch of the view direction about the camera's `up` axis.
#[derive(Debug, Clone, PartialEq)]
pub struct Orbit {
    pub target: Vec3,
    pub distance: f32,
    /// Angle about `up`, radians.
    pub yaw: f32,
    /// Elevation of the camera above the plane normal to `up`, radians.
    pub pitch: f32,
    up: Vec3,
    /// Two unit axes spanning the plane normal to `up` (yaw 0 = `e0`).
    e0: Vec3,
    e1: Vec3,
}

impl Orbit {
    /// The orbit that reproduces `camera` (same position, target and up).
    pub fn from_camera(camera: &Camera) -> Orbit {
        let up = camera.up.try_normalize().unwrap_or(Vec3::Y);
        let e0 = up.any_orthonormal_vector();
        let e1 = up.cross(e0);
        let offset = camera.position - camera.look_at;
        let distance = offset.length().max(1e-4);
        let d = offset / distance;
        let pitch = d.dot(up).clamp(-1.0, 1.0).asin();
        let yaw = d.dot(e1).atan2(d.dot(e0));
        Orbit { target: camera.look_at, distance, yaw, pitch, up, e0, e1 }
    }

    /// Unit vector from the target to the camera.
    pub fn offset_dir(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        cp * (cy * self.e0 + sy * self.e1) + sp * self.up
    }

    /// `camera` moved to this orbit (field of view, size and up kept).
    pub fn apply(&self, camera: &Camera) -> Camera {
        Camera {
            position: self.target + self.offset_dir() * self.distance,
            look_at: self.target,
            up: self.up,
            ..camera.clone()
        }
    }

    /// Orbit by a mouse motion of (dx, dy) pixels: right drags turn the scene right, down
    /// drags raise the camera.
    pub fn orbit(&mut self, dx: f32, dy: f32) {
        self.yaw -= dx * ORBIT_RAD_PER_PIXEL;
        let lim = std::f32::consts::FRAC_PI_2 - POLE_MARGIN;
        self.pitch = (self.pitch + dy * ORBIT_RAD_PER_PIXEL).clamp(-lim, lim);
    }

    /// Pan by (dx, dy) pixels of an image `height` pixels high seen through `camera`: the point
    /// at the target's depth follows the mouse.
    pub fn pan(&mut self, camera: &Camera, dx: f32, dy: f32) {
        let cam = self.apply(camera);
        let per_pixel = 2.0 * self.distance * (cam.fov_y_deg.to_radians() * 0.5).tan() / cam.height.max(1) as f32;
        self.target += (-dx * cam.right() + dy * cam.true_up()) * per_pixel;
    }

    /// Zoom by `steps` wheel notches (positive: closer).
    pub fn zoom(&mut self, steps: f32) {
        self.distance = (self.distance * ZOOM_PER_STEP.powf(steps)).clamp(1e-3, 1e6);
    }
}

/// Where world point `p` lands in `camera`'s image, in pixels ((0,0) = top-left), and its depth
/// along the view axis; `None` behind the camera.
pub fn project(camera: &Camera, p: Vec3) -> Option<(glam::Vec2, f32)> {
    let v = p - camera.position;
    let z = v.dot(camera.forward());
    if z <= 1e-6 {
        return None;
    }
    let t = (camera.fov_y_deg.to_radians() * 0.5).tan();
    let sx = v.dot(camera.right()) / (z * t * camera.aspect());
    let sy = v.dot(camera.true_up()) / (z * t);
    let x = (sx + 1.0) * 0.5 * camera.width as f32;
    let y = (1.0 - sy) * 0.5 * camera.height as f32;
    Some((glam::Vec2::new(x, y), z))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam() -> Camera {
        caustics::Scene::default_scene().camera
    }

    #[test]
    fn from_camera_reproduces_the_camera() {
        let c = cam();
        let o = Orbit::from_camera(&c);
        let d = o.apply(&c);
        assert!((d.position - c.position).length() < 1e-4, "{:?} vs {:?}", d.position, c.position);
        assert_eq!(d.look_at, c.look_at);
    }

    #[test]
    fn orbit_keeps_distance_and_target() {
        let c = cam();
        let mut o = Orbit::from_camera(&c);
        let r = o.distance;
        o.orbit(120.0, -40.0);
        let d = o.apply(&c);
        assert!(((d.position - d.look_at).length() - r).abs() < 1e-4);
        assert_eq!(d.look_at, c.look_at);
        assert!((d.position - c.position).length() > 0.1 * r);
        // Orbiting back returns to the start.
        o.orbit(-120.0, 40.0);
        assert!((o.apply(&c).position - c.position).length() < 1e-3);
    }

    #[test]
    fn pitch_never_flips_over_the_pole() {
        let c = cam();
        let mut o = Orbit::from_camera(&c);
        o.orbit(0.0, 1e5);
        let d = o.apply(&c);
        assert!(d.forward().dot(d.up.normalize()) > -1.0 + 1e-5);
        assert!(d.right().is_finite());
    }

    #[test]
    fn pan_moves_the_target_with_the_mouse() {
        let c = cam();
        let mut o = Orbit::from_camera(&c);
        let before = project(&c, c.look_at).map(|(p, _)| p);
        o.pan(&c, 10.0, 0.0);
        let d = o.apply(&c);
        // The old target now lies 10 pixels to the right of the image centre.
        let (p, _) = project(&d, c.look_at).expect("in front");
        let centre = before.expect("in front");
        assert!((p.x - centre.x - 10.0).abs() < 0.05, "{p:?} {centre:?}");
        assert!((p.y - centre.y).abs() < 0.05);
    }

    #[test]
    fn zoom_scales_the_distance() {
        let c = cam();
        let mut o = Orbit::from_camera(&c);
        let r = o.distance;
        o.zoom(2.0);
        assert!((o.distance - r * 0.81).abs() < 1e-4);
        o.zoom(-2.0);
        assert!((o.distance - r).abs() < 1e-4);
    }

    #[test]
    fn project_inverts_ray_dir() {
        let c = cam();
        let p = c.position + c.ray_dir(17.5, 33.25) * 3.0;
        let (q, _) = project(&c, p).expect("in front");
        assert!((q - glam::Vec2::new(17.5, 33.25)).length() < 1e-2, "{q:?}");
    }
}
