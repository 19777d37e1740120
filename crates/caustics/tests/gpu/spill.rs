//! Spill faces of spot lights (`lightspace::spill_face`, `RenderSettings::spill_faces`): a
//! second, wider light face that receives the caustic light glass bends outside the spot's own
//! view.
//!
//! - geometry: the spot face and the spill face together see every point of the scene's
//!   bounds; the spill face's half-angle is capped at 75°;
//! - a glass ball close to a narrow spot light throws a third of its light outside the spot's
//!   view: with the spill face none is booked `lost_outside`, the landed flux rises by exactly
//!   what was lost, and the camera's caustic energy moves to the CPU reference's;
//! - the spot face's caustic map keeps the bits it has without the spill face; `Off` is the old
//!   path, and `Auto` on a scene that gets no spill face renders `Off`'s bits;
//! - two frames are bit-identical and the frames after the first create no GPU object.

use crate::common;
use caustics::Scene;
use caustics::lightspace::{LightView, MAX_SPOT_FRUSTUM_DEG};
use caustics::render::{RenderSettings, SpillFaces, Tracer, render};
use caustics::renderer::{FrameRequest, Renderer};
use caustics::scene::Light;
use common::gpu;
use glam::Vec3;
use std::path::Path;

/// A glass ball (radius 0.3 m) 0.6 m below a spot light (cone 32°, the ball's silhouette 30°)
/// over a 12 m floor: the light through the ball's rim bends past the spot's view (3.3 % of the
/// emitted flux at a 128² grid).
fn ball_near_spot() -> Scene {
    spot_scene(32.0, 3.4, 0.3, 12.0)
}

/// A small glass ball (radius 0.1 m) 2 m below the same spot light, narrowed to 12°, over a
/// 0.6 m floor: the scene's bounds lie inside the spot's view.
fn all_inside_spot() -> Scene {
    spot_scene(12.0, 2.0, 0.1, 0.6)
}

/// A spot light at (0, 4, 0) pointing down (`cone` degrees), a glass ball of `radius` at height
/// `y` on its axis, a square floor of side `floor` (m).
fn spot_scene(cone: f32, y: f32, radius: f32, floor: f32) -> Scene {
    let falloff = cone - 4.0;
    let json = format!(
        r#"{{"schema_version": 1, "name": "ball_near_spot",
        "camera": {{"position": [0, 4.5, 5.5], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov_y_deg": 40, "width": 64, "height": 48}},
        "lights": [{{"type": "spot", "position": [0, 4, 0], "direction": [0, -1, 0], "cone_angle_deg": {cone},
                     "falloff_start_deg": {falloff}, "intensity": [40, 40, 40]}}],
        "materials": {{"floor": {{"type": "diffuse", "albedo": 0.8}}, "glass": {{"type": "dielectric", "ior": 1.5, "ext_ior": 1.0}}}},
        "objects": [{{"type": "sphere", "center": [0, {y}, 0], "radius": {radius}, "material": "glass"}},
                    {{"type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [{floor}, {floor}], "material": "floor"}}]}}"#
    );
    Scene::from_json(&json, "ball_near_spot.json", Path::new(".")).unwrap()
}

fn settings(spill: SpillFaces) -> RenderSettings {
    RenderSettings {
        photons: caustics::settings::PhotonSettings {
            count: 128,
            caustic_map_size: 128,
            tracer: Tracer::Exact,
            ..Default::default()
        },
        shading: caustics::settings::ShadingSettings { shadow_map_size: 256, spill_faces: spill, ..Default::default() },
        ..Default::default()
    }
}

fn catalogue(name: &str) -> Scene {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    Scene::load(&dir.join(format!("{name}.json"))).unwrap()
}

fn bits(img: &caustics::image_io::Image) -> Vec<u32> {
    img.pixels.iter().flat_map(|p| p.map(f32::to_bits)).collect()
}

fn energy(img: &caustics::image_io::Image) -> f64 {
    img.pixels.iter().map(|p| (p[0] + p[1] + p[2]) as f64).sum()
}

#[test]
fn spot_and_spill_face_see_the_whole_scene() {
    let tan_cap = MAX_SPOT_FRUSTUM_DEG.to_radians().tan();
    for scene in [ball_near_spot(), catalogue("ball_over_bunny"), catalogue("glass_sphere"), catalogue("stacked_balls")]
    {
        let light = &scene.lights[0];
        let view = LightView::with_spill(&scene, light);
        assert_eq!(view.faces.len(), 2, "{}", scene.name);
        assert_eq!(view.emit_faces, 1);
        assert!(view.has_spill());
        // The spot face is LightView::new's, unchanged.
        assert_eq!(view.faces[0], LightView::new(&scene, light).faces[0]);
        // The spill face's half-angle: from the projection's x scale (1 / tan).
        let tan_half = 1.0 / view.faces[1].world_to_clip.col(0).truncate().length();
        assert!(tan_half <= tan_cap * 1.0001, "{}: tan {tan_half}", scene.name);
        let (lo, hi) = scene.bounds();
        let m = 256;
        let mut in_spill = 0;
        // Points the 75° square sees (from the spot's eye, along its axis) lie in a face.
        let Light::Spot { position, direction, .. } = light else { unreachable!() };
        let eye = glam::Mat4::look_at_rh(*position, *position + *direction, Vec3::Z);
        for k in 0..=20u32 * 20 * 20 {
            // A 21³ lattice over the bounds, corners included.
            let t = Vec3::new((k % 21) as f32, (k / 21 % 21) as f32, (k / 441) as f32) / 20.0;
            let p = lo + (hi - lo) * t;
            let v = eye.transform_point3(p);
            if -v.z <= 0.0 || v.x.abs().max(v.y.abs()) > -v.z * tan_cap * 0.999 {
                assert_ne!(scene.name, "glass_sphere", "its bounds lie inside the cap");
                continue;
            }
            let (f, x, y) = view.project(p, m).unwrap_or_else(|| panic!("{}: {p} outside both faces", scene.name));
            assert!((0.0..=m as f32).contains(&x) && (0.0..=m as f32).contains(&y));
            in_spill += (f == 1) as u32;
        }
        assert!(in_spill > 0, "{}: the spill face sees nothing the spot face does not", scene.name);
    }
    // A scene reaching behind the light: the spill face is capped at 75°.
    let mut scene = ball_near_spot();
    if let Light::Spot { position, .. } = &mut scene.lights[0] {
        position.y = 0.5;
    }
    let view = LightView::with_spill(&scene, &scene.lights[0]);
    let tan_half = 1.0 / view.faces[1].world_to_clip.col(0).truncate().length();
    assert!((tan_half / tan_cap - 1.0).abs() < 1e-4, "capped: tan {tan_half} against {tan_cap}");
    // Point and directional lights and wide spots get none.
    let mut wide = ball_near_spot();
    if let Light::Spot { cone_angle, .. } = &mut wide.lights[0] {
        *cone_angle = 80f32.to_radians();
    }
    assert_eq!(LightView::with_spill(&wide, &wide.lights[0]), LightView::new(&wide, &wide.lights[0]));
}

#[test]
fn auto_rule() {
    let s = RenderSettings::default();
    // Glass in the view and a floor past the cone.
    assert!(s.uses_spill_face(&ball_near_spot(), &ball_near_spot().lights[0]));
    let bob = catalogue("ball_over_bunny");
    assert!(s.uses_spill_face(&bob, &bob.lights[0]));
    // A floor inside the spot's view: no face.
    let small = all_inside_spot();
    assert!(!s.uses_spill_face(&small, &small.lights[0]));
    // Off never, On where Auto would not; caustic maps over 1024² not under Auto.
    assert!(
        !RenderSettings {
            shading: caustics::settings::ShadingSettings { spill_faces: SpillFaces::Off, ..s.shading },
            ..s.clone()
        }
        .uses_spill_face(&bob, &bob.lights[0])
    );
    assert!(
        RenderSettings {
            shading: caustics::settings::ShadingSettings { spill_faces: SpillFaces::On, ..s.shading },
            ..s.clone()
        }
        .uses_spill_face(&small, &small.lights[0])
    );
    assert!(
        !RenderSettings {
            photons: caustics::settings::PhotonSettings { caustic_map_size: 2048, ..s.photons },
            ..s.clone()
        }
        .uses_spill_face(&bob, &bob.lights[0])
    );
    // Lights whose surface caustic comes from beams: never.
    let beams = RenderSettings {
        shading: caustics::settings::ShadingSettings { spill_faces: SpillFaces::On, ..s.shading },
        sources: caustics::settings::SourceSettings {
            local: caustics::render::LocalSource::Beams,
            ..Default::default()
        },
        ..s.clone()
    };
    assert!(!beams.uses_spill_face(&bob, &bob.lights[0]));
    assert_eq!(s.light_view(&small, &small.lights[0]), LightView::new(&small, &small.lights[0]));
}

#[test]
fn spill_face_lands_the_light_outside_the_spot() {
    let Some(ctx) = gpu() else { return };
    let scene = ball_near_spot();
    let off = render(&ctx, &scene, &settings(SpillFaces::Off)).unwrap();
    let on = render(&ctx, &scene, &settings(SpillFaces::Auto)).unwrap();
    assert_eq!(off.caustic_maps[0].len(), 1);
    assert_eq!(on.caustic_maps[0].len(), 2);
    let (a, b) = (&off.flux[0], &on.flux[0]);
    eprintln!("off: {a:?}\nauto: {b:?}");
    // Same photons (the spot face alone emits).
    assert_eq!(a.emitted, b.emitted);
    assert_eq!(off.photons_traced, on.photons_traced);
    assert!(a.lost_outside > 0.02 * a.emitted, "the stand-in scene must lose light outside the spot's view");
    assert!(b.lost_outside <= 1e-3 * b.emitted, "lost outside with the spill face: {}", b.lost_outside / b.emitted);
    // Landed rises by what was lost (the other books do not move).
    assert!(((b.landed - a.landed) - (a.lost_outside - b.lost_outside)).abs() <= 1e-6 * a.emitted);
    assert_eq!(a.lost_no_receiver, b.lost_no_receiver);
    // The spot face's map keeps its bits: the spill face only adds.
    let m = 128 * 128 * 3;
    assert_eq!(off.caustic_flux_bits[0][..m], on.caustic_flux_bits[0][..m]);
    assert!(on.caustic_flux_bits[0][m..].iter().any(|&w| w != 0));
    // The camera's caustic energy against the CPU reference (first-diffuse paths, the ones the
    // GPU renders): the spill face brings it close.
    let rs = caustics_reference::reference::ReferenceSettings {
        photons_per_light: 2_000_000,
        camera_spp: 1,
        caustic_map_size: 16,
        caustic_paths: caustics_reference::reference::CausticPaths::FirstDiffuse,
        ..Default::default()
    };
    let cpu = caustics_reference::reference::render(&scene, &rs).unwrap();
    let (eo, ea, ec) = (energy(&off.caustic), energy(&on.caustic), energy(&cpu.caustic));
    eprintln!("camera caustic energy / CPU: off {:.4}, auto {:.4}", eo / ec, ea / ec);
    assert!((ea / ec - 1.0).abs() < (eo / ec - 1.0).abs());
    assert!((ea / ec - 1.0).abs() < 0.05, "auto / CPU {}", ea / ec);
}

#[test]
fn off_and_auto_without_a_spill_face_agree_bit_for_bit() {
    let Some(ctx) = gpu() else { return };
    // The floor lies inside the spot's view: Auto adds no face.
    let scene = all_inside_spot();
    let off = render(&ctx, &scene, &settings(SpillFaces::Off)).unwrap();
    let auto = render(&ctx, &scene, &settings(SpillFaces::Auto)).unwrap();
    assert_eq!(auto.caustic_maps[0].len(), 1);
    assert_eq!(bits(&off.image), bits(&auto.image));
    assert_eq!(bits(&off.caustic), bits(&auto.caustic));
    assert_eq!(off.caustic_flux_bits, auto.caustic_flux_bits);
}

#[test]
fn frames_with_a_spill_face_are_deterministic_and_create_nothing() {
    let Some(ctx) = gpu() else { return };
    let mut r = Renderer::with_context(ctx.clone(), ball_near_spot(), settings(SpillFaces::Auto)).unwrap();
    let frame = |r: &mut Renderer| {
        let before = r.created();
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        r.encode(&mut enc, FrameRequest { stats: true }).unwrap();
        let created = (r.created() - before).total();
        ctx.queue.submit([enc.finish()]);
        let st = r.wait_stats().unwrap().expect("stats");
        let img = r.read_image().unwrap();
        (st, created, bits(&img), r.read_caustic_flux_bits(0).unwrap())
    };
    let (first, created, img1, flux1) = frame(&mut r);
    assert!(created > 0);
    assert!(first.technique.photons_traced > 0);
    assert_eq!(flux1.len(), 2 * 128 * 128 * 3, "two faces");
    r.invalidate();
    let (_, created, img2, flux2) = frame(&mut r);
    assert_eq!(created, 0, "a full frame after the first created GPU objects");
    assert_eq!(img1, img2);
    assert_eq!(flux1, flux2);
    // Camera only: no photon work, nothing created.
    let mut cam = r.scene().camera.clone();
    cam.position.x += 0.2;
    r.set_camera(cam).unwrap();
    let (st, created, _, _) = frame(&mut r);
    assert_eq!(created, 0);
    assert_eq!(st.technique.photons_traced, 0);
    assert_eq!(st.lights_redone, [false]);
}

#[test]
fn the_temporal_filter_keeps_a_static_spill_face() {
    let Some(ctx) = gpu() else { return };
    use caustics::temporal::{TemporalFilter, TemporalSettings};
    let scene = ball_near_spot();
    let s = settings(SpillFaces::Auto);
    let unfiltered = render(&ctx, &scene, &s).unwrap();
    let mut filter = TemporalFilter::new(TemporalSettings::default());
    for frame in 0..2 {
        let out = filter.render(&ctx, &scene, &s).unwrap();
        let raw = filter.raw_maps(&ctx).unwrap();
        assert_eq!(raw[0].len(), 2);
        for (f, map) in raw[0].iter().enumerate() {
            assert_eq!(bits(&out.caustic_maps[0][f]), bits(map), "frame {frame} face {f}");
            assert_eq!(bits(map), bits(&unfiltered.caustic_maps[0][f]), "frame {frame} face {f}");
        }
        assert_eq!(bits(&out.image), bits(&unfiltered.image), "frame {frame}");
        let st = filter.stats(&ctx).unwrap()[0];
        assert_eq!(st.rejected + st.blended, 2 * 128 * 128);
    }
}
