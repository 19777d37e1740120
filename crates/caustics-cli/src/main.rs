//! `caustics`: render scenes with caustics on the GPU (or the CPU reference), compare images,
//! list adapters, view scenes interactively. Exit codes: 0 success, 2 bad input (scene, settings,
//! paths), 130 cancelled by Ctrl-C, 1 anything else.

mod bench;
mod bench_beams;
mod compare;
mod progress;
mod spheres;
mod view;

use anyhow::Result;
use caustics::render::{GpuRender, RenderSettings};
use caustics::{Error, Scene};
use caustics_reference::ImageIo as _;
use clap::{Parser, Subcommand, ValueEnum};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Parser)]
#[command(name = "caustics", version, about = "Real-time caustics on wgpu, with an exact CPU reference renderer")]
#[command(after_help = "Examples:
  caustics render                                   the built-in scene (a glass ball) to caustics.png
  caustics render scenes/mirror_ring.json -o ring.exr --photons 2048
  caustics render scenes/glass_bunny.json --dump dump/   also writes the light-space buffers
  caustics render scenes/glass_sphere.json --backend cpu -o reference.exr
  caustics compare out.exr references/a_glass_sphere_caustic.exr --mask references/a_glass_sphere_specmask.png
  caustics view scenes/two_spheres.json             the interactive viewer
  caustics info                                     adapters, features and limits")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Backend {
    /// The GPU if an adapter exists, else the CPU reference (with a notice).
    Auto,
    Gpu,
    Cpu,
}

/// `--technique`: one of the library's photon techniques, or `beams` (adaptive beam tracing for
/// the caustics of spot and point lights on surfaces as in the medium, no photon maps: the same
/// as `--surface-caustics beams` with the basic technique for the lights beams do not cover).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct TechniqueChoice {
    pub technique: caustics::render::Technique,
    pub beams: bool,
}

impl TechniqueChoice {
    /// The settings' technique and where the surface caustic comes from (`beams` overrides
    /// `surface`).
    pub fn apply(
        self,
        surface: caustics::render::SurfaceCaustics,
    ) -> (caustics::render::Technique, caustics::render::SurfaceCaustics) {
        (self.technique, if self.beams { caustics::render::SurfaceCaustics::Beams } else { surface })
    }
}

/// `--technique`: the library's techniques, by name, with their help (a new technique needs
/// no edit here), and `beams`.
pub(crate) fn technique_parser() -> impl clap::builder::TypedValueParser<Value = TechniqueChoice> {
    use caustics::render::Technique as T;
    use clap::builder::TypedValueParser;
    let mut values: Vec<clap::builder::PossibleValue> =
        T::ALL.iter().map(|t| clap::builder::PossibleValue::new(t.name()).help(t.describe())).collect();
    values.push(clap::builder::PossibleValue::new("beams").help(
        "Adaptive beam tracing (Liktor & Dachsbacher 2011): the caustics of spot and point lights on surfaces and in the medium from beams, no photon maps (the same as --surface-caustics beams; directional lights: basic)",
    ));
    clap::builder::PossibleValuesParser::new(values).map(|s| match T::parse(&s) {
        Some(technique) => TechniqueChoice { technique, beams: false },
        None => TechniqueChoice { technique: T::Basic, beams: true },
    })
}

/// `--tracer`: the library's photon tracers, by name, with their help.
pub(crate) fn tracer_parser() -> impl clap::builder::TypedValueParser<Value = caustics::render::Tracer> {
    use caustics::render::Tracer as T;
    use clap::builder::TypedValueParser;
    clap::builder::PossibleValuesParser::new(
        T::ALL.map(|t| clap::builder::PossibleValue::new(t.name()).help(t.describe())),
    )
    .map(|s| T::parse(&s).expect("a listed tracer"))
}

/// `--splat`: the library's splat modes, by name, with their help.
pub(crate) fn splat_parser() -> impl clap::builder::TypedValueParser<Value = caustics::render::SplatMode> {
    use caustics::render::SplatMode as S;
    use clap::builder::TypedValueParser;
    clap::builder::PossibleValuesParser::new(
        S::ALL.map(|m| clap::builder::PossibleValue::new(m.name()).help(m.describe())),
    )
    .map(|s| S::parse(&s).expect("a listed splat mode"))
}

/// `--surface-caustics`: where the caustic on surfaces comes from, by name, with its help.
pub(crate) fn surface_caustics_parser()
-> impl clap::builder::TypedValueParser<Value = caustics::render::SurfaceCaustics> {
    use caustics::render::SurfaceCaustics as S;
    use clap::builder::TypedValueParser;
    clap::builder::PossibleValuesParser::new(
        S::ALL.map(|m| clap::builder::PossibleValue::new(m.name()).help(m.describe())),
    )
    .map(|s| S::parse(&s).expect("a listed source"))
}

/// `--beam-volume`: how the volume caustic's beams reach the pixels, by name, with its help.
pub(crate) fn beam_volume_parser() -> impl clap::builder::TypedValueParser<Value = caustics::render::BeamVolume> {
    use caustics::render::BeamVolume as V;
    use clap::builder::TypedValueParser;
    clap::builder::PossibleValuesParser::new(
        V::ALL.map(|m| clap::builder::PossibleValue::new(m.name()).help(m.describe())),
    )
    .map(|s| V::parse(&s).expect("a listed way"))
}

/// `--spill-faces`: whether spot lights get a spill face, by name.
pub(crate) fn spill_faces_parser() -> impl clap::builder::TypedValueParser<Value = caustics::render::SpillFaces> {
    use caustics::render::SpillFaces as S;
    use clap::builder::TypedValueParser;
    clap::builder::PossibleValuesParser::new(S::ALL.map(|m| m.name())).map(|s| S::parse(&s).expect("a listed value"))
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene to PNG (tone-mapped) or EXR (linear radiance, W/(m^2 sr)).
    Render {
        /// Scene file (JSON, see docs/scene-format.md); the built-in glass-ball scene if omitted.
        scene: Option<PathBuf>,
        /// Output image (.png or .exr).
        #[arg(short, long, default_value = "caustics.png")]
        output: PathBuf,
        /// Photon grid size N per light-view face (N x N photons), 16 to 8192 (adaptive: the
        /// equivalent finest grid, a power of two up to 65536).
        #[arg(long, default_value_t = 1024)]
        photons: u32,
        /// Image size WxH, overriding the scene's camera.
        #[arg(long, value_parser = parse_size)]
        size: Option<(u32, u32)>,
        #[arg(long, default_value = "basic", value_parser = technique_parser())]
        technique: TechniqueChoice,
        /// How photons are splatted into the caustic map.
        #[arg(long, default_value = "triangles", value_parser = splat_parser())]
        splat: caustics::render::SplatMode,
        /// How photons are traced from the first caster to the receiver.
        #[arg(long, default_value = "exact", value_parser = tracer_parser())]
        tracer: caustics::render::Tracer,
        /// Exact tracer: specular interactions a photon path may have (1 to 64).
        #[arg(long, default_value_t = caustics::render::RenderSettings::default().max_depth)]
        max_depth: u32,
        /// Trace only the light transmitted at glass, not the second photon per cell that carries
        /// the light reflected at the first dielectric surface (half the cost; every technique:
        /// the beams then make only their transmitted branch).
        #[arg(long)]
        no_glass_reflection: bool,
        /// Do not rasterize the light's second caster layer (the casters behind the nearest one;
        /// drawn only for scenes with caster meshes and two casters or more): a mesh hidden from
        /// the light behind another caster is then missed by the photons (for comparisons).
        #[arg(long)]
        no_light_second_layer: bool,
        /// Segments around tessellated spheres and cylinders (rasterization only; the CPU
        /// reference intersects them exactly).
        #[arg(long, default_value_t = 192)]
        tessellation: u32,
        /// Adaptive techniques: the coarse photon grid the hierarchy starts from.
        #[arg(long, default_value_t = 64)]
        base_grid: u32,
        /// Maximal caustic map error: a cluster converges when its photons land within this many
        /// caustic-map texels (0: in one texel).
        #[arg(long, default_value_t = 0.0)]
        max_error_tolerance: f32,
        /// Maximal caustic map error with caustic triangles: also stop refining a cluster whose
        /// cell quad maps linearly, its corners' and children's landing points within this many
        /// texels of the bilinear interpolation of its corners (0: off, the paper's rule alone).
        #[arg(long, default_value_t = 0.0)]
        quad_linearity: f32,
        /// Maximal caustic map error: check convergence for clusters whose photons lie on a grid
        /// of at least this size (Wyman & Nichols: 512).
        #[arg(long, default_value_t = 512)]
        error_check_grid: u32,
        /// Maximal caustic map error: check every level from --error-check-grid on, as the paper
        /// does, instead of skipping the levels where a cluster's spread predicts no convergence.
        #[arg(long)]
        no_error_skip: bool,
        #[arg(long, value_enum, default_value = "auto")]
        backend: Backend,
        /// Caustic map size per light-view face (texels, a multiple of 16); default 1024, or the
        /// largest that fits the adapter (point lights need six faces).
        #[arg(long)]
        caustic_map: Option<u32>,
        /// Shadow map size per light-view face (texels).
        #[arg(long, default_value_t = 2048)]
        shadow_map: u32,
        /// Scenes with a medium: ray-march steps of the lights' single scattering along each
        /// camera ray (GPU; 1 to 4096).
        #[arg(long, default_value_t = 64)]
        medium_steps: u32,
        /// Heterogeneous media (a density grid): ray-march steps of each transmittance toward a
        /// light (GPU; 1 to 1024).
        #[arg(long, default_value_t = 16)]
        medium_light_steps: u32,
        /// Scenes with a medium: light between the diffuse surfaces and the medium (light →
        /// floor → fog, light → fog → floor) from virtual point lights, this many blocks per
        /// side of each light face (GPU; 0 to 64, 0: off).
        #[arg(long, default_value_t = 16)]
        medium_bounce_grid: u32,
        /// Steps of the camera ray march that gathers the light the surfaces reflect into the
        /// medium (GPU; 1 to 4096).
        #[arg(long, default_value_t = 8)]
        medium_bounce_steps: u32,
        /// Scenes with a medium: leave out the medium along the camera rays beyond their first
        /// specular surface (glass then shows what lies behind it unattenuated and without the
        /// fog's light; GPU, cheaper).
        #[arg(long)]
        no_medium_beyond_specular: bool,
        /// Scenes with an environment light: the directional lights it is segmented into on
        /// the GPU (cube-map median cut; 1 to 256).
        #[arg(long, default_value_t = caustics::settings::DEFAULT_ENV_LIGHTS)]
        env_lights: u32,
        /// Sub-directions each environment region's caustic is spread over (GPU; 0 to 32,
        /// 0: one direction per region).
        #[arg(long, default_value_t = caustics::settings::DEFAULT_ENV_TAPS)]
        env_taps: u32,
        #[command(flatten)]
        beams: BeamArgs,
        /// Where the caustic on diffuse surfaces of spot and point lights comes from: the photon
        /// caustic maps, or the beams of adaptive beam tracing (GPU; scenes with a specular
        /// caster, with or without a medium; their photon maps are then not traced).
        #[arg(long, default_value = "photons", value_parser = surface_caustics_parser())]
        surface_caustics: caustics::render::SurfaceCaustics,
        /// Spill faces of spot lights: a second, wider light face that receives the caustic
        /// light glass bends outside the spot's view (auto: where a specular caster is in the
        /// spot's view and the scene reaches beyond it, caustic maps up to 1024²). The CPU
        /// backend gives its caustic maps the same faces.
        #[arg(long, default_value = "auto", value_parser = spill_faces_parser())]
        spill_faces: caustics::render::SpillFaces,
        /// Gaussian splat standard deviation (caustic-map texels).
        #[arg(long, default_value_t = 1.0)]
        splat_sigma: f32,
        /// Memory for photon storage, MiB (basic: one batch of the grid; hierarchical: a dense
        /// tile; adaptive: the photon hierarchy of one batch).
        #[arg(long, default_value_t = 64)]
        photon_memory: u64,
        /// Write the intermediate buffers (light-space normals, depths, caustic maps) here.
        #[arg(long)]
        dump: Option<PathBuf>,
        /// Also write the caustic light alone (same format as the output) to this file.
        #[arg(long)]
        caustic_output: Option<PathBuf>,
        /// Adapter to use (a part of its name, see `caustics info`).
        #[arg(long)]
        adapter: Option<String>,
        /// CPU backend: camera samples per pixel.
        #[arg(long, default_value_t = 16)]
        spp: u32,
        /// CPU backend: random seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// CPU backend: render a participating medium with single scattering only.
        #[arg(long)]
        single_scattering: bool,
        /// CPU backend: which caustic paths the caustic light (--caustic-output, and the image)
        /// holds: all; first-diffuse (light, specular chain, the first diffuse surface, camera:
        /// what the GPU renders); rest (the others: diffuse interreflection of caustic light,
        /// volume caustics).
        #[arg(long, default_value = "all", value_parser = ["all", "first-diffuse", "rest"])]
        caustic_paths: String,
        /// CPU backend: caustic photons transmit at every dielectric interface with weight
        /// 1 - F (total internal reflection still reflects) instead of reflecting partially:
        /// the light the GPU's transmitted branch carries (compare with the GPU's
        /// --no-glass-reflection, like for like).
        #[arg(long)]
        no_partial_reflections: bool,
        /// CPU backend, scenes with a medium and glass or mirrors: photons per light traced as
        /// photon beams for the caustic light seen in the medium through specular surfaces
        /// (light, glass, fog, glass, camera); 0 leaves that light out.
        #[arg(long, default_value_t = 1 << 18)]
        medium_beams: u64,
        /// CPU backend: the photon beams' kernel radius in metres (0: half a pixel's footprint
        /// at the specular objects).
        #[arg(long, default_value_t = 0.0)]
        medium_beam_radius: f32,
        /// CPU backend, scenes with glass or mirrors: photons per light whose first diffuse hits
        /// are kept for the caustic seen on surfaces through specular surfaces (light, glass,
        /// floor, glass, camera); 0 leaves that light out.
        #[arg(long, default_value_t = 1 << 18)]
        specular_view_photons: u64,
        /// CPU backend: their kernel radius in metres (0: a pixel's footprint at the specular
        /// objects).
        #[arg(long, default_value_t = 0.0)]
        specular_view_radius: f32,
        /// The same as --technique caustic-spheres (kept as an alias): the caustics of
        /// directional lights come from precomputed caustic spheres (cached; built first if
        /// needed) in one eye-space pass; spot and point lights get basic caustic maps.
        #[arg(long)]
        caustic_spheres: bool,
        #[command(flatten)]
        sphere_args: spheres::SphereArgs,
    },
    /// Precompute the caustic spheres of a scene's caustic objects into the cache (what
    /// `render --technique caustic-spheres` loads).
    Precompute {
        /// Scene file (JSON); the built-in glass-ball scene if omitted.
        scene: Option<PathBuf>,
        #[command(flatten)]
        sphere_args: spheres::SphereArgs,
    },
    /// Compare two images (EXR or PNG): RMSE, relative MSE, PSNR, FLIP, energy ratio.
    Compare {
        a: PathBuf,
        b: PathBuf,
        /// Only compare where this mask is black (e.g. a reference's *_specmask.png).
        #[arg(long)]
        mask: Option<PathBuf>,
        /// Write a difference heat map (PNG).
        #[arg(long)]
        heatmap: Option<PathBuf>,
    },
    /// Compare photon emission techniques on one scene (Table 1 of Wyman & Nichols 2009):
    /// photons splatted, relevant photons, coverage, GPU ms per pass, memory, batches.
    Bench(bench::BenchArgs),
    /// The interactive viewer: orbit, move lights and objects, switch techniques live, compare
    /// with the CPU reference (a window; needs a GPU adapter).
    View(view::ViewArgs),
    /// List GPU adapters with their features and limits.
    Info,
}

pub(crate) fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or("expected WxH, e.g. 800x600")?;
    let w: u32 = w.trim().parse().map_err(|_| format!("bad width \"{w}\""))?;
    let h: u32 = h.trim().parse().map_err(|_| format!("bad height \"{h}\""))?;
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        return Err(format!("{w}x{h}: each side must be 1 to 16384 pixels"));
    }
    Ok((w, h))
}

/// Keep Mesa's device-selection layer from printing "error: XDG_RUNTIME_DIR is invalid or not
/// set in the environment." (twice) on machines without a Wayland session. The layer
/// (`VK_LAYER_MESA_device_select`, an implicit Vulkan layer installed with Mesa's drivers)
/// calls `wl_display_connect` inside every `vkEnumeratePhysicalDevices` when the instance
/// enables `VK_KHR_wayland_surface`, which wgpu always does; libwayland-client prints that line
/// when the connection cannot even be attempted. Only where no Wayland display can be reached
/// (no `WAYLAND_SOCKET`, neither `XDG_RUNTIME_DIR` nor `WAYLAND_DISPLAY` an absolute path) and
/// the user chose nothing about the layer, it is switched off through the variable its manifest
/// names for that (`disable_environment`: `NODEVICE_SELECT=1`). Real errors still print.
#[expect(unsafe_code, reason = "std::env::set_var is unsafe in edition 2024; called before any thread exists")]
fn quiet_headless_vulkan() {
    let var = |k: &str| std::env::var_os(k).filter(|v| !v.is_empty());
    let absolute = |k: &str| var(k).is_some_and(|v| std::path::Path::new(&v).is_absolute());
    let wayland = var("WAYLAND_SOCKET").is_some() || absolute("XDG_RUNTIME_DIR") || absolute("WAYLAND_DISPLAY");
    if !wayland && var("NODEVICE_SELECT").is_none() && var("MESA_VK_DEVICE_SELECT").is_none() {
        // SAFETY: called first thing in `main`, before any other thread exists.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
}

fn main() -> ExitCode {
    quiet_headless_vulkan();
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.downcast_ref::<Error>().is_some_and(|e| matches!(e, Error::Cancelled)) => {
            eprintln!("cancelled: nothing was written");
            ExitCode::from(progress::CANCELLED_EXIT)
        }
        Err(mut e) => {
            flag_names(&mut e);
            let input = e.downcast_ref::<Error>().is_some_and(Error::is_input);
            eprintln!("error: {e:#}");
            ExitCode::from(if input { 2 } else { 1 })
        }
    }
}

/// Volume caustics by adaptive beam tracing (scenes with a medium and a specular caster; GPU).
/// A separate switch from --technique: the beams render the light focused into the medium,
/// the photon technique the caustic on surfaces, and both run in the same frame.
#[derive(clap::Args, Debug, Clone)]
pub struct BeamArgs {
    /// Do not render volume caustics (beams; `--surface-caustics beams` still builds them for
    /// the surfaces).
    #[arg(long)]
    no_beams: bool,
    /// Beams: cells per side of the coarse projected grid over each light face.
    #[arg(long, default_value_t = 16)]
    beam_grid: u32,
    /// Beams: refinement levels (each splits a beam 1 -> 4); 0 for a regular grid.
    #[arg(long, default_value_t = 3)]
    beam_levels: u32,
    /// Beams: split where the edges' first-surface normals differ by more (degrees).
    #[arg(long, default_value_t = 25.0)]
    beam_normal_threshold: f32,
    /// Beams: split where the edges' distances to the first surface differ by more (fraction).
    #[arg(long, default_value_t = 0.1)]
    beam_depth_threshold: f32,
    /// Beams: split where flux (relative to the face's) x convergence exceeds this.
    #[arg(long, default_value_t = 0.05)]
    beam_energy_threshold: f32,
    /// Beams: split where the beam's width over its distance to the camera exceeds this (rad).
    #[arg(long, default_value_t = 0.2)]
    beam_camera_threshold: f32,
    /// Beams: split where a beam misplaces more than this fraction of its triangle's light (the
    /// exactly traced light of the triangle's centroid against the beam's); 0 turns it off.
    #[arg(long, default_value_t = 0.05)]
    beam_linearity_threshold: f32,
    /// Beams: the residual branch's least probability of reflecting at a dielectric interface
    /// (it reflects with max(F, p): the light reflected partially where no other branch follows
    /// it, drawn at random per triangle); 0 turns it off, below 1.
    #[arg(long, default_value_t = 0.3)]
    beam_residual: f32,
    /// Beams: the energy cutoff, a radiance in W/(m² sr): a beam diverging beyond its last
    /// focus ends where the rest of its light, seen along it, is this (per beam; shorter hulls,
    /// fewer fragments, some of a faint glow lost; beams lighting a surface with
    /// `--surface-caustics beams` are not cut); 0 (default) draws every beam to its end.
    #[arg(long, default_value_t = 0.0)]
    beam_cutoff: f32,
    /// Beams held per light (more is an overflow, reported as an error).
    #[arg(long, default_value_t = 1 << 17)]
    beam_capacity: u32,
    /// Beams: midpoint-rule points per piece of a camera ray inside a beam.
    #[arg(long, default_value_t = 4)]
    beam_samples: u32,
    /// Beams: camera rays per pixel side (box filter; n² per pixel).
    #[arg(long, default_value_t = 1)]
    beam_pixel_samples: u32,
    /// Surface caustics from beams (`--surface-caustics beams`): points per pixel side on the
    /// surface (box filter; n² per pixel), 1 to 8.
    #[arg(long, default_value_t = 4)]
    beam_surface_samples: u32,
    /// Beams: integrate a beam over each pixel's footprint where its section, seen from the
    /// camera, is narrower than this many pixels (near a focus); 0 turns it off (rays only).
    #[arg(long, default_value_t = 2.0)]
    beam_footprint: f32,
    /// Beams: lines per side of a thin section in the footprint integral (lines²), 1 to 4.
    #[arg(long, default_value_t = 2)]
    beam_footprint_lines: u32,
    /// Beams: beams per dispatch of the gather, as a multiple of what lavapipe's loop limit
    /// allows; 0 chooses (1 on CPU adapters, 16 on GPUs), at most 1024.
    #[arg(long, default_value_t = 0)]
    beam_chunk_scale: u32,
    /// Beams: how the volume caustic is drawn: the beams' hulls (indirect draws; need float32
    /// blending), a per-pixel gather over all beams, or auto (hulls where the adapter can).
    #[arg(long, default_value = "auto", value_parser = beam_volume_parser())]
    beam_volume: caustics::render::BeamVolume,
}

impl BeamArgs {
    pub fn settings(&self) -> caustics::settings::BeamSettings {
        caustics::settings::BeamSettings {
            enabled: !self.no_beams,
            grid: self.beam_grid,
            levels: self.beam_levels,
            normal_threshold_deg: self.beam_normal_threshold,
            depth_threshold: self.beam_depth_threshold,
            energy_threshold: self.beam_energy_threshold,
            camera_threshold: self.beam_camera_threshold,
            linearity_threshold: self.beam_linearity_threshold,
            capacity: self.beam_capacity,
            samples: self.beam_samples,
            pixel_samples: self.beam_pixel_samples,
            surface_samples: self.beam_surface_samples,
            reflection: true,
            residual: self.beam_residual,
            cutoff: self.beam_cutoff,
            footprint: self.beam_footprint,
            footprint_lines: self.beam_footprint_lines,
            chunk_scale: self.beam_chunk_scale,
            volume: self.beam_volume,
        }
    }
}

/// The library names a bad setting by its field (`<settings>`, `photons`); the user gave it as a
/// flag: say so.
fn flag_names(e: &mut anyhow::Error) {
    const FLAGS: &[(&str, &str)] = &[
        ("photons", "--photons"),
        ("base_grid", "--base-grid"),
        ("caustic_map_size", "--caustic-map"),
        ("max_error_tolerance", "--max-error-tolerance"),
        ("photon_memory", "--photon-memory"),
        ("quad_linearity", "--quad-linearity"),
        ("shadow_map_size", "--shadow-map"),
        ("medium_steps", "--medium-steps"),
        ("medium_light_steps", "--medium-light-steps"),
        ("medium_bounce_grid", "--medium-bounce-grid"),
        ("medium_bounce_steps", "--medium-bounce-steps"),
        ("env_lights", "--env-lights"),
        ("env_taps", "--env-taps"),
        ("beams.grid", "--beam-grid"),
        ("beams.levels", "--beam-levels"),
        ("beams.normal_threshold_deg", "--beam-normal-threshold"),
        ("beams.depth_threshold", "--beam-depth-threshold"),
        ("beams.energy_threshold", "--beam-energy-threshold"),
        ("beams.camera_threshold", "--beam-camera-threshold"),
        ("beams.linearity_threshold", "--beam-linearity-threshold"),
        ("beams.capacity", "--beam-capacity"),
        ("beams.residual", "--beam-residual"),
        ("beams.cutoff", "--beam-cutoff"),
        ("beams.samples", "--beam-samples"),
        ("beams.pixel_samples", "--beam-pixel-samples"),
        ("beams.surface_samples", "--beam-surface-samples"),
        ("beams.footprint", "--beam-footprint"),
        ("beams.footprint_lines", "--beam-footprint-lines"),
        ("beams.chunk_scale", "--beam-chunk-scale"),
        ("camera.size", "--size"),
        ("splat_sigma", "--splat-sigma"),
        ("max_depth", "--max-depth"),
        ("tessellation", "--tessellation"),
        ("adapter", "--adapter"),
    ];
    if let Some(Error::NoAdapter(m)) = e.downcast_mut::<Error>()
        && m.ends_with("render with the CPU reference")
    {
        *m += " (`--backend cpu`)";
    }
    if let Some(Error::Input { file, field, .. }) = e.downcast_mut::<Error>()
        && file == "<settings>"
        && let Some((_, flag)) = FLAGS.iter().find(|(f, _)| f == field)
    {
        *file = "<command line>".into();
        *field = flag.to_string();
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Info => info(),
        Command::Bench(args) => bench::run(&args),
        Command::View(args) => view::run(args),
        Command::Precompute { scene, sphere_args } => {
            let scene = match &scene {
                Some(p) => Scene::load(p)?,
                None => Scene::default_scene(),
            };
            let built = spheres::build(&scene, &sphere_args)?;
            if built.is_empty() {
                println!("{}: no caustic object, nothing to precompute", scene.source);
            }
            Ok(())
        }
        Command::Compare { a, b, mask, heatmap } => Ok(compare::run(&a, &b, mask.as_deref(), heatmap.as_deref())?),
        Command::Render {
            scene,
            output,
            photons,
            size,
            technique,
            splat,
            tracer,
            max_depth,
            no_glass_reflection,
            no_light_second_layer,
            tessellation,
            base_grid,
            max_error_tolerance,
            quad_linearity,
            error_check_grid,
            no_error_skip,
            backend,
            caustic_map,
            shadow_map,
            medium_steps,
            medium_light_steps,
            medium_bounce_grid,
            medium_bounce_steps,
            no_medium_beyond_specular,
            env_lights,
            env_taps,
            beams,
            surface_caustics,
            spill_faces,
            splat_sigma,
            photon_memory,
            dump,
            caustic_output,
            adapter,
            spp,
            seed,
            single_scattering,
            caustic_paths,
            no_partial_reflections,
            medium_beams,
            medium_beam_radius,
            specular_view_photons,
            specular_view_radius,
            caustic_spheres,
            sphere_args,
        } => {
            check_output(&output)?;
            // `--technique beams` is `--surface-caustics beams`; `--caustic-spheres` is
            // `--technique caustic-spheres`.
            let (technique, surface_caustics) = technique.apply(surface_caustics);
            let technique = if caustic_spheres { caustics::render::Technique::CausticSpheres } else { technique };
            let caustic_spheres = technique == caustics::render::Technique::CausticSpheres;
            if let Some(c) = &caustic_output {
                check_output(c)?;
            }
            let mut scene = match &scene {
                Some(p) => Scene::load(p)?,
                None => Scene::default_scene(),
            };
            for w in &scene.warnings {
                eprintln!("warning: {w}");
            }
            if let Some((w, h)) = size {
                scene.camera.width = w;
                scene.camera.height = h;
            }
            let mut settings = RenderSettings {
                photons,
                technique,
                splat,
                tracer,
                max_depth,
                dielectric_reflection: !no_glass_reflection,
                light_second_layer: !no_light_second_layer,
                tessellation: caustics::scene::Tessellation {
                    sphere_segments: tessellation,
                    cylinder_segments: tessellation.saturating_mul(8) / 3,
                },
                base_grid,
                max_error_tolerance,
                quad_linearity,
                error_check_grid,
                error_skip_hopeless: !no_error_skip,
                caustic_map_size: caustic_map.unwrap_or(1024),
                shadow_map_size: shadow_map,
                medium_steps,
                medium_light_steps,
                medium_bounce_grid,
                medium_bounce_steps,
                medium_beyond_specular: !no_medium_beyond_specular,
                env_lights,
                env_taps,
                beams: caustics::settings::BeamSettings { reflection: !no_glass_reflection, ..beams.settings() },
                surface_caustics,
                spill_faces,
                splat_sigma,
                photon_memory: photon_memory.saturating_mul(1 << 20),
                ..Default::default()
            };
            let ctx = match backend {
                Backend::Cpu => None,
                Backend::Gpu => Some(caustics::gpu::GpuContext::new(adapter.as_deref())?),
                Backend::Auto => match caustics::gpu::GpuContext::new(adapter.as_deref()) {
                    Ok(c) => Some(c),
                    Err(e @ Error::Input { .. }) => return Err(e.into()),
                    Err(e) => {
                        eprintln!("notice: {e}");
                        eprintln!("notice: rendering with the CPU reference renderer instead");
                        None
                    }
                },
            };
            println!("scene: {} ({}), {}x{}", scene.name, scene.source, scene.camera.width, scene.camera.height);
            match ctx {
                Some(ctx) => {
                    if caustic_map.is_none() {
                        settings.caustic_map_size = RenderSettings::fitting_caustic_map_size(&ctx, &scene, 1024);
                    }
                    if !caustic_spheres {
                        progress::exit_on_ctrl_c();
                    }
                    let t0 = std::time::Instant::now();
                    let out = match dump.as_deref() {
                        Some(_) if caustic_spheres => {
                            return Err(Error::input(
                                "<command line>",
                                "--dump",
                                "not available with caustic spheres (no light-space caustic maps for directional lights)",
                            )
                            .into());
                        }
                        _ if caustic_spheres => {
                            let tables = spheres::build(&scene, &sphere_args)?;
                            progress::exit_on_ctrl_c();
                            let t0 = std::time::Instant::now();
                            let mut r = caustics::renderer::Renderer::with_context(
                                ctx.clone(),
                                scene.clone(),
                                settings.clone(),
                            )?;
                            r.set_caustic_spheres(
                                tables,
                                caustics::caustic_spheres::Blend::Triangle,
                                sphere_args.half,
                            )?;
                            r.set_caustic_spheres_compiled(sphere_args.sphere_compiled);
                            let out = r.render_once()?;
                            println!(
                                "caustic spheres on the GPU: {:.1} MiB; render {:.1} ms",
                                r.caustic_sphere_bytes() as f64 / (1 << 20) as f64,
                                t0.elapsed().as_secs_f64() * 1e3
                            );
                            out
                        }
                        Some(dir) => {
                            let (out, images) = caustics::render::render_dump(&ctx, &scene, &settings)?;
                            progress::begin_outputs();
                            caustics_reference::dump::write(dir, &images)?;
                            out
                        }
                        None => caustics::render::render(&ctx, &scene, &settings)?,
                    };
                    let wall = t0.elapsed().as_secs_f64() * 1e3;
                    report_gpu(&out, wall);
                    progress::begin_outputs();
                    out.image.write(&output, scene.exposure)?;
                    if let Some(c) = &caustic_output {
                        out.caustic.write(c, scene.exposure)?;
                    }
                }
                None => {
                    if caustic_spheres {
                        eprintln!("notice: the CPU reference renders the exact caustics, not the caustic spheres");
                    }
                    if surface_caustics != caustics::render::SurfaceCaustics::Photons {
                        eprintln!(
                            "notice: the CPU reference renders the exact caustics; --surface-caustics applies to the GPU"
                        );
                    }
                    let rs = caustics_reference::reference::ReferenceSettings {
                        photons_per_light: (photons as u64).pow(2),
                        camera_spp: spp,
                        seed,
                        medium_single_scattering_only: single_scattering,
                        caustic_paths: caustics_reference::reference::CausticPaths::parse(&caustic_paths)
                            .expect("a listed class"),
                        // The caustic maps get a spill face where the GPU's would (at the GPU's
                        // default caustic map size when none is given).
                        spill_faces: scene.lights.iter().any(|l| settings.uses_spill_face(&scene, l)),
                        partial_reflections: !no_partial_reflections,
                        medium_beam_photons: medium_beams,
                        medium_beam_radius,
                        specular_view_photons,
                        specular_view_radius,
                        ..Default::default()
                    };
                    let t0 = std::time::Instant::now();
                    let out = progress::reference_render(&scene, &rs)?;
                    println!("backend: CPU reference, {:.1} s", t0.elapsed().as_secs_f64());
                    println!("{}", out.stats);
                    out.image.write(&output, scene.exposure)?;
                    if let Some(c) = &caustic_output {
                        out.caustic.write(c, scene.exposure)?;
                    }
                }
            }
            println!("wrote {}", output.display());
            Ok(())
        }
    }
}

/// Fail early, before any work, when the output cannot be written.
fn check_output(path: &Path) -> Result<(), Error> {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    if !matches!(ext.as_deref(), Some("png") | Some("exr")) {
        return Err(Error::input(
            "<command line>",
            "--output",
            format!("{}: the output must end in .png or .exr", path.display()),
        ));
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !dir.is_dir() {
        return Err(Error::input(
            "<command line>",
            "--output",
            format!("{}: folder {} does not exist", path.display(), dir.display()),
        ));
    }
    if path.is_dir() {
        return Err(Error::input("<command line>", "--output", format!("{} is a folder", path.display())));
    }
    Ok(())
}

fn report_gpu(out: &GpuRender, wall_ms: f64) {
    println!("adapter: {}", out.adapter);
    let t = &out.technique;
    println!("photons: {} traced in {} batch(es)", out.photons_traced, out.batches);
    for (li, (b, _)) in out.beams.iter().enumerate() {
        println!(
            "beams (light {li}): {} rendered ({} on the residual branch); kept per level {:?}, traced per level {:?}; {} lost at the last level (no corner on a caustic path), {} grazing, {} over capacity, {} cut by the energy cutoff, {} dropped without light",
            b.beams,
            b.residual,
            b.kept_per_level,
            b.visited_per_level,
            b.inconsistent,
            b.grazing,
            b.overflow,
            b.cut,
            b.dark
        );
    }
    println!(
        "technique {}: {} photons splatted, {} relevant (dense {}^2 photons hitting a caster), coverage {:.2} %, photon memory {:.1} MiB (peak {:.1} MiB)",
        t.technique,
        t.photons_splatted,
        t.relevant,
        t.grid,
        100.0 * t.coverage(),
        t.photon_bytes as f64 / (1 << 20) as f64,
        t.peak_photon_bytes as f64 / (1 << 20) as f64
    );
    if t.corners_traced > 0 {
        println!("caustic triangles: {} cell-corner photons traced", t.corners_traced);
    }
    if t.levels.len() > 1 {
        for l in &t.levels {
            println!(
                "  level {:>6}^2: {:>10} cells, {:>10} traced, {:>10} emitted",
                l.grid, l.cells, l.traced, l.emitted
            );
        }
    }
    if out.timings.is_empty() {
        println!("GPU pass timings: unavailable (no timestamp queries on this adapter)");
    } else {
        println!("{:<22} {:>10}", "pass", "GPU ms");
        let mut total = 0.0;
        for (name, ms) in &out.timings {
            println!("{name:<22} {ms:>10.3}");
            total += ms;
        }
        println!("{:<22} {:>10.3}", "total", total);
        let photon_ms: f64 = out.timings.iter().filter(|(n, _)| n.starts_with("photon_")).map(|(_, ms)| ms).sum();
        if photon_ms > 0.0 {
            println!("photons per ms (trace + splat): {:.0}", out.photons_traced as f64 / photon_ms);
        }
    }
    // Watts with four decimals, or four significant digits for small fluxes (a scene in
    // millimetres carries microwatts).
    let w = |x: f64| if x == 0.0 || x.abs() >= 0.01 { format!("{x:.4}") } else { format!("{x:.4e}") };
    for (i, f) in out.flux.iter().enumerate() {
        println!(
            "light {i}: caustic flux {} W onto casters, {} W in the caustic map; lost: {} W no exit, {} W total internal reflection, {} W no receiver, {} W outside the map; {} W in Fresnel branches not traced",
            w(f.emitted),
            w(f.landed),
            w(f.lost_no_exit),
            w(f.lost_tir),
            w(f.lost_no_receiver),
            w(f.lost_outside),
            w(f.untraced_branches)
        );
    }
    println!("frame: {:.1} ms from submission to completion (host clock)", out.frame_wall_ms);
    println!("wall time: {wall_ms:.0} ms");
}

fn info() -> Result<()> {
    let adapters = caustics::gpu::list_adapters();
    if adapters.is_empty() {
        println!(
            "no GPU adapter found. Install a GPU driver or Mesa's software Vulkan driver (apt-get install mesa-vulkan-drivers); `caustics render` falls back to the CPU reference."
        );
    }
    for a in adapters {
        let i = a.get_info();
        let f = a.features();
        let l = a.limits();
        println!("{} ({:?}, {:?}, driver {} {})", i.name, i.backend, i.device_type, i.driver, i.driver_info);
        for (name, feat) in [
            ("timestamp queries", wgpu::Features::TIMESTAMP_QUERY),
            ("timestamps inside passes", wgpu::Features::TIMESTAMP_QUERY_INSIDE_PASSES),
            ("float32 atomics", wgpu::Features::SHADER_FLOAT32_ATOMIC),
            ("int64 atomics (min/max)", wgpu::Features::SHADER_INT64_ATOMIC_MIN_MAX),
            ("subgroups", wgpu::Features::SUBGROUP),
        ] {
            println!("  {name:<26} {}", if f.contains(feat) { "yes" } else { "no" });
        }
        println!("  max texture 2D            {}", l.max_texture_dimension_2d);
        println!("  max storage binding       {} MiB", l.max_storage_buffer_binding_size >> 20);
        println!("  max buffer                {} MiB", l.max_buffer_size >> 20);
    }
    Ok(())
}
