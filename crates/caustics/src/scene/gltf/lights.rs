//! `KHR_lights_punctual` lights in our radiometric units: candela and lux divided by
//! [`LUMENS_PER_WATT`], colour × intensity per channel, the node's −Z as the direction.

use super::geometry::Placed;
use super::{Ctx, LUMENS_PER_WATT};
use crate::error::Result;
use crate::scene::Light;
use glam::{Mat4, Vec3};
use gltf::json::Root;
use gltf::json::extensions::scene::khr_lights_punctual::{Light as GltfLight, Type};
use gltf::json::validation::Checked;

/// Irradiance (W/m²) of the light added to a scene without lights.
pub(crate) const DEFAULT_IRRADIANCE: f32 = 3.0;

/// Radiant intensity (W/sr, or W/m² for directional lights) of a glTF light's photometric
/// `intensity` (cd or lx) and linear `color`.
pub(crate) fn radiometric(color: [f32; 3], intensity: f32) -> Vec3 {
    Vec3::from_array(color) * intensity / LUMENS_PER_WATT
}

/// The lights of the placed light nodes, in scene order; a default directional light (with a
/// warning) where there are none.
pub(crate) fn convert(cx: &mut Ctx, root: &Root, placed: &[Placed]) -> Result<Vec<Light>> {
    let defs = root.extensions.as_ref().and_then(|e| e.khr_lights_punctual.as_ref()).map_or(&[][..], |l| &l.lights[..]);
    let mut out = Vec::new();
    for p in placed {
        let def = defs.get(p.item).ok_or_else(|| {
            cx.err(
                format!("/nodes/{}/extensions/KHR_lights_punctual/light", p.node),
                format!("light {} does not exist (the file has {})", p.item, defs.len()),
            )
        })?;
        out.push(light(cx, def, p.item, p.world)?);
    }
    if out.is_empty() {
        cx.warn("", format!(
            "the scene has no light (KHR_lights_punctual): added a directional light of {DEFAULT_IRRADIANCE} W/m² from above"
        ));
        out.push(Light::Directional {
            direction: Vec3::new(0.3, -1.0, -0.2).normalize(),
            irradiance: Vec3::splat(DEFAULT_IRRADIANCE),
        });
    }
    Ok(out)
}

fn light(cx: &mut Ctx, def: &GltfLight, i: usize, world: Mat4) -> Result<Light> {
    let at = format!("/extensions/KHR_lights_punctual/lights/{i}");
    let who = match &def.name {
        Some(n) if !n.is_empty() => format!("light \"{n}\" ({at})"),
        _ => format!("light {at}"),
    };
    if !(def.intensity.is_finite() && def.intensity >= 0.0) {
        return Err(cx.err(format!("{at}/intensity"), format!("must be a non-negative number (got {})", def.intensity)));
    }
    if !def.color.iter().all(|c| c.is_finite() && *c >= 0.0) {
        return Err(cx.err(format!("{at}/color"), format!("must be non-negative numbers (got {:?})", def.color)));
    }
    if def.range.is_some() {
        cx.warn(
            &format!("{at}/range"),
            format!("{who}: range ignored: the light falls off with the inverse square law to any distance"),
        );
    }
    let power = radiometric(def.color, def.intensity);
    let position = world.transform_point3(Vec3::ZERO);
    let direction = world.transform_vector3(Vec3::NEG_Z).normalize_or_zero();
    let kind = match def.type_ {
        Checked::Valid(t) => t,
        Checked::Invalid => return Err(cx.err(format!("{at}/type"), "must be \"directional\", \"point\" or \"spot\"")),
    };
    if kind != Type::Point && direction == Vec3::ZERO {
        return Err(cx.err(&at, format!("{who}: its node's transform gives it no direction")));
    }
    Ok(match kind {
        Type::Point => Light::Point { position, intensity: power },
        Type::Directional => Light::Directional { direction, irradiance: power },
        Type::Spot => {
            let spot = def.spot.as_ref().ok_or_else(|| cx.err(&at, "a spot light needs \"spot\""))?;
            let (inner, outer) = (spot.inner_cone_angle, spot.outer_cone_angle);
            if !(outer.is_finite() && outer > 0.0 && outer <= std::f32::consts::FRAC_PI_2) {
                return Err(cx.err(format!("{at}/spot/outerConeAngle"), format!("must lie in (0, π/2] (got {outer})")));
            }
            if !(inner.is_finite() && inner >= 0.0 && inner <= outer) {
                return Err(cx.err(
                    format!("{at}/spot/innerConeAngle"),
                    format!("must lie in [0, outerConeAngle = {outer}] (got {inner})"),
                ));
            }
            // glTF's own curve, exactly (`SpotProfile::Gltf`).
            Light::Spot {
                position,
                direction,
                cone_angle: outer,
                falloff_start: inner,
                intensity: power,
                profile: crate::scene::SpotProfile::Gltf,
            }
        }
    })
}
