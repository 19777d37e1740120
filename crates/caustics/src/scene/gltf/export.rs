//! A [`Scene`] written as glTF 2.0 (`caustics convert`, `docs/gltf.md` "Export"): world-space
//! meshes (analytic shapes tessellated), metallic-roughness materials with
//! `KHR_materials_transmission`/`_ior`/`_volume`, `KHR_lights_punctual` lights in photometric
//! units, a perspective camera node; and the exact scene in the `CAUSTICS_scene` extension
//! (`vendor`), which [`Scene::load`] prefers, so that the round trip is bit for bit.

use super::LUMENS_PER_WATT;
use super::vendor::{
    CameraExt, DensityExt, EnvironmentExt, Ext, LightExt, MaterialExt, MaterialKind, MediumExt, NAME, ObjectExt,
    ShapeExt, VERSION, WaveExt, WavesExt,
};
use crate::error::{Error, Result};
use crate::scene::{Light, Material, Phase, Scene, Shape, Tessellation, TriMesh};
use glam::{Mat3, Quat, Vec3};
use serde_json::{Value, json};
use std::path::Path;

/// Accessor component types and buffer-view targets (glTF 2.0, 5.1.2 and 5.11).
const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;

/// The binary buffer and the views and accessors into it.
#[derive(Default)]
struct Bin {
    data: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Bin {
    fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        while !self.data.len().is_multiple_of(4) {
            self.data.push(0);
        }
        let mut v = json!({ "buffer": 0, "byteOffset": self.data.len(), "byteLength": bytes.len() });
        if let Some(t) = target {
            v["target"] = json!(t);
        }
        self.data.extend_from_slice(bytes);
        self.views.push(v);
        self.views.len() - 1
    }

    fn accessor(&mut self, view: usize, component: u32, count: usize, ty: &str) -> usize {
        self.accessors.push(json!({ "bufferView": view, "componentType": component, "count": count, "type": ty }));
        self.accessors.len() - 1
    }

    /// VEC3 floats; `bounds`: with `min` and `max` (required of POSITION).
    fn vec3(&mut self, v: &[Vec3], target: Option<u32>, bounds: bool) -> usize {
        let bytes: Vec<u8> = v.iter().flat_map(|p| p.to_array()).flat_map(f32::to_le_bytes).collect();
        let view = self.view(&bytes, target);
        let a = self.accessor(view, FLOAT, v.len(), "VEC3");
        if bounds {
            let lo = v.iter().fold(Vec3::splat(f32::INFINITY), |a, p| a.min(*p));
            let hi = v.iter().fold(Vec3::splat(f32::NEG_INFINITY), |a, p| a.max(*p));
            self.accessors[a]["min"] = json!(lo.to_array());
            self.accessors[a]["max"] = json!(hi.to_array());
        }
        a
    }

    fn scalars(&mut self, v: &[f32]) -> usize {
        let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.view(&bytes, None);
        self.accessor(view, FLOAT, v.len(), "SCALAR")
    }

    fn indices(&mut self, t: &[[u32; 3]]) -> usize {
        let bytes: Vec<u8> = t.iter().flatten().flat_map(|i| i.to_le_bytes()).collect();
        let view = self.view(&bytes, Some(ELEMENT_ARRAY_BUFFER));
        self.accessor(view, UNSIGNED_INT, t.len() * 3, "SCALAR")
    }

    /// A triangle mesh's accessors: positions, normals (where it has one per vertex), indices.
    fn mesh(&mut self, m: &TriMesh) -> (usize, Option<usize>, usize) {
        let p = self.vec3(&m.positions, Some(ARRAY_BUFFER), true);
        let n = (m.normals.len() == m.positions.len()).then(|| self.vec3(&m.normals, Some(ARRAY_BUFFER), false));
        (p, n, self.indices(&m.indices))
    }
}

/// Write `scene` to `path`: a `.glb`, or a `.gltf` with its buffer embedded as a base64 `data:`
/// URI. The file is written whole to a temporary file beside it, then renamed over `path`.
pub fn write_gltf(scene: &Scene, path: &Path) -> Result<()> {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    let glb = match ext.as_deref() {
        Some("glb") => true,
        Some("gltf") => false,
        _ => {
            return Err(Error::input(
                path.display().to_string(),
                "",
                "the output must be a .glb or .gltf file (by its extension)",
            ));
        }
    };
    let bytes = if glb { to_glb(scene)? } else { to_gltf(scene)? };
    write_atomic(path, &bytes)
}

/// The scene as `.glb` bytes.
pub fn to_glb(scene: &Scene) -> Result<Vec<u8>> {
    let (doc, mut bin) = document(scene)?;
    let mut json = serde_json::to_vec(&doc).map_err(|e| internal(scene, e))?;
    pad(&mut json, b' ');
    pad(&mut bin, 0);
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let total = u32::try_from(total).map_err(|_| {
        Error::input(&scene.source, "", format!("the scene needs {total} bytes: a GLB holds at most 4 GiB"))
    })?;
    let mut out = Vec::with_capacity(total as usize);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&total.to_le_bytes());
    for (ty, chunk) in [(0x4E4F_534Au32, &json), (0x004E_4942, &bin)] {
        out.extend_from_slice(&(chunk.len() as u32).to_le_bytes());
        out.extend_from_slice(&ty.to_le_bytes());
        out.extend_from_slice(chunk);
    }
    Ok(out)
}

/// The scene as `.gltf` JSON bytes, its buffer a base64 `data:` URI.
pub fn to_gltf(scene: &Scene) -> Result<Vec<u8>> {
    use base64::Engine;
    let (mut doc, bin) = document(scene)?;
    let uri =
        format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(&bin));
    doc["buffers"][0]["uri"] = json!(uri);
    serde_json::to_vec_pretty(&doc).map_err(|e| internal(scene, e))
}

fn internal(scene: &Scene, e: serde_json::Error) -> Error {
    Error::input(&scene.source, "", format!("cannot write the scene as JSON: {e}"))
}

fn pad(b: &mut Vec<u8>, with: u8) {
    while !b.len().is_multiple_of(4) {
        b.push(with);
    }
}

/// Write to a temporary file in the same folder, then rename it over `path`: readers see the
/// old file or the whole new one.
fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let err = |e: std::io::Error| Error::Output { path: path.to_path_buf(), message: e.to_string() };
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.{}.tmp", std::process::id()));
    let written = std::fs::write(&tmp, bytes).and_then(|()| std::fs::rename(&tmp, path));
    if written.is_err() {
        std::fs::remove_file(&tmp).ok();
    }
    written.map_err(err)
}

/// Colour and photometric intensity of a radiometric power per channel: the colour's largest
/// channel is 1.
fn photometric(power: Vec3) -> ([f32; 3], f32) {
    let m = power.max_element();
    if m > 0.0 { ((power / m).to_array(), m * LUMENS_PER_WATT) } else { ([1.0; 3], 0.0) }
}

/// The glTF rendition of a material (metallic-roughness, transmission, IOR).
fn material(name: &str, m: &Material) -> Value {
    let pbr = |color: Vec3, metallic: f32, roughness: f32| json!({ "baseColorFactor": [color.x, color.y, color.z, 1.0], "metallicFactor": metallic, "roughnessFactor": roughness });
    match m {
        Material::Diffuse { albedo } => json!({ "name": name, "pbrMetallicRoughness": pbr(*albedo, 0.0, 1.0) }),
        Material::Mirror { reflectance } => {
            json!({ "name": name, "pbrMetallicRoughness": pbr(*reflectance, 1.0, 0.0) })
        }
        Material::Conductor { eta, k } => {
            // Reflectance at normal incidence.
            let f0 = ((*eta - 1.0).powf(2.0) + *k * *k) / ((*eta + 1.0).powf(2.0) + *k * *k);
            json!({ "name": name, "pbrMetallicRoughness": pbr(f0.clamp(Vec3::ZERO, Vec3::ONE), 1.0, 0.0) })
        }
        Material::Dielectric { ior, ext_ior, absorption } => {
            // Absorption as glTF's colour left after 1 m (σa = −ln(c) / d); the exact σa is in
            // CAUSTICS_scene.
            let volume = if *absorption == Vec3::ZERO {
                json!({ "thicknessFactor": 1.0 })
            } else {
                let c = (-*absorption).exp().max(Vec3::splat(1e-6));
                json!({ "thicknessFactor": 1.0, "attenuationColor": c.to_array(), "attenuationDistance": 1.0 })
            };
            json!({
                "name": name,
                "pbrMetallicRoughness": pbr(Vec3::ONE, 0.0, 0.0),
                "extensions": {
                    "KHR_materials_transmission": { "transmissionFactor": 1.0 },
                    // glTF's IOR is relative to air and at least 1; the exact pair is in CAUSTICS_scene.
                    "KHR_materials_ior": { "ior": (ior / ext_ior).max(1.0) },
                    "KHR_materials_volume": volume,
                }
            })
        }
    }
}

fn material_ext(name: &str, m: &Material) -> MaterialExt {
    let kind = match *m {
        Material::Diffuse { albedo } => MaterialKind::Diffuse { albedo: albedo.to_array() },
        Material::Dielectric { ior, ext_ior, absorption } => MaterialKind::Dielectric {
            ior,
            ext_ior,
            absorption: (absorption != Vec3::ZERO).then_some(absorption.to_array()),
        },
        Material::Mirror { reflectance } => MaterialKind::Mirror { reflectance: reflectance.to_array() },
        Material::Conductor { eta, k } => MaterialKind::Conductor { eta: eta.to_array(), k: k.to_array() },
    };
    MaterialExt { name: name.to_string(), material: kind }
}

/// The glTF light and its node's rotation (glTF lights shine down their node's −Z).
fn light(l: &Light) -> (Value, LightExt, Option<Vec3>, Quat) {
    let aim = |d: Vec3| Quat::from_rotation_arc(Vec3::NEG_Z, d.normalize());
    match *l {
        Light::Point { position, intensity } => {
            let (color, cd) = photometric(intensity);
            let ext = LightExt::Point { position: position.to_array(), intensity: intensity.to_array() };
            (json!({ "type": "point", "color": color, "intensity": cd }), ext, Some(position), Quat::IDENTITY)
        }
        Light::Directional { direction, irradiance } => {
            let (color, lux) = photometric(irradiance);
            let ext = LightExt::Directional { direction: direction.to_array(), irradiance: irradiance.to_array() };
            (json!({ "type": "directional", "color": color, "intensity": lux }), ext, None, aim(direction))
        }
        Light::Spot { position, direction, cone_angle, falloff_start, intensity, profile } => {
            let (color, cd) = photometric(intensity);
            // glTF cones open at most π/2, the inner one strictly inside the outer one.
            let outer = cone_angle.min(std::f32::consts::FRAC_PI_2);
            let inner = falloff_start.min(outer * (1.0 - 1e-6));
            let ext = LightExt::Spot {
                position: position.to_array(),
                direction: direction.to_array(),
                cone_angle,
                falloff_start,
                intensity: intensity.to_array(),
                falloff: (profile == crate::scene::SpotProfile::Gltf).then(|| "gltf".to_string()),
            };
            let def = json!({ "type": "spot", "color": color, "intensity": cd,
                              "spot": { "innerConeAngle": inner, "outerConeAngle": outer } });
            (def, ext, Some(position), aim(direction))
        }
    }
}

/// The glTF document (its buffer's `uri` not set) and the buffer's bytes.
fn document(scene: &Scene) -> Result<(Value, Vec<u8>)> {
    let mut bin = Bin::default();
    let mut nodes = Vec::new();
    let mut meshes = Vec::new();
    let tess = Tessellation::default();

    let mut objects = Vec::new();
    for (i, o) in scene.objects.iter().enumerate() {
        let (shape, drawn) = match &o.shape {
            Shape::Sphere { center, radius } => {
                (ShapeExt::Sphere { center: center.to_array(), radius: *radius }, bin.mesh(&o.shape.tessellate(&tess)))
            }
            Shape::Rectangle { center, normal, u, v, size } => (
                ShapeExt::Rectangle {
                    center: center.to_array(),
                    normal: normal.to_array(),
                    u: u.to_array(),
                    v: v.to_array(),
                    size: size.to_array(),
                },
                bin.mesh(&o.shape.tessellate(&tess)),
            ),
            Shape::Cylinder { base_center, axis, radius, height } => (
                ShapeExt::Cylinder {
                    base_center: base_center.to_array(),
                    axis: axis.to_array(),
                    radius: *radius,
                    height: *height,
                },
                bin.mesh(&o.shape.tessellate(&tess)),
            ),
            Shape::Mesh(m) => {
                if m.indices.is_empty() {
                    return Err(Error::input(&scene.source, format!("objects[{i}]"), "a mesh without triangles"));
                }
                let (p, n, t) = bin.mesh(m);
                (ShapeExt::Mesh { positions: p, normals: n, indices: t }, (p, n, t))
            }
        };
        let (p, n, t) = drawn;
        let mut attributes = json!({ "POSITION": p });
        if let Some(n) = n {
            attributes["NORMAL"] = json!(n);
        }
        let name = format!("object_{i}");
        meshes.push(json!({ "name": name,
            "primitives": [{ "attributes": attributes, "indices": t, "material": o.material }] }));
        nodes.push(json!({ "name": name, "mesh": meshes.len() - 1 }));
        let waves = o.waves.as_ref().map(|w| WavesExt {
            center: w.center.to_array(),
            size: w.size.to_array(),
            surface: w.surface,
            bottom: w.bottom,
            grid: w.grid,
            smooth_normals: w.smooth_normals,
            waves: w
                .waves
                .iter()
                .map(|x| WaveExt {
                    amplitude: x.amplitude,
                    wavelength: x.wavelength,
                    direction_deg: x.direction_deg,
                    steepness: x.steepness,
                    phase: x.phase,
                })
                .collect(),
        });
        objects.push(ObjectExt {
            node: nodes.len() - 1,
            material: o.material,
            caustic_caster: o.caustic_caster,
            shape,
            waves,
        });
    }

    let mut light_defs = Vec::new();
    let mut lights = Vec::new();
    for (i, l) in scene.lights.iter().enumerate() {
        let (def, ext, position, rotation) = light(l);
        let mut node = json!({ "name": format!("light_{i}"), "rotation": rotation.to_array(),
                               "extensions": { "KHR_lights_punctual": { "light": i } } });
        if let Some(p) = position {
            node["translation"] = json!(p.to_array());
        }
        light_defs.push(def);
        lights.push(ext);
        nodes.push(node);
    }

    let c = &scene.camera;
    let basis = Mat3::from_cols(c.right(), c.true_up(), -c.forward());
    nodes.push(json!({ "name": "camera", "camera": 0, "translation": c.position.to_array(),
                       "rotation": Quat::from_mat3(&basis).normalize().to_array() }));
    let cameras = json!([{ "name": "camera", "type": "perspective", "perspective": {
        "yfov": c.fov_y_deg.to_radians(), "aspectRatio": c.aspect(), "znear": 0.01 } }]);

    let materials: Vec<Value> =
        scene.materials.iter().zip(&scene.material_names).map(|(m, n)| material(n, m)).collect();

    let medium = scene.medium.as_ref().map(|m| MediumExt {
        sigma_s: m.sigma_s.to_array(),
        sigma_a: m.sigma_a.to_array(),
        hg_g: match m.phase {
            Phase::Isotropic => None,
            Phase::HenyeyGreenstein { g } => Some(g),
        },
        bounds_min: m.bounds_min.to_array(),
        bounds_max: m.bounds_max.to_array(),
        density: m.density.as_ref().map(|d| DensityExt { dims: d.dims, values: bin.scalars(&d.data) }),
    });
    let environment = scene.environment.as_ref().map(|e| EnvironmentExt {
        path: e.path.display().to_string(),
        width: e.width,
        height: e.height,
        texels: bin.vec3(&e.texels, None, false),
        scale: e.scale.to_array(),
        rotate_y: e.rotate_y,
        clamped_negative: e.clamped_negative,
    });
    let ext = Ext {
        version: VERSION,
        name: scene.name.clone(),
        description: scene.description.clone(),
        camera: CameraExt {
            position: c.position.to_array(),
            look_at: c.look_at.to_array(),
            up: c.up.to_array(),
            fov_y_deg: c.fov_y_deg,
            width: c.width,
            height: c.height,
        },
        exposure: scene.exposure,
        lights,
        materials: scene.materials.iter().zip(&scene.material_names).map(|(m, n)| material_ext(n, m)).collect(),
        objects,
        medium,
        environment,
    };

    let mut used = vec![NAME];
    let mut root_ext = serde_json::Map::new();
    root_ext.insert(NAME.into(), serde_json::to_value(&ext).map_err(|e| internal(scene, e))?);
    if !light_defs.is_empty() {
        used.push("KHR_lights_punctual");
        root_ext.insert("KHR_lights_punctual".into(), json!({ "lights": light_defs }));
    }
    if scene.materials.iter().any(|m| matches!(m, Material::Dielectric { .. })) {
        used.extend(["KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_volume"]);
    }
    let mut scene_json = json!({ "name": scene.name, "nodes": (0..nodes.len()).collect::<Vec<_>>() });
    if let Some(d) = &scene.description {
        scene_json["extras"] = json!({ "description": d });
    }
    let doc = json!({
        "asset": { "version": "2.0", "generator": concat!("caustics convert ", env!("CARGO_PKG_VERSION")) },
        "extensionsUsed": used,
        "extensions": root_ext,
        "scene": 0,
        "scenes": [scene_json],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "cameras": cameras,
        "accessors": bin.accessors,
        "bufferViews": bin.views,
        "buffers": [{ "byteLength": bin.data.len() }],
    });
    Ok((doc, bin.data))
}
