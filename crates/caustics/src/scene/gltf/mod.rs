//! glTF 2.0 scenes (`.gltf`, `.glb`) read into a [`Scene`] (`docs/gltf.md`): the default scene's
//! node hierarchy flattened to world-space meshes, perspective cameras, `KHR_lights_punctual`
//! lights in physical units, metallic-roughness, transmission, IOR and volume materials mapped
//! onto ours. What changes the picture and is not modelled is one warning in
//! [`Scene::warnings`]; bad input is an [`Error::Input`] naming the file and the JSON pointer.
//!
//! The `gltf` crate's JSON types are used without its validation (which refuses files that
//! require `KHR_materials_volume`); every index, offset and count is checked here instead.

mod camera;
mod container;
mod export;
mod geometry;
mod lights;
mod materials;
mod vendor;

pub use export::{to_glb, to_gltf, write_gltf};

use super::Scene;
use crate::error::{Error, Result};
use gltf::json::Root;
use std::path::Path;

/// Luminous efficacy (lm/W) that converts glTF's photometric light units to our radiometric
/// ones: candela → W/sr for point and spot lights, lux → W/m² for directional lights. 683 lm/W
/// is the peak efficacy of the photopic curve (555 nm), the constant Blender's glTF importer and
/// exporter use (`PBR_WATTS_TO_LUMENS`).
pub const LUMENS_PER_WATT: f32 = 683.0;

/// What the loader carries around: the file's name for errors and the warnings so far.
pub(crate) struct Ctx<'a> {
    /// The file, as errors name it.
    pub file: &'a str,
    /// Warnings, each naming the file and the JSON pointer of what it is about.
    pub warnings: Vec<String>,
}

impl Ctx<'_> {
    /// An input error at JSON pointer `field`.
    pub fn err(&self, field: impl Into<String>, msg: impl Into<String>) -> Error {
        Error::input(self.file, field, msg)
    }
    /// Record a warning about the value at JSON pointer `field`.
    pub fn warn(&mut self, field: &str, msg: impl AsRef<str>) {
        let w = if field.is_empty() {
            format!("{}: {}", self.file, msg.as_ref())
        } else {
            format!("{}: {field}: {}", self.file, msg.as_ref())
        };
        if !self.warnings.contains(&w) {
            self.warnings.push(w);
        }
    }
}

/// A display name for element `i` of a glTF array: `"name" (/kind/i)` or `/kind/i`.
pub(crate) fn label(kind: &str, i: usize, name: Option<&String>) -> String {
    let array = if kind == "mesh" { "meshes".to_string() } else { format!("{kind}s") };
    match name {
        Some(n) if !n.is_empty() => format!("{kind} \"{n}\" (/{array}/{i})"),
        _ => format!("{kind} /{array}/{i}"),
    }
}

/// Load a `.gltf` or `.glb` file; `camera` picks a camera by node or camera name, or by index
/// into the file's `cameras` (the first camera of the scene when `None`).
pub(crate) fn load(path: &Path, camera: Option<&str>) -> Result<Scene> {
    let file = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| Error::input(&file, "", format!("cannot read glTF file: {e}")))?;
    let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    from_bytes(&bytes, &file, &base, &name, camera)
}

/// Read glTF bytes (GLB or JSON); `file` names it in errors, `base` resolves relative URIs.
fn from_bytes(bytes: &[u8], file: &str, base: &Path, name: &str, camera: Option<&str>) -> Result<Scene> {
    let mut cx = Ctx { file, warnings: Vec::new() };
    let doc = container::parse(&cx, bytes, base)?;
    check_extensions(&mut cx, &doc.root)?;
    if let Some(ext) = doc.root.extensions.as_ref().and_then(|e| e.others.get(vendor::NAME)) {
        let mut scene = vendor::load(&mut cx, &doc, ext, file)?;
        if camera.is_some() {
            let flat = geometry::flatten(&mut cx, &doc)?;
            scene.camera = camera::choose(&mut cx, &doc.root, &flat.cameras, camera, scene.bounds())?;
            scene.warnings.append(&mut cx.warnings);
        }
        return Ok(scene);
    }
    let flat = geometry::flatten(&mut cx, &doc)?;
    let (materials, material_names, remap) = materials::convert(&mut cx, &doc.root, &flat.used_materials)?;
    let objects = geometry::objects(&mut cx, flat.meshes, &remap, &materials);
    if objects.is_empty() {
        return Err(cx.err("/meshes", "the scene has no triangle to render"));
    }
    let bounds = super::bounds_of(objects.iter());
    let lights = lights::convert(&mut cx, &doc.root, &flat.lights)?;
    let camera = camera::choose(&mut cx, &doc.root, &flat.cameras, camera, bounds)?;
    let name = if name.trim().is_empty() { "gltf".to_string() } else { name.to_string() };
    Ok(Scene {
        name,
        description: None,
        source: file.to_string(),
        camera,
        exposure: 1.0,
        lights,
        materials,
        material_names,
        objects,
        medium: None,
        environment: None,
        warnings: cx.warnings,
    })
}

/// Extensions read (fully or in part, with warnings): a file may require these.
const READ_EXTENSIONS: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_transmission",
    "KHR_materials_ior",
    "KHR_materials_volume",
    "KHR_materials_dispersion",
    "KHR_materials_emissive_strength",
    "KHR_texture_transform",
    vendor::NAME,
];

/// Refuse files that require an extension we do not read; warn once about each extension used
/// that we do not read (where it is used, the material or node names it too).
fn check_extensions(cx: &mut Ctx, root: &Root) -> Result<()> {
    for (i, e) in root.extensions_required.iter().enumerate() {
        if !READ_EXTENSIONS.contains(&e.as_str()) {
            return Err(cx.err(
                format!("/extensionsRequired/{i}"),
                format!(
                    "the file requires extension {e}, which this program does not read (it reads {})",
                    READ_EXTENSIONS.join(", ")
                ),
            ));
        }
    }
    for (i, e) in root.extensions_used.iter().enumerate() {
        if !READ_EXTENSIONS.contains(&e.as_str()) {
            cx.warn(&format!("/extensionsUsed/{i}"), format!("extension {e} is not read: ignored"));
        }
    }
    if !root.animations.is_empty() {
        cx.warn(
            "/animations",
            format!(
                "{} animation(s) ignored: the scene is rendered in the nodes' static transforms",
                root.animations.len()
            ),
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests;
