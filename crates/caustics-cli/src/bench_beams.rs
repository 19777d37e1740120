//! The beams' part of `caustics bench` (scenes with a medium, or `--set sources.local=beams`):
//! per run, the beams kept per refinement level, the fragments their hulls shaded
//! (`beams.volume` hulls) and the GPU milliseconds of each beam pass (`beam_refine` summed over
//! its levels, `beam_shrink` (the parts of last-level triangles), `beam_order` with its
//! `beam_order_runs`, `beam_gather` and `beam_surface` summed over their chunks,
//! `beam_surface_raster` (the surface caustic's hulls), `beam_hull`, `beam_raster` and
//! `beam_resolve`; timestamp queries, "-" where the adapter has
//! none or the pass did not run). Its own module so that the photon tables of `bench.rs` stay
//! as they are.

use caustics::output::GpuRender;
use std::fmt::Write;

/// The beam passes, in the order they run.
const PASSES: [&str; 9] = [
    "beam_refine",
    "beam_shrink",
    "beam_order",
    "beam_gather",
    "beam_surface",
    "beam_surface_raster",
    "beam_hull",
    "beam_raster",
    "beam_resolve",
];

/// GPU ms of a beam pass in a render (all its dispatches), if it was timed.
fn pass_ms(out: &GpuRender, pass: &str) -> Option<f64> {
    let v: Vec<f64> = out.timings.iter().filter(|(p, _)| p == pass).map(|(_, ms)| *ms).collect();
    (!v.is_empty()).then(|| v.iter().sum())
}

/// A markdown table of the runs (label, render) that rendered beams; empty when none did.
pub fn markdown<'a>(runs: impl Iterator<Item = (String, &'a GpuRender)>) -> String {
    let mut s = String::new();
    for (label, out) in runs {
        for (li, (stats, _)) in out.beams.iter().enumerate() {
            if s.is_empty() {
                let heads: Vec<String> = PASSES.iter().map(|p| format!(" {p} ms |")).collect();
                let _ = writeln!(
                    s,
                    "\n## Volume caustics (beams)\n\nBeams kept per refinement level (all branches), beams rendered, beams the energy cutoff shortened or dropped (`beams.cutoff`), fragments their hulls shaded (`beams.volume` hulls) and those of them that added light, and GPU ms per beam pass (timestamp queries; \"-\": not timed or not run).\n\n| run | light | kept per level | beams | cut | hull fragments | of them lit |{}\n| --- | ---: | --- | ---: | ---: | ---: | ---: |{}",
                    heads.concat(),
                    " ---: |".repeat(PASSES.len())
                );
            }
            let levels: Vec<String> = stats.kept_per_level.iter().map(u32::to_string).collect();
            let ms: Vec<String> =
                PASSES.iter().map(|p| pass_ms(out, p).map_or(" - |".into(), |v| format!(" {v:.2} |"))).collect();
            let _ = writeln!(
                s,
                "| {label} | {li} | {} | {} | {} | {} | {} |{}",
                levels.join(" / "),
                stats.beams,
                stats.cut,
                stats.hull_fragments,
                stats.hull_lit_fragments,
                ms.concat()
            );
        }
    }
    s
}
