//! Light space: how each light sees the scene. The GPU's receiver, shadow and caustic maps and
//! the CPU reference's caustic map share this parameterization, so that the two can be compared
//! texel by texel.
//!
//! - spot light (cone up to 75°): one perspective view along the spot axis, square, with a field
//!   of view of twice the cone angle;
//! - point light, or a spot wider than 75° (up to 90°: a hemisphere): a cube of six 90°
//!   perspective views on one eye; caustic triangles and shadow lookups cross its seams
//!   (docs/photon-tracing.md, "Wide lights");
//! - directional light: one orthographic view along the light direction, covering the scene's
//!   bounds.
//!
//! A spot light's view may also get a *spill face* ([`LightView::with_spill`]): a second, wider
//! square perspective face on the same eye and axis, covering the scene's bounds (half-angle at
//! most 75°). It emits no photons and has no caster buffers; it receives the photons whose
//! landing point lies outside the spot's own face (glass bends light out of the cone).
//! [`LightView::project`] tries the faces in order, so the spot face keeps every point it sees.
//!
//! Texel (i, j) of face f covers NDC x in [-1 + 2i/N, -1 + 2(i+1)/N] and y (top = +1) in
//! [1 - 2(j+1)/N, 1 - 2j/N]. A caustic map stores, per texel, the caustic irradiance (W/m²) on
//! the receiver point seen through the texel's centre.

use crate::scene::{Light, Scene};
use glam::{Mat4, Vec3, Vec4Swizzles};

/// The widest spot cone drawn with one perspective view; wider ones use a cube.
pub const MAX_SPOT_FRUSTUM_DEG: f32 = 75.0;

/// One face of a light view: an eye position (or direction, for orthographic faces) and a
/// world-to-clip matrix.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightFace {
    /// World-to-clip matrix (right-handed, depth range 0..1).
    pub world_to_clip: Mat4,
    /// Orthographic (a directional light's face) rather than perspective.
    pub orthographic: bool,
    /// Light position (perspective) or the direction light travels (orthographic).
    pub origin_or_dir: Vec3,
}

/// How one light sees the scene: one face, or six for a cube.
#[derive(Debug, Clone, PartialEq)]
pub struct LightView {
    /// The faces: one, or six for a cube, then the spill face if there is one.
    pub faces: Vec<LightFace>,
    /// Near plane distance of the faces (m).
    pub near: f32,
    /// Far plane distance of the faces (m).
    pub far: f32,
    /// Radius of the scene's bounding sphere (m).
    pub scene_radius: f32,
    /// tan of half the field of view of the emitting perspective faces (0 for orthographic
    /// views).
    pub tan_half_fov: f32,
    /// The faces photons start from, `faces[..emit_faces]`; the rest (a spot light's spill face)
    /// only receive. Only the emitting faces have caster buffers.
    pub emit_faces: usize,
}

/// The near plane of a perspective view reaching `far` (m): 1e-4 of it, at least 1 mm, but
/// never more than 1e-3 of it (a millimetre-sized scene keeps its near plane inside it).
pub(crate) fn near_plane(far: f32) -> f32 {
    (far * 1e-4).max((far * 1e-3).min(1e-3))
}

fn up_for(dir: Vec3) -> Vec3 {
    if dir.y.abs() > 0.99 { Vec3::Z } else { Vec3::Y }
}

impl LightView {
    /// The light view of `light` in `scene`.
    pub fn new(scene: &Scene, light: &Light) -> LightView {
        let (lo, hi) = scene.bounds();
        let center = (lo + hi) * 0.5;
        let radius = ((hi - lo).length() * 0.5).max(1e-3);
        match light {
            Light::Spot { position, direction, cone_angle, .. } if cone_angle.to_degrees() <= MAX_SPOT_FRUSTUM_DEG => {
                let far = (position.distance(center) + radius) * 1.01;
                let near = crate::lightspace::near_plane(far);
                let view = Mat4::look_at_rh(*position, *position + *direction, up_for(*direction));
                let proj = Mat4::perspective_rh(2.0 * cone_angle, 1.0, near, far);
                LightView {
                    faces: vec![LightFace {
                        world_to_clip: proj * view,
                        orthographic: false,
                        origin_or_dir: *position,
                    }],
                    near,
                    far,
                    scene_radius: radius,
                    tan_half_fov: cone_angle.tan(),
                    emit_faces: 1,
                }
            }
            Light::Spot { position, .. } | Light::Point { position, .. } => {
                let far = (position.distance(center) + radius) * 1.01;
                let near = crate::lightspace::near_plane(far);
                let proj = Mat4::perspective_rh(std::f32::consts::FRAC_PI_2, 1.0, near, far);
                let faces = CUBE_DIRS
                    .iter()
                    .map(|(d, up)| {
                        let view = Mat4::look_at_rh(*position, *position + *d, *up);
                        LightFace { world_to_clip: proj * view, orthographic: false, origin_or_dir: *position }
                    })
                    .collect();
                LightView { faces, near, far, scene_radius: radius, tan_half_fov: 1.0, emit_faces: 6 }
            }
            Light::Directional { direction, .. } => {
                let eye = center - *direction * (radius * 2.0);
                let view = Mat4::look_at_rh(eye, center, up_for(*direction));
                let proj = Mat4::orthographic_rh(-radius, radius, -radius, radius, radius * 0.5, radius * 3.5);
                LightView {
                    faces: vec![LightFace {
                        world_to_clip: proj * view,
                        orthographic: true,
                        origin_or_dir: *direction,
                    }],
                    near: radius * 0.5,
                    far: radius * 3.5,
                    scene_radius: radius,
                    tan_half_fov: 0.0,
                    emit_faces: 1,
                }
            }
        }
    }

    /// The light view of `light` with a spill face after the spot's own face
    /// ([`spill_face`]), for a spot light drawn with one perspective face (cone up to 75°);
    /// other lights' views are [`LightView::new`]'s.
    pub fn with_spill(scene: &Scene, light: &Light) -> LightView {
        let mut view = LightView::new(scene, light);
        if let Some(face) = spill_face(scene, light, view.near, view.far) {
            view.faces.push(face);
        }
        view
    }

    /// Whether the last face is a spill face (receives, emits no photons).
    pub fn has_spill(&self) -> bool {
        self.emit_faces < self.faces.len()
    }

    /// Face and texel coordinates (continuous, in texels, origin top-left) of world point `p` in a
    /// map of `size`² texels per face; `None` outside every face.
    pub fn project(&self, p: Vec3, size: u32) -> Option<(usize, f32, f32)> {
        for (f, face) in self.faces.iter().enumerate() {
            let c = face.world_to_clip * p.extend(1.0);
            if c.w <= 0.0 {
                continue;
            }
            let ndc = c.xyz() / c.w;
            if ndc.x.abs() <= 1.0 && ndc.y.abs() <= 1.0 && (0.0..=1.0).contains(&ndc.z) {
                let s = size as f32;
                return Some((f, (ndc.x * 0.5 + 0.5) * s, (0.5 - ndc.y * 0.5) * s));
            }
        }
        None
    }

    /// The ray through texel coordinates (x, y) of face `f`: origin and unit direction.
    pub fn texel_ray(&self, f: usize, x: f32, y: f32, size: u32) -> (Vec3, Vec3) {
        let face = &self.faces[f];
        let inv = face.world_to_clip.inverse();
        let ndc_x = 2.0 * x / size as f32 - 1.0;
        let ndc_y = 1.0 - 2.0 * y / size as f32;
        let a = inv.project_point3(Vec3::new(ndc_x, ndc_y, 0.0));
        let b = inv.project_point3(Vec3::new(ndc_x, ndc_y, 1.0));
        (a, (b - a).normalize())
    }

    /// Area (m²) on a receiver, at world point `p` with unit normal `n`, that one texel of face
    /// `f` covers. Divide a texel's flux by it to get irradiance.
    pub fn texel_area(&self, f: usize, p: Vec3, n: Vec3, size: u32) -> f32 {
        let face = &self.faces[f];
        let inv = face.world_to_clip.inverse();
        // Footprint of one texel on the plane through p facing the light, then projected onto
        // the receiver's plane.
        let c = face.world_to_clip * p.extend(1.0);
        let ndc = c.xyz() / c.w;
        let d = 2.0 / size as f32;
        let p0 = inv.project_point3(ndc);
        let px = inv.project_point3(ndc + Vec3::new(d, 0.0, 0.0));
        let py = inv.project_point3(ndc + Vec3::new(0.0, d, 0.0));
        let to_light = if face.orthographic { -face.origin_or_dir } else { (face.origin_or_dir - p).normalize() };
        // (px - p0) and (py - p0) span a parallelogram on the plane of constant NDC depth; its
        // area along the light ray is |cross| projected onto the ray, spread over the receiver.
        let perp_area = (px - p0).cross(py - p0).dot(to_light).abs();
        perp_area / n.dot(to_light).abs().max(1e-4)
    }
}

/// tan of the half-angle a square perspective view along `direction` from `position` needs to
/// see every corner of the box (lo, hi); `None` where a corner lies at or behind the eye's plane
/// (no perspective face sees it).
pub fn tan_half_angle_covering(position: Vec3, direction: Vec3, (lo, hi): (Vec3, Vec3)) -> Option<f32> {
    let view = Mat4::look_at_rh(position, position + direction, up_for(direction));
    let mut t = 0.0f32;
    for k in 0..8 {
        let p = Vec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        );
        let v = view.transform_point3(p);
        // Looking down -z in view space.
        if -v.z <= 1e-6 {
            return None;
        }
        t = t.max(v.x.abs().max(v.y.abs()) / -v.z);
    }
    Some(t)
}

/// tan of the widest half-angle of a spill face: [`MAX_SPOT_FRUSTUM_DEG`].
pub fn max_spill_tan() -> f32 {
    MAX_SPOT_FRUSTUM_DEG.to_radians().tan()
}

/// The spill face of a spot light (cone up to 75°): a square perspective face on the spot's eye
/// and axis (same up vector, near and far planes as its own face), wide enough to see the
/// scene's bounds (every corner of the box: a frustum is convex, so it then holds the whole
/// box), at most 75° half-angle, and never narrower than the cone. `None` for other lights.
pub fn spill_face(scene: &Scene, light: &Light, near: f32, far: f32) -> Option<LightFace> {
    let Light::Spot { position, direction, cone_angle, .. } = light else { return None };
    if cone_angle.to_degrees() > MAX_SPOT_FRUSTUM_DEG {
        return None;
    }
    let cap = max_spill_tan();
    let need = tan_half_angle_covering(*position, *direction, scene.bounds()).unwrap_or(cap);
    let tan_half = need.max(cone_angle.tan()).min(cap);
    let view = Mat4::look_at_rh(*position, *position + *direction, up_for(*direction));
    let proj = Mat4::perspective_rh(2.0 * tan_half.atan(), 1.0, near, far);
    Some(LightFace { world_to_clip: proj * view, orthographic: false, origin_or_dir: *position })
}

/// Whether the scene's bounds reach outside a spot light's own face (cone up to 75°): some
/// corner of the box is behind the eye or outside the cone's square. `false` for other lights.
pub fn bounds_beyond_spot(scene: &Scene, light: &Light) -> bool {
    let Light::Spot { position, direction, cone_angle, .. } = light else { return false };
    if cone_angle.to_degrees() > MAX_SPOT_FRUSTUM_DEG {
        return false;
    }
    tan_half_angle_covering(*position, *direction, scene.bounds()).is_none_or(|t| t > cone_angle.tan())
}

/// Cube faces: +X, -X, +Y, -Y, +Z, -Z, each with its up vector.
pub const CUBE_DIRS: [(Vec3, Vec3); 6] = [
    (Vec3::X, Vec3::NEG_Y),
    (Vec3::NEG_X, Vec3::NEG_Y),
    (Vec3::Y, Vec3::Z),
    (Vec3::NEG_Y, Vec3::NEG_Z),
    (Vec3::Z, Vec3::NEG_Y),
    (Vec3::NEG_Z, Vec3::NEG_Y),
];

/// Whether the box of the scene's casters reaches into `face`'s view (conservatively: a box
/// with a corner behind the eye counts as in view).
pub(crate) fn casters_in_view(scene: &Scene, face: &LightFace) -> bool {
    match caster_box(scene, face) {
        CasterBox::NoCasters => false,
        CasterBox::Behind => true,
        CasterBox::Ndc(a, b) => a.x <= 1.0 && a.y <= 1.0 && b.x >= -1.0 && b.y >= -1.0,
    }
}

/// The casters' bounding box as a light face sees it.
pub(crate) enum CasterBox {
    NoCasters,
    /// A corner of the box lies behind the face's view (no NDC box).
    Behind,
    /// The NDC rectangle (lo, hi) of the box's eight projected corners (not clamped).
    Ndc(glam::Vec2, glam::Vec2),
}

pub(crate) fn caster_box(scene: &Scene, face: &LightFace) -> CasterBox {
    let Some((lo, hi)) = scene.caster_bounds() else { return CasterBox::NoCasters };
    let (mut a, mut b) = (glam::Vec2::splat(f32::MAX), glam::Vec2::splat(f32::MIN));
    for k in 0..8 {
        let p = Vec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        );
        let c = face.world_to_clip * p.extend(1.0);
        if c.w <= 1e-6 {
            return CasterBox::Behind;
        }
        let q = glam::Vec2::new(c.x / c.w, c.y / c.w);
        a = a.min(q);
        b = b.max(q);
    }
    CasterBox::Ndc(a, b)
}
