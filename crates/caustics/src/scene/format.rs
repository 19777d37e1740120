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

#[derive(Debug, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum LightDesc {
    Spot {
        position: [f32; 3],
        direction: [f32; 3],
        cone_angle_deg: f32,
        #[serde(default)]
        falloff_start_deg: Option<f32>,
        intensity: Rgb,
    },
    Point {
        position: [f32; 3],
        intensity: Rgb,
    },
    Directional {
        direction: [f32; 3],
        irradiance: Rgb,
    },
}

#[derive(Debug, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum MaterialDesc {
    Diffuse {
        albedo: Rgb,
    },
    Dielectric {
        ior: f32,
        #[serde(default = "one")]
        ext_ior: f32,
    },
    Mirror {
        reflectance: Rgb,
    },
    Conductor {
        eta: Rgb,
        k: Rgb,
    },
}

#[derive(Debug, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum ObjectDesc {
    Sphere {
        center: [f32; 3],
        radius: f32,
        material: String,
        #[serde(default)]
        caustic_caster: Option<bool>,
    },
    Rectangle {
        center: [f32; 3],
        normal: [f32; 3],
        size: [f32; 2],
        material: String,
        #[serde(default)]
        u_axis: Option<[f32; 3]>,
        #[serde(default)]
        caustic_caster: Option<bool>,
    },
    Cylinder {
        base_center: [f32; 3],
        axis: [f32; 3],
        radius: f32,
        height: f32,
        material: String,
        #[serde(default)]
        caustic_caster: Option<bool>,
    },
    Mesh {
        path: String,
        #[serde(default = "yes")]
        smooth_normals: bool,
        #[serde(default)]
        transform: Option<TransformDesc>,
        material: String,
        #[serde(default)]
        caustic_caster: Option<bool>,
    },
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
