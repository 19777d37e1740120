//! The technique benchmark's report: the table of Wyman & Nichols 2009's Table 1 and more, as
//! markdown and JSON, with the caustic maps' distance (HDR-FLIP) from the densest one.

use super::{BenchArgs, Run, is_photon_pass};
use caustics::image_io::Image;
use caustics::render::GpuRender;
use caustics::settings::Technique;
use serde_json::{Value, json};
use std::fmt::Write as _;

fn find(runs: &[Run], t: Technique, n: u32) -> Option<&Run> {
    runs.iter().find(|r| r.technique == t && r.n == n)
}

/// Mean HDR-FLIP between two caustic maps (all lights and faces, concatenated).
fn map_flip(a: &GpuRender, b: &GpuRender) -> Option<f64> {
    let cat = |r: &GpuRender| -> Option<Image> {
        let maps: Vec<&Image> = r.caustic_maps.iter().flatten().collect();
        let w = maps.first()?.width;
        let mut img = Image::new(w, w * maps.len() as u32);
        for (k, m) in maps.iter().enumerate() {
            img.pixels[k * (w * w) as usize..(k + 1) * (w * w) as usize].copy_from_slice(&m.pixels);
        }
        Some(img)
    };
    caustics_reference::metrics::hdr_flip(&cat(a)?, &cat(b)?, None).ok().map(|f| f.mean)
}

fn mib(b: u64) -> String {
    format!("{:.2}", b as f64 / (1 << 20) as f64)
}

pub(super) fn markdown(
    scene: &str,
    adapter: &str,
    a: &BenchArgs,
    grids: &[u32],
    techniques: &[Technique],
    runs: &[Run],
    skipped: &[(Technique, u32, String)],
) -> String {
    let mut s = String::new();
    let coverage = runs.first().map_or(0.0, |r| r.out.technique.coverage());
    let _ = writeln!(s, "# Photon emission techniques: {scene}\n");
    let _ = writeln!(
        s,
        "Adapter: {adapter}. Caustic map {0}x{0}, photon memory {1} MiB, base grid {2}, splat {7}, tracer {9}, max-error tolerance {3} texels (0: one texel){8}, camera {4}x{5}. Coverage (casters in the light's view): **{6:.2} %**.\n",
        a.base.photons.caustic_map_size,
        a.base.photons.memory >> 20,
        a.base.adaptive.base_grid,
        a.base.adaptive.error_tolerance,
        a.size.0,
        a.size.1,
        100.0 * coverage,
        a.base.photons.splat,
        if !a.base.testing.error_skip_hopeless {
            ", every level checked (the paper's traversal)"
        } else {
            ", hopeless check levels skipped"
        },
        a.base.photons.tracer,
    );
    let _ = writeln!(s, "## Photons splatted (Table 1 of Wyman & Nichols 2009)\n");
    let mut head = String::from("| photon grid | relevant |");
    let mut rule = String::from("| ---: | ---: |");
    for t in techniques {
        let _ = write!(head, " {t} |");
        rule.push_str(" ---: |");
    }
    for t in techniques.iter().filter(|t| !matches!(t, Technique::Photons(caustics::settings::Emission::Basic))) {
        let _ = write!(head, " {t} / relevant |");
        rule.push_str(" ---: |");
    }
    let _ = writeln!(s, "{head}\n{rule}");
    for &n in grids {
        let relevant = runs.iter().find(|r| r.n == n).map(|r| r.out.technique.relevant);
        let _ = write!(s, "| {n}² | {} |", relevant.map_or("-".into(), |v| v.to_string()));
        for &t in techniques {
            let _ = write!(
                s,
                " {} |",
                find(runs, t, n).map_or("N/A".into(), |r| r.out.technique.photons_splatted.to_string())
            );
        }
        for &t in techniques.iter().filter(|t| !matches!(t, Technique::Photons(caustics::settings::Emission::Basic))) {
            let v = find(runs, t, n).and_then(|r| {
                let rel = r.out.technique.relevant;
                (rel > 0).then(|| format!("{:.3}", r.out.technique.photons_splatted as f64 / rel as f64))
            });
            let _ = write!(s, " {} |", v.unwrap_or("N/A".into()));
        }
        s.push('\n');
    }
    let _ = writeln!(
        s,
        "\n## Work, time and memory\n\nTraced: photons traced (with caustic triangles over the adaptive hierarchy, + the cell-corner photons traced for the quads). Evaluated: cells kept over all levels of the hierarchy plus photons traced below the last level (adaptive), or cells plus photons splatted (hierarchical); divided by the relevant photons. Photon GPU ms: coverage mip, tracing, traversal and splat (timestamp queries); speed-up: basic's photon GPU ms at the same grid over this technique's. Frame ms: host wall-clock from the frame's submission to its completion (all GPU work of the frame, no recording, pipeline builds or read-back); frame speed-up: basic's frame ms over this technique's. Where pass timestamps miss work (lavapipe: the basic technique's splat escapes its own, see docs/benchmarks.md), compare the frame columns. Wall ms: the whole render call.\n"
    );
    let _ = writeln!(
        s,
        "| photon grid | technique | traced | evaluated / relevant | photon GPU ms | speed-up vs basic | frame GPU ms | frame ms | frame speed-up vs basic | wall ms | photon memory MiB | peak used MiB | batches | FLIP vs dense |"
    );
    let _ = writeln!(
        s,
        "| ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"
    );
    for &n in grids {
        for &t in techniques {
            let Some(r) = find(runs, t, n) else { continue };
            let ts = &r.out.technique;
            let basic = find(runs, Technique::Photons(caustics::settings::Emission::Basic), n);
            let speed = basic.map_or("-".into(), |b| format!("{:.2}", b.photon_ms / r.photon_ms.max(1e-9)));
            let frame_speed =
                basic.map_or("-".into(), |b| format!("{:.2}", b.frame_wall_ms / r.frame_wall_ms.max(1e-9)));
            let dense = basic.or_else(|| {
                find(runs, Technique::Photons(caustics::settings::Emission::AdaptiveLevel), n)
                    .filter(|_| t != Technique::Photons(caustics::settings::Emission::AdaptiveLevel))
            });
            let flip = match dense {
                Some(d) if !std::ptr::eq(d, r) => map_flip(&r.out, &d.out).map_or("-".into(), |f| format!("{f:.4}")),
                _ => "-".into(),
            };
            let eval = if ts.relevant > 0 && t != Technique::Photons(caustics::settings::Emission::Basic) {
                format!("{:.3}", ts.evaluated as f64 / ts.relevant as f64)
            } else {
                "-".into()
            };
            let traced = if ts.corners_traced > 0 {
                format!("{} (+{} corners)", ts.photons_traced, ts.corners_traced)
            } else {
                ts.photons_traced.to_string()
            };
            let _ = writeln!(
                s,
                "| {n}² | {t} | {traced} | {eval} | {:.1} | {speed} | {:.1} | {:.1} | {frame_speed} | {:.0} | {} | {} | {} | {flip} |",
                r.photon_ms,
                r.frame_ms,
                r.frame_wall_ms,
                r.wall_ms,
                mib(ts.photon_bytes),
                mib(ts.peak_photon_bytes),
                ts.batches
            );
        }
    }
    let _ = writeln!(
        s,
        "\nFLIP vs dense: mean HDR-FLIP of the caustic map against basic caustic maps at the same grid (against adaptive-level where basic cannot run).\n"
    );
    let _ = writeln!(s, "## GPU milliseconds per pass\n");
    let mut passes: Vec<String> = Vec::new();
    for r in runs {
        for (p, _) in &r.out.timings {
            if is_photon_pass(p) && !passes.contains(p) {
                passes.push(p.clone());
            }
        }
    }
    let _ = writeln!(s, "| photon grid | technique | {} |", passes.join(" | "));
    let _ = writeln!(s, "| ---: | --- |{}", " ---: |".repeat(passes.len()));
    for r in runs {
        let cells: Vec<String> = passes
            .iter()
            .map(|p| r.out.timings.iter().find(|(q, _)| q == p).map_or("-".into(), |(_, ms)| format!("{ms:.1}")))
            .collect();
        let _ = writeln!(s, "| {}² | {} | {} |", r.n, r.technique, cells.join(" | "));
    }
    let _ = writeln!(s, "\n## Photons per level (adaptive)\n");
    let _ = writeln!(s, "| photon grid | technique | level grid | cells kept | photons traced | photons emitted |");
    let _ = writeln!(s, "| ---: | --- | ---: | ---: | ---: | ---: |");
    for r in runs.iter().filter(|r| r.technique.emission().is_adaptive()) {
        for l in &r.out.technique.levels {
            let _ = writeln!(
                s,
                "| {}² | {} | {}² | {} | {} | {} |",
                r.n, r.technique, l.grid, l.cells, l.traced, l.emitted
            );
        }
    }
    if !skipped.is_empty() {
        let _ = writeln!(s, "\nNot run:\n");
        for (t, n, why) in skipped {
            let _ = writeln!(s, "- {t} at {n}²: {why}");
        }
    }
    s
}

pub(super) fn to_json(
    scene: &str,
    adapter: &str,
    a: &BenchArgs,
    runs: &[Run],
    skipped: &[(Technique, u32, String)],
) -> Value {
    let rows: Vec<Value> = runs
        .iter()
        .map(|r| {
            let ts = &r.out.technique;
            let basic = find(runs, Technique::Photons(caustics::settings::Emission::Basic), r.n).filter(|b| !std::ptr::eq(*b, r));
            json!({
                "technique": r.technique.name(),
                "photon_grid": r.n,
                "photons_splatted": ts.photons_splatted,
                "photons_traced": ts.photons_traced,
                "corners_traced": ts.corners_traced,
                "relevant": ts.relevant,
                "evaluated": ts.evaluated,
                "coverage": ts.coverage(),
                "photon_gpu_ms": r.photon_ms,
                "frame_gpu_ms": r.frame_ms,
                "frame_wall_ms": r.frame_wall_ms,
                "wall_ms": r.wall_ms,
                "speedup_vs_basic": basic.map(|b| b.photon_ms / r.photon_ms.max(1e-9)),
                "frame_speedup_vs_basic": basic.map(|b| b.frame_wall_ms / r.frame_wall_ms.max(1e-9)),
                "flip_vs_basic": basic.and_then(|b| map_flip(&r.out, &b.out)),
                "photon_bytes": ts.photon_bytes,
                "peak_photon_bytes": ts.peak_photon_bytes,
                "batches": ts.batches,
                "flux_landed_w": r.out.flux.iter().map(|f| f.landed).sum::<f64>(),
                "passes_ms": r.out.timings.iter().map(|(p, ms)| (p.clone(), json!(ms))).collect::<serde_json::Map<_, _>>(),
                "levels": ts.levels.iter().map(|l| json!({"grid": l.grid, "cells": l.cells, "traced": l.traced, "emitted": l.emitted})).collect::<Vec<_>>(),
            })
        })
        .collect();
    json!({
        "scene": scene,
        "adapter": adapter,
        "caustic_map": a.base.photons.caustic_map_size,
        "photon_memory_mib": a.base.photons.memory >> 20,
        "base_grid": a.base.adaptive.base_grid,
        "max_error_tolerance": a.base.adaptive.error_tolerance,
        "error_skip_hopeless": a.base.testing.error_skip_hopeless,
        "runs": rows,
        "not_run": skipped.iter().map(|(t, n, why)| json!({"technique": t.name(), "photon_grid": n, "why": why})).collect::<Vec<_>>(),
    })
}
