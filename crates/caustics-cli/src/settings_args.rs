//! The render settings on the command line, the same for `render`, `bench` and `view`: one
//! `clap::Args` struct per section of [`RenderSettings`] with its common flags, and for every
//! other setting `--set section.key=value` and `--settings file.json`. `--print-settings` prints
//! the effective settings as JSON.
//!
//! The order: the subcommand's defaults, then the file, then the flags, then each `--set` in turn
//! (the last word wins). Besides the library's sections, two of the command line's own read the
//! same way: `cpu` (the CPU reference backend, [`CpuSettings`]) and `spheres` (the caustic
//! spheres' tables, [`crate::spheres::SphereArgs`]).

use caustics::Error;
use caustics::render::{RenderSettings, SplatMode, Technique, Tracer};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// `--technique`: the library's shorthands ([`Technique`]: an emission technique, `caustic-spheres`
/// or `beams`), by name, with their help.
pub(crate) fn technique_parser() -> impl clap::builder::TypedValueParser<Value = Technique> {
    use clap::builder::TypedValueParser;
    clap::builder::PossibleValuesParser::new(
        Technique::ALL.map(|t| clap::builder::PossibleValue::new(t.name()).help(t.describe())),
    )
    .map(|s| Technique::parse(&s).expect("a listed technique"))
}

/// `--tracer`: the library's photon tracers, by name, with their help.
pub(crate) fn tracer_parser() -> impl clap::builder::TypedValueParser<Value = Tracer> {
    use clap::builder::TypedValueParser;
    clap::builder::PossibleValuesParser::new(
        Tracer::ALL.map(|t| clap::builder::PossibleValue::new(t.name()).help(t.describe())),
    )
    .map(|s| Tracer::parse(&s).expect("a listed tracer"))
}

/// `--splat`: the library's splat modes, by name, with their help.
pub(crate) fn splat_parser() -> impl clap::builder::TypedValueParser<Value = SplatMode> {
    use clap::builder::TypedValueParser;
    clap::builder::PossibleValuesParser::new(
        SplatMode::ALL.map(|m| clap::builder::PossibleValue::new(m.name()).help(m.describe())),
    )
    .map(|s| SplatMode::parse(&s).expect("a listed splat mode"))
}

/// The `photons` section's common flags (the grid and the technique are [`GridArgs`]: `bench`
/// takes lists of them).
#[derive(clap::Args, Debug, Clone, Default)]
#[command(next_help_heading = "Photons (--set photons.KEY=VALUE for the rest)")]
pub struct PhotonArgs {
    /// How photons are splatted into the caustic map [default: triangles].
    #[arg(long, value_parser = splat_parser())]
    pub splat: Option<SplatMode>,
    /// How photons are traced from the first caster to the receiver [default: exact].
    #[arg(long, value_parser = tracer_parser())]
    pub tracer: Option<Tracer>,
    /// Caustic map size per light-view face (texels, a multiple of 16) [default: 1024, or for
    /// `render` the largest that fits the adapter].
    #[arg(long, value_name = "TEXELS")]
    pub caustic_map: Option<u32>,
}

/// `--photons N` and `--technique NAME` (`render` and `view`; `bench` takes lists).
#[derive(clap::Args, Debug, Clone, Default)]
#[command(next_help_heading = "Photons (--set photons.KEY=VALUE for the rest)")]
pub struct GridArgs {
    /// Photon grid size N per light-view face (N x N photons), 16 to 8192 (adaptive: the
    /// equivalent finest grid, a power of two up to 65536) [default: 1024; view: 512].
    #[arg(long, value_name = "N")]
    pub photons: Option<u32>,
    /// The photon emission technique, or `beams` [default: basic].
    #[arg(long, value_name = "NAME", value_parser = technique_parser())]
    pub technique: Option<Technique>,
}

impl GridArgs {
    fn apply(&self, s: &mut RenderSettings) {
        if let Some(n) = self.photons {
            s.photons.count = n;
        }
        if let Some(t) = self.technique {
            t.apply(s);
        }
    }
}

/// The `adaptive` section's common flags.
#[derive(clap::Args, Debug, Clone, Default)]
#[command(next_help_heading = "Adaptive caustic maps (--set adaptive.KEY=VALUE for the rest)")]
pub struct AdaptiveArgs {
    /// Maximal caustic map error: a cluster converges when its photons land within this many
    /// caustic-map texels (0: in one texel) [default: 0].
    #[arg(long, value_name = "TEXELS")]
    pub max_error_tolerance: Option<f32>,
}

/// The `shading` section's common flags.
#[derive(clap::Args, Debug, Clone, Default)]
#[command(next_help_heading = "Shading (--set shading.KEY=VALUE for the rest)")]
pub struct ShadingArgs {
    /// Shadow map size per light-view face (texels) [default: 2048].
    #[arg(long, value_name = "TEXELS")]
    pub shadow_map: Option<u32>,
}

/// The `medium` section's common flags.
#[derive(clap::Args, Debug, Clone, Default)]
#[command(next_help_heading = "Participating media (--set medium.KEY=VALUE for the rest)")]
pub struct MediumArgs {
    /// Scenes with a medium: ray-march steps of the lights' single scattering along each camera
    /// ray (1 to 4096) [default: 64].
    #[arg(long, value_name = "N")]
    pub medium_steps: Option<u32>,
}

/// The `environment` section's common flags.
#[derive(clap::Args, Debug, Clone, Default)]
#[command(next_help_heading = "Environment light (--set environment.KEY=VALUE for the rest)")]
pub struct EnvironmentArgs {
    /// Scenes with an environment light: the directional lights it is segmented into (cube-map
    /// median cut; 1 to 256) [default: 24].
    #[arg(long, value_name = "N")]
    pub env_lights: Option<u32>,
}

/// The `beams` section's common flags.
#[derive(clap::Args, Debug, Clone, Default)]
#[command(next_help_heading = "Beams (--set beams.KEY=VALUE for the rest)")]
pub struct BeamArgs {
    /// Beams: cells per side of the coarse projected grid over each light face [default: 16].
    #[arg(long, value_name = "N")]
    pub beam_grid: Option<u32>,
    /// Beams: refinement levels (each splits a beam 1 -> 4); 0 for a regular grid [default: 3].
    #[arg(long, value_name = "N")]
    pub beam_levels: Option<u32>,
}

/// The CPU reference backend's settings (`render --backend cpu`): the `cpu` section of the
/// command line's settings (`--set cpu.spp=64`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CpuSettings {
    /// Camera samples per pixel.
    pub spp: u32,
    /// Random seed.
    pub seed: u64,
    /// Render a participating medium with single scattering only.
    pub single_scattering: bool,
    /// Interactions (surfaces and scattering events) a path may have at most, 1 to 1024. Dense
    /// fog needs more than the default 16 for every order (albedo 0.95 keeps 0.95^16 = 0.44 of
    /// a path's light after 16 events): `--set cpu.max_depth=256`.
    pub max_depth: u32,
    /// Which caustic paths the caustic light (--caustic-output, and the image) holds: all;
    /// first-diffuse (light, specular chain, the first diffuse surface, camera: what the GPU
    /// renders); rest (the others: diffuse interreflection of caustic light, volume caustics).
    pub caustic_paths: String,
    /// Which diffuse bounce orders of the light the image holds (the number of diffuse surfaces
    /// on a path from the light to the camera; glass, mirrors and the medium do not count):
    /// all; N (that order alone: 1 is direct light and the first-hit caustics, what the GPU
    /// renders; 0 the environment seen directly or through glass, light scattered in the medium
    /// alone); A-B; A- (A and up: 2- is the light that bounced off diffuse surfaces).
    #[serde(deserialize_with = "string_or_count")]
    pub diffuse_orders: String,
    /// Caustic photons reflect partially at dielectric interfaces; false: they transmit with
    /// weight 1 - F (total internal reflection still reflects): the light the GPU's transmitted
    /// branch carries (`photons.reflection = false`).
    pub partial_reflections: bool,
    /// Scenes with a medium and glass or mirrors: photons per light traced as photon beams for
    /// the caustic light seen in the medium through specular surfaces; 0 leaves it out.
    pub medium_beams: u64,
    /// The photon beams' kernel radius in metres (0: half a pixel's footprint at the specular
    /// objects).
    pub medium_beam_radius: f32,
    /// Scenes with glass or mirrors: photons per light whose first diffuse hits are kept for the
    /// caustic seen on surfaces through specular surfaces; 0 leaves it out.
    pub specular_view_photons: u64,
    /// Their kernel radius in metres (0: a pixel's footprint at the specular objects).
    pub specular_view_radius: f32,
}

/// The diffuse orders as text, also from a bare count: `--set cpu.diffuse_orders=1` reads `1`
/// as JSON.
fn string_or_count<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<String, D::Error> {
    struct Orders;
    impl serde::de::Visitor<'_> for Orders {
        type Value = String;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("all, N, A-B or A- (diffuse bounce orders, 0 and up)")
        }
        fn visit_str<E: serde::de::Error>(self, v: &str) -> std::result::Result<String, E> {
            Ok(v.to_string())
        }
        fn visit_u64<E: serde::de::Error>(self, v: u64) -> std::result::Result<String, E> {
            Ok(v.to_string())
        }
    }
    d.deserialize_any(Orders)
}

impl Default for CpuSettings {
    fn default() -> Self {
        CpuSettings {
            spp: 16,
            seed: 1,
            single_scattering: false,
            max_depth: 16,
            caustic_paths: "all".into(),
            diffuse_orders: "all".into(),
            partial_reflections: true,
            medium_beams: 1 << 18,
            medium_beam_radius: 0.0,
            specular_view_photons: 1 << 18,
            specular_view_radius: 0.0,
        }
    }
}

/// The settings of `render`, `bench` and `view`: every section's common flags, `--settings`,
/// `--set` and `--print-settings`.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct SettingsArgs {
    #[command(flatten)]
    pub photons: PhotonArgs,
    #[command(flatten)]
    pub adaptive: AdaptiveArgs,
    #[command(flatten)]
    pub shading: ShadingArgs,
    #[command(flatten)]
    pub medium: MediumArgs,
    #[command(flatten)]
    pub environment: EnvironmentArgs,
    #[command(flatten)]
    pub beams: BeamArgs,
    /// Read the settings from this JSON file (sections as `--print-settings` writes them; keys
    /// left out keep their defaults), before the flags and `--set`.
    #[arg(long, value_name = "FILE", help_heading = "Settings")]
    pub settings: Option<PathBuf>,
    /// Set one setting by its path, e.g. `--set beams.cutoff=0.01`, `--set photons.emission=hierarchical`
    /// (repeatable; the value is read as JSON, else as a string). `--print-settings` lists every
    /// key.
    #[arg(long = "set", value_name = "SECTION.KEY=VALUE", help_heading = "Settings")]
    pub set: Vec<String>,
    /// Print the effective settings as JSON and exit.
    #[arg(long, help_heading = "Settings")]
    pub print_settings: bool,
}

/// The settings a command runs with, every source applied.
#[derive(Debug, Clone)]
pub struct Resolved {
    pub render: RenderSettings,
    pub cpu: CpuSettings,
    pub spheres: crate::spheres::SphereArgs,
    /// The caustic map size was given (by a flag, the file or `--set`): `render` keeps it rather
    /// than fitting the adapter.
    pub caustic_map_given: bool,
}

impl Resolved {
    /// Every section as one JSON object (what `--print-settings` prints and `--settings` reads).
    pub fn to_json(&self) -> serde_json::Value {
        let mut v = self.render.to_json();
        let map = v.as_object_mut().expect("an object");
        map.insert("cpu".into(), caustics::settings::json_value(&self.cpu));
        map.insert("spheres".into(), caustics::settings::json_value(&self.spheres));
        v
    }
}

const CLI_SECTIONS: [&str; 2] = ["cpu", "spheres"];

impl SettingsArgs {
    /// The settings over `base` (the subcommand's defaults) and `grid` (`--photons`,
    /// `--technique`, where the subcommand takes them): the file, the flags, each `--set`.
    pub fn resolve(&self, base: RenderSettings, grid: Option<&GridArgs>) -> Result<Resolved, Error> {
        let mut r = Resolved {
            render: base,
            cpu: CpuSettings::default(),
            spheres: crate::spheres::SphereArgs::default(),
            caustic_map_given: false,
        };
        if let Some(path) = &self.settings {
            let file = path.display().to_string();
            let text = std::fs::read_to_string(path).map_err(|e| Error::input(&file, "", e.to_string()))?;
            let mut json: serde_json::Value = serde_json::from_str(&text).map_err(|e| Error::Input {
                file: file.clone(),
                field: String::new(),
                line: Some((e.line(), e.column())),
                message: e.to_string(),
            })?;
            let Some(map) = json.as_object_mut() else {
                return Err(Error::input(&file, "", "the settings must be a JSON object of sections"));
            };
            r.caustic_map_given |= map.get("photons").is_some_and(|p| p.get("caustic_map_size").is_some());
            let cpu = map.remove("cpu");
            let spheres = map.remove("spheres");
            // The file's keys over the subcommand's defaults.
            let mut merged = r.render.to_json();
            merge(&mut merged, serde_json::Value::Object(std::mem::take(map)));
            r.render = RenderSettings::from_json(&file, &merged.to_string()).map_err(|e| relabel(e, &file))?;
            if let Some(c) = cpu {
                r.cpu = from_value(&file, "cpu", c)?;
            }
            if let Some(s) = spheres {
                r.spheres = from_value(&file, "spheres", s)?;
            }
        }
        if let Some(g) = grid {
            g.apply(&mut r.render);
        }
        let s = &mut r.render;
        let p = &self.photons;
        s.photons.splat = p.splat.unwrap_or(s.photons.splat);
        s.photons.tracer = p.tracer.unwrap_or(s.photons.tracer);
        if let Some(m) = p.caustic_map {
            s.photons.caustic_map_size = m;
            r.caustic_map_given = true;
        }
        s.adaptive.error_tolerance = self.adaptive.max_error_tolerance.unwrap_or(s.adaptive.error_tolerance);
        s.shading.shadow_map_size = self.shading.shadow_map.unwrap_or(s.shading.shadow_map_size);
        s.medium.steps = self.medium.medium_steps.unwrap_or(s.medium.steps);
        s.environment.lights = self.environment.env_lights.unwrap_or(s.environment.lights);
        s.beams.grid = self.beams.beam_grid.unwrap_or(s.beams.grid);
        s.beams.levels = self.beams.beam_levels.unwrap_or(s.beams.levels);
        for item in &self.set {
            let (key, value) = item.split_once('=').ok_or_else(|| {
                Error::input("<command line>", "--set", format!("expected SECTION.KEY=VALUE, got \"{item}\""))
            })?;
            let key = key.trim();
            // JSON where it reads as JSON (numbers, true, "quoted", objects), else the text.
            let value = serde_json::from_str(value.trim())
                .unwrap_or_else(|_| serde_json::Value::String(value.trim().to_string()));
            let (section, rest) = key.split_once('.').unwrap_or((key, ""));
            if CLI_SECTIONS.contains(&section) {
                let mut v =
                    if section == "cpu" { serde_json::to_value(&r.cpu) } else { serde_json::to_value(&r.spheres) }
                        .expect("serializes");
                let map = v.as_object_mut().expect("an object");
                if !map.contains_key(rest) {
                    let known: Vec<&str> = map.keys().map(String::as_str).collect();
                    return Err(Error::input(
                        "<command line>",
                        key,
                        format!("no key `{rest}` in `{section}`; known keys: {}", known.join(", ")),
                    ));
                }
                map.insert(rest.to_string(), value);
                if section == "cpu" {
                    r.cpu = from_value("<command line>", key, v)?;
                } else {
                    r.spheres = from_value("<command line>", key, v)?;
                }
            } else {
                r.render.set(key, value).map_err(|e| relabel(e, "<command line>"))?;
                r.caustic_map_given |= key == "photons.caustic_map_size";
            }
        }
        Ok(r)
    }
}

/// `patch`'s keys over `base`, object by object.
fn merge(base: &mut serde_json::Value, patch: serde_json::Value) {
    match (base, patch) {
        (serde_json::Value::Object(b), serde_json::Value::Object(p)) => {
            for (k, v) in p {
                match b.get_mut(&k) {
                    Some(slot) if slot.is_object() && v.is_object() => merge(slot, v),
                    _ => {
                        b.insert(k, v);
                    }
                }
            }
        }
        (b, p) => *b = p,
    }
}

fn from_value<T: serde::de::DeserializeOwned>(file: &str, field: &str, v: serde_json::Value) -> Result<T, Error> {
    serde_json::from_value(v).map_err(|e| Error::input(file, field, e.to_string()))
}

/// The library's settings errors name `<settings>`; say where they came from.
/// An error of the merged settings as the user's file's: named by `file` and field path, without
/// a line and column (they would point into the merged document, not the file).
fn relabel(mut e: Error, file: &str) -> Error {
    if let Error::Input { file: f, line, message, .. } = &mut e {
        *f = file.to_string();
        *line = None;
        if let Some(i) = message.find(" at line ") {
            message.truncate(i);
        }
    }
    e
}
