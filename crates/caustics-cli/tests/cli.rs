//! The command line: exit codes, error messages naming file and field, no half-written output.

use std::path::PathBuf;
use std::process::Command;

fn caustics() -> Command {
    Command::new(env!("CARGO_BIN_EXE_caustics"))
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("caustics-cli-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

fn run_err(args: &[&str]) -> String {
    let out = caustics().args(args).output().unwrap();
    assert_eq!(out.status.code(), Some(2), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stderr).to_string()
}

#[test]
fn bad_scene_file_exits_2_and_names_it() {
    let bad = tmp("bad.json");
    std::fs::write(&bad, "{ \"schema_version\": 1,\n \"name\": 3 }").unwrap();
    let out = tmp("never.png");
    let e = run_err(&["render", bad.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert!(e.contains("bad.json") && e.contains("line 2"), "{e}");
    assert!(!out.exists(), "an output file was written for a bad scene");
    let e = run_err(&["render", "/nonexistent/scene.json"]);
    assert!(e.contains("/nonexistent/scene.json"), "{e}");
}

#[test]
fn bad_gltf_and_camera_choice_exit_2_and_name_them() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let good = std::fs::read(root.join("scenes/gltf/glass_ball.glb")).unwrap();
    let bad = tmp("bad.glb");
    std::fs::write(&bad, &good[..good.len() / 3]).unwrap();
    let out = tmp("never_gltf.png");
    let e = run_err(&["render", bad.to_str().unwrap(), "-o", out.to_str().unwrap(), "--backend", "cpu"]);
    assert!(e.contains("bad.glb") && e.contains("GLB"), "{e}");
    assert!(!out.exists(), "an output file was written for a bad scene");
    let glb = root.join("scenes/gltf/glass_ball.glb");
    let e =
        run_err(&["render", glb.to_str().unwrap(), "--camera", "7", "-o", out.to_str().unwrap(), "--backend", "cpu"]);
    assert!(e.contains("--camera") && e.contains("0 main"), "{e}");
    let e = run_err(&["render", "--camera", "main", "--backend", "cpu"]);
    assert!(e.contains("--camera"), "{e}");
}

#[test]
fn bad_environment_map_exits_2_and_names_it() {
    let scene = tmp("env_scene.json");
    let map = tmp("not_a_map.exr");
    std::fs::write(&map, "not an image").unwrap();
    std::fs::write(
        &scene,
        r#"{ "schema_version": 1, "name": "env",
          "camera": { "position": [0, 1, 3], "look_at": [0, 0, 0], "fov_y_deg": 40, "width": 8, "height": 8 },
          "lights": [ { "type": "environment", "path": "not_a_map.exr" } ],
          "materials": { "floor": { "type": "diffuse", "albedo": 0.5 } },
          "objects": [ { "type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [2, 2], "material": "floor" } ] }"#,
    )
    .unwrap();
    let out = tmp("never_env.png");
    let e = run_err(&["render", scene.to_str().unwrap(), "--backend", "cpu", "-o", out.to_str().unwrap()]);
    assert!(e.contains("env_scene.json") && e.contains("lights[0].path") && e.contains("not_a_map.exr"), "{e}");
    assert!(!out.exists());
}

/// `--environment FILE` adds an environment light to a scene without one (here a glTF file, whose
/// format has none): the background seen directly is the map times `--environment-scale`; bad
/// uses exit 2 naming the flag.
#[test]
fn an_environment_file_lights_a_scene_without_one() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let glb = root.join("scenes/gltf/glass_ball.glb");
    let sky = root.join("scenes/envmaps/sky.exr");
    let (glb, sky) = (glb.to_str().unwrap(), sky.to_str().unwrap());
    let top_row = |extra: &[&str], name: &str| {
        let out = tmp(name);
        let mut args =
            vec!["render", glb, "--backend", "cpu", "--size", "16x8", "--photons", "16", "--set", "cpu.spp=1"];
        args.extend_from_slice(extra);
        args.extend_from_slice(&["-o", out.to_str().unwrap()]);
        let run = caustics().args(&args).output().unwrap();
        assert!(run.status.success(), "{args:?}: {}", String::from_utf8_lossy(&run.stderr));
        // (read back through the environment map reader: a linear EXR, twice as wide as high)
        let img = caustics::scene::Environment::load(&out, glam::Vec3::ONE, 0.0).unwrap();
        img.texels[..16].iter().map(|t| t.x as f64).collect::<Vec<_>>()
    };
    let none = top_row(&[], "env_none.exr");
    let one = top_row(&["--environment", sky], "env_one.exr");
    let two = top_row(&["--environment", sky, "--environment-scale", "2", "--environment-rotate", "-0"], "env_two.exr");
    assert!(none.iter().all(|v| *v == 0.0), "the top row without an environment: {none:?}");
    assert!(one.iter().all(|v| *v > 0.0), "the top row sees the sky: {one:?}");
    for (a, b) in one.iter().zip(&two) {
        assert!((b / a - 2.0).abs() < 1e-5, "scale 2: {b} against {a}");
    }
    let out = tmp("never_env_flag.png");
    let o = out.to_str().unwrap();
    let has_one = root.join("scenes/glass_sphere_sky.json");
    let e = run_err(&["render", has_one.to_str().unwrap(), "--environment", sky, "--backend", "cpu", "-o", o]);
    assert!(e.contains("--environment") && e.contains("already"), "{e}");
    let e = run_err(&["render", glb, "--environment", sky, "--environment-scale", "-1", "--backend", "cpu", "-o", o]);
    assert!(e.contains("--environment-scale"), "{e}");
    let e = run_err(&["render", glb, "--environment", "/nonexistent/sky.exr", "--backend", "cpu", "-o", o]);
    assert!(e.contains("--environment") && e.contains("/nonexistent/sky.exr"), "{e}");
    let e = run_err(&["render", glb, "--environment-scale", "2", "--backend", "cpu", "-o", o]);
    assert!(e.contains("--environment"), "{e}");
    assert!(!out.exists());
}

/// `bench --load` times loading a scene and building its BVHs, CPU only.
#[test]
fn bench_load_reports_each_step() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let glb = root.join("scenes/gltf/glass_ball.glb");
    let out = caustics().args(["bench", glb.to_str().unwrap(), "--load"]).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    for step in ["triangles", "parse and flatten", "GPU renderer's BVH", "CPU reference's BVH"] {
        assert!(text.contains(step), "{step}: {text}");
    }
    let e = run_err(&["bench", "--load"]);
    assert!(e.contains("--load"), "{e}");
}

#[test]
fn bad_output_and_settings_exit_2() {
    let e = run_err(&["render", "-o", "/nonexistent-dir/x.png"]);
    assert!(e.contains("--output") && e.contains("/nonexistent-dir"), "{e}");
    let e = run_err(&["render", "-o", tmp("x.txt").to_str().unwrap()]);
    assert!(e.contains(".png or .exr"), "{e}");
    let out = tmp("big.png");
    // Settings errors name the setting by its path, whether a flag or `--set` gave it.
    let e = run_err(&["render", "--photons", "100000", "-o", out.to_str().unwrap()]);
    assert!(e.contains("photons.count"), "{e}");
    assert!(!out.exists());
    let e = run_err(&["render", "--env-lights", "0", "-o", out.to_str().unwrap()]);
    assert!(e.contains("environment.lights") && e.contains("1 to 256"), "{e}");
    assert!(!out.exists());
    let e = run_err(&["render", "--caustic-map", "100", "-o", out.to_str().unwrap()]);
    assert!(e.contains("photons.caustic_map_size") && e.contains("multiple of 16"), "{e}");
    assert!(!out.exists());
    let e = run_err(&["render", "--set", "beams.cutoff=-0.001", "-o", out.to_str().unwrap()]);
    assert!(e.contains("beams.cutoff") && e.contains("at least 0"), "{e}");
    assert!(!out.exists());
}

#[test]
fn a_bad_set_key_names_the_path_and_the_known_keys() {
    let e = run_err(&["render", "--set", "beams.gird=8"]);
    assert!(e.contains("beams.gird") && e.contains("known keys") && e.contains("grid"), "{e}");
    let e = run_err(&["render", "--set", "nope.x=1"]);
    assert!(e.contains("nope") && e.contains("photons") && e.contains("beams"), "{e}");
    let e = run_err(&["bench", "--set", "cpu.sp=1"]);
    assert!(e.contains("cpu.sp") && e.contains("spp"), "{e}");
    let e = run_err(&["view", "--set", "photons.count=\"many\""]);
    assert!(e.contains("photons.count"), "{e}");
    let e = run_err(&["render", "--set", "photons.emission=nope"]);
    assert!(e.contains("photons.emission") && e.contains("nope"), "{e}");
    let e = run_err(&["render", "--set", "beams"]);
    assert!(e.contains("SECTION.KEY=VALUE"), "{e}");
}

fn print_settings(args: &[&str]) -> serde_json::Value {
    let out = caustics().args(args).arg("--print-settings").output().unwrap();
    assert!(out.status.success(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

/// `--print-settings` prints every section; flags, `--set` and `--settings` land in the same
/// keys, in the order file, flags, `--set`; `render`, `bench` and `view` read them alike.
#[test]
fn settings_come_from_flags_set_and_files_alike() {
    let d = print_settings(&["render"]);
    for section in ["photons", "adaptive", "shading", "medium", "environment", "beams", "indirect", "cpu", "spheres"] {
        assert!(d[section].is_object(), "no section {section}: {d}");
    }
    assert_eq!(d["photons"]["count"], 1024);
    assert_eq!(d["photons"]["emission"], "basic");
    let s = print_settings(&["render", "--photons", "256", "--technique", "beams", "--set", "beams.cutoff=0.5"]);
    assert_eq!(s["photons"]["count"], 256);
    assert_eq!(s["sources"]["local"], "beams");
    assert_eq!(s["beams"]["cutoff"], 0.5);
    let t =
        print_settings(&["render", "--set", "photons.emission=hierarchical", "--set", "medium.beyond_specular=false"]);
    assert_eq!(t["photons"]["emission"], "hierarchical");
    assert_eq!(t["medium"]["beyond_specular"], false);
    // A file of some keys over the defaults, then the flags and `--set` over the file.
    let file = tmp("settings.json");
    std::fs::write(
        &file,
        r#"{ "photons": { "count": 128, "splat": "fixed" }, "beams": { "grid": 4 }, "cpu": { "spp": 2 } }"#,
    )
    .unwrap();
    let f = file.to_str().unwrap();
    for cmd in ["render", "bench", "view"] {
        let u = print_settings(&[cmd, "--settings", f, "--splat", "multires", "--set", "beams.levels=1"]);
        assert_eq!(u["photons"]["splat"], "multires", "{cmd}");
        assert_eq!(u["beams"]["grid"], 4, "{cmd}");
        assert_eq!(u["beams"]["levels"], 1, "{cmd}");
        assert_eq!(u["cpu"]["spp"], 2, "{cmd}");
    }
    assert_eq!(print_settings(&["render", "--settings", f])["photons"]["count"], 128);
    // What one command prints, another reads back as it is.
    std::fs::write(&file, serde_json::to_string(&s).unwrap()).unwrap();
    assert_eq!(print_settings(&["render", "--settings", f]), s);
    // A file with an unknown key names it.
    std::fs::write(&file, r#"{ "beams": { "gird": 4 } }"#).unwrap();
    let e = run_err(&["render", "--settings", f]);
    assert!(e.contains("settings.json") && e.contains("gird"), "{e}");
}

/// Every EXR holds the settings it was rendered with in its header (CPU reference: no GPU
/// needed), and they read back as a settings file.
#[test]
fn an_exr_holds_its_settings() {
    let out = tmp("with_settings.exr");
    let args = ["render", "--backend", "cpu", "--size", "8x6", "--photons", "16", "--set", "cpu.spp=1"];
    let o = caustics().args(args).args(["--set", "beams.grid=5", "-o", out.to_str().unwrap()]).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json = caustics_reference::io::read_exr_settings(&out).unwrap().expect("no settings in the EXR header");
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(v["photons"]["count"], 16);
    assert_eq!(v["beams"]["grid"], 5);
    assert_eq!(v["cpu"]["spp"], 1);
    let file = tmp("from_exr.json");
    std::fs::write(&file, &json).unwrap();
    assert_eq!(print_settings(&["render", "--settings", file.to_str().unwrap()]), v);
}

/// `render --help` shows the common flags only (the rest through `--set`).
#[test]
fn render_help_is_short() {
    let out = caustics().args(["render", "--help"]).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    // Flag lines (`  -o, --output <OUTPUT>`, `      --set ...`), not the lists of values (`- basic: ...`).
    let flags = text.lines().map(str::trim_start).filter(|l| l.starts_with('-') && !l.starts_with("- ")).count();
    // 22 common flags plus `--camera` and `--environment` (a glTF file's camera, docs/gltf.md; an
    // environment light for a scene without one).
    assert!(flags <= 24, "{flags} flags in render --help:\n{text}");
    assert!(text.contains("--set") && text.contains("--settings") && text.contains("--print-settings"), "{text}");
}

#[test]
fn compare_reports_metrics() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../references");
    let a = root.join("a_glass_sphere.exr");
    let out = caustics().args(["compare", a.to_str().unwrap(), a.to_str().unwrap()]).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let s = String::from_utf8_lossy(&out.stdout);
    assert!(s.contains("RMSE") && s.contains("FLIP") && s.contains("energy ratio"), "{s}");
    let e = run_err(&["compare", a.to_str().unwrap(), "/nonexistent/b.exr"]);
    assert!(e.contains("/nonexistent/b.exr"), "{e}");
}

#[test]
fn view_bad_input_exits_2_before_any_window() {
    let e = run_err(&["view", "/nonexistent/missing.json"]);
    assert!(e.contains("/nonexistent/missing.json"), "{e}");
    let e = run_err(&["view", "--technique", "nope"]);
    assert!(e.contains("--technique") && e.contains("nope"), "{e}");
    let e = run_err(&["view", "--screenshot-dir", "/nonexistent-dir"]);
    assert!(e.contains("--screenshot-dir"), "{e}");
}

/// Ctrl-C during a CPU reference render: a one-line message, exit code 130, no output file.
#[cfg(unix)]
#[test]
fn ctrl_c_cancels_the_cpu_reference_cleanly() {
    let dir = tmp("cancel");
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("cancelled.png");
    let child = caustics()
        .args(["render", "--backend", "cpu", "--photons", "8192", "--set", "cpu.spp=256", "-o", out.to_str().unwrap()])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(1500));
    let t0 = std::time::Instant::now();
    let status = Command::new("kill").args(["-INT", &child.id().to_string()]).status().unwrap();
    assert!(status.success());
    let o = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(130), "{err}");
    assert!(err.contains("cancelled"), "{err}");
    assert!(t0.elapsed().as_secs_f64() < 20.0, "cancelling took {:?}", t0.elapsed());
    assert!(!out.exists(), "a cancelled render left {}", out.display());
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0, "a cancelled render left files behind");
}

/// Ctrl-C during a GPU render (a large photon grid, seconds on lavapipe): exit code 130 and no
/// output file, temporary or final. The signal is sent once the render has started (the CLI
/// has printed the scene line, after the device is open). Skips without a GPU adapter, except
/// in CI.
#[cfg(unix)]
#[test]
fn ctrl_c_stops_a_gpu_render_without_output() {
    use std::io::BufRead as _;
    let dir = tmp("cancel_gpu");
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("cancelled.exr");
    let mut child = caustics()
        .args(["render", "--backend", "gpu", "--photons", "4096", "--size", "320x240", "-o", out.to_str().unwrap()])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdout = std::io::BufReader::new(child.stdout.take().unwrap());
    let mut line = String::new();
    stdout.read_line(&mut line).unwrap();
    if !line.starts_with("scene:") {
        let o = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!std::env::var("CI").is_ok_and(|v| v == "true"), "no GPU render in CI: {err}");
        eprintln!("skipping: no GPU render ({err})");
        return;
    }
    std::thread::sleep(std::time::Duration::from_millis(500));
    let t0 = std::time::Instant::now();
    let status = Command::new("kill").args(["-INT", &child.id().to_string()]).status().unwrap();
    assert!(status.success());
    let o = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(130), "{err}");
    assert!(err.contains("cancelled"), "{err}");
    assert!(t0.elapsed().as_secs_f64() < 5.0, "stopping took {:?}", t0.elapsed());
    assert!(!out.exists(), "a cancelled render left {}", out.display());
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0, "a cancelled render left files behind");
}

#[test]
fn precompute_builds_then_reads_the_cache() {
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/glass_sphere_3dir.json");
    let cache = tmp("sphere-cache");
    let _ = std::fs::remove_dir_all(&cache);
    let args = [
        "precompute",
        scene,
        "--directions",
        "3",
        "--spheres",
        "4",
        "--sphere-size",
        "16x8",
        "--sphere-photons",
        "4096",
        "--half",
        "--sphere-cache",
        cache.to_str().unwrap(),
    ];
    let first = caustics().args(args).output().unwrap();
    assert!(first.status.success(), "{}", String::from_utf8_lossy(&first.stderr));
    let text = String::from_utf8_lossy(&first.stdout);
    assert!(text.contains("precomputed") && text.contains("MiB"), "{text}");
    let second = caustics().args(args).output().unwrap();
    assert!(second.status.success());
    assert!(String::from_utf8_lossy(&second.stdout).contains("read from the cache"));
    // A truncated cache is rebuilt, never trusted.
    let file = std::fs::read_dir(&cache).unwrap().next().unwrap().unwrap().path();
    let bytes = std::fs::read(&file).unwrap();
    std::fs::write(&file, &bytes[..bytes.len() - 100]).unwrap();
    let third = caustics().args(args).output().unwrap();
    let text = String::from_utf8_lossy(&third.stdout);
    assert!(third.status.success() && text.contains("precomputed") && text.contains("checksum"), "{text}");
    let e = run_err(&["precompute", scene, "--directions", "4"]);
    assert!(e.contains("--directions"), "{e}");
    let _ = std::fs::remove_dir_all(&cache);
}

#[test]
fn sun_in_fog_renders_through_caustic_spheres() {
    // scenes/glass_sphere_fog_sun.json: a directional light with a medium (the loader used to
    // refuse it), rendered on the GPU with the caustic spheres: the sun's in-scattered light
    // (`medium_scatter`) in the full image, the floor's and the fog's caustic from the spheres
    // in the caustic-only one (GPU; skipped without an adapter, as the render then says).
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/glass_sphere_fog_sun.json");
    let cache = tmp("sphere-cache-fog-sun");
    let _ = std::fs::remove_dir_all(&cache);
    let (full, caustic) = (tmp("fog_sun.exr"), tmp("fog_sun_caustic.exr"));
    let mut args = vec!["render", scene, "--backend", "gpu", "--size", "32x32", "--technique", "caustic-spheres"];
    let cache_key = format!("spheres.cache={}", cache.to_str().unwrap());
    args.extend_from_slice(&[
        "--set",
        "spheres.directions=3",
        "--set",
        "spheres.count=4",
        "--set",
        "spheres.size=[16,8]",
    ]);
    args.extend_from_slice(&["--set", "spheres.photons=4096", "--set", &cache_key]);
    args.extend_from_slice(&["-o", full.to_str().unwrap(), "--caustic-output", caustic.to_str().unwrap()]);
    let out = caustics().args(&args).output().unwrap();
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("adapter") && std::env::var("CI").is_err(), "{err}");
        eprintln!("skipping: {err}");
        return;
    }
    // The caustic-only image against the full one: both lit, the caustic a part of the whole.
    let cmp = caustics().args(["compare", caustic.to_str().unwrap(), full.to_str().unwrap()]).output().unwrap();
    assert!(cmp.status.success(), "{}", String::from_utf8_lossy(&cmp.stderr));
    let text = String::from_utf8_lossy(&cmp.stdout);
    let value = |name: &str| -> f64 {
        let line = text.lines().find(|l| l.starts_with(name)).unwrap_or_else(|| panic!("no {name}: {text}"));
        line[name.len()..].split_whitespace().next().unwrap().parse().unwrap()
    };
    let (ea, eb) = (value("energy A"), value("energy B"));
    assert!(ea > 0.0 && eb > ea, "caustic {ea}, full {eb}");
    let _ = std::fs::remove_dir_all(&cache);
}

#[test]
fn caustic_spheres_by_flag_and_by_set_render_the_same_image() {
    // `--technique caustic-spheres` is `--set sources.distant=spheres`: the same bits
    // (GPU; skipped without an adapter, as the render then says).
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/glass_sphere_3dir.json");
    let cache = tmp("sphere-cache-alias");
    let _ = std::fs::remove_dir_all(&cache);
    let cache_key = format!("spheres.cache={}", cache.to_str().unwrap());
    let run = |how: &[&str], out: &PathBuf| {
        let mut args = vec!["render", scene, "--backend", "gpu", "--size", "48x48", "--photons", "64"];
        args.extend_from_slice(how);
        args.extend_from_slice(&["--set", "spheres.directions=3", "--set", "spheres.count=4"]);
        args.extend_from_slice(&["--set", "spheres.size=[16,8]", "--set", "spheres.photons=4096", "--set", &cache_key]);
        args.extend_from_slice(&["-o", out.to_str().unwrap()]);
        caustics().args(&args).output().unwrap()
    };
    let (a, b) = (tmp("spheres_technique.exr"), tmp("spheres_set.exr"));
    let first = run(&["--technique", "caustic-spheres"], &a);
    if !first.status.success() {
        let err = String::from_utf8_lossy(&first.stderr);
        assert!(err.contains("adapter") && std::env::var("CI").is_err(), "{err}");
        eprintln!("skipping: {err}");
        return;
    }
    let second = run(&["--set", "sources.distant=spheres"], &b);
    assert!(second.status.success(), "{}", String::from_utf8_lossy(&second.stderr));
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap(), "the two spellings render other bits");
    let _ = std::fs::remove_dir_all(&cache);
}

/// `--technique beams` (the issue's name for adaptive beam tracing) renders what
/// `--set sources.local=beams` does: the caustics of spot and point lights from beams on surfaces
/// and in the fog, no photon maps; the same bytes. Skips without a GPU adapter, except in CI.
#[test]
fn technique_beams_is_surface_caustics_from_beams() {
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/volume_caustic_fog.json");
    let render = |name: &str, extra: &[&str]| -> Option<(Vec<u8>, String)> {
        let out = tmp(name);
        let mut args = vec!["render", scene, "--size", "24x18", "--beam-grid", "8", "--beam-levels", "1"];
        args.extend_from_slice(extra);
        args.extend_from_slice(&["-o", out.to_str().unwrap()]);
        let o = caustics().args(&args).output().unwrap();
        let stdout = String::from_utf8_lossy(&o.stdout).to_string();
        if !o.status.success() {
            let err = String::from_utf8_lossy(&o.stderr);
            assert!(!std::env::var("CI").is_ok_and(|v| v == "true"), "no GPU render in CI: {err}");
            eprintln!("skipping: no GPU render ({err})");
            return None;
        }
        Some((std::fs::read(&out).unwrap(), stdout))
    };
    let Some((a, out_a)) = render("technique_beams.exr", &["--technique", "beams"]) else { return };
    let (b, _) = render("surface_beams.exr", &["--set", "sources.local=beams"]).unwrap();
    assert!(a == b, "--technique beams and --set sources.local=beams differ");
    assert!(out_a.contains("0 photons splatted"), "{out_a}");
    let (c, _) = render("photons.exr", &[]).unwrap();
    assert!(a != c, "the photon maps' surface caustic is the same as the beams'");
}

/// `render --time T` poses the scene's waves at T seconds: the same T gives the same bytes,
/// another T another image; a time that is no number exits 2 naming the flag.
#[test]
fn render_time_poses_the_waves() {
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/pool_sun.json");
    let render = |t: &str, name: &str| {
        let out = tmp(name);
        let args = ["render", scene, "--backend", "cpu", "--size", "16x12", "--photons", "64", "--set", "cpu.spp=1"];
        let o = caustics().args(args).args(["--time", t, "-o", out.to_str().unwrap()]).output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        std::fs::read(&out).unwrap()
    };
    let (a, again, later) = (render("0", "t0.exr"), render("0", "t0_again.exr"), render("0.5", "t05.exr"));
    assert_eq!(a, again, "the same time rendered twice differs");
    assert_ne!(a, later, "the waves did not move");
    let out = tmp("nan.png");
    let e = run_err(&["render", scene, "--backend", "cpu", "--time", "NaN", "-o", out.to_str().unwrap()]);
    assert!(e.contains("--time"), "{e}");
    assert!(!out.exists(), "a refused render wrote {}", out.display());
}

/// `cpu.diffuse_orders` (the CPU reference's diffuse bounce orders): a bad range exits 2 naming
/// the key and writes nothing; a bare order (read as a JSON number) and a range render.
#[test]
fn cpu_diffuse_orders_are_checked() {
    let out = tmp("orders.exr");
    let args = ["render", "--backend", "cpu", "--size", "8x6", "--photons", "16", "--set", "cpu.spp=1"];
    for bad in ["2-1", "x", "-1", "1.5"] {
        let set = format!("cpu.diffuse_orders={bad}");
        let mut a = args.to_vec();
        a.extend(["--set", &set, "-o", out.to_str().unwrap()]);
        let e = run_err(&a);
        assert!(e.contains("cpu.diffuse_orders"), "{bad}: {e}");
        assert!(!out.exists(), "{bad}: an output file was written");
    }
    for good in ["1", "2-", "0-1", "all"] {
        let set = format!("cpu.diffuse_orders={good}");
        let o = caustics().args(args).args(["--set", &set, "-o", out.to_str().unwrap()]).output().unwrap();
        assert!(o.status.success(), "{good}: {}", String::from_utf8_lossy(&o.stderr));
    }
}

#[test]
fn convert_writes_gltf_that_renders_and_exits_2_on_bad_output() {
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/glass_sphere.json");
    let out = tmp("converted.glb");
    let r = caustics().args(["convert", scene, "-o", out.to_str().unwrap()]).output().unwrap();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let loaded = caustics::Scene::load(&out).unwrap();
    assert_eq!(loaded.name, "glass_sphere");
    let e = run_err(&["convert", scene, "-o", tmp("converted.obj").to_str().unwrap()]);
    assert!(e.contains("converted.obj") && e.contains(".glb or .gltf"), "{e}");
    let missing = tmp("no such folder").join("x.gltf");
    let e = run_err(&["convert", scene, "-o", missing.to_str().unwrap()]);
    assert!(e.contains("x.gltf"), "{e}");
    let e = run_err(&["convert", "no_such_scene.json", "-o", out.to_str().unwrap()]);
    assert!(e.contains("no_such_scene.json"), "{e}");
}
