//! The viewer without a display: a scripted session (open, orbit, drag the light, switch
//! technique, screenshot) on one shared GPU device, compared with a golden image; the egui
//! panels driven by synthetic input; the background reference and its cancellation.
//!
//! GPU tests skip with a printed reason when there is no adapter, except in CI (`CI=true`),
//! where they fail. `CAUSTICS_ACCEPT_GOLDEN=1` rewrites the golden image (as the library's
//! golden tests); on a mismatch the screenshot is written beside it (`*.actual.png`).

use super::camera::project;
use super::pick::Selection;
use super::session::{Action, Mods, Session, ViewMode};
use super::ui::{self, UiState};
use caustics::Scene;
use caustics::image_io::{Image, srgb_encode};
use caustics::render::RenderSettings;
use caustics::settings::Emission;
use caustics_reference::ImageIo;
use std::path::PathBuf;
use std::sync::OnceLock;

/// The golden image of the scripted session (96 × 72, 64² photons, lavapipe).
const GOLDEN: &str = "tests/golden/view_session.png";
/// Tolerance against the golden image, in sRGB-encoded [0, 1] values: RMSE at most 0.02 and at
/// most 1 % of the pixels off by more than 0.1 (other GPUs round differently at edges; a wrong
/// camera, light or technique after the script is far outside this).
const GOLDEN_RMSE: f64 = 0.02;
const GOLDEN_OUTLIERS: f64 = 0.01;

/// One device for every test of this binary.
fn device() -> Option<&'static (wgpu::Device, wgpu::Queue)> {
    static DEVICE: OnceLock<Option<(wgpu::Device, wgpu::Queue)>> = OnceLock::new();
    DEVICE
        .get_or_init(|| match super::open_device(&super::instance(), None, None) {
            Ok((_, d, q)) => Some((d, q)),
            Err(e) => {
                if std::env::var("CI").is_ok_and(|v| v == "true") {
                    panic!("CI requires a GPU adapter (install mesa-vulkan-drivers): {e}");
                }
                eprintln!("skipping GPU test: {e}");
                None
            }
        })
        .as_ref()
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("caustics-view-test-{}", std::process::id()));
    std::fs::create_dir_all(&d).expect("temp folder");
    d.join(name)
}

/// Small and fast on a software rasterizer.
fn small_settings() -> RenderSettings {
    RenderSettings {
        photons: caustics::settings::PhotonSettings { count: 64, caustic_map_size: 256, ..Default::default() },
        shading: caustics::settings::ShadingSettings { shadow_map_size: 512, ..Default::default() },
        ..Default::default()
    }
}

fn session(d: &(wgpu::Device, wgpu::Queue)) -> Session {
    let s = Session::new(&d.0, &d.1, Scene::default_scene(), small_settings(), tmp(""))
        .expect("a session on the built-in scene");
    let mut s = s;
    s.act(Action::Resize { width: 96, height: 72 }).expect("resize");
    s
}

fn frame(s: &mut Session) {
    assert!(s.render().expect("frame"), "nothing changed: no frame");
    s.update();
}

#[test]
fn scripted_session_matches_golden() {
    let Some(d) = device() else { return };
    let t0 = std::time::Instant::now();
    let mut s = session(d);
    frame(&mut s);
    let cam0 = s.scene().camera.clone();
    assert_eq!((cam0.width, cam0.height), (96, 72));

    // Orbit a little.
    s.act(Action::Orbit { dx: 25.0, dy: -8.0 }).expect("orbit");
    s.act(Action::Zoom { steps: 1.0 }).expect("zoom");
    assert_ne!(s.scene().camera.position, cam0.position);
    frame(&mut s);

    // Grab the spot light by its marker and drag it 6 pixels right.
    let light0 = s.scene().lights[0].clone();
    let p = light0.position().expect("the built-in light is a spot");
    let (q, _) = project(&s.scene().camera, p).expect("the light is in view");
    s.act(Action::Press { x: q.x, y: q.y, mods: Mods::default() }).expect("press");
    assert_eq!(s.selection, Some(Selection::Light(0)));
    assert!(s.dragging());
    s.act(Action::Drag { x: q.x + 6.0, y: q.y }).expect("drag");
    s.act(Action::Release).expect("release");
    let moved = s.scene().lights[0].position().expect("spot");
    assert!((moved - p).length() > 1e-3, "the light did not move");
    let (q2, _) = project(&s.scene().camera, moved).expect("in view");
    assert!((q2.x - q.x - 6.0).abs() < 0.05 && (q2.y - q.y).abs() < 0.05, "{q:?} -> {q2:?}");
    frame(&mut s);

    // Switch technique.
    s.act(Action::SetTechnique(Emission::AdaptiveLevel)).expect("technique");
    assert_eq!(s.settings().photons.emission, Emission::AdaptiveLevel);
    frame(&mut s);
    s.wait_stats();
    let stats = s.stats.clone().expect("frame statistics");
    assert_eq!(stats.technique.technique, Emission::AdaptiveLevel);
    assert!(stats.technique.photons_traced > 0);
    assert_eq!(stats.flux.len(), 1);

    // Screenshot, PNG and EXR.
    let png = tmp("session.png");
    let exr = tmp("session.exr");
    s.act(Action::Screenshot(png.clone())).expect("png");
    s.act(Action::Screenshot(exr.clone())).expect("exr");
    let linear = Image::read(&exr).expect("the EXR screenshot");
    assert_eq!((linear.width, linear.height), (96, 72));
    assert!(linear.sum() > 0.0);
    let shot = Image::read(&png).expect("the PNG screenshot");
    compare_with_golden(&shot, &png);
    eprintln!("scripted session: {:.1} s", t0.elapsed().as_secs_f64());
}

fn compare_with_golden(shot: &Image, png: &std::path::Path) {
    let golden = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(GOLDEN);
    let bless = std::env::var("CAUSTICS_ACCEPT_GOLDEN").is_ok_and(|v| v == "1");
    if bless || !golden.exists() {
        assert!(
            !std::env::var("CI").is_ok_and(|v| v == "true") || bless,
            "{} is missing (CAUSTICS_ACCEPT_GOLDEN=1 writes it; commit it)",
            golden.display()
        );
        std::fs::create_dir_all(golden.parent().expect("folder")).expect("golden folder");
        std::fs::copy(png, &golden).expect("write the golden image");
        eprintln!("wrote the golden image {}", golden.display());
        return;
    }
    let g = Image::read(&golden).expect("the golden image");
    assert_eq!((g.width, g.height), (shot.width, shot.height));
    let (mut se, mut outliers) = (0.0f64, 0usize);
    for (a, b) in shot.pixels.iter().zip(&g.pixels) {
        let mut worst = 0.0f32;
        for k in 0..3 {
            let d = srgb_encode(a[k]) - srgb_encode(b[k]);
            se += (d * d) as f64;
            worst = worst.max(d.abs());
        }
        if worst > 0.1 {
            outliers += 1;
        }
    }
    let n = shot.pixels.len() as f64;
    let rmse = (se / (3.0 * n)).sqrt();
    let frac = outliers as f64 / n;
    if rmse > GOLDEN_RMSE || frac > GOLDEN_OUTLIERS {
        let _ = std::fs::copy(png, golden.with_extension("actual.png"));
    }
    assert!(
        rmse <= GOLDEN_RMSE && frac <= GOLDEN_OUTLIERS,
        "screenshot {} differs from {}: RMSE {rmse:.4} (limit {GOLDEN_RMSE}), {:.2} % outliers (limit {:.2} %); wrote *.actual.png beside it",
        png.display(),
        golden.display(),
        frac * 100.0,
        GOLDEN_OUTLIERS * 100.0
    );
}

#[test]
fn invalid_settings_show_the_error_and_keep_the_state() {
    let Some(d) = device() else { return };
    let mut s = session(d);
    let before = s.settings().clone();
    let e = s.act(Action::SetPhotons(3)).expect_err("3² photons is too few");
    assert!(e.is_input(), "{e}");
    assert_eq!(format!("{:?}", s.settings()), format!("{before:?}"));
    assert!(s.error.as_deref().is_some_and(|m| m.contains("photons")), "{:?}", s.error);
    // An impossible image size is refused and the camera stays.
    let cam = s.scene().camera.clone();
    assert!(s.act(Action::Resize { width: 0, height: 10 }).is_err());
    assert_eq!(s.scene().camera, cam);
    // IOR of something that is not glass.
    assert!(s.act(Action::SetIor { material: usize::MAX, ior: 1.5 }).is_err());
    // A good change clears the error.
    s.act(Action::SetTechnique(Emission::Hierarchical)).expect("hierarchical");
    assert!(s.error.is_none());
}

#[test]
fn object_drag_rotate_and_ior() {
    let Some(d) = device() else { return };
    let mut s = session(d);
    let scene = s.scene().clone();
    let ball =
        scene.objects.iter().position(|o| matches!(o.shape, caustics::scene::Shape::Sphere { .. })).expect("a ball");
    let c = super::pick::centre(&scene.objects[ball].shape);
    let (q, _) = project(&scene.camera, c).expect("in view");
    s.act(Action::Press { x: q.x, y: q.y, mods: Mods::default() }).expect("press");
    assert_eq!(s.selection, Some(Selection::Object(ball)));
    s.act(Action::Drag { x: q.x, y: q.y + 5.0 }).expect("drag");
    s.act(Action::Release).expect("release");
    let c2 = super::pick::centre(&s.scene().objects[ball].shape);
    assert!((c2 - c).length() > 1e-3);
    // A press on the floor (the start of an orbit) keeps the selection.
    s.act(Action::Press { x: 1.0, y: 70.0, mods: Mods::default() }).expect("press");
    assert!(!s.dragging());
    assert_eq!(s.selection, Some(Selection::Object(ball)));
    s.act(Action::Release).expect("release");
    // Ctrl-drag rotates about the centre: the centre stays.
    s.act(Action::Press { x: 1.0, y: 1.0, mods: Mods { rotate: true } }).expect("press");
    s.act(Action::Drag { x: 40.0, y: 1.0 }).expect("rotate");
    s.act(Action::Release).expect("release");
    let c3 = super::pick::centre(&s.scene().objects[ball].shape);
    assert!((c3 - c2).length() < 1e-3, "{c2:?} {c3:?}");
    // The ball's glass gets another IOR (a new renderer, same state).
    let (m, _) = s.material_of(ball).expect("material");
    let cam = s.scene().camera.clone();
    s.act(Action::SetIor { material: m, ior: 1.7 }).expect("ior");
    assert!(matches!(s.material_of(ball), Some((_, caustics::scene::Material::Dielectric { ior, .. })) if ior == 1.7));
    assert_eq!(s.scene().camera, cam);
    assert!((super::pick::centre(&s.scene().objects[ball].shape) - c3).length() < 1e-4);
    frame(&mut s);
}

#[test]
fn reference_runs_in_the_background_and_is_cancelled_by_a_view_change() {
    let Some(d) = device() else { return };
    let mut s = session(d);
    s.reference_settings.photons_per_light = 1 << 14;
    s.reference_settings.camera_spp = 1;
    frame(&mut s);
    s.act(Action::StartReference).expect("start");
    assert!(s.reference_progress().is_some());
    let generation = s.generation();
    s.act(Action::Orbit { dx: 5.0, dy: 0.0 }).expect("orbit");
    assert!(s.reference_progress().is_none(), "the view changed: the job is cancelled");
    assert_eq!(s.generation(), generation + 1);
    frame(&mut s);
    s.act(Action::StartReference).expect("start");
    s.wait_reference();
    let r = s.reference().expect("the reference of this view");
    assert_eq!((r.image.width, r.image.height), (96, 72));
    let (_, mean) = r.diff.as_ref().expect("a difference against the GPU frame");
    assert!(*mean < 0.2, "mean tone-mapped difference {mean}");
    s.act(Action::ComputeFlip).expect("flip");
    let flip = s.reference().and_then(|r| r.flip).expect("HDR-FLIP");
    assert!(flip > 0.0 && flip < 0.5, "HDR-FLIP {flip}");
    // A settings change keeps the reference (same view); a light change drops it.
    s.act(Action::SetTechnique(Emission::Hierarchical)).expect("technique");
    assert!(s.reference().is_some());
    let mut l = s.scene().lights[0].clone();
    if let caustics::scene::Light::Spot { position, .. } = &mut l {
        position.x += 0.01;
    }
    s.act(Action::SetLight(0, l)).expect("light");
    assert!(s.reference().is_none());
}

/// The panels and the view area, driven by synthetic egui input (no window, no painting).
#[test]
fn panels_turn_input_into_actions() {
    let Some(d) = device() else { return };
    let mut s = session(d);
    frame(&mut s);
    let ctx = egui::Context::default();
    let mut state = UiState::new(1.0);
    let screen = egui::Rect::from_min_size(egui::Pos2::ZERO, egui::vec2(700.0, 400.0));
    let mut run = |s: &mut Session, events: Vec<egui::Event>| {
        let raw = egui::RawInput { screen_rect: Some(screen), events, ..Default::default() };
        let out = ctx.run_ui(raw, |ui| ui::draw(ui, &mut state, s, None));
        drop(out);
    };
    run(&mut s, vec![]);
    run(&mut s, vec![]);
    // The view area took the space left of the panel: the camera follows it.
    let cam = s.scene().camera.clone();
    assert!(cam.width > 200 && cam.width < 700 && cam.height == 400, "{}x{}", cam.width, cam.height);
    // A left drag on empty floor orbits.
    let down = |p: egui::Pos2, pressed| egui::Event::PointerButton {
        pos: p,
        button: egui::PointerButton::Primary,
        pressed,
        modifiers: Default::default(),
    };
    let a = egui::pos2(20.0, 390.0);
    let b = egui::pos2(80.0, 380.0);
    run(&mut s, vec![egui::Event::PointerMoved(a), down(a, true)]);
    run(&mut s, vec![egui::Event::PointerMoved(egui::pos2(40.0, 385.0))]);
    run(&mut s, vec![egui::Event::PointerMoved(b)]);
    run(&mut s, vec![down(b, false)]);
    assert_ne!(s.scene().camera.position, cam.position, "the drag did not orbit");
    // Grab the ball and move it; the last motion arrives with the release in one pass (as after
    // a slow frame) and still counts.
    let scene = s.scene().clone();
    let ball =
        scene.objects.iter().position(|o| matches!(o.shape, caustics::scene::Shape::Sphere { .. })).expect("a ball");
    let c = super::pick::centre(&scene.objects[ball].shape);
    let (q, _) = project(&scene.camera, c).expect("in view");
    let a = egui::pos2(q.x, q.y);
    let b = egui::pos2(q.x + 30.0, q.y);
    run(&mut s, vec![egui::Event::PointerMoved(a), down(a, true)]);
    run(&mut s, vec![egui::Event::PointerMoved(egui::pos2(q.x + 10.0, q.y))]);
    run(&mut s, vec![egui::Event::PointerMoved(b), down(b, false)]);
    assert_eq!(s.selection, Some(Selection::Object(ball)));
    let (q2, _) = project(&s.scene().camera, super::pick::centre(&s.scene().objects[ball].shape)).expect("in view");
    // The grabbed surface point follows the mouse; the centre, further away, moves a little less.
    assert!(q2.x - q.x > 20.0 && q2.x - q.x <= 30.5 && (q2.y - q.y).abs() < 0.5, "the ball went from {q:?} to {q2:?}");
    // Keys: B shows the reference, D the difference.
    let key = |k| egui::Event::Key {
        key: k,
        physical_key: None,
        pressed: true,
        repeat: false,
        modifiers: Default::default(),
    };
    run(&mut s, vec![key(egui::Key::B)]);
    assert_eq!(s.view_mode, ViewMode::Reference);
    run(&mut s, vec![key(egui::Key::D)]);
    assert_eq!(s.view_mode, ViewMode::Difference);
    s.act(Action::CancelReference).expect("cancel");
}

#[test]
fn spot_handle_aims_the_light_and_temporal_frames_settle() {
    let Some(d) = device() else { return };
    let mut s = session(d);
    let h = super::pick::spot_handle(s.scene(), 0).expect("a spot light");
    let (q, _) = project(&s.scene().camera, h).expect("the handle is in view");
    let dir0 = match &s.scene().lights[0] {
        caustics::scene::Light::Spot { direction, .. } => *direction,
        _ => unreachable!(),
    };
    s.act(Action::Press { x: q.x, y: q.y, mods: Mods::default() }).expect("press");
    assert_eq!(s.selection, Some(Selection::Light(0)));
    s.act(Action::Drag { x: q.x + 8.0, y: q.y }).expect("drag");
    s.act(Action::Release).expect("release");
    let (pos, dir) = match &s.scene().lights[0] {
        caustics::scene::Light::Spot { position, direction, .. } => (*position, *direction),
        _ => unreachable!(),
    };
    assert!(dir.dot(dir0) < 0.9999, "the light was not aimed");
    let h2 = super::pick::spot_handle(s.scene(), 0).expect("spot");
    let (q2, _) = project(&s.scene().camera, h2).expect("in view");
    assert!(q2.x > q.x + 1.0, "the handle did not follow the mouse: {q:?} -> {q2:?}");
    assert_eq!(s.scene().lights[0].position(), Some(pos));
    // The temporal filter renders a few frames more after a change, then stops.
    s.act(Action::SetTemporal(true)).expect("temporal");
    let mut n = 0;
    while s.render().expect("frame") {
        n += 1;
        assert!(n < 20, "frames never stop");
    }
    assert!(n > 1, "{n} frames");
}

/// A progressive interreflection cache keeps the viewer rendering while it refines (6 frames a
/// batch of history), then the viewer stops.
#[test]
fn a_progressive_cache_keeps_frames_coming_until_it_settles() {
    let Some(d) = device() else { return };
    let mut s = session(d);
    let mut on = s.settings().clone();
    on.indirect.photons = 4096;
    on.indirect.history = 2;
    s.act(Action::SetSettings(Box::new(on))).expect("settings");
    let mut n = 0;
    while s.render().expect("frame") {
        s.update();
        n += 1;
        assert!(n < 40, "frames never stop");
    }
    assert_eq!(n, 12, "frames of refinement (6 x history)");
}

/// A dropped file opens its scene (glTF here) at the view's size, its warnings in the status
/// line; a file that does not load leaves the scene as it was, the error in the panel.
#[test]
fn a_dropped_file_opens_its_scene_and_a_bad_one_keeps_the_old() {
    let Some(d) = device() else { return };
    let mut s = session(d);
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    s.act(Action::Open(dir.join("gltf/glass_ball.glb"))).expect("open a glb");
    assert_eq!(s.scene().source, dir.join("gltf/glass_ball.glb").display().to_string());
    assert_eq!((s.scene().camera.width, s.scene().camera.height), (96, 72));
    assert!(s.status.starts_with("opened"), "{}", s.status);
    frame(&mut s);
    let bad = tmp("broken.glb");
    std::fs::write(&bad, b"glTF\x02\x00\x00\x00").unwrap();
    assert!(s.act(Action::Open(bad.clone())).is_err());
    assert!(s.error.as_deref().is_some_and(|e| e.contains("broken.glb")), "{:?}", s.error);
    assert_eq!(s.scene().source, dir.join("gltf/glass_ball.glb").display().to_string());
}

/// The window's painting path offscreen: panels plus the renderer's display texture through
/// egui-wgpu. The view area shows the display texture's values unchanged (no second sRGB
/// encoding or decoding on the way).
#[test]
fn painting_shows_the_display_texture_unchanged() {
    let Some(d) = device() else { return };
    let mut s = session(d);
    let ctx = egui::Context::default();
    let mut state = UiState::new(1.0);
    state.overlays = false;
    let (w, h) = (700u32, 400u32);
    let format = wgpu::TextureFormat::Rgba8Unorm;
    let target = d.0.create_texture(&wgpu::TextureDescriptor {
        label: Some("offscreen window"),
        size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    });
    let view = target.create_view(&wgpu::TextureViewDescriptor::default());
    let mut painter = super::paint::Painter::new(&d.0, format);
    let screen = egui::Rect::from_min_size(egui::Pos2::ZERO, egui::vec2(w as f32, h as f32));
    let mut pass = |s: &mut Session, painter: &mut super::paint::Painter| {
        let raw = egui::RawInput { screen_rect: Some(screen), ..Default::default() };
        let display = painter.display_id();
        let out = ctx.run_ui(raw, |ui| ui::draw(ui, &mut state, s, display));
        painter.paint(&d.0, &d.1, &view, [w, h], &ctx, out);
    };
    pass(&mut s, &mut painter);
    pass(&mut s, &mut painter);
    assert!(s.render().expect("frame"));
    painter.set_display(&d.0, s.display().expect("a display texture"));
    pass(&mut s, &mut painter);
    let gpu = caustics::gpu::GpuContext::from_device(&d.0, &d.1);
    let shown = gpu.read_texture(&target, 0, 4).expect("read the window");
    let display = s.display().expect("display").clone();
    let want = gpu.read_texture(&display, 0, 4).expect("read the display texture");
    let (dw, dh) = (display.width(), display.height());
    assert_eq!(dh, h, "the view area is the window's height");
    let (mut abs, mut signed, mut n) = (0.0f64, 0.0f64, 0.0f64);
    // Away from the view area's right edge, where the panel's border lies.
    for y in 0..dh {
        for x in 0..dw.saturating_sub(4) {
            for c in 0..3 {
                let a = shown[((y * w + x) * 4 + c) as usize] as f64;
                let b = want[((y * dw + x) * 4 + c) as usize] as f64;
                abs += (a - b).abs();
                signed += a - b;
                n += 1.0;
            }
        }
    }
    let (abs, signed) = (abs / n, signed / n);
    eprintln!("window vs display texture: mean abs diff {abs:.3}, mean diff {signed:.3} of 255");
    assert!(
        abs < 3.0 && signed.abs() < 1.0,
        "the window shows the display texture off by {abs:.2} (mean |diff|), {signed:.2} (mean diff) of 255"
    );
}

/// Time-budget mode: with a budget far below what the grid costs, frames that redo the light
/// make the controller step the photon grid down; camera-only frames teach it nothing.
#[test]
fn time_budget_lowers_the_grid_from_light_frames_only() {
    let Some(d) = device() else { return };
    let mut s = session(d);
    s.act(Action::SetSettings(Box::new(RenderSettings {
        photons: caustics::settings::PhotonSettings { count: 256, ..small_settings().photons },
        ..small_settings()
    })))
    .expect("settings");
    frame(&mut s);
    s.act(Action::SetBudget(Some(0.01))).expect("budget");
    // Camera-only frames: the grid stays.
    for _ in 0..8 {
        s.act(Action::Orbit { dx: 2.0, dy: 0.0 }).expect("orbit");
        assert!(s.render().expect("frame"));
        s.wait_stats();
    }
    assert_eq!(s.settings().photons.count, 256, "camera-only frames moved the budget");
    // Frames that redo the light: the grid goes down.
    for k in 0..30 {
        let mut l = s.scene().lights[0].clone();
        if let caustics::scene::Light::Spot { position, .. } = &mut l {
            position.x += if k % 2 == 0 { 0.01 } else { -0.01 };
        }
        s.act(Action::SetLight(0, l)).expect("light");
        assert!(s.render().expect("frame"));
        s.wait_stats();
    }
    let q = s.budget().expect("budget on").quality();
    assert!(s.settings().photons.count < 256, "the grid did not come down: {}", s.settings().photons.count);
    assert_eq!(q.grid, s.settings().photons.count);
    s.act(Action::SetBudget(None)).expect("off");
    assert!(s.budget().is_none());
}

#[test]
fn environment_rotation_turns_its_lights_live() {
    // The sky scene: turning the environment turns its directional lights (no re-segmentation:
    // the same irradiances, directions rotated about +Y) and the frame after creates nothing.
    let Some(d) = device() else { return };
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes/glass_sphere_sky.json");
    let scene = Scene::load(&path).unwrap();
    let settings = RenderSettings {
        environment: caustics::settings::EnvironmentSettings { lights: 6, ..small_settings().environment },
        ..small_settings()
    };
    let mut s = Session::new(&d.0, &d.1, scene, settings, tmp("")).expect("a session on the sky scene");
    s.act(Action::Resize { width: 48, height: 36 }).unwrap();
    frame(&mut s);
    let before = s.renderer().environment_lights();
    // (The first frames fill the ring of statistics buffers; the turn after creates nothing.)
    for deg in [30.0, 60.0] {
        s.act(Action::SetEnvironmentRotation(deg)).unwrap();
        frame(&mut s);
        s.wait_stats();
    }
    s.act(Action::SetEnvironmentRotation(90.0)).unwrap();
    assert_eq!(s.renderer().environment_rotation(), Some(90.0));
    let created = s.renderer().created().total();
    frame(&mut s);
    assert_eq!(s.renderer().created().total(), created, "a turned environment creates nothing");
    let after = s.renderer().environment_lights();
    let r = glam::Mat3::from_rotation_y(90f32.to_radians());
    for (a, b) in before.iter().zip(&after) {
        assert_eq!(a.irradiance, b.irradiance);
        assert!((r * a.centre - b.centre).length() < 1e-5, "{} vs {}", r * a.centre, b.centre);
    }
    // The same rotation again changes nothing: no frame.
    s.act(Action::SetEnvironmentRotation(90.0)).unwrap();
    assert!(!s.render().unwrap());
}

#[test]
fn caustic_spheres_switch_loads_tables_and_follows_the_environment() {
    // Switching to caustic spheres precomputes (here: tiny tables) before the first frame that
    // needs them; the environment's directional lights then cast their caustics through the
    // spheres, and turning the environment turns the caustic with no new table.
    let Some(d) = device() else { return };
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes/glass_sphere_sky.json");
    let scene = Scene::load(&path).unwrap();
    let settings = RenderSettings {
        environment: caustics::settings::EnvironmentSettings { lights: 6, ..small_settings().environment },
        ..small_settings()
    };
    let mut s = Session::new(&d.0, &d.1, scene, settings, tmp("")).expect("a session on the sky scene");
    s.sphere_args = crate::spheres::SphereArgs {
        directions: 3,
        spheres: 4,
        sphere_size: (16, 12),
        sphere_photons: 1 << 12,
        half: false,
        sphere_cache: tmp("sphere-cache"),
        sphere_compiled: false,
    };
    s.act(Action::Resize { width: 48, height: 36 }).unwrap();
    let mut spheres_on = s.settings().clone();
    spheres_on.sources.distant = caustics::settings::DistantSource::Spheres;
    s.act(Action::SetSettings(Box::new(spheres_on))).unwrap();
    frame(&mut s);
    assert!(s.renderer().caustic_sphere_bytes() > 0, "tables set before the frame");
    let before = s.renderer().read_caustic_image().unwrap();
    assert!(before.sum() > 0.0, "the environment's caustic through the spheres");
    let bytes = s.renderer().caustic_sphere_bytes();
    s.act(Action::SetEnvironmentRotation(90.0)).unwrap();
    frame(&mut s);
    let after = s.renderer().read_caustic_image().unwrap();
    assert_eq!(s.renderer().caustic_sphere_bytes(), bytes);
    assert!(before.pixels != after.pixels, "the caustic turned with the environment");
}

#[test]
fn medium_density_and_beam_settings_change_live() {
    // The fog scene: doubling the medium's density changes the frame; a bad value is refused
    // and keeps the state; the loaded values again give the first frame bit for bit; the beams
    // gathered instead of drawn give the same caustic light; switching the beams off removes the
    // volume caustic (the caustic light in the fog).
    let Some(d) = device() else { return };
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes/volume_caustic_fog.json");
    let scene = Scene::load(&path).unwrap();
    let mut settings = small_settings();
    settings.beams.grid = 4;
    settings.beams.levels = 1;
    let mut s = Session::new(&d.0, &d.1, scene, settings, tmp("")).expect("a session on the fog scene");
    s.act(Action::Resize { width: 32, height: 32 }).unwrap();
    frame(&mut s);
    let first = s.renderer().read_image().unwrap();
    let caustic_sum = |s: &Session| -> f64 {
        s.renderer().read_caustic_image().unwrap().pixels.iter().flatten().map(|&v| v as f64).sum()
    };
    let with_beams = caustic_sum(&s);
    let m0 = s.loaded_medium().cloned().expect("the scene has a medium");
    // Denser fog.
    s.act(Action::SetMedium { sigma_s: m0.sigma_s * 2.0, sigma_a: m0.sigma_a * 2.0, phase: m0.phase }).unwrap();
    assert_eq!(s.scene().medium.as_ref().unwrap().sigma_s, m0.sigma_s * 2.0);
    frame(&mut s);
    let denser = s.renderer().read_image().unwrap();
    assert_ne!(denser.pixels, first.pixels, "doubling the density changed nothing");
    // A negative coefficient is refused, named, and changes nothing.
    let e = s.act(Action::SetMedium { sigma_s: -m0.sigma_s, sigma_a: m0.sigma_a, phase: m0.phase }).unwrap_err();
    assert!(e.to_string().contains("medium.sigma_s"), "{e}");
    assert!(s.error.is_some());
    assert_eq!(s.scene().medium.as_ref().unwrap().sigma_s, m0.sigma_s * 2.0);
    let e = s
        .act(Action::SetMedium {
            sigma_s: m0.sigma_s,
            sigma_a: m0.sigma_a,
            phase: caustics::scene::Phase::HenyeyGreenstein { g: 1.0 },
        })
        .unwrap_err();
    assert!(e.to_string().contains("medium.phase.g"), "{e}");
    // Back to the scene's values: the first frame again, bit for bit.
    s.act(Action::SetMedium { sigma_s: m0.sigma_s, sigma_a: m0.sigma_a, phase: m0.phase }).unwrap();
    frame(&mut s);
    let again = s.renderer().read_image().unwrap();
    let diff: Vec<(usize, f32, f32)> = (again.pixels.iter().zip(&first.pixels).enumerate())
        .filter(|(_, (a, b))| a != b)
        .map(|(i, (a, b))| (i, a[0], b[0]))
        .collect();
    assert!(
        diff.is_empty(),
        "restored medium, other image: {} pixels differ, e.g. {:?}",
        diff.len(),
        &diff[..diff.len().min(8)]
    );
    // The way the beams are drawn, switched live (auto: hulls where the adapter blends float32
    // targets; then the gather): the same volume caustic to rounding.
    let mut gather = s.settings().clone();
    gather.beams.volume = caustics::render::BeamVolume::Gather;
    s.act(Action::SetSettings(Box::new(gather))).unwrap();
    frame(&mut s);
    let gathered = caustic_sum(&s);
    assert!((gathered / with_beams - 1.0).abs() < 1e-5, "caustic light: {with_beams} drawn, {gathered} gathered");
    // The lit floor's glow off (`medium_bounce_grid` 0): the fog over the floor darkens.
    let sum = |img: &caustics::image_io::Image| -> f64 { img.pixels.iter().flatten().map(|&v| v as f64).sum() };
    let glowing = sum(&s.renderer().read_image().unwrap());
    let mut dark = s.settings().clone();
    dark.medium.bounce_grid = 0;
    s.act(Action::SetSettings(Box::new(dark))).unwrap();
    frame(&mut s);
    let unlit = sum(&s.renderer().read_image().unwrap());
    assert!(unlit < glowing, "image: {glowing} with the glow, {unlit} without");
    // The medium beyond glass off ("fog seen through glass"): the pixels that see glass change.
    let beyond = s.renderer().read_image().unwrap();
    let mut near = s.settings().clone();
    near.medium.beyond_specular = false;
    s.act(Action::SetSettings(Box::new(near))).unwrap();
    frame(&mut s);
    let changed = s.renderer().read_image().unwrap().pixels.iter().zip(&beyond.pixels).filter(|(a, b)| a != b).count();
    assert!(changed > 0, "the medium beyond glass switched off changed no pixel");
    let mut back = s.settings().clone();
    back.medium.beyond_specular = true;
    s.act(Action::SetSettings(Box::new(back))).unwrap();
    frame(&mut s);
    // Beams off: the caustic light in the fog goes.
    let mut off = s.settings().clone();
    off.sources.volume = caustics::settings::VolumeSource::None;
    s.act(Action::SetSettings(Box::new(off))).unwrap();
    frame(&mut s);
    let without = caustic_sum(&s);
    assert!(with_beams > 0.0 && without < with_beams, "caustic light: beams {with_beams}, none {without}");
    // The panel draws its medium section (no input: nothing but the view area's size changes).
    let ctx = egui::Context::default();
    let mut state = UiState::new(1.0);
    let raw = egui::RawInput {
        screen_rect: Some(egui::Rect::from_min_size(egui::Pos2::ZERO, egui::vec2(700.0, 700.0))),
        ..Default::default()
    };
    drop(ctx.run_ui(raw, |ui| ui::draw(ui, &mut state, &mut s, None)));
    assert!(s.error.is_none(), "{:?}", s.error);
}

#[test]
fn the_pool_plays_its_waves() {
    // An animated scene: a time poses the waves (the renderer's mesh changes, the view's
    // generation too), the same time again renders nothing, and playing keeps frames coming
    // with the time moving on; pausing stops them.
    let Some(d) = device() else { return };
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes/pool_sun.json");
    let scene = Scene::load(&path).unwrap();
    let mut s = Session::new(&d.0, &d.1, scene.clone(), small_settings(), tmp("")).expect("a session on the pool");
    assert!(s.animated());
    s.act(Action::Resize { width: 32, height: 24 }).unwrap();
    frame(&mut s);
    let mesh = |s: &Session| match &s.scene().objects[0].shape {
        caustics::scene::Shape::Mesh(m) => m.positions.clone(),
        _ => panic!("the water is no mesh"),
    };
    let rest = mesh(&s);
    let g = s.generation();
    s.act(Action::SetTime(0.5)).unwrap();
    assert!(s.generation() > g && s.needs_frame());
    frame(&mut s);
    let posed = mesh(&s);
    assert_ne!(rest, posed, "the waves did not move");
    let caustics::scene::Shape::Mesh(want) = &scene.at_time(0.5).objects[0].shape else { unreachable!() };
    assert_eq!(posed, want.positions, "the renderer's waves are not the scene's at 0.5 s");
    s.act(Action::SetTime(0.5)).unwrap();
    assert!(!s.render().unwrap(), "the same time rendered again");
    s.act(Action::Play(true)).unwrap();
    for _ in 0..2 {
        std::thread::sleep(std::time::Duration::from_millis(20));
        assert!(s.render().unwrap(), "playing renders");
        s.wait_stats();
    }
    assert!(s.time() > 0.5 && s.playing());
    s.act(Action::Play(false)).unwrap();
    s.render().unwrap();
    assert!(!s.needs_frame(), "paused, yet frames keep coming");
}
