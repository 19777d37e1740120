//! Helpers more than one module of the GPU tests uses.

use caustics::Scene;
use glam::Vec3;

/// Unpolarised Fresnel reflectance (as shared/common.wgsl), eta = n_t / n_i.
pub fn fresnel(cos_i: f64, eta: f64) -> f64 {
    let s2 = (1.0 - cos_i * cos_i) / (eta * eta);
    if s2 >= 1.0 {
        return 1.0;
    }
    let ct = (1.0 - s2).sqrt();
    let rs = (cos_i - eta * ct) / (cos_i + eta * ct);
    let rp = (eta * cos_i - ct) / (eta * cos_i + ct);
    0.5 * (rs * rs + rp * rp)
}

/// The pixels of `sc`'s camera whose footprint (corners and centre) misses the glass ball of
/// radius 0.5 centred 1.5 m above the origin (`beams::ball_in_fog`'s, `sphere_volume`'s): the
/// GPU stops its march at the ball, the reference sees the volume caustic through the glass
/// only after refraction, which neither renders the same way.
pub fn ball_mask(sc: &Scene) -> caustics_reference::metrics::Mask {
    let cam = &sc.camera;
    let (w, h) = (cam.width, cam.height);
    let mut mask = caustics_reference::metrics::Mask::all(w, h);
    for y in 0..h {
        for x in 0..w {
            let mut hit = false;
            for (dx, dy) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0), (0.5, 0.5)] {
                let d = cam.ray_dir(x as f32 + dx, y as f32 + dy);
                let oc = cam.position - Vec3::new(0.0, 1.5, 0.0);
                let b = oc.dot(d);
                hit |= b * b - (oc.length_squared() - 0.25) > 0.0 && b < 0.0;
            }
            mask.include[(y * w + x) as usize] = !hit;
        }
    }
    mask
}
