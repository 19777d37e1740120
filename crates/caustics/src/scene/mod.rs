//! Scenes: the JSON format (`format`), meshes (`mesh`), and the validated, resolved [`Scene`]
//! that both the GPU renderer and the CPU reference read.
//!
//! Loading checks every value a renderer depends on and reports the file and the field
//! (`lights[0].intensity`) of the first problem; it never panics on bad input.

pub mod density;
pub mod environment;
pub mod environment_lights;
pub(crate) mod format;
mod gltf;
mod load;
pub mod mesh;
pub mod waves;

use crate::error::{Error, Result};
use format::*;
use glam::{Vec2, Vec3};
use std::path::Path;
use std::sync::Arc;

pub use density::DensityGrid;
pub use environment::Environment;
pub use gltf::{LUMENS_PER_WATT, to_glb, to_gltf, write_gltf};
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
    /// the axis, then falling to 0 at `cone_angle` by `profile`.
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
        /// How the intensity falls from `falloff_start` to `cone_angle`.
        profile: SpotProfile,
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
            Light::Spot { direction, cone_angle, falloff_start, intensity, profile, .. } => {
                intensity * spot_falloff(direction.dot(dir), *cone_angle, *falloff_start, *profile)
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

/// How a spot light's intensity falls between its core (`falloff_start`) and its edge
/// (`cone_angle`): `docs/scene-format.md`, "Spot falloff".
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SpotProfile {
    /// Linear in the angle off the axis (the scene format's default).
    #[default]
    Linear,
    /// `KHR_lights_punctual`'s curve: the square of a ramp linear in the cosine of the angle,
    /// from 0 at the outer cone (`cone_angle`) to 1 at the inner cone (`falloff_start`).
    Gltf,
}

impl SpotProfile {
    /// The name in the scene file's `falloff` field.
    pub fn name(self) -> &'static str {
        match self {
            SpotProfile::Linear => "linear",
            SpotProfile::Gltf => "gltf",
        }
    }
}

/// The spot profile of `docs/scene-format.md`: 1 up to `falloff_start` off the axis, 0 from
/// `cone_angle`, and between them linear in the angle or glTF's curve. `cos_angle` is the cosine
/// of the angle off the axis.
pub fn spot_falloff(cos_angle: f32, cone_angle: f32, falloff_start: f32, profile: SpotProfile) -> f32 {
    match profile {
        SpotProfile::Linear => {
            let angle = cos_angle.clamp(-1.0, 1.0).acos();
            if angle <= falloff_start {
                1.0
            } else if angle >= cone_angle {
                0.0
            } else {
                (cone_angle - angle) / (cone_angle - falloff_start)
            }
        }
        SpotProfile::Gltf => {
            // KHR_lights_punctual's reference implementation, its 0.001 floor included (an inner
            // cone equal to the outer one is a hard edge).
            let (inner, outer) = (falloff_start.cos(), cone_angle.cos());
            let scale = 1.0 / (inner - outer).max(0.001);
            let t = ((cos_angle - outer) * scale).clamp(0.0, 1.0);
            t * t
        }
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
    /// Smooth dielectric: Fresnel reflection and refraction; light travelling a distance s
    /// inside it is multiplied by exp(−`absorption`·s) per channel (Beer–Lambert).
    Dielectric {
        /// Index of refraction inside the object (positive).
        ior: f32,
        /// Index of refraction outside the object (positive).
        ext_ior: f32,
        /// Absorption coefficient σa of the inside (1/m) per channel (non-negative; zero: clear).
        absorption: Vec3,
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
    /// A clear dielectric (no absorption).
    pub fn clear_dielectric(ior: f32, ext_ior: f32) -> Self {
        Material::Dielectric { ior, ext_ior, absorption: Vec3::ZERO }
    }
    /// The absorption coefficient (1/m) of the inside of a dielectric; zero for other materials.
    pub fn absorption(&self) -> Vec3 {
        match self {
            Material::Dielectric { absorption, .. } => *absorption,
            _ => Vec3::ZERO,
        }
    }
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
    /// Animated water (`{"type": "waves"}`): `shape` is its mesh at the scene's time, posed
    /// again by [`Scene::at_time`] (and `Renderer::set_time`).
    pub waves: Option<Arc<waves::Waves>>,
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
    /// Whether any object moves with time (`waves`).
    pub fn is_animated(&self) -> bool {
        self.objects.iter().any(|o| o.waves.is_some())
    }

    /// The scene at time `t` (seconds; a file poses it at 0): every `waves` object's mesh posed
    /// at `t`, the rest unchanged.
    pub fn at_time(&self, t: f32) -> Scene {
        let mut s = self.clone();
        for o in &mut s.objects {
            if let Some(w) = &o.waves {
                o.shape = Shape::Mesh(Arc::new(w.mesh(t)));
            }
        }
        s
    }

    /// Load and validate a scene file: our JSON (`docs/scene-format.md`), or glTF 2.0 by the
    /// extension `.gltf` or `.glb` (`docs/gltf.md`, its first camera).
    pub fn load(path: &Path) -> Result<Scene> {
        Scene::load_with_camera(path, None)
    }

    /// [`Scene::load`] with the camera of a glTF file chosen by node or camera name, or by index
    /// into its `cameras` (`None`: its first camera). A choice for a JSON scene, which has one
    /// camera, is an error.
    pub fn load_with_camera(path: &Path, camera: Option<&str>) -> Result<Scene> {
        if is_gltf(path) {
            return gltf::load(path, camera);
        }
        let file = path.display().to_string();
        if camera.is_some() {
            return Err(Error::input(&file, "--camera", "only glTF scenes (.gltf, .glb) have cameras to choose from"));
        }
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
        load::resolve(desc, file, base)
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

/// Whether `path` names a glTF file (`.gltf` or `.glb`, any case).
fn is_gltf(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("gltf") || e.eq_ignore_ascii_case("glb"))
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
