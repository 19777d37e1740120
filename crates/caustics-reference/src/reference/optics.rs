//! Specular optics: reflection, refraction, dielectric and conductor Fresnel.

use glam::Vec3;

/// Mirror `d` about unit `n` (either side).
#[inline]
pub fn reflect(d: Vec3, n: Vec3) -> Vec3 {
    d - 2.0 * d.dot(n) * n
}

/// Unpolarised Fresnel reflectance of a smooth dielectric interface.
/// `cos_i` = |cos| of the incidence angle, `eta` = n_transmitted / n_incident.
/// Returns (reflectance, cos of the transmission angle); reflectance 1 under total internal
/// reflection.
#[inline]
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> (f32, f32) {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return (1.0, 0.0);
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    (0.5 * (rs * rs + rp * rp), cos_t)
}

/// Refracted direction of unit `d` through an interface with unit normal `n` facing the
/// incident side (d·n < 0), `eta` = n_t / n_i, `cos_t` from [`fresnel_dielectric`].
#[inline]
pub fn refract(d: Vec3, n: Vec3, eta: f32, cos_t: f32) -> Vec3 {
    let cos_i = -d.dot(n);
    (d / eta + (cos_i / eta - cos_t) * n).normalize()
}

/// Unpolarised Fresnel reflectance of a conductor with complex IOR `eta + i k` (relative to the
/// outside medium), per channel. Exact formula (e.g. pbrt-v3 `FrConductor`).
pub fn fresnel_conductor(cos_i: f32, eta: Vec3, k: Vec3) -> Vec3 {
    let c = cos_i.clamp(0.0, 1.0) as f64;
    let f = |eta: f32, k: f32| -> f32 {
        let (eta, k) = (eta as f64, k as f64);
        let c2 = c * c;
        let s2 = 1.0 - c2;
        let eta2 = eta * eta;
        let k2 = k * k;
        let t0 = eta2 - k2 - s2;
        let a2b2 = (t0 * t0 + 4.0 * eta2 * k2).sqrt();
        let t1 = a2b2 + c2;
        let a = (0.5 * (a2b2 + t0)).max(0.0).sqrt();
        let t2 = 2.0 * c * a;
        let rs = (t1 - t2) / (t1 + t2);
        let t3 = c2 * a2b2 + s2 * s2;
        let t4 = t2 * s2;
        let rp = rs * (t3 - t4) / (t3 + t4);
        (0.5 * (rp + rs)).clamp(0.0, 1.0) as f32
    };
    Vec3::new(f(eta.x, k.x), f(eta.y, k.y), f(eta.z, k.z))
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn normal_incidence() {
        let (r, ct) = fresnel_dielectric(1.0, 1.5);
        assert!((r - 0.04).abs() < 1e-6 && (ct - 1.0).abs() < 1e-6);
        let (r2, _) = fresnel_dielectric(1.0, 1.0 / 1.5);
        assert!((r2 - 0.04).abs() < 1e-6);
        // Conductor with k = 0 is a dielectric.
        let rc = fresnel_conductor(0.6, Vec3::splat(1.5), Vec3::ZERO);
        let (rd, _) = fresnel_dielectric(0.6, 1.5);
        assert!((rc.x - rd).abs() < 1e-5, "{rc} {rd}");
        // Total internal reflection.
        assert_eq!(fresnel_dielectric(0.1, 1.0 / 1.5).0, 1.0);
    }
}
