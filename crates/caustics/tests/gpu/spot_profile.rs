//! glTF's spot falloff (`"falloff": "gltf"`, `SpotProfile::Gltf`) on the GPU against
//! `KHR_lights_punctual`'s formula, written out here from the extension's text: the direct light
//! on a floor pixel by pixel, and the flux of the photons onto a glass ball in the falloff ring.

use crate::common;
use caustics::Scene;
use caustics::render::{RenderSettings, render};
use common::gpu;
use glam::Vec3;
use std::path::Path;

const ALBEDO: f32 = 0.8;
const LIGHT: Vec3 = Vec3::new(0.0, 2.0, 0.0);
const INTENSITY: f64 = 3.0;
const INNER_DEG: f64 = 10.0;
const OUTER_DEG: f64 = 30.0;
const BALL: (Vec3, f32) = (Vec3::new(0.6, 0.5, 0.0), 0.15);

/// KHR_lights_punctual: `lightAngleScale = 1 / max(0.001, cos(inner) - cos(outer))`,
/// `lightAngleOffset = -cos(outer) * lightAngleScale`, attenuation
/// `saturate(cd * scale + offset)²` with `cd` the cosine off the axis.
fn khr(cos_off_axis: f64) -> f64 {
    let (inner, outer) = (INNER_DEG.to_radians().cos(), OUTER_DEG.to_radians().cos());
    let scale = 1.0 / (inner - outer).max(0.001);
    let t = (cos_off_axis * scale - outer * scale).clamp(0.0, 1.0);
    t * t
}

fn scene() -> Scene {
    let json = format!(
        r#"{{"schema_version": 1, "name": "gltf_spot",
        "camera": {{"position": [0, 2.2, 1.2], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov_y_deg": 70, "width": 64, "height": 64}},
        "lights": [{{"type": "spot", "position": [0, 2, 0], "direction": [0, -1, 0], "cone_angle_deg": {OUTER_DEG},
                     "falloff_start_deg": {INNER_DEG}, "falloff": "gltf", "intensity": [{INTENSITY}, {INTENSITY}, {INTENSITY}]}}],
        "materials": {{"floor": {{"type": "diffuse", "albedo": {ALBEDO}}}, "glass": {{"type": "dielectric", "ior": 1.5, "ext_ior": 1.0}}}},
        "objects": [{{"type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [8, 8], "material": "floor"}},
                    {{"type": "sphere", "center": [{}, {}, {}], "radius": {}, "material": "glass"}}]}}"#,
        BALL.0.x, BALL.0.y, BALL.0.z, BALL.1
    );
    Scene::from_json(&json, "gltf_spot.json", Path::new(".")).unwrap()
}

#[test]
fn a_gltf_spot_lights_the_floor_and_the_ball_by_the_khr_curve() {
    let Some(ctx) = gpu() else { return };
    let sc = scene();
    let s = RenderSettings {
        photons: caustics::settings::PhotonSettings { count: 512, caustic_map_size: 256, ..Default::default() },
        shading: caustics::settings::ShadingSettings { shadow_map_size: 512, ..Default::default() },
        ..Default::default()
    };
    let out = render(&ctx, &sc, &s).unwrap();
    // The direct light on the floor (the image less its caustic) against ρ/π I f cos / r², on
    // floor pixels where f > 0.05 away from the ball's shadow.
    let cam = &sc.camera;
    let (mut lo, mut hi, mut n, mut ramp) = (f64::MAX, f64::MIN, 0, 0);
    for y in 0..cam.height {
        for x in 0..cam.width {
            let d = cam.ray_dir(x as f32 + 0.5, y as f32 + 0.5);
            let p = cam.position + d * (-cam.position.y / d.y);
            let to_p = (p - LIGHT).as_dvec3();
            let r = to_p.length();
            let f = khr(-to_p.y / r);
            // The ball, and its shadow: the segment to the camera or the light passes within 5 cm
            // of the ball.
            let near_ball = |a: Vec3, b: Vec3| {
                let t = ((BALL.0 - a).dot(b - a) / (b - a).length_squared()).clamp(0.0, 1.0);
                (a + (b - a) * t - BALL.0).length() < BALL.1 + 0.05
            };
            if f < 0.05 || near_ball(p, LIGHT) || near_ball(p, cam.position) {
                continue;
            }
            let expect = ALBEDO as f64 / std::f64::consts::PI * INTENSITY * f * (-to_p.y / r) / (r * r);
            let i = (y * cam.width + x) as usize;
            let got = (out.image.pixels[i][0] - out.caustic.pixels[i][0]) as f64;
            lo = lo.min(got / expect);
            hi = hi.max(got / expect);
            n += 1;
            ramp += usize::from(f < 0.9);
        }
    }
    eprintln!("direct light / KHR curve in [{lo:.4}, {hi:.4}] over {n} pixels ({ramp} in the falloff ring)");
    assert!(n > 800 && ramp > 400, "{n} pixels, {ramp} in the ring");
    assert!(lo > 0.99 && hi < 1.01, "direct light / KHR curve in [{lo}, {hi}]");
    // The photons onto the ball (which lies in the ring, 21.8° off the axis): their flux against
    // ∫ I f dΩ over the ball's cone (midpoint rule in the cone's polar angle and azimuth), r + g + b.
    let axis = (BALL.0 - LIGHT).as_dvec3();
    let (dist, half) = (axis.length(), (BALL.1 as f64 / axis.length()).asin());
    let w = axis / dist;
    let u = w.cross(glam::DVec3::Z).normalize();
    let v = w.cross(u);
    let (na, nb) = (400, 400);
    let mut flux = 0.0;
    for i in 0..na {
        let a = (i as f64 + 0.5) / na as f64 * half;
        for j in 0..nb {
            let b = (j as f64 + 0.5) / nb as f64 * std::f64::consts::TAU;
            let dir = w * a.cos() + (u * b.cos() + v * b.sin()) * a.sin();
            flux += INTENSITY * khr(-dir.y) * a.sin() * (half / na as f64) * (std::f64::consts::TAU / nb as f64);
        }
    }
    let got = out.flux[0].emitted;
    eprintln!("photon flux onto the ball {got:.5} W, KHR curve {:.5} W", 3.0 * flux);
    assert!((got / (3.0 * flux) - 1.0).abs() < 0.01, "photon flux onto the ball {got} vs {}", 3.0 * flux);
}
