//! Scenes: the JSON format (`format`), meshes (`mesh`), and the validated, resolved [`Scene`]
//! that both the GPU renderer and the CPU reference read.
//!
//! Loading checks every value a renderer depends on and reports the file and the field
//! (`lights[0].intensity`) of the first problem; it never panics on bad input.

pub mod density;
pub mod environment;
pub mod environment_lights;
pub(crate) mod format;
pub mod mesh;

use crate::error::{Error, Result};
use format::*;
use glam::{Mat3, Vec2, Vec3};
use std::path::{Path, PathBuf};
use std::sync::Arc;

pub use density::DensityGrid;
pub use environment::Environment;
pub use mesh::TriMesh;

/// The scene embedded in the binary: `caustics render` with no scene renders it.
pub const DEFAULT_SCENE_JSON: &str = include_str!("../../../../scenes/glass_sphere.json");
/// Name of the embedded default scene, as error messages show it.
pub const DEFAULT_SCENE_NAME: &str = "<built-in scenes/glass_sphere.json>";

/// A pinhole camera (`docs/scene-format.md`: vertical field of view, image x = forward × up,
/// pixel (0,0) top-left).
#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    /// Eye point (m).
    pub position: Vec3,
    /// Point the camera looks at (m).
    pub look_at: Vec3,
    /// Up direction; need not be perpendicular to the view direction ([`Self::true_up`] is).
    pub up: Vec3,
    /// Full vertical field of view, in degrees, in (0, 180).
    pub fov_y_deg: f32,
    /// Image width in pixels (1 to 16384).
    pub width: u32,
    /// Image height in pixels (1 to 16384).
    pub height: u32,
}

impl Camera {
    /// Unit vector the camera looks along.
    pub fn forward(&self) -> Vec3 {
        (self.look_at - self.position).normalize()
    }
    /// Unit image x axis (forward × up).
    pub fn right(&self) -> Vec3 {
        self.forward().cross(self.up).normalize()
    }
    /// Unit image up axis (right × forward).
    pub fn true_up(&self) -> Vec3 {
        self.right().cross(self.forward())
    }
    /// Aspect ratio, width over height.
    pub fn aspect(&self) -> f32 {
        self.width as f32 / self.height as f32
    }
    /// Direction (unit) of the ray through image point (x, y) in pixels, (0,0) = top-left corner
    /// of the image, (width, height) = bottom-right corner.
    pub fn ray_dir(&self, x: f32, y: f32) -> Vec3 {
        let t = (self.fov_y_deg.to_radians() * 0.5).tan();
        let sx = (2.0 * x / self.width as f32 - 1.0) * t * self.aspect();
        let sy = (1.0 - 2.0 * y / self.height as f32) * t;
        (self.forward() + sx * self.right() + sy * self.true_up()).normalize()
    }
    /// World-to-view matrix (right-handed, looking down -Z).
    pub fn world_to_view(&self) -> glam::Mat4 {
        glam::Mat4::look_at_rh(self.position, self.look_at, self.true_up())
    }
    /// View-to-clip matrix (wgpu depth range 0..1).
    pub fn view_to_clip(&self, near: f32, far: f32) -> glam::Mat4 {
        glam::Mat4::perspective_rh(self.fov_y_deg.to_radians(), self.aspect(), near, far)
    }
}

/// A light, in physical units.
#[derive(Debug, Clone, PartialEq)]
pub enum Light {
    /// Radiant intensity `intensity` (W/sr) on the axis, full up to `falloff_start` (radians) off
    /// the axis, then linear in the angle down to 0 at `cone_angle`.
    Spot {
        /// Position (m).
        position: Vec3,
        /// Unit axis, the way the light shines.
        direction: Vec3,
        /// Half-angle (radians) where the intensity reaches 0, in (0, π).
        cone_angle: f32,
        /// Half-angle (radians) of the full-intensity core, in [0, `cone_angle`].
        falloff_start: f32,
        /// Radiant intensity on the axis (W/sr), per channel.
        intensity: Vec3,
    },
    /// Isotropic radiant intensity (W/sr).
    Point {
        /// Position (m).
        position: Vec3,
        /// Radiant intensity in every direction (W/sr), per channel.
        intensity: Vec3,
    },
    /// Parallel light travelling along `direction` (unit) with `irradiance` (W/m²) on a surface
    /// facing it.
    Directional {
        /// Unit direction the light travels.
        direction: Vec3,
        /// Irradiance on a surface facing the light (W/m²), per channel.
        irradiance: Vec3,
    },
}

impl Light {
    /// Radiant intensity (W/sr) toward unit direction `dir` from the light; zero for directional
    /// lights, which have none.
    pub fn intensity_toward(&self, dir: Vec3) -> Vec3 {
        match self {
            Light::Spot { direction, cone_angle, falloff_start, intensity, .. } => {
                intensity * spot_falloff(direction.dot(dir), *cone_angle, *falloff_start)
            }
            Light::Point { intensity, .. } => *intensity,
            Light::Directional { .. } => Vec3::ZERO,
        }
    }
    /// Position of a spot or point light.
    pub fn position(&self) -> Option<Vec3> {
        match self {
            Light::Spot { position, .. } | Light::Point { position, .. } => Some(*position),
            Light::Directional { .. } => None,
        }
    }
    /// The light's `type` in the scene file: `"spot"`, `"point"` or `"directional"`.
    pub fn kind(&self) -> &'static str {
        match self {
            Light::Spot { .. } => "spot",
            Light::Point { .. } => "point",
            Light::Directional { .. } => "directional",
        }
    }
}

/// The spot profile of `docs/scene-format.md`: 1 up to `falloff_start` off the axis, linear in
/// the angle to 0 at `cone_angle`. `cos_angle` is the cosine of the angle off the axis.
pub fn spot_falloff(cos_angle: f32, cone_angle: f32, falloff_start: f32) -> f32 {
    let angle = cos_angle.clamp(-1.0, 1.0).acos();
    if angle <= falloff_start {
        1.0
    } else if angle >= cone_angle {
        0.0
    } else {
        (cone_angle - angle) / (cone_angle - falloff_start)
    }
}

/// A surface material.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Material {
    /// Lambertian, two-sided.
    Diffuse {
        /// Reflectance per channel, in [0, 1].
        albedo: Vec3,
    },
    /// Smooth dielectric: Fresnel reflection and refraction, no absorption.
    Dielectric {
        /// Index of refraction inside the object (positive).
        ior: f32,
        /// Index of refraction outside the object (positive).
        ext_ior: f32,
    },
    /// Perfect specular reflector, angle-independent, two-sided.
    Mirror {
        /// Reflectance per channel, in [0, 1].
        reflectance: Vec3,
    },
    /// Smooth conductor with complex IOR `eta + i k`, full Fresnel, two-sided.
    Conductor {
        /// Real part of the IOR per channel (positive).
        eta: Vec3,
        /// Imaginary part of the IOR (extinction coefficient) per channel (non-negative).
        k: Vec3,
    },
}

impl Material {
    /// Dielectric, mirror and conductor materials are specular: they cast caustics.
    pub fn is_specular(&self) -> bool {
        !matches!(self, Material::Diffuse { .. })
    }
}

/// Geometry of an object, in world space.
#[derive(Debug, Clone)]
pub enum Shape {
    /// A sphere, its normals facing out.
    Sphere {
        /// Centre (m).
        center: Vec3,
        /// Radius (m).
        radius: f32,
    },
    /// A rectangle spanning `size.x` along `u` and `size.y` along `v = normal × u`.
    Rectangle {
        /// Centre (m).
        center: Vec3,
        /// Unit normal.
        normal: Vec3,
        /// Unit in-plane axis: the scene file's `u_axis` (default +X, or +Z when the normal is
        /// within 25° of the x axis) projected onto the plane.
        u: Vec3,
        /// Unit in-plane axis `normal × u`.
        v: Vec3,
        /// Side lengths along `u` and `v` (m).
        size: Vec2,
    },
    /// An open tube (no caps) from `base_center` along unit `axis`.
    Cylinder {
        /// Centre of the base circle (m).
        base_center: Vec3,
        /// Unit axis, from the base toward the top.
        axis: Vec3,
        /// Radius (m).
        radius: f32,
        /// Length along `axis` (m).
        height: f32,
    },
    /// A triangle mesh, already transformed to world space.
    Mesh(Arc<TriMesh>),
}

/// An object: a shape and its material.
#[derive(Debug, Clone)]
pub struct Object {
    /// Its geometry, in world space.
    pub shape: Shape,
    /// Index into [`Scene::materials`].
    pub material: usize,
    /// Whether it casts caustics (default: specular materials do).
    pub caustic_caster: bool,
}

/// Phase function of a participating medium.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Phase {
    /// Every direction equally likely: 1/(4π) per steradian.
    Isotropic,
    /// Henyey–Greenstein (the scene file's `hg`).
    HenyeyGreenstein {
        /// Asymmetry, the mean cosine of the scattering angle, in (-1, 1); positive scatters
        /// forward.
        g: f32,
    },
}

/// A participating medium filling an axis-aligned box (outside dielectrics): homogeneous, or
/// heterogeneous with a density grid that multiplies `sigma_s` and `sigma_a` point by point.
#[derive(Debug, Clone, PartialEq)]
pub struct Medium {
    /// Scattering coefficient per channel (1/m) at density 1.
    pub sigma_s: Vec3,
    /// Absorption coefficient per channel (1/m) at density 1.
    pub sigma_a: Vec3,
    /// Phase function, the same for every channel.
    pub phase: Phase,
    /// Lower corner of the box (m).
    pub bounds_min: Vec3,
    /// Upper corner of the box (m), above `bounds_min` on every axis.
    pub bounds_max: Vec3,
    /// The density grid over the box (`None`: density 1 everywhere, a homogeneous medium).
    pub density: Option<Arc<DensityGrid>>,
}

impl Medium {
    /// The density at the world point `p` (inside the box; 1 without a grid).
    pub fn density_at(&self, p: Vec3) -> f32 {
        match &self.density {
            None => 1.0,
            Some(g) => g.lookup((p - self.bounds_min) / (self.bounds_max - self.bounds_min)),
        }
    }

    /// The largest density in the box (1 without a grid).
    pub fn max_density(&self) -> f32 {
        self.density.as_ref().map_or(1.0, |g| g.max)
    }
}

/// How finely analytic shapes are turned into triangles for rasterization.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Tessellation {
    /// Segments around a sphere's equator (half as many from pole to pole).
    pub sphere_segments: u32,
    /// Segments around a cylinder.
    pub cylinder_segments: u32,
}

impl Default for Tessellation {
    fn default() -> Self {
        Tessellation { sphere_segments: 192, cylinder_segments: 512 }
    }
}

/// A validated scene, ready to render.
#[derive(Debug, Clone)]
pub struct Scene {
    /// The scene's name, the output file stem (not empty).
    pub name: String,
    /// The scene file's free-text `description`.
    pub description: Option<String>,
    /// The file it came from (or the built-in name).
    pub source: String,
    /// The camera.
    pub camera: Camera,
    /// Display exposure (`display.exposure`, default 1): multiplies radiance before the PNG tone
    /// mapping; not physics.
    pub exposure: f32,
    /// The spot, point and directional lights, in the file's order, without the environment
    /// light.
    pub lights: Vec<Light>,
    /// The materials, in the order of their names.
    pub materials: Vec<Material>,
    /// The name of each material in [`Self::materials`], sorted.
    pub material_names: Vec<String>,
    /// The objects, in the file's order; not empty.
    pub objects: Vec<Object>,
    /// The participating medium, if any.
    pub medium: Option<Medium>,
    /// The environment light (`{"type": "environment"}` in `lights`), if any: kept apart from
    /// [`Self::lights`], which are the lights the GPU renders with light-space maps.
    pub environment: Option<Arc<Environment>>,
    /// Problems that do not stop rendering (open dielectric meshes, dropped degenerate triangles).
    pub warnings: Vec<String>,
}

impl Scene {
    /// Load and validate a scene file.
    pub fn load(path: &Path) -> Result<Scene> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path)
            .map_err(|e| Error::input(&file, "", format!("cannot read scene file: {e}")))?;
        let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        Scene::from_json(&text, &file, &base)
    }

    /// The built-in default scene.
    pub fn default_scene() -> Scene {
        Scene::from_json(DEFAULT_SCENE_JSON, DEFAULT_SCENE_NAME, Path::new("."))
            .expect("the built-in scene is valid (checked by a test)")
    }

    /// Parse and validate scene JSON; `file` names it in errors, `base` resolves relative paths.
    pub fn from_json(text: &str, file: &str, base: &Path) -> Result<Scene> {
        let de = &mut serde_json::Deserializer::from_str(text);
        let desc: SceneFile = serde_path_to_error::deserialize(de).map_err(|e| {
            let path = e.path().to_string();
            let inner = e.into_inner();
            let line = (inner.line() > 0).then(|| (inner.line(), inner.column()));
            let mut message = inner.to_string();
            // serde_json appends " at line L column C"; we print that ourselves.
            if let Some(i) = message.rfind(" at line ") {
                message.truncate(i);
            }
            let mut field = if path == "." { String::new() } else { path };
            // An error inside a tagged element carries the path within it (format::variant).
            if let Some(rest) = message.strip_prefix(format::INNER_PATH)
                && let Some((inner_path, msg)) = rest.split_once(format::INNER_PATH)
            {
                if inner_path != "." {
                    field = format!("{field}.{inner_path}");
                }
                message = msg.to_string();
            }
            Error::Input { file: file.into(), field, line, message }
        })?;
        resolve(desc, file, base)
    }

    /// Material of an object.
    pub fn material_of(&self, object: &Object) -> &Material {
        &self.materials[object.material]
    }

    /// Axis-aligned bounds of every object (rectangles and meshes exactly, spheres and cylinders
    /// conservatively).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        bounds_of(self.objects.iter())
    }

    /// Bounds of the caustic casters only; `None` if there are none.
    pub fn caster_bounds(&self) -> Option<(Vec3, Vec3)> {
        let casters: Vec<_> = self.objects.iter().filter(|o| o.caustic_caster).collect();
        (!casters.is_empty()).then(|| bounds_of(casters.into_iter()))
    }
}

fn bounds_of<'a>(objects: impl Iterator<Item = &'a Object>) -> (Vec3, Vec3) {
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for o in objects {
        let (a, b) = o.shape.bounds();
        lo = lo.min(a);
        hi = hi.max(b);
    }
    (lo, hi)
}

impl Shape {
    /// Axis-aligned bounds.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        match self {
            Shape::Sphere { center, radius } => (center - Vec3::splat(*radius), center + Vec3::splat(*radius)),
            Shape::Rectangle { center, u, v, size, .. } => {
                let e = (u * size.x * 0.5).abs() + (v * size.y * 0.5).abs();
                (center - e, center + e)
            }
            Shape::Cylinder { base_center, axis, radius, height } => {
                // Exact box of a disc of radius r with normal a: r * sqrt(1 - a_i^2) per axis.
                let e = (Vec3::ONE - *axis * *axis).max(Vec3::ZERO).map(f32::sqrt) * *radius;
                let top = base_center + axis * *height;
                (base_center.min(top) - e, base_center.max(top) + e)
            }
            Shape::Mesh(m) => m.bounds(),
        }
    }

    /// The shape moved by `t`, a rotation, translation and uniform scale (a similarity keeps
    /// spheres spheres); anything else is an error message.
    pub fn transformed(&self, t: &glam::Affine3A) -> std::result::Result<Shape, String> {
        let m = glam::Mat3::from(t.matrix3);
        let s = m.x_axis.length();
        let ortho = m * (1.0 / s.max(f32::MIN_POSITIVE));
        let off = (ortho.transpose() * ortho - glam::Mat3::IDENTITY)
            .to_cols_array()
            .iter()
            .fold(0.0f32, |a, x| a.max(x.abs()));
        if !(s.is_finite() && s > 1e-12) || off > 1e-4 || ortho.determinant() < 0.0 || !t.translation.is_finite() {
            return Err("must be a rotation, translation and positive uniform scale".into());
        }
        let p = |x: Vec3| t.transform_point3(x);
        let d = |x: Vec3| (ortho * x).normalize();
        Ok(match self {
            Shape::Sphere { center, radius } => Shape::Sphere { center: p(*center), radius: radius * s },
            Shape::Rectangle { center, normal, u, v, size } => {
                Shape::Rectangle { center: p(*center), normal: d(*normal), u: d(*u), v: d(*v), size: *size * s }
            }
            Shape::Cylinder { base_center, axis, radius, height } => {
                Shape::Cylinder { base_center: p(*base_center), axis: d(*axis), radius: radius * s, height: height * s }
            }
            Shape::Mesh(mesh) => Shape::Mesh(Arc::new(TriMesh {
                positions: mesh.positions.iter().map(|x| p(*x)).collect(),
                normals: mesh.normals.iter().map(|x| d(*x)).collect(),
                indices: mesh.indices.clone(),
            })),
        })
    }

    /// Triangles for rasterization, in world space, with shading normals.
    pub fn tessellate(&self, t: &Tessellation) -> TriMesh {
        match self {
            Shape::Sphere { center, radius } => mesh::sphere(*center, *radius, t.sphere_segments.max(8)),
            Shape::Rectangle { center, normal, u, v, size } => mesh::rectangle(*center, *normal, *u, *v, *size),
            Shape::Cylinder { base_center, axis, radius, height } => {
                mesh::cylinder(*base_center, *axis, *radius, *height, t.cylinder_segments.max(8))
            }
            Shape::Mesh(m) => (**m).clone(),
        }
    }
}

fn v3(a: [f32; 3]) -> Vec3 {
    Vec3::from_array(a)
}

struct Ctx<'a> {
    file: &'a str,
}

impl Ctx<'_> {
    fn err(&self, field: impl Into<String>, msg: impl Into<String>) -> Error {
        Error::input(self.file, field, msg)
    }
    fn finite3(&self, field: &str, a: [f32; 3]) -> Result<Vec3> {
        if a.iter().all(|x| x.is_finite()) { Ok(v3(a)) } else { Err(self.err(field, "must be finite numbers")) }
    }
    fn dir(&self, field: &str, a: [f32; 3]) -> Result<Vec3> {
        let v = self.finite3(field, a)?;
        if v.length() < 1e-12 {
            return Err(self.err(field, "must be a non-zero direction"));
        }
        Ok(v.normalize())
    }
    fn nonneg_rgb(&self, field: &str, c: Rgb) -> Result<Vec3> {
        let v = self.finite3(field, c.0)?;
        if v.min_element() < 0.0 {
            return Err(self.err(field, format!("must not be negative (got {:?})", c.0)));
        }
        Ok(v)
    }
    fn unit_rgb(&self, field: &str, c: Rgb) -> Result<Vec3> {
        let v = self.nonneg_rgb(field, c)?;
        if v.max_element() > 1.0 {
            return Err(self.err(field, format!("must lie in [0, 1]: more would create energy (got {:?})", c.0)));
        }
        Ok(v)
    }
    fn positive(&self, field: &str, x: f32) -> Result<f32> {
        if x.is_finite() && x > 0.0 {
            Ok(x)
        } else {
            Err(self.err(field, format!("must be a positive number (got {x})")))
        }
    }
}

fn resolve(d: SceneFile, file: &str, base: &Path) -> Result<Scene> {
    let cx = Ctx { file };
    if d.schema_version != 1 {
        return Err(
            cx.err("schema_version", format!("unsupported version {} (this program reads 1)", d.schema_version))
        );
    }
    if d.name.trim().is_empty() {
        return Err(cx.err("name", "must not be empty (it is the output file stem)"));
    }

    let c = &d.camera;
    let camera = Camera {
        position: cx.finite3("camera.position", c.position)?,
        look_at: cx.finite3("camera.look_at", c.look_at)?,
        up: cx.dir("camera.up", c.up)?,
        fov_y_deg: c.fov_y_deg,
        width: c.width,
        height: c.height,
    };
    if camera.position.distance(camera.look_at) < 1e-9 {
        return Err(cx.err("camera.look_at", "must differ from camera.position"));
    }
    if camera.forward().cross(camera.up).length() < 1e-6 {
        return Err(cx.err("camera.up", "must not be parallel to the viewing direction"));
    }
    if !(c.fov_y_deg > 0.0 && c.fov_y_deg < 180.0) {
        return Err(cx.err("camera.fov_y_deg", format!("must lie in (0, 180) degrees (got {})", c.fov_y_deg)));
    }
    for (f, v) in [("camera.width", c.width), ("camera.height", c.height)] {
        if v == 0 || v > 16384 {
            return Err(cx.err(f, format!("must be between 1 and 16384 pixels (got {v})")));
        }
    }
    let exposure = d.display.as_ref().map_or(1.0, |x| x.exposure);
    if !(exposure.is_finite() && exposure > 0.0) {
        return Err(cx.err("display.exposure", format!("must be a positive number (got {exposure})")));
    }

    if d.lights.is_empty() {
        return Err(cx.err("lights", "the scene has no light"));
    }
    let mut lights = Vec::new();
    let mut environment: Option<(usize, Arc<Environment>)> = None;
    let mut warnings = Vec::new();
    for (i, l) in d.lights.iter().enumerate() {
        let f = |s: &str| format!("lights[{i}].{s}");
        lights.push(match l {
            LightDesc::Spot(SpotDesc { position, direction, cone_angle_deg, falloff_start_deg, intensity }) => {
                let cone = *cone_angle_deg;
                if !(cone > 0.0 && cone < 180.0) {
                    return Err(cx.err(f("cone_angle_deg"), format!("must lie in (0, 180) degrees (got {cone})")));
                }
                let start = falloff_start_deg.unwrap_or(0.75 * cone);
                if !(start >= 0.0 && start <= cone) {
                    return Err(cx.err(
                        f("falloff_start_deg"),
                        format!("must lie in [0, cone_angle_deg = {cone}] (got {start})"),
                    ));
                }
                Light::Spot {
                    position: cx.finite3(&f("position"), *position)?,
                    direction: cx.dir(&f("direction"), *direction)?,
                    cone_angle: cone.to_radians(),
                    falloff_start: start.to_radians(),
                    intensity: cx.nonneg_rgb(&f("intensity"), *intensity)?,
                }
            }
            LightDesc::Point(PointDesc { position, intensity }) => Light::Point {
                position: cx.finite3(&f("position"), *position)?,
                intensity: cx.nonneg_rgb(&f("intensity"), *intensity)?,
            },
            LightDesc::Directional(DirectionalDesc { direction, irradiance }) => Light::Directional {
                direction: cx.dir(&f("direction"), *direction)?,
                irradiance: cx.nonneg_rgb(&f("irradiance"), *irradiance)?,
            },
            LightDesc::Environment(e) => {
                if let Some((k, _)) = &environment {
                    return Err(cx.err(
                        format!("lights[{i}]"),
                        format!("at most one environment light (lights[{k}] is one already)"),
                    ));
                }
                let scale = cx.nonneg_rgb(&f("scale"), e.scale.unwrap_or(Rgb([1.0; 3])))?;
                if !e.rotate_y_deg.is_finite() {
                    return Err(cx.err(f("rotate_y_deg"), "must be finite"));
                }
                let full = resolve_path(base, &e.path);
                let env = Environment::load(&full, scale, e.rotate_y_deg)
                    .map_err(|msg| cx.err(f("path"), format!("environment map {}: {msg}", full.display())))?;
                if env.clamped_negative > 0 {
                    warnings.push(format!(
                        "{file}: {}: set {} negative value(s) of environment map {} to 0 (lossy compression rings around bright texels)",
                        f("path"),
                        env.clamped_negative,
                        full.display()
                    ));
                }
                environment = Some((i, Arc::new(env)));
                continue;
            }
        });
    }

    let mut materials = Vec::new();
    let mut material_names = Vec::new();
    for (name, m) in &d.materials {
        let f = |s: &str| format!("materials.{name}.{s}");
        materials.push(match m {
            MaterialDesc::Diffuse(DiffuseDesc { albedo }) => {
                Material::Diffuse { albedo: cx.unit_rgb(&f("albedo"), *albedo)? }
            }
            MaterialDesc::Dielectric(DielectricDesc { ior, ext_ior }) => Material::Dielectric {
                ior: cx.positive(&f("ior"), *ior)?,
                ext_ior: cx.positive(&f("ext_ior"), *ext_ior)?,
            },
            MaterialDesc::Mirror(MirrorDesc { reflectance }) => {
                Material::Mirror { reflectance: cx.unit_rgb(&f("reflectance"), *reflectance)? }
            }
            MaterialDesc::Conductor(ConductorDesc { eta, k }) => {
                let eta = cx.nonneg_rgb(&f("eta"), *eta)?;
                if eta.min_element() <= 0.0 {
                    return Err(cx.err(f("eta"), "must be positive"));
                }
                Material::Conductor { eta, k: cx.nonneg_rgb(&f("k"), *k)? }
            }
        });
        material_names.push(name.clone());
    }

    let mut objects = Vec::new();
    for (i, o) in d.objects.iter().enumerate() {
        let f = |s: &str| format!("objects[{i}].{s}");
        let (mat_name, caster) = match o {
            ObjectDesc::Sphere(SphereDesc { material, caustic_caster, .. })
            | ObjectDesc::Rectangle(RectangleDesc { material, caustic_caster, .. })
            | ObjectDesc::Cylinder(CylinderDesc { material, caustic_caster, .. })
            | ObjectDesc::Mesh(MeshDesc { material, caustic_caster, .. }) => (material, caustic_caster),
        };
        let material = material_names.iter().position(|n| n == mat_name).ok_or_else(|| {
            cx.err(
                f("material"),
                format!("unknown material \"{mat_name}\" (the scene defines: {})", material_names.join(", ")),
            )
        })?;
        let shape = match o {
            ObjectDesc::Sphere(SphereDesc { center, radius, .. }) => Shape::Sphere {
                center: cx.finite3(&f("center"), *center)?,
                radius: cx.positive(&f("radius"), *radius)?,
            },
            ObjectDesc::Rectangle(RectangleDesc { center, normal, size, u_axis, .. }) => {
                let normal = cx.dir(&f("normal"), *normal)?;
                let size = Vec2::new(cx.positive(&f("size[0]"), size[0])?, cx.positive(&f("size[1]"), size[1])?);
                let default_u = if normal.dot(Vec3::X).abs() > 25f32.to_radians().cos() { Vec3::Z } else { Vec3::X };
                let u0 = match u_axis {
                    Some(a) => cx.dir(&f("u_axis"), *a)?,
                    None => default_u,
                };
                let u = u0 - normal * normal.dot(u0);
                if u.length() < 1e-6 {
                    return Err(cx.err(f("u_axis"), "must not be parallel to the normal"));
                }
                let u = u.normalize();
                Shape::Rectangle { center: cx.finite3(&f("center"), *center)?, normal, u, v: normal.cross(u), size }
            }
            ObjectDesc::Cylinder(CylinderDesc { base_center, axis, radius, height, .. }) => Shape::Cylinder {
                base_center: cx.finite3(&f("base_center"), *base_center)?,
                axis: cx.dir(&f("axis"), *axis)?,
                radius: cx.positive(&f("radius"), *radius)?,
                height: cx.positive(&f("height"), *height)?,
            },
            ObjectDesc::Mesh(MeshDesc { path, smooth_normals, transform, .. }) => {
                let t = transform.as_ref();
                let scale = match t.and_then(|t| t.scale) {
                    Some(Scale(s)) => {
                        for (k, x) in s.iter().enumerate() {
                            if !(x.is_finite() && *x > 0.0) {
                                return Err(
                                    cx.err(f(&format!("transform.scale[{k}]")), format!("must be positive (got {x})"))
                                );
                            }
                        }
                        v3(s)
                    }
                    None => Vec3::ONE,
                };
                let rot = t.map_or(0.0, |t| t.rotate_y_deg);
                if !rot.is_finite() {
                    return Err(cx.err(f("transform.rotate_y_deg"), "must be finite"));
                }
                let translate = cx.finite3(&f("transform.translate"), t.map_or([0.0; 3], |t| t.translate))?;
                let full = resolve_path(base, path);
                let mut m = mesh::load_obj(&full)
                    .map_err(|msg| cx.err(f("path"), format!("mesh {}: {msg}", full.display())))?;
                let dropped = m.drop_degenerate();
                if dropped > 0 {
                    warnings.push(format!(
                        "{file}: {}: dropped {dropped} degenerate triangle(s) of {}",
                        f("path"),
                        full.display()
                    ));
                }
                if m.indices.is_empty() {
                    return Err(cx.err(f("path"), format!("mesh {} has no usable triangle", full.display())));
                }
                let rot = Mat3::from_rotation_y(rot.to_radians());
                m.transform(Mat3::from_diagonal(scale), rot, translate);
                if !*smooth_normals {
                    m.use_face_normals();
                }
                if matches!(materials[material], Material::Dielectric { .. }) {
                    let open = m.boundary_edges();
                    if open > 0 {
                        warnings.push(format!(
                            "{file}: {}: dielectric mesh {} is not closed ({open} boundary edges); refraction through its holes is undefined",
                            f("path"),
                            full.display()
                        ));
                    }
                }
                Shape::Mesh(Arc::new(m))
            }
        };
        objects.push(Object { shape, material, caustic_caster: caster.unwrap_or(materials[material].is_specular()) });
    }
    if objects.is_empty() {
        return Err(cx.err("objects", "the scene has no object"));
    }

    let medium = match &d.medium {
        None => None,
        Some(m) => {
            let phase = match m.phase {
                None | Some(PhaseDesc::Isotropic) => Phase::Isotropic,
                Some(PhaseDesc::Hg { g }) => {
                    if !(g > -1.0 && g < 1.0) {
                        return Err(cx.err("medium.phase.g", format!("must lie in (-1, 1) (got {g})")));
                    }
                    Phase::HenyeyGreenstein { g }
                }
            };
            let lo = cx.finite3("medium.bounds.min", m.bounds.min)?;
            let hi = cx.finite3("medium.bounds.max", m.bounds.max)?;
            if !lo.cmplt(hi).all() {
                return Err(cx.err(
                    "medium.bounds",
                    format!("min must be below max on every axis (an empty or inverted box: min {lo}, max {hi})"),
                ));
            }
            if let Some((k, _)) = &environment {
                return Err(
                    cx.err("medium", format!("a medium cannot be combined with an environment light (lights[{k}])"))
                );
            }
            let sigma_s = cx.nonneg_rgb("medium.sigma_s", m.sigma_s)?;
            let sigma_a = cx.nonneg_rgb("medium.sigma_a", m.sigma_a)?;
            let density = match &m.density {
                None => None,
                Some(d) => {
                    let full = resolve_path(base, &d.path);
                    let g = DensityGrid::load(&full).map_err(|msg| {
                        cx.err("medium.density.path", format!("density grid {}: {msg}", full.display()))
                    })?;
                    Some(Arc::new(g))
                }
            };
            Some(Medium { sigma_s, sigma_a, phase, bounds_min: lo, bounds_max: hi, density })
        }
    };

    Ok(Scene {
        name: d.name,
        description: d.description,
        source: file.to_string(),
        camera,
        exposure,
        lights,
        materials,
        material_names,
        objects,
        medium,
        environment: environment.map(|(_, e)| e),
        warnings,
    })
}

fn resolve_path(base: &Path, p: &str) -> PathBuf {
    let p = Path::new(p);
    if p.is_absolute() { p.to_path_buf() } else { base.join(p) }
}
