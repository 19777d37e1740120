//! Caustic spheres on the command line: `caustics precompute SCENE` builds the caches ahead of
//! time, `caustics render --technique caustic-spheres` (and `bench`, `view`) loads (or builds)
//! them and renders directional lights' caustics from them. Tables are built on the GPU
//! (`caustics::caustic_spheres::build`) unless `precompute --on cpu` asks for the CPU
//! reference's precomputation; both write the same cache files. The precomputation shows a
//! progress bar (indicatif) and Ctrl-C cancels it cleanly (no cache file written).

use caustics::Scene;
use caustics::caustic_spheres::cache::{self, Storage};
use caustics::caustic_spheres::{CausticSpheres, DirectionLayout, SphereSettings};
use caustics::gpu::GpuContext;
use caustics_reference::reference::Progress;
use caustics_reference::reference::spheres::{Origin, precompute};
use std::path::PathBuf;
use std::sync::Arc;

/// Where `precompute` builds the tables.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum On {
    // The exact GPU tracer (`caustics::caustic_spheres::build`).
    #[default]
    Gpu,
    // The CPU reference (all cores), the GPU builder's check.
    Cpu,
}

/// The builder of tables not found in the cache.
#[derive(Clone, Copy)]
pub enum Builder<'a> {
    Gpu(&'a GpuContext),
    Cpu,
}

/// The caustic spheres' tables: `precompute`'s flags, and the `spheres` section of the other
/// commands' settings (`--set spheres.directions=9`).
#[derive(clap::Args, Debug, Clone, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SphereArgs {
    /// Caustic spheres: side N of the octahedral grid of precomputed light directions (odd, 3
    /// to 33; (N-1)^2 + 2 directions).
    #[arg(long, default_value_t = 7)]
    pub directions: u32,
    /// Caustic spheres: concentric spheres per object (radii by the paper's equation (1)).
    #[serde(rename = "count")]
    #[arg(long, default_value_t = 16)]
    pub spheres: u32,
    /// Caustic spheres: longitudes x latitudes per sphere.
    #[serde(rename = "size")]
    #[arg(long, default_value = "64x48", value_parser = crate::parse_size)]
    pub sphere_size: (u32, u32),
    /// Caustic spheres: photons traced per precomputed direction.
    #[serde(rename = "photons")]
    #[arg(long, default_value_t = 1 << 18)]
    pub sphere_photons: u64,
    /// Caustic spheres: store the tables as half floats (half the disk and memory).
    #[arg(long)]
    pub half: bool,
    /// Caustic spheres: the cache folder.
    #[serde(rename = "cache")]
    #[arg(long, default_value = ".caustics-cache")]
    pub sphere_cache: PathBuf,
    /// Caustic spheres: the compiled variant (every light summed into one table per object
    /// each frame, then one lookup per object and pixel) instead of a lookup per light.
    #[serde(rename = "compiled")]
    #[arg(long)]
    pub sphere_compiled: bool,
}

impl Default for SphereArgs {
    /// The command line's defaults (the viewer's tests make sessions without one).
    fn default() -> Self {
        SphereArgs {
            directions: 7,
            spheres: 16,
            sphere_size: (64, 48),
            sphere_photons: 1 << 18,
            half: false,
            sphere_cache: PathBuf::from(".caustics-cache"),
            sphere_compiled: false,
        }
    }
}

impl SphereArgs {
    pub fn settings(&self) -> SphereSettings {
        SphereSettings {
            directions: self.directions,
            spheres: self.spheres,
            width: self.sphere_size.0,
            height: self.sphere_size.1,
            photons: self.sphere_photons,
            max_depth: 16,
        }
    }
}

/// The caustic spheres of object `object`: read from the cache in `dir` when a file for the
/// same object, material and settings is there and intact, else built by `builder` and written
/// there (atomically). `storage` chooses f32 or half floats on disk. (The reference's
/// `load_or_precompute`, with either builder.)
fn load_or_build(
    scene: &Scene,
    object: usize,
    settings: &SphereSettings,
    (storage, dir): (Storage, &std::path::Path),
    builder: Builder,
    progress: &Progress,
) -> caustics::Result<(CausticSpheres, Origin)> {
    let Some(o) = scene.objects.get(object) else {
        return Err(caustics::Error::input(&scene.source, "objects", format!("no object {object}")));
    };
    let key = cache::key(scene, o, settings);
    let path = cache::path(dir, key, storage);
    let reason = match std::fs::read(&path) {
        Ok(bytes) => match cache::decode(&bytes, key, settings) {
            Ok((sp, _)) => return Ok((sp, Origin::Cache)),
            Err(e) => format!("{}: {e}", path.display()),
        },
        Err(e) => format!("{}: {e}", path.display()),
    };
    let sp = match builder {
        Builder::Cpu => precompute(scene, object, settings, None, progress)?,
        Builder::Gpu(ctx) => caustics::caustic_spheres::build_with(ctx, scene, object, settings, None, &mut |d, t| {
            progress.report(d, t);
            !progress.is_cancelled()
        })?,
    };
    let bytes = cache::encode(&sp, key, storage);
    cache::write(&path, &bytes)?;
    // What the renderer uses is what a later run reads back (half floats included).
    let (sp, _) = cache::decode(&bytes, key, settings).map_err(|e| caustics::Error::Output {
        path: path.clone(),
        message: format!("cache does not read back: {e}"),
    })?;
    Ok((sp, Origin::Built(reason)))
}

/// The caustic spheres of every caustic object of `scene`: from the cache, or built by
/// `builder` with a progress bar and cached. Reports what it did and the memory per object.
pub fn build(
    scene: &Scene,
    args: &SphereArgs,
    builder: Builder,
) -> caustics::Result<Vec<(usize, Arc<CausticSpheres>)>> {
    let settings = args.settings();
    settings.validate()?;
    let storage = if args.half { Storage::F16 } else { Storage::F32 };
    let progress = Arc::new(Progress::new());
    {
        let p = progress.clone();
        let _ = ctrlc::set_handler(move || p.cancel());
    }
    let dirs = DirectionLayout::new(settings.directions).dirs.len();
    let mut out = Vec::new();
    for (oi, o) in scene.objects.iter().enumerate() {
        if !o.caustic_caster || !scene.material_of(o).is_specular() {
            continue;
        }
        let t0 = std::time::Instant::now();
        let result = crate::progress::with_bar(&format!("caustic spheres, object {oi}"), &progress, || {
            load_or_build(scene, oi, &settings, (storage, &args.sphere_cache), builder, &progress)
        });
        let (sp, origin) = result?;
        let mib = |b: u64| b as f64 / (1 << 20) as f64;
        let bytes = if args.half { sp.bytes() / 2 } else { sp.bytes() };
        match origin {
            Origin::Cache => println!("caustic spheres, object {oi}: read from the cache"),
            Origin::Built(why) => println!(
                "caustic spheres, object {oi}: precomputed on the {} in {:.1} s ({dirs} directions x {} photons; no usable cache: {why})",
                if matches!(builder, Builder::Cpu) { "CPU" } else { "GPU" },
                t0.elapsed().as_secs_f64(),
                settings.photons
            ),
        }
        println!(
            "caustic spheres, object {oi}: {} spheres of {}x{} cells, radii {:.4} to {:.4} m; {:.1} MiB on disk ({}), {:.1} MiB on the GPU (f32)",
            settings.spheres,
            settings.width,
            settings.height,
            sp.geometry.radii[0],
            sp.geometry.radii[settings.spheres as usize - 1],
            mib(bytes),
            if args.half { "f16" } else { "f32" },
            mib(sp.bytes())
        );
        out.push((oi, Arc::new(sp)));
    }
    Ok(out)
}

/// With `Technique::CausticSpheres`, sets the caustic spheres of `scene`'s caustic objects on
/// `r` (from `tables`, loaded or built on first use and kept for later calls); otherwise does
/// nothing.
pub fn attach(
    r: &mut caustics::renderer::Renderer,
    scene: &Scene,
    args: &SphereArgs,
    tables: &mut Option<Vec<(usize, Arc<CausticSpheres>)>>,
) -> caustics::Result<()> {
    if !r.settings().caustic_spheres() {
        return Ok(());
    }
    let t = match tables {
        Some(t) => t.clone(),
        None => tables.insert(build(scene, args, Builder::Gpu(r.context()))?).clone(),
    };
    r.set_caustic_spheres(t, caustics::caustic_spheres::Blend::Triangle, args.half)?;
    r.set_caustic_spheres_compiled(args.sphere_compiled);
    Ok(())
}
