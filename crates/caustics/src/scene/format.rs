//! The scene JSON format, schema_version 1, as `docs/scene-format.md` defines it.
//!
//! These structs mirror the file one to one (serde, unknown fields rejected); `super::load`
//! validates them and resolves them into a [`super::Scene`].

use serde::Deserialize;
use serde::de::{self, Deserializer, SeqAccess, Visitor};
use std::collections::BTreeMap;
use std::fmt;

/// A linear RGB colour: `[r, g, b]` or a single number for grey.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rgb(pub [f32; 3]);

impl<'de> Deserialize<'de> for Rgb {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Rgb;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number or an array of 3 numbers (linear RGB)")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<Rgb, E> {
                Ok(Rgb([v as f32; 3]))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Rgb, E> {
                Ok(Rgb([v as f32; 3]))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Rgb, E> {
                Ok(Rgb([v as f32; 3]))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Rgb, A::Error> {
                let mut c = [0.0f32; 3];
                for (i, x) in c.iter_mut().enumerate() {
                    *x = seq.next_element()?.ok_or_else(|| de::Error::invalid_length(i, &self))?;
                }
                if seq.next_element::<f32>()?.is_some() {
                    return Err(de::Error::invalid_length(4, &self));
                }
                Ok(Rgb(c))
            }
        }
        d.deserialize_any(V)
    }
}

/// A uniform scale (number) or a per-axis scale (`[x, y, z]`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scale(pub [f32; 3]);

impl<'de> Deserialize<'de> for Scale {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        Rgb::deserialize(d).map(|Rgb(c)| Scale(c))
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    pub schema_version: u32,
    pub name: String,
    #[serde(default)]
    pub description: Option<String>,
    pub camera: CameraDesc,
    #[serde(default)]
    pub display: Option<DisplayDesc>,
    pub lights: Vec<LightDesc>,
    pub materials: BTreeMap<String, MaterialDesc>,
    pub objects: Vec<ObjectDesc>,
    #[serde(default)]
    pub medium: Option<MediumDesc>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraDesc {
    pub position: [f32; 3],
    pub look_at: [f32; 3],
    #[serde(default = "default_up")]
    pub up: [f32; 3],
    pub fov_y_deg: f32,
    pub width: u32,
    pub height: u32,
}

fn default_up() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DisplayDesc {
    #[serde(default = "one")]
    pub exposure: f32,
}

fn one() -> f32 {
    1.0
}

/// Prefix of an error message that carries the path of the field inside a tagged element (see
/// [`tagged`]); `super::Scene::from_json` moves it into the error's field.
pub(super) const INNER_PATH: char = '\u{1}';

/// The `"type"` tag and the remaining fields of a tagged element (light, material, object).
/// serde's own internally tagged enums buffer the element, which loses the path of an error
/// inside it (`objects[0]` instead of `objects[0].radius`); these enums are read in two steps
/// instead: the tag, then the variant's fields by [`variant`], which keeps the path.
fn tagged<'de, D: Deserializer<'de>>(
    d: D,
    variants: &'static [&'static str],
) -> Result<(String, serde_json::Map<String, serde_json::Value>), D::Error> {
    let mut fields = serde_json::Map::<String, serde_json::Value>::deserialize(d)?;
    let tag = match fields.remove("type") {
        Some(serde_json::Value::String(t)) => t,
        Some(other) => return Err(de::Error::custom(format!("field `type`: expected a string, got {other}"))),
        None => return Err(de::Error::missing_field("type")),
    };
    if !variants.contains(&tag.as_str()) {
        return Err(de::Error::unknown_variant(&tag, variants));
    }
    Ok((tag, fields))
}

/// A variant's fields, with the path of any error inside them (message prefixed by
/// [`INNER_PATH`]`path`[`INNER_PATH`]).
fn variant<T: de::DeserializeOwned, E: de::Error>(fields: serde_json::Map<String, serde_json::Value>) -> Result<T, E> {
    serde_path_to_error::deserialize(serde_json::Value::Object(fields))
        .map_err(|e| E::custom(format!("{INNER_PATH}{}{INNER_PATH}{}", e.path(), e.inner())))
}

#[derive(Debug)]
pub enum LightDesc {
    Spot(SpotDesc),
    Point(PointDesc),
    Directional(DirectionalDesc),
    Environment(EnvironmentDesc),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpotDesc {
    pub position: [f32; 3],
    pub direction: [f32; 3],
    pub cone_angle_deg: f32,
    #[serde(default)]
    pub falloff_start_deg: Option<f32>,
    pub intensity: Rgb,
    /// `"linear"` (default) or `"gltf"`.
    #[serde(default)]
    pub falloff: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PointDesc {
    pub position: [f32; 3],
    pub intensity: Rgb,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DirectionalDesc {
    pub direction: [f32; 3],
    pub irradiance: Rgb,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnvironmentDesc {
    pub path: String,
    #[serde(default)]
    pub scale: Option<Rgb>,
    #[serde(default)]
    pub rotate_y_deg: f32,
}

impl<'de> Deserialize<'de> for LightDesc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let (tag, f) = tagged(d, &["spot", "point", "directional", "environment"])?;
        Ok(match tag.as_str() {
            "spot" => LightDesc::Spot(variant(f)?),
            "point" => LightDesc::Point(variant(f)?),
            "environment" => LightDesc::Environment(variant(f)?),
            _ => LightDesc::Directional(variant(f)?),
        })
    }
}

#[derive(Debug)]
pub enum MaterialDesc {
    Diffuse(DiffuseDesc),
    Dielectric(DielectricDesc),
    Mirror(MirrorDesc),
    Conductor(ConductorDesc),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiffuseDesc {
    pub albedo: Rgb,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DielectricDesc {
    pub ior: f32,
    #[serde(default = "one")]
    pub ext_ior: f32,
    #[serde(default)]
    pub absorption: Option<Rgb>,
    #[serde(default)]
    pub attenuation_color: Option<Rgb>,
    #[serde(default)]
    pub attenuation_distance: Option<f32>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MirrorDesc {
    pub reflectance: Rgb,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConductorDesc {
    pub eta: Rgb,
    pub k: Rgb,
}

impl<'de> Deserialize<'de> for MaterialDesc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let (tag, f) = tagged(d, &["diffuse", "dielectric", "mirror", "conductor"])?;
        Ok(match tag.as_str() {
            "diffuse" => MaterialDesc::Diffuse(variant(f)?),
            "dielectric" => MaterialDesc::Dielectric(variant(f)?),
            "mirror" => MaterialDesc::Mirror(variant(f)?),
            _ => MaterialDesc::Conductor(variant(f)?),
        })
    }
}

#[derive(Debug)]
pub enum ObjectDesc {
    Sphere(SphereDesc),
    Rectangle(RectangleDesc),
    Cylinder(CylinderDesc),
    Mesh(MeshDesc),
    Waves(WavesDesc),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SphereDesc {
    pub center: [f32; 3],
    pub radius: f32,
    pub material: String,
    #[serde(default)]
    pub caustic_caster: Option<bool>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RectangleDesc {
    pub center: [f32; 3],
    pub normal: [f32; 3],
    pub size: [f32; 2],
    pub material: String,
    #[serde(default)]
    pub u_axis: Option<[f32; 3]>,
    #[serde(default)]
    pub caustic_caster: Option<bool>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CylinderDesc {
    pub base_center: [f32; 3],
    pub axis: [f32; 3],
    pub radius: f32,
    pub height: f32,
    pub material: String,
    #[serde(default)]
    pub caustic_caster: Option<bool>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshDesc {
    pub path: String,
    #[serde(default = "yes")]
    pub smooth_normals: bool,
    #[serde(default)]
    pub transform: Option<TransformDesc>,
    pub material: String,
    #[serde(default)]
    pub caustic_caster: Option<bool>,
}

/// A closed water body with a wavy top (`scene::waves`, this project's extension).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WavesDesc {
    #[serde(default)]
    pub center: [f32; 2],
    pub size: [f32; 2],
    pub surface: f32,
    pub bottom: f32,
    #[serde(default = "waves_grid")]
    pub grid: u32,
    #[serde(default = "yes")]
    pub smooth_normals: bool,
    pub waves: Vec<WaveDesc>,
    pub material: String,
    #[serde(default)]
    pub caustic_caster: Option<bool>,
}

fn waves_grid() -> u32 {
    64
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WaveDesc {
    pub amplitude: f32,
    pub wavelength: f32,
    pub direction_deg: f32,
    #[serde(default)]
    pub steepness: f32,
    #[serde(default)]
    pub phase: f32,
}

impl<'de> Deserialize<'de> for ObjectDesc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let (tag, f) = tagged(d, &["sphere", "rectangle", "cylinder", "mesh", "waves"])?;
        Ok(match tag.as_str() {
            "sphere" => ObjectDesc::Sphere(variant(f)?),
            "rectangle" => ObjectDesc::Rectangle(variant(f)?),
            "cylinder" => ObjectDesc::Cylinder(variant(f)?),
            "waves" => ObjectDesc::Waves(variant(f)?),
            _ => ObjectDesc::Mesh(variant(f)?),
        })
    }
}

fn yes() -> bool {
    true
}

#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct TransformDesc {
    #[serde(default)]
    pub scale: Option<Scale>,
    #[serde(default)]
    pub rotate_y_deg: f32,
    #[serde(default)]
    pub translate: [f32; 3],
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MediumDesc {
    pub sigma_s: Rgb,
    pub sigma_a: Rgb,
    #[serde(default)]
    pub phase: Option<PhaseDesc>,
    pub bounds: BoundsDesc,
    /// Heterogeneous medium: a density grid scaling `sigma_s` and `sigma_a` (this project's
    /// extension, `docs/scene-format.md`).
    #[serde(default)]
    pub density: Option<DensityDesc>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DensityDesc {
    /// A `.vol` file (`scene::density`), relative to the scene file.
    pub path: String,
}

#[derive(Debug, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum PhaseDesc {
    Isotropic,
    Hg { g: f32 },
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoundsDesc {
    pub min: [f32; 3],
    pub max: [f32; 3],
}
