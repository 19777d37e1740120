//! `CAUSTICS_scene`, this program's glTF extension (`docs/gltf.md`, "Export"): the exact scene
//! that `caustics convert` wrote, beside the glTF rendition other programs read. Where a file
//! has it, it is read instead of the glTF materials, lights and camera, so that the scene comes
//! back bit for bit; the triangles, environment texels and density values are read from the
//! file's accessors.

use super::container::Document;
use super::{Ctx, geometry};
use crate::error::Result;
use crate::scene::waves::{Wave, Waves};
use crate::scene::{Camera, DensityGrid, Environment, Light, Material, Medium, Object, Phase, Scene, Shape, TriMesh};
use glam::{Vec2, Vec3};
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// The extension's name, in `extensionsUsed` and the root's `extensions`.
pub(crate) const NAME: &str = "CAUSTICS_scene";
/// The layout this program writes and reads.
pub(crate) const VERSION: u32 = 1;

/// The extension's JSON: every value in our units (metres, radians, W/sr, W/m²), as the
/// loaded [`Scene`] holds it.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct Ext {
    pub version: u32,
    pub name: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    pub camera: CameraExt,
    pub exposure: f32,
    pub lights: Vec<LightExt>,
    pub materials: Vec<MaterialExt>,
    pub objects: Vec<ObjectExt>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub medium: Option<MediumExt>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub environment: Option<EnvironmentExt>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct CameraExt {
    pub position: [f32; 3],
    pub look_at: [f32; 3],
    pub up: [f32; 3],
    pub fov_y_deg: f32,
    pub width: u32,
    pub height: u32,
}

#[derive(Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub(crate) enum LightExt {
    Spot {
        position: [f32; 3],
        direction: [f32; 3],
        cone_angle: f32,
        falloff_start: f32,
        intensity: [f32; 3],
        /// `"gltf"` for glTF's falloff curve; absent: ours, linear in the angle.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        falloff: Option<String>,
    },
    Point {
        position: [f32; 3],
        intensity: [f32; 3],
    },
    Directional {
        direction: [f32; 3],
        irradiance: [f32; 3],
    },
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct MaterialExt {
    pub name: String,
    pub material: MaterialKind,
}

#[derive(Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub(crate) enum MaterialKind {
    Diffuse {
        albedo: [f32; 3],
    },
    Dielectric {
        ior: f32,
        ext_ior: f32,
        /// Beer–Lambert absorption inside (1/m per channel); absent: clear.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        absorption: Option<[f32; 3]>,
    },
    Mirror {
        reflectance: [f32; 3],
    },
    Conductor {
        eta: [f32; 3],
        k: [f32; 3],
    },
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ObjectExt {
    /// The node that draws it (its glTF rendition).
    pub node: usize,
    /// Index into the extension's `materials`.
    pub material: usize,
    pub caustic_caster: bool,
    pub shape: ShapeExt,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub waves: Option<WavesExt>,
}

#[derive(Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub(crate) enum ShapeExt {
    Sphere {
        center: [f32; 3],
        radius: f32,
    },
    Rectangle {
        center: [f32; 3],
        normal: [f32; 3],
        u: [f32; 3],
        v: [f32; 3],
        size: [f32; 2],
    },
    Cylinder {
        base_center: [f32; 3],
        axis: [f32; 3],
        radius: f32,
        height: f32,
    },
    /// Triangles in world space: accessors of the node's primitive.
    Mesh {
        positions: usize,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        normals: Option<usize>,
        indices: usize,
    },
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct WavesExt {
    pub center: [f32; 2],
    pub size: [f32; 2],
    pub surface: f32,
    pub bottom: f32,
    pub grid: u32,
    pub smooth_normals: bool,
    pub waves: Vec<WaveExt>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct WaveExt {
    pub amplitude: f32,
    pub wavelength: f32,
    pub direction_deg: f32,
    pub steepness: f32,
    pub phase: f32,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct MediumExt {
    pub sigma_s: [f32; 3],
    pub sigma_a: [f32; 3],
    /// Henyey–Greenstein asymmetry; absent: isotropic.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hg_g: Option<f32>,
    pub bounds_min: [f32; 3],
    pub bounds_max: [f32; 3],
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub density: Option<DensityExt>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct DensityExt {
    pub dims: [u32; 3],
    /// A SCALAR float accessor, x fastest.
    pub values: usize,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct EnvironmentExt {
    /// The map file it was loaded from, for messages.
    pub path: String,
    pub width: u32,
    pub height: u32,
    /// A VEC3 float accessor: radiance (scale applied), row-major, top row first.
    pub texels: usize,
    pub scale: [f32; 3],
    /// Radians.
    pub rotate_y: f32,
    pub clamped_negative: usize,
}

/// Every number of a JSON value, as the f32 it is read into, is finite.
fn all_finite(v: &serde_json::Value) -> bool {
    match v {
        serde_json::Value::Number(n) => n.as_f64().is_some_and(|x| (x as f32).is_finite()),
        serde_json::Value::Array(a) => a.iter().all(all_finite),
        serde_json::Value::Object(o) => o.values().all(all_finite),
        _ => true,
    }
}

fn v3(a: [f32; 3]) -> Vec3 {
    Vec3::from_array(a)
}

/// The scene of a file with `CAUSTICS_scene` (its value `ext`); `source` names the file.
pub(crate) fn load(cx: &mut Ctx, doc: &Document, ext: &serde_json::Value, source: &str) -> Result<Scene> {
    let at = format!("/extensions/{NAME}");
    if !all_finite(ext) {
        return Err(cx.err(&at, "holds a number beyond the range of 32-bit floats"));
    }
    let e: Ext = serde_path_to_error::deserialize(ext).map_err(|err| {
        let path = err.path().to_string().replace(['.', '['], "/").replace(']', "");
        cx.err(format!("{at}/{path}"), format!("not a valid {NAME} extension: {}", err.into_inner()))
    })?;
    if e.version != VERSION {
        return Err(cx.err(
            format!("{at}/version"),
            format!("unsupported version {} (this program reads {VERSION})", e.version),
        ));
    }
    let f = |s: &str| format!("{at}/{s}");
    let nonzero = |field: String, a: [f32; 3]| {
        if v3(a).length() > 1e-12 { Ok(v3(a)) } else { Err(cx.err(field, "must be a non-zero direction")) }
    };
    let c = &e.camera;
    let camera = Camera {
        position: v3(c.position),
        look_at: v3(c.look_at),
        up: nonzero(f("camera/up"), c.up)?,
        fov_y_deg: c.fov_y_deg,
        width: c.width,
        height: c.height,
    };
    if !(c.fov_y_deg > 0.0 && c.fov_y_deg < 180.0) {
        return Err(cx.err(f("camera/fov_y_deg"), format!("must lie in (0, 180) (got {})", c.fov_y_deg)));
    }
    for (k, n) in [("width", c.width), ("height", c.height)] {
        if n == 0 || n > 16384 {
            return Err(cx.err(f(&format!("camera/{k}")), format!("must be 1 to 16384 pixels (got {n})")));
        }
    }
    if camera.position.distance(camera.look_at) < 1e-9 || camera.forward().cross(camera.up).length() < 1e-6 {
        return Err(cx.err(f("camera"), "look_at must differ from position, and up must not be parallel to the view"));
    }
    if e.exposure <= 0.0 {
        return Err(cx.err(f("exposure"), format!("must be positive (got {})", e.exposure)));
    }
    let mut lights = Vec::new();
    for (i, l) in e.lights.iter().enumerate() {
        let lf = |s: &str| f(&format!("lights/{i}/{s}"));
        let nonneg = |field: String, a: [f32; 3]| {
            if a.iter().all(|x| *x >= 0.0) { Ok(v3(a)) } else { Err(cx.err(field, "must not be negative")) }
        };
        lights.push(match l {
            LightExt::Spot { position, direction, cone_angle, falloff_start, intensity, falloff } => {
                if !(*cone_angle > 0.0 && *cone_angle < std::f32::consts::PI) {
                    return Err(cx.err(lf("cone_angle"), "must lie in (0, π)"));
                }
                if !(*falloff_start >= 0.0 && falloff_start <= cone_angle) {
                    return Err(cx.err(lf("falloff_start"), "must lie in [0, cone_angle]"));
                }
                let profile = match falloff.as_deref() {
                    None => crate::scene::SpotProfile::Linear,
                    Some("gltf") => crate::scene::SpotProfile::Gltf,
                    Some(other) => {
                        return Err(cx.err(lf("falloff"), format!("must be \"gltf\" or absent (got \"{other}\")")));
                    }
                };
                Light::Spot {
                    position: v3(*position),
                    direction: nonzero(lf("direction"), *direction)?,
                    cone_angle: *cone_angle,
                    falloff_start: *falloff_start,
                    intensity: nonneg(lf("intensity"), *intensity)?,
                    profile,
                }
            }
            LightExt::Point { position, intensity } => {
                Light::Point { position: v3(*position), intensity: nonneg(lf("intensity"), *intensity)? }
            }
            LightExt::Directional { direction, irradiance } => Light::Directional {
                direction: nonzero(lf("direction"), *direction)?,
                irradiance: nonneg(lf("irradiance"), *irradiance)?,
            },
        });
    }
    let mut materials = Vec::new();
    let mut material_names = Vec::new();
    for (i, m) in e.materials.iter().enumerate() {
        let mf = |s: &str| f(&format!("materials/{i}/{s}"));
        let unit = |field: &str, a: [f32; 3]| {
            if a.iter().all(|x| (0.0..=1.0).contains(x)) {
                Ok(v3(a))
            } else {
                Err(cx.err(mf(field), format!("must lie in [0, 1] (got {a:?})")))
            }
        };
        let positive = |field: &str, a: &[f32]| {
            if a.iter().all(|x| *x > 0.0) { Ok(()) } else { Err(cx.err(mf(field), "must be positive")) }
        };
        materials.push(match m.material {
            MaterialKind::Diffuse { albedo } => Material::Diffuse { albedo: unit("albedo", albedo)? },
            MaterialKind::Mirror { reflectance } => Material::Mirror { reflectance: unit("reflectance", reflectance)? },
            MaterialKind::Dielectric { ior, ext_ior, absorption } => {
                positive("ior", &[ior])?;
                positive("ext_ior", &[ext_ior])?;
                let absorption = absorption.unwrap_or([0.0; 3]);
                if !absorption.iter().all(|x| x.is_finite() && *x >= 0.0) {
                    return Err(cx.err(mf("absorption"), "must be finite and not negative"));
                }
                Material::Dielectric { ior, ext_ior, absorption: v3(absorption) }
            }
            MaterialKind::Conductor { eta, k } => {
                positive("eta", &eta)?;
                if k.iter().any(|x| *x < 0.0) {
                    return Err(cx.err(mf("k"), "must not be negative"));
                }
                Material::Conductor { eta: v3(eta), k: v3(k) }
            }
        });
        material_names.push(m.name.clone());
    }
    let mut objects = Vec::new();
    for (i, o) in e.objects.iter().enumerate() {
        let of = |s: &str| f(&format!("objects/{i}/{s}"));
        if o.material >= materials.len() {
            return Err(cx.err(
                of("material"),
                format!("material {} does not exist (the extension has {})", o.material, materials.len()),
            ));
        }
        let positive = |field: &str, x: f32| {
            if x > 0.0 { Ok(x) } else { Err(cx.err(of(field), format!("must be positive (got {x})"))) }
        };
        let shape = match &o.shape {
            ShapeExt::Sphere { center, radius } => {
                Shape::Sphere { center: v3(*center), radius: positive("shape/radius", *radius)? }
            }
            ShapeExt::Rectangle { center, normal, u, v, size } => Shape::Rectangle {
                center: v3(*center),
                normal: nonzero(of("shape/normal"), *normal)?,
                u: nonzero(of("shape/u"), *u)?,
                v: nonzero(of("shape/v"), *v)?,
                size: Vec2::new(positive("shape/size/0", size[0])?, positive("shape/size/1", size[1])?),
            },
            ShapeExt::Cylinder { base_center, axis, radius, height } => Shape::Cylinder {
                base_center: v3(*base_center),
                axis: nonzero(of("shape/axis"), *axis)?,
                radius: positive("shape/radius", *radius)?,
                height: positive("shape/height", *height)?,
            },
            ShapeExt::Mesh { positions, normals, indices } => {
                Shape::Mesh(Arc::new(read_mesh(cx, doc, &of("shape"), *positions, *normals, *indices)?))
            }
        };
        let waves = match &o.waves {
            None => None,
            Some(w) => Some(Arc::new(read_waves(cx, &of("waves"), w)?)),
        };
        objects.push(Object { shape, material: o.material, caustic_caster: o.caustic_caster, waves });
    }
    if objects.is_empty() {
        return Err(cx.err(f("objects"), "the scene has no object"));
    }
    let medium = match &e.medium {
        None => None,
        Some(m) => Some(read_medium(cx, doc, &f("medium"), m)?),
    };
    let environment = match &e.environment {
        None => None,
        Some(env) => Some(Arc::new(read_environment(cx, doc, &f("environment"), env)?)),
    };
    if lights.is_empty() && environment.is_none() {
        return Err(cx.err(f("lights"), "the scene has no light"));
    }
    Ok(Scene {
        name: e.name,
        description: e.description,
        source: source.to_string(),
        camera,
        exposure: e.exposure,
        lights,
        materials,
        material_names,
        objects,
        medium,
        environment,
        warnings: std::mem::take(&mut cx.warnings),
    })
}

/// An accessor index of the extension (`at` names it).
fn index(cx: &Ctx, at: &str, i: usize) -> Result<gltf::json::Index<gltf::json::Accessor>> {
    let i = u32::try_from(i).map_err(|_| cx.err(at, format!("accessor {i} does not exist")))?;
    Ok(gltf::json::Index::new(i))
}

/// A mesh read as written: no normal fixing, no transform.
fn read_mesh(
    cx: &Ctx,
    doc: &Document,
    at: &str,
    positions: usize,
    normals: Option<usize>,
    indices: usize,
) -> Result<TriMesh> {
    let p = geometry::read_vec3(cx, doc, index(cx, at, positions)?, &format!("{at}/positions"))?;
    let n = match normals {
        Some(n) => {
            let n = geometry::read_vec3(cx, doc, index(cx, at, n)?, &format!("{at}/normals"))?;
            if n.len() != p.len() {
                return Err(cx.err(format!("{at}/normals"), format!("{} normals for {} positions", n.len(), p.len())));
            }
            n
        }
        None => Vec::new(),
    };
    let idx = geometry::read_indices(cx, doc, index(cx, at, indices)?, &format!("{at}/indices"))?;
    if !idx.len().is_multiple_of(3) || idx.iter().any(|&i| i as usize >= p.len()) {
        return Err(cx.err(
            format!("{at}/indices"),
            format!("{} indices are not whole triangles of the {} vertices", idx.len(), p.len()),
        ));
    }
    Ok(TriMesh { positions: p, normals: n, indices: idx.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect() })
}

fn read_waves(cx: &Ctx, at: &str, w: &WavesExt) -> Result<Waves> {
    if !(2..=1024).contains(&w.grid) || w.waves.is_empty() || w.waves.len() > 64 {
        return Err(cx.err(at, "grid must lie in 2..=1024 and there must be 1 to 64 waves"));
    }
    if !(w.size[0] > 0.0 && w.size[1] > 0.0) {
        return Err(cx.err(format!("{at}/size"), "must be positive"));
    }
    let mut waves = Vec::new();
    for (k, d) in w.waves.iter().enumerate() {
        if !(d.amplitude >= 0.0 && d.wavelength > 0.0 && (0.0..=1.0).contains(&d.steepness)) {
            return Err(cx.err(format!("{at}/waves/{k}"), "amplitude must be ≥ 0, wavelength > 0, steepness in [0, 1]"));
        }
        waves.push(Wave {
            amplitude: d.amplitude,
            wavelength: d.wavelength,
            direction_deg: d.direction_deg,
            steepness: d.steepness,
            phase: d.phase,
        });
    }
    Ok(Waves {
        center: Vec2::from_array(w.center),
        size: Vec2::from_array(w.size),
        surface: w.surface,
        bottom: w.bottom,
        grid: w.grid,
        smooth_normals: w.smooth_normals,
        waves,
    })
}

fn read_medium(cx: &Ctx, doc: &Document, at: &str, m: &MediumExt) -> Result<Medium> {
    let (lo, hi) = (v3(m.bounds_min), v3(m.bounds_max));
    if !lo.cmplt(hi).all() {
        return Err(cx.err(format!("{at}/bounds_min"), "must be below bounds_max on every axis"));
    }
    if m.sigma_s.iter().chain(&m.sigma_a).any(|x| *x < 0.0) {
        return Err(cx.err(at, "sigma_s and sigma_a must not be negative"));
    }
    let phase = match m.hg_g {
        None => Phase::Isotropic,
        Some(g) if g > -1.0 && g < 1.0 => Phase::HenyeyGreenstein { g },
        Some(g) => return Err(cx.err(format!("{at}/hg_g"), format!("must lie in (-1, 1) (got {g})"))),
    };
    let density = match &m.density {
        None => None,
        Some(d) => {
            let dat = format!("{at}/density/values");
            let values = geometry::read_scalars(cx, doc, index(cx, &dat, d.values)?, &dat)?;
            Some(Arc::new(DensityGrid::new(d.dims, values).map_err(|msg| cx.err(dat, msg))?))
        }
    };
    Ok(Medium { sigma_s: v3(m.sigma_s), sigma_a: v3(m.sigma_a), phase, bounds_min: lo, bounds_max: hi, density })
}

fn read_environment(cx: &Ctx, doc: &Document, at: &str, e: &EnvironmentExt) -> Result<Environment> {
    let tat = format!("{at}/texels");
    let texels = geometry::read_vec3(cx, doc, index(cx, &tat, e.texels)?, &tat)?;
    if texels.iter().any(|t| t.min_element() < 0.0) {
        return Err(cx.err(tat, "radiance must not be negative"));
    }
    let mut env = Environment::from_texels(e.width, e.height, texels, 0.0).map_err(|msg| cx.err(at, msg))?;
    env.set_rotate_y(e.rotate_y);
    env.path = e.path.clone().into();
    env.scale = v3(e.scale);
    env.clamped_negative = e.clamped_negative;
    Ok(env)
}
