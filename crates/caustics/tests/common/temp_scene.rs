//! A scene written to a temporary folder with its files (generated meshes) and loaded from
//! there, as a user's scene would be. Included by the test files that build their own meshes
//! (the `gpu` binary's `temp_scene` module).

use caustics::Scene;
use std::sync::atomic::{AtomicU32, Ordering};

/// Write `files` (name, contents) and `json` as `scene.json` into a fresh folder, load the scene
/// and remove the folder. One folder per call: the tests of a file run in parallel threads of
/// one process.
pub fn load(tag: &str, files: &[(&str, String)], json: &str) -> Scene {
    static CALLS: AtomicU32 = AtomicU32::new(0);
    let call = CALLS.fetch_add(1, Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("caustics_{tag}_{}_{call}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (name, contents) in files {
        std::fs::write(dir.join(name), contents).unwrap();
    }
    let path = dir.join("scene.json");
    std::fs::write(&path, json).unwrap();
    let scene = Scene::load(&path).unwrap();
    std::fs::remove_dir_all(&dir).ok();
    scene
}
