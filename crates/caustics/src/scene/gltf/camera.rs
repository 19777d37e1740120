//! The camera: a perspective camera node of the scene (chosen by name or index), or, without
//! one, a view framing the scene's bounds.

use super::geometry::Placed;
use super::{Ctx, label};
use crate::error::Result;
use crate::scene::Camera;
use glam::{Mat4, Vec3};
use gltf::json::Root;
use gltf::json::validation::Checked;

/// Image height (pixels) of a glTF camera; the width follows its aspect ratio.
const IMAGE_HEIGHT: u32 = 600;
/// Aspect ratio where the file gives none.
const DEFAULT_ASPECT: f32 = 4.0 / 3.0;
/// Vertical field of view (degrees) of the framing camera.
const FRAMING_FOV_DEG: f32 = 40.0;

/// The camera `choice` names (a node or camera name, or an index into `cameras`), else the
/// scene's first camera, else a framing view of `bounds`.
pub(crate) fn choose(
    cx: &mut Ctx,
    root: &Root,
    placed: &[Placed],
    choice: Option<&str>,
    bounds: (Vec3, Vec3),
) -> Result<Camera> {
    let pick = match choice {
        None => placed.first(),
        Some(c) => Some(find(cx, root, placed, c)?),
    };
    let Some(p) = pick else {
        cx.warn("/cameras", "the scene has no camera: a view framing the whole scene is used");
        return Ok(frame(bounds, DEFAULT_ASPECT));
    };
    let at = format!("/cameras/{}", p.item);
    let cam = root.cameras.get(p.item).ok_or_else(|| {
        cx.err(
            format!("/nodes/{}/camera", p.node),
            format!("camera {} does not exist (the file has {})", p.item, root.cameras.len()),
        )
    })?;
    let who = label("camera", p.item, cam.name.as_ref());
    let Some(persp) = cam
        .perspective
        .as_ref()
        .filter(|_| !matches!(cam.type_, Checked::Valid(gltf::json::camera::Type::Orthographic)))
    else {
        cx.warn(&at, format!("{who}: only perspective cameras are read: a view framing the whole scene is used"));
        return Ok(frame(bounds, DEFAULT_ASPECT));
    };
    let yfov = persp.yfov;
    if !(yfov.is_finite() && yfov > 0.0 && yfov < std::f32::consts::PI) {
        return Err(cx.err(format!("{at}/perspective/yfov"), format!("must lie in (0, π) radians (got {yfov})")));
    }
    let aspect = persp.aspect_ratio.unwrap_or(DEFAULT_ASPECT);
    if !(aspect.is_finite() && aspect > 0.0) {
        return Err(
            cx.err(format!("{at}/perspective/aspectRatio"), format!("must be a positive number (got {aspect})"))
        );
    }
    from_node(p.world, yfov, aspect).ok_or_else(|| {
        cx.err(format!("/nodes/{}", p.node), format!("the transform of {who}'s node gives it no view direction"))
    })
}

/// The placed camera that `choice` names.
fn find<'a>(cx: &Ctx, root: &Root, placed: &'a [Placed], choice: &str) -> Result<&'a Placed> {
    let by_index = choice.parse::<usize>().ok();
    let hit = placed.iter().find(|p| {
        by_index == Some(p.item)
            || root.nodes[p.node].name.as_deref() == Some(choice)
            || root.cameras.get(p.item).and_then(|c| c.name.as_deref()) == Some(choice)
    });
    hit.ok_or_else(|| {
        let have: Vec<String> = placed
            .iter()
            .map(|p| {
                let name =
                    root.cameras.get(p.item).and_then(|c| c.name.clone()).or_else(|| root.nodes[p.node].name.clone());
                format!("{} {}", p.item, name.unwrap_or_default()).trim().to_string()
            })
            .collect();
        let have = if have.is_empty() { "none".to_string() } else { have.join(", ") };
        cx.err("--camera", format!("no camera \"{choice}\" in the scene (its cameras, index and name: {have})"))
    })
}

/// A glTF camera node: it looks down its −Z with +Y up.
fn from_node(world: Mat4, yfov: f32, aspect: f32) -> Option<Camera> {
    let position = world.transform_point3(Vec3::ZERO);
    let forward = world.transform_vector3(Vec3::NEG_Z).normalize_or_zero();
    let up = world.transform_vector3(Vec3::Y).normalize_or_zero();
    if forward == Vec3::ZERO || up == Vec3::ZERO || forward.cross(up).length() < 1e-6 {
        return None;
    }
    let (width, height) = size(aspect);
    Some(Camera { position, look_at: position + forward, up, fov_y_deg: yfov.to_degrees(), width, height })
}

fn size(aspect: f32) -> (u32, u32) {
    let width = (IMAGE_HEIGHT as f32 * aspect).round().clamp(1.0, 16384.0) as u32;
    (width, IMAGE_HEIGHT)
}

/// A camera that sees the whole of `bounds` from the front (+Z, glTF's front) and above.
pub(crate) fn frame(bounds: (Vec3, Vec3), aspect: f32) -> Camera {
    let (lo, hi) = bounds;
    let center = (lo + hi) * 0.5;
    let radius = ((hi - lo).length() * 0.5).max(1e-3);
    let half_v = FRAMING_FOV_DEG.to_radians() * 0.5;
    let half = half_v.min((half_v.tan() * aspect).atan());
    let distance = radius / half.sin() * 1.05;
    let dir = Vec3::new(0.0, 0.5, 1.0).normalize();
    let (width, height) = size(aspect);
    Camera {
        position: center + dir * distance,
        look_at: center,
        up: Vec3::Y,
        fov_y_deg: FRAMING_FOV_DEG,
        width,
        height,
    }
}
