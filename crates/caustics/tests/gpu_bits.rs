//! The frame's bits: every catalogue scene under each photon technique, each surface-caustic
//! source and (for scenes with directional or environment light) caustic spheres, rendered small,
//! hashed (FNV-1a of the radiance and caustic-only images and the caustic flux words) and
//! compared with `tests/data/image_bits.json`. A refactor must leave every hash as it was; a
//! change that alters pixels on purpose rewrites the file in its own commit
//! (`CAUSTICS_ACCEPT_BITS=1 cargo test --release --test gpu_bits -- --include-ignored`) and says
//! why. CI runs the scenes that take seconds; `-- --include-ignored` runs every scene (about 20
//! minutes on 2 cores).
//!
//! The hashes hold for one adapter and driver (recorded in the file): on another the test prints
//! why it does not compare and passes (floating-point results differ between drivers).

mod common;
use caustics::Scene;
use caustics::caustic_spheres::{CausticSpheres, SphereSettings};
use caustics::render::{Emission, RenderSettings, Technique};
use caustics::renderer::Renderer;
use caustics::scene::Light;
use caustics_reference::reference::Progress;
use caustics_reference::reference::spheres;
use common::gpu;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

/// The variants each scene is rendered under: (name, the `--technique` shorthand that sets it).
const VARIANTS: &[(&str, Technique)] = &[
    ("basic", Technique::Photons(Emission::Basic)),
    ("hierarchical", Technique::Photons(Emission::Hierarchical)),
    ("adaptive-level", Technique::Photons(Emission::AdaptiveLevel)),
    ("adaptive-error", Technique::Photons(Emission::AdaptiveError)),
    ("surface-beams", Technique::Beams),
    ("caustic-spheres", Technique::CausticSpheres),
];

fn fnv1a(h: &mut u64, bytes: &[u8]) {
    for b in bytes {
        *h ^= u64::from(*b);
        *h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
}

fn data_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/image_bits.json")
}

fn scenes_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes")
}

/// Tiny tables: this test checks bits, not the tables' accuracy.
fn sphere_settings() -> SphereSettings {
    SphereSettings { directions: 3, spheres: 4, width: 16, height: 16, photons: 1 << 12, max_depth: 8 }
}

fn has_directional_light(s: &Scene) -> bool {
    s.environment.is_some() || s.lights.iter().any(|l| matches!(l, Light::Directional { .. }))
}

/// The hash of one render, or `invalid` where the settings refuse the scene.
fn render_hash(ctx: &caustics::gpu::GpuContext, scene: &Scene, technique: Technique) -> String {
    let mut settings = RenderSettings {
        photons: caustics::settings::PhotonSettings { count: 64, caustic_map_size: 64, ..Default::default() },
        shading: caustics::settings::ShadingSettings { shadow_map_size: 128, ..Default::default() },
        medium: caustics::settings::MediumSettings { steps: 16, light_steps: 4, ..Default::default() },
        ..Default::default()
    };
    technique.apply(&mut settings);
    let mut r = match Renderer::with_context(ctx.clone(), scene.clone(), settings) {
        Ok(r) => r,
        Err(_) => return "invalid".into(),
    };
    if technique == Technique::CausticSpheres {
        let mut tables = Vec::new();
        for (oi, o) in scene.objects.iter().enumerate() {
            if o.caustic_caster && scene.material_of(o).is_specular() {
                let t = spheres::precompute(scene, oi, &sphere_settings(), None, &Progress::new()).unwrap();
                tables.push((oi, Arc::new(t) as Arc<CausticSpheres>));
            }
        }
        if r.set_caustic_spheres(tables, caustics::caustic_spheres::Blend::Triangle, false).is_err() {
            return "invalid".into();
        }
    }
    let out = match r.render_once() {
        Ok(o) => o,
        Err(_) => return "invalid".into(),
    };
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for img in [&out.image, &out.caustic] {
        for p in &img.pixels {
            for c in p {
                fnv1a(&mut h, &c.to_le_bytes());
            }
        }
    }
    for words in out.caustic_flux_bits.iter().flatten() {
        fnv1a(&mut h, &words.to_le_bytes());
    }
    format!("{h:016x}")
}

/// The recorded file: the adapter it holds for and the hashes by `scene/variant`.
#[derive(serde::Serialize, serde::Deserialize, Default)]
struct Recorded {
    adapter: String,
    driver: String,
    hashes: BTreeMap<String, String>,
}

fn adapter_of(ctx: &caustics::gpu::GpuContext) -> (String, String) {
    (ctx.info.name.clone(), format!("{} {}", ctx.info.driver, ctx.info.driver_info))
}

fn accepting() -> bool {
    std::env::var("CAUSTICS_ACCEPT_BITS").is_ok_and(|v| v == "1")
}

/// One test at a time rewrites the file while accepting.
static WRITING: Mutex<()> = Mutex::new(());

fn check(name: &str) {
    let Some(ctx) = gpu() else { return };
    let mut scene = Scene::load(&scenes_dir().join(format!("{name}.json"))).unwrap();
    scene.camera.height = (scene.camera.height * 32 / scene.camera.width).max(1);
    scene.camera.width = 32;
    let directional = has_directional_light(&scene);
    let mut got = BTreeMap::new();
    for (variant, technique) in VARIANTS {
        if *technique == Technique::CausticSpheres && !directional {
            continue;
        }
        // The dragon in fog: beams over 100k triangles take minutes a variant on lavapipe; its
        // other variants are the glass dragon's and the fog scenes'.
        if name == "glass_dragon_fog" && *variant != "basic" {
            continue;
        }
        let t0 = std::time::Instant::now();
        got.insert(format!("{name}/{variant}"), render_hash(&ctx, &scene, *technique));
        eprintln!("{name}/{variant}: {:.1} s", t0.elapsed().as_secs_f64());
    }
    let (adapter, driver) = adapter_of(&ctx);
    if accepting() {
        // Each scene's test adds its hashes to the file as it finishes (so a filtered run
        // records just those scenes).
        let _guard = WRITING.lock().unwrap();
        let mut rec: Recorded = std::fs::read_to_string(data_path())
            .ok()
            .and_then(|t| serde_json::from_str(&t).ok())
            .filter(|r: &Recorded| r.adapter == adapter && r.driver == driver)
            .unwrap_or(Recorded { adapter, driver, ..Default::default() });
        rec.hashes.retain(|k, _| !k.starts_with(&format!("{name}/")));
        rec.hashes.extend(got);
        std::fs::create_dir_all(data_path().parent().unwrap()).unwrap();
        std::fs::write(data_path(), serde_json::to_string_pretty(&rec).unwrap() + "\n").unwrap();
        eprintln!("recorded {name} in {}", data_path().display());
        return;
    }
    let rec: Recorded = serde_json::from_str(&std::fs::read_to_string(data_path()).unwrap()).unwrap();
    if rec.adapter != adapter || rec.driver != driver {
        eprintln!(
            "not comparing image bits: recorded on {} ({}), this adapter is {adapter} ({driver})",
            rec.adapter, rec.driver
        );
        return;
    }
    let mut wrong = Vec::new();
    for (k, v) in &got {
        match rec.hashes.get(k) {
            Some(want) if want == v => {}
            Some(want) => wrong.push(format!("{k}: {v}, recorded {want}")),
            None => wrong.push(format!("{k}: {v}, not recorded")),
        }
    }
    assert!(wrong.is_empty(), "image bits changed:\n{}", wrong.join("\n"));
}

/// Scenes whose variants render in seconds on lavapipe run in CI; the rest (meshes under beams,
/// fog scenes: minutes on 2 cores) run with `-- --include-ignored` after every refactoring step.
macro_rules! scenes {
    (ci: $($fast:ident),* ; full: $($slow:ident),* $(,)?) => {
        const SCENES: &[&str] = &[$(stringify!($fast),)* $(stringify!($slow)),*];
        $(#[test] fn $fast() { check(stringify!($fast)); })*
        $(
            #[test]
            #[ignore = "minutes on lavapipe: run with --include-ignored"]
            fn $slow() { check(stringify!($slow)); }
        )*
    };
}

scenes!(
    ci: a_glass_sphere,
    b_mirror_ring,
    glass_sphere,
    glass_sphere_3dir,
    glass_sphere_sky,
    mirror_ring,
    pool_sun,
    pool_sun_under,
    tinted_block,
    two_spheres;
    full: ball_over_bunny,
    cornell_glass,
    pool,
    pool_walls,
    bunny_over_ball,
    dragon_spheres,
    glass_buddha,
    glass_bunny,
    glass_dragon,
    glass_dragon_fog,
    glass_of_water,
    glass_sphere_fog,
    glass_sphere_fog_sun,
    glass_sphere_studio,
    smoke_puff,
    stacked_balls,
    stacked_balls_fog,
    volume_caustic_fog,
);

/// Every scene of the catalogue has its test (a new scene must be added above).
#[test]
fn every_catalogue_scene_is_hashed() {
    let mut on_disk: Vec<String> = std::fs::read_dir(scenes_dir())
        .unwrap()
        .filter_map(|e| {
            let p = e.unwrap().path();
            (p.extension()? == "json").then(|| p.file_stem().unwrap().to_string_lossy().into_owned())
        })
        .collect();
    on_disk.sort();
    let mut listed: Vec<String> = SCENES.iter().map(|s| s.to_string()).collect();
    listed.sort();
    assert_eq!(on_disk, listed);
}
