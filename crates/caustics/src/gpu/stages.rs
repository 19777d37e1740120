//! The WGSL stages and shared modules, the `#import` preprocessor that assembles a stage's
//! source, naga validation, and the pipeline build logging.

use crate::error::{Error, Result};

/// Every WGSL stage, with its source. Each is prepended with `shaders/shared/common.wgsl`.
pub const STAGES: &[(&str, &str)] = &[
    ("raster", include_str!("../../shaders/raster.wgsl")),
    ("raster_peel", include_str!("../../shaders/raster_peel.wgsl")),
    ("photon_trace", include_str!("../../shaders/photon_trace.wgsl")),
    ("photon_splat", include_str!("../../shaders/photon_splat.wgsl")),
    ("caustic_resolve", include_str!("../../shaders/caustic_resolve.wgsl")),
    ("temporal_filter", include_str!("../../shaders/temporal_filter.wgsl")),
    ("shade_receivers", include_str!("../../shaders/shade_receivers.wgsl")),
    ("caustic_mask", include_str!("../../shaders/caustic_mask.wgsl")),
    ("shadow_tiles", include_str!("../../shaders/shadow_tiles.wgsl")),
    ("sphere_gather", include_str!("../../shaders/sphere_gather.wgsl")),
    ("sphere_compile", include_str!("../../shaders/sphere_compile.wgsl")),
    ("sphere_volume", include_str!("../../shaders/sphere_volume.wgsl")),
    ("sphere_visibility", include_str!("../../shaders/sphere_visibility.wgsl")),
    ("sphere_visibility_sum", include_str!("../../shaders/sphere_visibility_sum.wgsl")),
    ("sphere_weights", include_str!("../../shaders/sphere_weights.wgsl")),
    ("sphere_trace", include_str!("../../shaders/sphere_trace.wgsl")),
    ("composite", include_str!("../../shaders/composite.wgsl")),
    ("medium_scatter", include_str!("../../shaders/medium_scatter.wgsl")),
    ("coverage_mip", include_str!("../../shaders/coverage_mip.wgsl")),
    ("adaptive_plan", include_str!("../../shaders/adaptive_plan.wgsl")),
    ("adaptive_init", include_str!("../../shaders/adaptive_init.wgsl")),
    ("adaptive_setup", include_str!("../../shaders/adaptive_setup.wgsl")),
    ("adaptive_refine", include_str!("../../shaders/adaptive_refine.wgsl")),
    ("hcm_traverse", include_str!("../../shaders/hcm_traverse.wgsl")),
    ("splat_lens", include_str!("../../shaders/splat_lens.wgsl")),
    ("splat_multires", include_str!("../../shaders/splat_multires.wgsl")),
    ("splat_multires_blend", include_str!("../../shaders/splat_multires_blend.wgsl")),
    ("caustic_triangles", include_str!("../../shaders/caustic_triangles.wgsl")),
    ("splat_quads", include_str!("../../shaders/splat_quads.wgsl")),
    ("display", include_str!("../../shaders/display.wgsl")),
    ("ray_query", include_str!("../../shaders/ray_query.wgsl")),
    ("medium_bounce_lights", include_str!("../../shaders/medium_bounce_lights.wgsl")),
    ("medium_bounce", include_str!("../../shaders/medium_bounce.wgsl")),
    ("medium_bounce_beams", include_str!("../../shaders/medium_bounce_beams.wgsl")),
    ("medium_bounce_glow", include_str!("../../shaders/medium_bounce_glow.wgsl")),
    ("medium_bounce_shafts", include_str!("../../shaders/medium_bounce_shafts.wgsl")),
    ("medium_bounce_surfaces", include_str!("../../shaders/medium_bounce_surfaces.wgsl")),
    ("medium_ms_trace", include_str!("../../shaders/medium_ms_trace.wgsl")),
    ("medium_ms_resolve", include_str!("../../shaders/medium_ms_resolve.wgsl")),
    ("medium_ms_view", include_str!("../../shaders/medium_ms_view.wgsl")),
    ("indirect_trace", include_str!("../../shaders/indirect_trace.wgsl")),
    ("indirect_resolve", include_str!("../../shaders/indirect_resolve.wgsl")),
    ("indirect_blend", include_str!("../../shaders/indirect_blend.wgsl")),
    ("indirect_gather", include_str!("../../shaders/indirect_gather.wgsl")),
    ("beam_refine", include_str!("../../shaders/beam_refine.wgsl")),
    ("beam_shrink", include_str!("../../shaders/beam_shrink.wgsl")),
    ("beam_order", include_str!("../../shaders/beam_order.wgsl")),
    ("beam_order_runs", include_str!("../../shaders/beam_order_runs.wgsl")),
    ("beam_gather", include_str!("../../shaders/beam_gather.wgsl")),
    ("beam_surface", include_str!("../../shaders/beam_surface.wgsl")),
    ("beam_hull", include_str!("../../shaders/beam_hull.wgsl")),
    ("beam_raster", include_str!("../../shaders/beam_raster.wgsl")),
    ("beam_surface_raster", include_str!("../../shaders/beam_surface_raster.wgsl")),
    ("beam_resolve", include_str!("../../shaders/beam_resolve.wgsl")),
    ("bvh_refit", include_str!("../../shaders/bvh_refit.wgsl")),
];
/// Shared WGSL every stage begins with (`shaders/shared/common.wgsl`): the structs the host
/// writes, optics, light-space projection and fixed-point helpers.
pub const COMMON_WGSL: &str = include_str!("../../shaders/shared/common.wgsl");

/// Shared WGSL modules a stage can pull in with a line `#import NAME`.
pub const SHARED: &[(&str, &str)] = &[
    ("shapes", include_str!("../../shaders/shared/shapes.wgsl")),
    ("raster_common", include_str!("../../shaders/shared/raster_common.wgsl")),
    ("raytrace", include_str!("../../shaders/shared/raytrace.wgsl")),
    ("trace", include_str!("../../shaders/shared/trace.wgsl")),
    ("hierarchy", include_str!("../../shaders/shared/hierarchy.wgsl")),
    ("coverage", include_str!("../../shaders/shared/coverage.wgsl")),
    ("splat", include_str!("../../shaders/shared/splat.wgsl")),
    ("splat_photons", include_str!("../../shaders/shared/splat_photons.wgsl")),
    ("triangles", include_str!("../../shaders/shared/triangles.wgsl")),
    ("environment", include_str!("../../shaders/shared/environment.wgsl")),
    ("medium", include_str!("../../shaders/shared/medium.wgsl")),
    ("medium_bounce", include_str!("../../shaders/shared/medium_bounce.wgsl")),
    ("medium_emit", include_str!("../../shaders/shared/medium_emit.wgsl")),
    ("medium_multiple", include_str!("../../shaders/shared/medium_multiple.wgsl")),
    ("photon_walk", include_str!("../../shaders/shared/photon_walk.wgsl")),
    ("indirect", include_str!("../../shaders/shared/indirect.wgsl")),
    ("beams", include_str!("../../shaders/shared/beams.wgsl")),
    ("beam_medium", include_str!("../../shaders/shared/beam_medium.wgsl")),
    ("beam_trace", include_str!("../../shaders/shared/beam_trace.wgsl")),
    ("beam_scatter", include_str!("../../shaders/shared/beam_scatter.wgsl")),
    ("beam_receive", include_str!("../../shaders/shared/beam_receive.wgsl")),
    ("beam_fan", include_str!("../../shaders/shared/beam_fan.wgsl")),
    ("sphere_table", include_str!("../../shaders/shared/sphere_table.wgsl")),
    ("scene", include_str!("../../shaders/shared/scene.wgsl")),
];

/// Build a pipeline with `make`; with the environment variable `CAUSTICS_LOG_PIPELINES` set,
/// say on stderr which pipeline is being built before the driver compiles it and how long that
/// took after, so that a driver whose shader compiler stalls on one stage names it (a device's
/// compiler runs inside `create_*_pipeline`, on the calling thread, before any GPU work).
pub(super) fn logged_build<T>(kind: &str, name: &str, make: impl FnOnce() -> T) -> T {
    if std::env::var_os("CAUSTICS_LOG_PIPELINES").is_none() {
        return make();
    }
    eprintln!("pipeline {kind} {name}: building");
    let t0 = std::time::Instant::now();
    let p = make();
    eprintln!("pipeline {kind} {name}: {:.1} ms", t0.elapsed().as_secs_f64() * 1e3);
    p
}

/// Full source of a stage: the shared code, then the stage with its `#import` lines replaced by
/// the modules they name (a tiny preprocessor, as vello does; WGSL has no includes).
pub fn stage_source(name: &str) -> String {
    let src =
        STAGES.iter().find(|(n, _)| *n == name).map(|(_, s)| *s).unwrap_or_else(|| panic!("no shader stage {name}"));
    let mut out = String::from(COMMON_WGSL);
    out.push('\n');
    for line in src.lines() {
        match line.trim().strip_prefix("#import ") {
            Some(module) => {
                let m = SHARED
                    .iter()
                    .find(|(n, _)| *n == module.trim())
                    .unwrap_or_else(|| panic!("{name}: no shared module {module}"));
                out.push_str(m.1);
            }
            None => out.push_str(line),
        }
        out.push('\n');
    }
    out
}

/// Validate a stage with naga (the tests do this for every stage).
pub fn validate_stage(name: &str) -> Result<naga::Module> {
    parse_stage(name).map(|(module, _)| module)
}

/// Stage `name` parsed and validated by naga, with what each function uses.
pub(super) fn parse_stage(name: &str) -> Result<(naga::Module, naga::valid::ModuleInfo)> {
    parse_source(name, &stage_source(name))
}

/// WGSL `src` (named `name` in errors) parsed and validated by naga.
pub(super) fn parse_source(name: &str, src: &str) -> Result<(naga::Module, naga::valid::ModuleInfo)> {
    let module = naga::front::wgsl::parse_str(src)
        .map_err(|e| Error::Shader { name: name.into(), message: e.emit_to_string(src) })?;
    let info = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
        .validate(&module)
        .map_err(|e| Error::Shader { name: name.into(), message: format!("{e:?}") })?;
    Ok((module, info))
}
