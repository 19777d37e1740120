//! `caustics bench --frames N`: the frame-loop benchmark at tiny sizes writes the four phases
//! with numbers; `caustics bench` on a fog scene times every beam pass (GPU: skipped without an
//! adapter, failed without one in CI).

use std::process::{Command, Output};

/// Runs `caustics bench` with `args`; None (the test skips, printing why) where no GPU adapter
/// exists outside CI; panics without one in CI and where the command fails.
fn bench(what: &str, args: &[&str]) -> Option<Output> {
    let run = Command::new(env!("CARGO_BIN_EXE_caustics")).arg("bench").args(args).output().unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    if !run.status.success() && stderr.contains("no Vulkan, Metal or DX12 adapter") {
        if std::env::var("CI").is_ok_and(|v| v == "true") {
            panic!("CI requires a GPU adapter (install mesa-vulkan-drivers): {stderr}");
        }
        eprintln!("skipping the {what} test: {stderr}");
        return None;
    }
    assert!(run.status.success(), "{stderr}");
    Some(run)
}

#[test]
fn frame_loop_bench_writes_four_phases() {
    let out = std::env::temp_dir().join(format!("caustics-frameloop-{}", std::process::id()));
    let args = ["--frames", "3", "--technique", "basic", "--photons", "64", "--size", "64x48", "--caustic-map", "64"];
    let Some(run) = bench("frame-loop bench", &[&args[..], &["--out", out.to_str().unwrap()]].concat()) else { return };
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(stdout.contains("# Frame loop: glass_sphere"), "{stdout}");
    let js: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("frameloop_glass_sphere.json")).unwrap()).unwrap();
    assert!(out.join("frameloop_glass_sphere.md").exists());
    let runs = js["runs"].as_array().unwrap();
    assert_eq!(runs.len(), 1);
    assert_eq!(runs[0]["technique"], "basic");
    assert_eq!(runs[0]["photon_grid"], 64);
    let phases = runs[0]["phases"].as_object().unwrap();
    for name in ["full", "camera", "light", "object"] {
        let p = &phases[name];
        assert_eq!(p["frames"], 3, "{name}");
        for key in ["frame_ms_median", "frame_ms_p95", "submit_ms_median"] {
            let v = p[key].as_f64().unwrap_or_else(|| panic!("{name}.{key}: {}", p[key]));
            assert!(v.is_finite() && v >= 0.0, "{name}.{key} = {v}");
        }
        assert!(p["first_frame"]["frame_ms"].as_f64().unwrap() > 0.0, "{name}");
        assert!(p["frame_ms_median"].as_f64().unwrap() > 0.0, "{name}");
        assert_eq!(p["created_per_frame"].as_array().unwrap().len(), 2, "{name}");
        assert_eq!(p["frames_after_first"].as_array().unwrap().len(), 2, "{name}");
        let passes = p["pass_ms_median"].as_object().unwrap();
        if js["adapter"].as_str().is_some_and(|a| !a.is_empty()) && !passes.is_empty() {
            assert!(passes.values().all(|v| v.as_f64().is_some_and(|x| x >= 0.0)), "{name}: {passes:?}");
        }
    }
    let _ = std::fs::remove_dir_all(&out);
}

/// The `mesh` phase on the animated pool: its waves move every frame, the BVH is refit on the
/// GPU (a `bvh_refit` time where the adapter has timestamps) and the light is redone.
#[test]
fn frame_loop_mesh_phase_refits_the_waves() {
    let out = std::env::temp_dir().join(format!("caustics-frameloop-mesh-{}", std::process::id()));
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/pool_sun.json");
    let args = [scene, "--frames", "3", "--phases", "mesh", "--technique", "basic", "--photons", "32"];
    let tiny = ["--size", "32x24", "--caustic-map", "64", "--out", out.to_str().unwrap()];
    if bench("mesh-phase bench", &[&args[..], &tiny].concat()).is_none() {
        return;
    }
    let js: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("frameloop_pool_sun.json")).unwrap()).unwrap();
    let p = &js["runs"][0]["phases"]["mesh"];
    assert_eq!(p["frames"], 3, "{p}");
    let passes = p["pass_ms_median"].as_object().unwrap();
    if !passes.is_empty() {
        assert!(passes.get("bvh_refit").and_then(|v| v.as_f64()).is_some_and(|x| x >= 0.0), "{passes:?}");
    }
    let _ = std::fs::remove_dir_all(&out);
}

/// `caustics bench` on a scene with fog: the beam table has a column for every beam pass and,
/// on an adapter with timestamp queries (lavapipe has them), a time for each pass that ran —
/// `beam_shrink` included (it was left out of the table once).
#[test]
fn bench_times_every_beam_pass() {
    let out = std::env::temp_dir().join(format!("caustics-beambench-{}", std::process::id()));
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/volume_caustic_fog.json");
    let args = [scene, "--technique", "basic", "--photons", "64", "--size", "24x16", "--caustic-map", "64"];
    let beams = ["--beam-grid", "8", "--beam-levels", "1", "--set", "sources.local=beams"];
    if bench("beam bench", &[&args[..], &beams, &["--out", out.to_str().unwrap()]].concat()).is_none() {
        return;
    }
    let md = std::fs::read_to_string(out.join("bench_volume_caustic_fog.md")).unwrap();
    let lines: Vec<&str> = md.lines().skip_while(|l| !l.starts_with("## Volume caustics (beams)")).collect();
    let head = lines.iter().find(|l| l.starts_with("| run |")).unwrap_or_else(|| panic!("no beam table:\n{md}"));
    let row = lines.iter().find(|l| l.starts_with("| basic")).unwrap_or_else(|| panic!("no beam row:\n{md}"));
    let cols: Vec<&str> = head.split('|').map(str::trim).collect();
    let vals: Vec<&str> = row.split('|').map(str::trim).collect();
    assert_eq!(cols.len(), vals.len(), "{head}\n{row}");
    // (an adapter without timestamp queries: "-" everywhere)
    let timed = vals[cols.iter().position(|c| *c == "beam_refine ms").unwrap()] != "-";
    for pass in ["beam_refine", "beam_shrink", "beam_order", "beam_surface_raster", "beam_hull", "beam_raster"] {
        let k =
            cols.iter().position(|c| *c == format!("{pass} ms")).unwrap_or_else(|| panic!("no {pass} column: {head}"));
        if timed {
            let ms: f64 = vals[k].parse().unwrap_or_else(|_| panic!("{pass}: {:?} in {row}", vals[k]));
            assert!(ms.is_finite() && ms >= 0.0, "{pass} {ms}");
        }
    }
    let beams: u32 = vals[cols.iter().position(|c| *c == "beams").unwrap()].parse().unwrap();
    assert!(beams > 0, "{row}");
    std::fs::remove_dir_all(&out).ok();
}
