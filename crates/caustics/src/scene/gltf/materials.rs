//! glTF materials mapped onto ours (`docs/gltf.md`): transmission → dielectric, smooth metal →
//! mirror, everything else → diffuse with the base colour; what is not modelled is one warning
//! per material and feature.

use super::{Ctx, label};
use crate::error::Result;
use crate::scene::Material;
use glam::Vec3;
use gltf::json::Root;
use gltf::json::material::AlphaMode;
use gltf::json::validation::Checked;
use std::collections::{BTreeSet, HashMap};

/// Metals at or below this roughness are mirrors; rougher ones are drawn diffuse.
const MIRROR_MAX_ROUGHNESS: f32 = 0.2;
/// Glass rougher than this is warned about (drawn smooth).
const GLASS_MAX_ROUGHNESS: f32 = 0.2;
/// The material of primitives without one: diffuse grey, like Blender's default material.
const DEFAULT_ALBEDO: f32 = 0.8;

/// Our materials, sorted by name, their names, and where each glTF material (`None`: the
/// default) went.
pub(crate) type Converted = (Vec<Material>, Vec<String>, HashMap<Option<usize>, usize>);

/// Convert the materials the scene uses.
pub(crate) fn convert(cx: &mut Ctx, root: &Root, used: &BTreeSet<Option<usize>>) -> Result<Converted> {
    let mut named: Vec<(String, Option<usize>, Material)> = Vec::new();
    let mut taken = BTreeSet::new();
    for &m in used {
        let (base, material) = match m {
            None => ("default".to_string(), Material::Diffuse { albedo: Vec3::splat(DEFAULT_ALBEDO) }),
            Some(i) => {
                let mat = root.materials.get(i).ok_or_else(|| {
                    cx.err(
                        "/materials",
                        format!(
                            "material {i} is used by a primitive but does not exist (the file has {})",
                            root.materials.len()
                        ),
                    )
                })?;
                let base = mat.name.clone().filter(|n| !n.trim().is_empty()).unwrap_or_else(|| format!("material_{i}"));
                (base, material(cx, mat, i)?)
            }
        };
        let mut name = base.clone();
        let mut k = 1;
        while !taken.insert(name.clone()) {
            name = format!("{base}_{k}");
            k += 1;
        }
        named.push((name, m, material));
    }
    named.sort_by(|a, b| a.0.cmp(&b.0));
    let remap = named.iter().enumerate().map(|(k, (_, m, _))| (*m, k)).collect();
    let materials = named.iter().map(|x| x.2).collect();
    let names = named.into_iter().map(|x| x.0).collect();
    Ok((materials, names, remap))
}

/// One glTF material as ours, with its warnings.
fn material(cx: &mut Ctx, mat: &gltf::json::Material, i: usize) -> Result<Material> {
    let at = format!("/materials/{i}");
    let who = label("material", i, mat.name.as_ref());
    let pbr = &mat.pbr_metallic_roughness;
    let c = pbr.base_color_factor.0;
    if !c.iter().all(|x| x.is_finite() && (0.0..=1.0).contains(x)) {
        return Err(cx.err(
            format!("{at}/pbrMetallicRoughness/baseColorFactor"),
            format!("must be 4 numbers in [0, 1] (got {c:?})"),
        ));
    }
    let base = Vec3::new(c[0], c[1], c[2]);
    let metallic = unit(cx, &format!("{at}/pbrMetallicRoughness/metallicFactor"), pbr.metallic_factor.0)?;
    let roughness = unit(cx, &format!("{at}/pbrMetallicRoughness/roughnessFactor"), pbr.roughness_factor.0)?;
    warn_unmodelled(cx, mat, &at, &who);
    let ext = mat.extensions.as_ref();
    let transmission = ext.and_then(|e| e.transmission.as_ref());
    let t = transmission.map_or(0.0, |t| t.transmission_factor.0);
    let t = unit(cx, &format!("{at}/extensions/KHR_materials_transmission/transmissionFactor"), t)?;
    if t > 0.0 {
        return glass(cx, mat, &at, &who, t, roughness);
    }
    if metallic >= 0.5 {
        if roughness <= MIRROR_MAX_ROUGHNESS {
            return Ok(Material::Mirror { reflectance: base });
        }
        cx.warn(&format!("{at}/pbrMetallicRoughness/roughnessFactor"), format!(
            "{who}: rough metal (roughness {roughness} > {MIRROR_MAX_ROUGHNESS}) is not modelled: drawn diffuse with its base colour"
        ));
    }
    Ok(Material::Diffuse { albedo: base })
}

fn unit(cx: &Ctx, at: &str, x: f32) -> Result<f32> {
    if x.is_finite() && (0.0..=1.0).contains(&x) {
        Ok(x)
    } else {
        Err(cx.err(at, format!("must lie in [0, 1] (got {x})")))
    }
}

/// `KHR_materials_transmission` (+ `KHR_materials_ior`, `KHR_materials_volume`) as our smooth
/// dielectric in air.
fn glass(cx: &mut Ctx, mat: &gltf::json::Material, at: &str, who: &str, t: f32, roughness: f32) -> Result<Material> {
    let ext = mat.extensions.as_ref();
    let ior = ext.and_then(|e| e.ior.as_ref()).map_or(1.5, |x| x.ior.0);
    if !(ior.is_finite() && ior >= 1.0) {
        return Err(
            cx.err(format!("{at}/extensions/KHR_materials_ior/ior"), format!("must be a number ≥ 1 (got {ior})"))
        );
    }
    let tat = format!("{at}/extensions/KHR_materials_transmission");
    if t < 1.0 {
        cx.warn(&tat, format!("{who}: partial transmission ({t}) is drawn as full transmission (a clear dielectric)"));
    }
    if roughness > GLASS_MAX_ROUGHNESS {
        cx.warn(
            &format!("{at}/pbrMetallicRoughness/roughnessFactor"),
            format!("{who}: rough glass (roughness {roughness} > {GLASS_MAX_ROUGHNESS}) is not modelled: drawn smooth"),
        );
    }
    if ext.and_then(|e| e.transmission.as_ref()).is_some_and(|x| x.transmission_texture.is_some()) {
        cx.warn(
            &format!("{tat}/transmissionTexture"),
            format!("{who}: transmissionTexture ignored: the factor is used"),
        );
    }
    let vat = format!("{at}/extensions/KHR_materials_volume");
    let mut absorption = glam::Vec3::ZERO;
    match ext.and_then(|e| e.volume.as_ref()) {
        Some(v) if v.thickness_factor.0 > 0.0 => {
            let (d, c) = (v.attenuation_distance.0, v.attenuation_color.0);
            // Beer–Lambert: σa = −ln(c) / d per channel; no distance (infinite): clear.
            if d.is_finite() && d > 0.0 {
                if !c.iter().all(|x| x.is_finite() && (0.0..=1.0).contains(x)) {
                    return Err(cx.err(format!("{vat}/attenuationColor"), format!("must lie in [0, 1] (got {c:?})")));
                }
                if c.contains(&0.0) {
                    cx.warn(&format!("{vat}/attenuationColor"), format!(
                        "{who}: attenuationColor {c:?} has a zero channel: drawn as 1e-6 of the light left after attenuationDistance"
                    ));
                }
                absorption = glam::Vec3::from_array(c.map(|x| (-x.max(1e-6).ln() / d).max(0.0)));
            } else if !(d.is_infinite() && d > 0.0) {
                return Err(cx.err(format!("{vat}/attenuationDistance"), format!("must be a positive number (got {d})")));
            }
            if v.thickness_texture.is_some() {
                cx.warn(&format!("{vat}/thicknessTexture"), format!("{who}: thicknessTexture ignored"));
            }
        }
        _ => cx.warn(&vat, format!(
            "{who}: thin-walled glass (no KHR_materials_volume or thicknessFactor 0) is not modelled yet: drawn as a closed refracting solid"
        )),
    }
    Ok(Material::Dielectric { ior, ext_ior: 1.0, absorption })
}

/// One warning per feature of the material that changes the picture and is not read.
fn warn_unmodelled(cx: &mut Ctx, mat: &gltf::json::Material, at: &str, who: &str) {
    let pbr = &mat.pbr_metallic_roughness;
    let textures = [
        (
            "pbrMetallicRoughness/baseColorTexture",
            pbr.base_color_texture.as_ref().map(|t| &t.extensions),
            "the base colour factor is used",
        ),
        (
            "pbrMetallicRoughness/metallicRoughnessTexture",
            pbr.metallic_roughness_texture.as_ref().map(|t| &t.extensions),
            "the factors are used",
        ),
        ("emissiveTexture", mat.emissive_texture.as_ref().map(|t| &t.extensions), "the surface does not emit"),
    ];
    for (field, tex, instead) in textures {
        if let Some(ext) = tex {
            let extra = match ext.as_ref().map(|e| e.others.contains_key("KHR_texture_transform")) {
                Some(true) => " (with its KHR_texture_transform)",
                _ => "",
            };
            cx.warn(&format!("{at}/{field}"), format!("{who}: textures are not read{extra}: {instead}"));
        }
    }
    if mat.normal_texture.is_some() {
        cx.warn(&format!("{at}/normalTexture"), format!("{who}: normal map ignored: the mesh's normals are used"));
    }
    if mat.occlusion_texture.is_some() {
        cx.warn(
            &format!("{at}/occlusionTexture"),
            format!("{who}: occlusion texture ignored (light transport is computed)"),
        );
    }
    if mat.emissive_factor.0.iter().any(|&x| x != 0.0) {
        cx.warn(&format!("{at}/emissiveFactor"), format!("{who}: emission ignored: the surface does not emit light"));
    }
    match mat.alpha_mode {
        Checked::Valid(AlphaMode::Opaque) => {}
        Checked::Valid(m) => {
            cx.warn(&format!("{at}/alphaMode"), format!("{who}: alpha mode {m:?} ignored: drawn opaque"))
        }
        Checked::Invalid => {
            cx.warn(&format!("{at}/alphaMode"), format!("{who}: unknown alpha mode ignored: drawn opaque"))
        }
    }
    for key in mat.extensions.iter().flat_map(|e| e.others.keys()) {
        let instead = match key.as_str() {
            "KHR_materials_dispersion" => "no dispersion model yet: one IOR for every wavelength",
            "KHR_materials_emissive_strength" => "the surface does not emit light",
            _ => "ignored",
        };
        cx.warn(&format!("{at}/extensions/{key}"), format!("{who}: extension {key} not read: {instead}"));
    }
}
