//! The persistent renderer: what a frame loop gets.
//!
//! - steady state: after the first frame of a configuration, frames (full, camera-only, moved
//!   light, moved object) create no GPU object;
//! - camera-only frames do no photon work, and a moved light redoes that light alone;
//! - a renderer brought to a state frame by frame (moved light, moved and rotated objects,
//!   changed settings, moved camera) renders the image and caustic maps of a fresh renderer
//!   set to that state, bit for bit.

use crate::common;
use caustics::Scene;
use caustics::render::{RenderSettings, SplatMode};
use caustics::renderer::{FrameRequest, FrameStats, Renderer};
use caustics::scene::Light;
use common::gpu;
use glam::{Affine3A, Quat, Vec3};
use std::path::Path;

fn small(mut scene: Scene) -> Scene {
    scene.camera.width = 96;
    scene.camera.height = 72;
    scene
}

fn settings() -> RenderSettings {
    RenderSettings {
        photons: caustics::settings::PhotonSettings { count: 64, caustic_map_size: 64, ..Default::default() },
        shading: caustics::settings::ShadingSettings { shadow_map_size: 256, ..Default::default() },
        ..Default::default()
    }
}

fn catalogue(name: &str) -> Scene {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    small(Scene::load(&dir.join(format!("{name}.json"))).unwrap())
}

/// One frame: encode, submit, wait; its statistics, and the GPU objects the encoding created.
fn frame(r: &mut Renderer) -> (FrameStats, u64) {
    let ctx = r.context().clone();
    let before = r.created();
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    r.encode(&mut enc, FrameRequest { stats: true }).unwrap();
    let created = (r.created() - before).total();
    ctx.queue.submit([enc.finish()]);
    (r.wait_stats().unwrap().expect("the frame asked for statistics"), created)
}

fn moved_spot(light: &Light, dx: f32) -> Light {
    let mut l = light.clone();
    if let Light::Spot { position, .. } = &mut l {
        position.x += dx;
    }
    l
}

/// The image's and every light's fixed-point caustic flux, as bits.
fn bits(r: &Renderer) -> (Vec<u32>, Vec<Vec<u64>>) {
    let img = r.read_image().unwrap();
    let pixels = img.pixels.iter().flat_map(|p| p.map(f32::to_bits)).collect();
    let flux = (0..r.scene().lights.len()).map(|l| r.read_caustic_flux_bits(l).unwrap()).collect();
    (pixels, flux)
}

#[test]
fn steady_state_creates_nothing_and_redoes_only_what_changed() {
    let Some(ctx) = gpu() else { return };
    let mut scene = catalogue("glass_sphere");
    // A second spot light, off to the side.
    let second = moved_spot(&scene.lights[0], 1.0);
    scene.lights.push(second);
    let mut r = Renderer::with_context(ctx, scene, settings()).unwrap();
    let (first, created) = frame(&mut r);
    assert!(created > 0);
    assert_eq!(first.lights_redone, [true, true]);
    assert!(first.technique.photons_traced > 0);
    // A frame like the first (every light redone): nothing created.
    r.invalidate();
    let (full, created) = frame(&mut r);
    assert_eq!(created, 0, "a full frame after the first created GPU objects");
    assert_eq!(full.lights_redone, [true, true]);
    assert_eq!(full.technique.photons_traced, first.technique.photons_traced);
    // Camera only: no light redone, no photon traced, nothing created.
    let mut cam = r.scene().camera.clone();
    cam.position += Vec3::new(0.3, 0.1, -0.2);
    r.set_camera(cam).unwrap();
    let (camera, created) = frame(&mut r);
    assert_eq!(created, 0);
    assert_eq!(camera.lights_redone, [false, false]);
    assert_eq!(camera.technique.photons_traced, 0);
    assert!(camera.timings.iter().all(|(name, _)| !name.starts_with("light_") && !name.starts_with("photon_")));
    // The shading tiles are the light's work: made with its maps, not in camera frames.
    let tiles = |s: &FrameStats| s.timings.iter().any(|(name, _)| name == "caustic_mask" || name == "shadow_tiles");
    assert!(!tiles(&camera));
    assert!(full.timings.is_empty() || tiles(&full));
    // The flux bookkeeping of kept maps is still reported.
    assert_eq!(camera.flux, full.flux);
    // A moved light redoes that light alone.
    let l1 = moved_spot(&r.scene().lights[1], 0.2);
    r.set_light(1, l1).unwrap();
    let (light, created) = frame(&mut r);
    assert_eq!(created, 0);
    assert_eq!(light.lights_redone, [false, true]);
    assert_eq!(light.technique.photons_traced, first.technique.photons_traced / 2);
    // A moved object redoes the lights that see it (both see the ball).
    r.set_object_transform(0, Affine3A::from_translation(Vec3::new(0.1, 0.0, 0.05))).unwrap();
    let (object, created) = frame(&mut r);
    assert_eq!(created, 0);
    assert_eq!(object.lights_redone, [true, true]);
    // A new setting makes what it needs once; the frames after it create nothing.
    let mut s = r.settings().clone();
    s.photons.splat = SplatMode::Fixed;
    r.set_settings(s).unwrap();
    let (_, created) = frame(&mut r);
    assert!(created > 0);
    r.invalidate();
    let (_, created) = frame(&mut r);
    assert_eq!(created, 0);
}

/// Bring `r` to the state `steps` describe one frame at a time, then compare with a fresh
/// renderer set to the final state at once.
fn same_as_fresh(scene: Scene, object: usize, light_dx: f32, rotate: Quat) {
    let Some(ctx) = gpu() else { return };
    let mut r = Renderer::with_context(ctx.clone(), scene.clone(), settings()).unwrap();
    frame(&mut r);
    let light = moved_spot(&scene.lights[0], light_dx);
    r.set_light(0, light.clone()).unwrap();
    frame(&mut r);
    let t = Affine3A::from_rotation_translation(rotate, Vec3::new(0.15, 0.05, -0.1));
    r.set_object_transform(object, t).unwrap();
    frame(&mut r);
    let mut s = settings();
    s.photons.count = 128;
    r.set_settings(s.clone()).unwrap();
    frame(&mut r);
    let mut cam = scene.camera.clone();
    cam.position += Vec3::new(-0.4, 0.2, 0.3);
    r.set_camera(cam.clone()).unwrap();
    let (last, _) = frame(&mut r);
    assert_eq!(last.lights_redone, [false]);
    let kept = bits(&r);

    let mut fresh = Renderer::with_context(ctx, scene.clone(), s).unwrap();
    fresh.set_light(0, light).unwrap();
    fresh.set_object_transform(object, t).unwrap();
    fresh.set_camera(cam).unwrap();
    frame(&mut fresh);
    let want = bits(&fresh);
    assert!(want.1[0].iter().any(|&b| b != 0), "the caustic map is empty");
    assert!(kept.0 == want.0, "the image differs from a fresh renderer's");
    assert!(kept.1 == want.1, "the caustic map differs from a fresh renderer's");
    // And the object did move: the map differs from the scene file's pose. (`r.scene()` has
    // the transform baked in: a renderer of it with the identity transform is the moved scene.)
    let unmoved = {
        let mut u = Renderer::with_context(r.context().clone(), scene, r.settings().clone()).unwrap();
        u.set_light(0, moved_spot(&u.scene().lights[0], light_dx)).unwrap();
        frame(&mut u);
        bits(&u)
    };
    assert!(unmoved.1 != want.1);
}

#[test]
fn frame_by_frame_matches_a_fresh_renderer_analytic() {
    // The glass ball (an analytic sphere: exact intersection moves with it) rotated and moved.
    same_as_fresh(catalogue("glass_sphere"), 0, 0.3, Quat::from_rotation_y(0.7));
}

#[test]
fn frame_by_frame_matches_a_fresh_renderer_mesh() {
    // A glass mesh (the Stanford bunny), rotated about two axes and moved.
    let scene = catalogue("glass_bunny");
    let bunny = scene.objects.iter().position(|o| matches!(o.shape, caustics::scene::Shape::Mesh(_))).unwrap();
    same_as_fresh(scene, bunny, -0.2, Quat::from_rotation_y(0.5) * Quat::from_rotation_x(0.3));
}

#[test]
fn one_shot_render_is_the_renderers_first_frame() {
    let Some(ctx) = gpu() else { return };
    let scene = catalogue("glass_sphere");
    let once = caustics::render::render(&ctx, &scene, &settings()).unwrap();
    let mut r = Renderer::with_context(ctx, scene, settings()).unwrap();
    frame(&mut r);
    assert!(once.image == r.read_image().unwrap());
    assert!(once.caustic_flux_bits[0] == r.read_caustic_flux_bits(0).unwrap());
    // The display texture is the PNG tone mapping of the image (within one 8-bit step: the GPU's
    // pow and the CPU's differ in the last bits).
    let img = r.read_image().unwrap();
    let tex = r_display(&mut r).clone();
    let disp = r.context().read_texture(&tex, 0, 4).unwrap();
    let mut worst = 0i32;
    for (p, d) in img.pixels.iter().zip(disp.chunks_exact(4)) {
        let want = caustics::image_io::tonemap(*p, r.scene().exposure);
        for c in 0..3 {
            worst = worst.max((want[c] as i32 - d[c] as i32).abs());
        }
    }
    assert!(worst <= 1, "display differs from the tone-mapped image by {worst} steps");
}

/// The display texture of a fresh frame.
fn r_display(r: &mut Renderer) -> &wgpu::Texture {
    let ctx = r.context().clone();
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    r.encode(&mut enc, FrameRequest::default()).unwrap();
    ctx.queue.submit([enc.finish()]);
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    let out = r.encode(&mut enc, FrameRequest::default()).unwrap();
    ctx.queue.submit([enc.finish()]);
    out.display
}

#[test]
fn bad_updates_are_input_errors() {
    let Some(ctx) = gpu() else { return };
    let scene = catalogue("glass_sphere");
    let mut r = Renderer::with_context(ctx, scene, settings()).unwrap();
    let shear = Affine3A::from_cols_array(&[1.0, 0.0, 0.0, 0.5, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]);
    let e = r.set_object_transform(0, shear).unwrap_err();
    assert!(e.is_input() && e.to_string().contains("objects[0].transform"), "{e}");
    assert!(r.set_object_transform(9, Affine3A::IDENTITY).unwrap_err().to_string().contains("objects[9]"));
    assert!(r.set_light(3, r.scene().lights[0].clone()).unwrap_err().is_input());
    let mut s = r.settings().clone();
    s.photons.count = 3;
    let e = r.set_settings(s).unwrap_err();
    assert!(e.to_string().contains("photons"), "{e}");
    assert_eq!(r.settings().photons.count, 64, "a refused setting leaves the old one");
}

#[test]
fn a_changed_material_matches_a_fresh_renderer() {
    let Some(ctx) = gpu() else { return };
    let scene = catalogue("glass_sphere");
    let glass = scene.objects[0].material;
    let mut r = Renderer::with_context(ctx.clone(), scene.clone(), settings()).unwrap();
    frame(&mut r);
    let before = bits(&r);
    let denser = caustics::scene::Material::clear_dielectric(1.7, 1.0);
    r.set_material(glass, denser).unwrap();
    let (stats, created) = frame(&mut r);
    assert_eq!(stats.lights_redone, [true]);
    assert_eq!(created, 0);
    let mut changed = scene.clone();
    changed.materials[glass] = denser;
    let mut fresh = Renderer::with_context(ctx, changed, settings()).unwrap();
    frame(&mut fresh);
    let (a, b) = (bits(&r), bits(&fresh));
    assert!(a == b, "a changed material differs from a fresh renderer's");
    assert!(a.1 != before.1, "the caustic did not change with the index of refraction");
    let bad = caustics::scene::Material::clear_dielectric(f32::NAN, 1.0);
    assert!(r.set_material(glass, bad).unwrap_err().is_input());
}

#[test]
fn adaptive_light_motion_creates_nothing() {
    // The adaptive hierarchy sizes its buffers from the casters' extent seen from the light: a
    // light moving a little keeps them.
    let Some(ctx) = gpu() else { return };
    let s = RenderSettings {
        photons: caustics::settings::PhotonSettings {
            emission: caustics::render::Emission::AdaptiveLevel,
            count: 512,
            ..settings().photons
        },
        ..settings()
    };
    let mut r = Renderer::with_context(ctx, catalogue("glass_sphere"), s).unwrap();
    frame(&mut r);
    for k in 1..6 {
        let l = moved_spot(&r.scene().lights[0], 0.1 * k as f32);
        r.set_light(0, l).unwrap();
        let (stats, created) = frame(&mut r);
        assert_eq!(stats.lights_redone, [true]);
        assert_eq!(created, 0, "frame {k} of a moving light created GPU objects");
    }
}

/// Moving an object by a transform renders what loading the scene with the object already
/// there renders (the CPU bakes the transform into the shape: an independent path), up to the
/// rounding of transforming vertices on the GPU instead of the CPU (measured on lavapipe: a
/// relative L1 difference of 3e-4 for the bunny's caustic map, 8e-5 for the sphere's; the
/// bound is 0.005, and the unmoved scene differs by 1.6).
///
/// The exact tracer's residual pass makes random Fresnel choices: a path through the bunny that
/// a rounding difference sends the other way diverges from then on (measured: a relative L1
/// difference of 0.019 with it, the noise of that pass), so this compares the deterministic
/// passes, and paths of at most 8 interactions: longer ones (chains of total internal
/// reflections inside the bunny's ears) are chaotic too, a rounding difference of the moved
/// vertices sending them elsewhere (measured at the default 16: 0.015).
fn transform_matches_baked(scene: Scene, object: usize, t: Affine3A) {
    let Some(ctx) = gpu() else { return };
    let settings = || RenderSettings {
        photons: caustics::settings::PhotonSettings { residual: false, max_depth: 8, ..settings().photons },
        ..settings()
    };
    let mut r = Renderer::with_context(ctx.clone(), scene.clone(), settings()).unwrap();
    r.set_object_transform(object, t).unwrap();
    frame(&mut r);
    let moved = r.read_caustic_maps(0).unwrap();
    let image = r.read_image().unwrap();
    let mut baked = scene.clone();
    baked.objects[object].shape = scene.objects[object].shape.transformed(&t).unwrap();
    let want = caustics::render::render(&ctx, &baked, &settings()).unwrap();
    let l1 = |a: &[[f32; 3]], b: &[[f32; 3]]| -> (f64, f64) {
        let d: f64 = a.iter().zip(b).map(|(p, q)| (0..3).map(|c| (p[c] - q[c]).abs() as f64).sum::<f64>()).sum();
        let s: f64 = b.iter().map(|q| q.iter().map(|&c| c as f64).sum::<f64>()).sum();
        (d, s)
    };
    let (d, s) = l1(&moved[0].pixels, &want.caustic_maps[0][0].pixels);
    assert!(s > 0.0, "empty caustic map");
    eprintln!("caustic map: relative L1 difference {:.5} to the baked scene", d / s);
    assert!(d / s < 0.005, "caustic map: relative L1 difference {:.4} to the baked scene", d / s);
    let (d, s) = l1(&image.pixels, &want.image.pixels);
    eprintln!("image: relative L1 difference {:.5} to the baked scene", d / s);
    assert!(d / s < 0.005, "image: relative L1 difference {:.4} to the baked scene", d / s);
    // And the move matters: the unmoved scene is far from it.
    let unmoved = caustics::render::render(&ctx, &scene, &settings()).unwrap();
    let (d, s) = l1(&unmoved.caustic_maps[0][0].pixels, &want.caustic_maps[0][0].pixels);
    eprintln!("unmoved: relative L1 difference {:.5}", d / s);
    assert!(d / s > 0.1, "the move changed the caustic map by only {:.4}", d / s);
}

#[test]
fn a_transformed_sphere_renders_as_the_baked_scene() {
    let t = Affine3A::from_rotation_translation(Quat::from_rotation_z(0.4), Vec3::new(0.25, -0.1, 0.1));
    transform_matches_baked(catalogue("glass_sphere"), 0, t);
}

#[test]
fn a_transformed_mesh_renders_as_the_baked_scene() {
    let scene = catalogue("glass_bunny");
    let bunny = scene.objects.iter().position(|o| matches!(o.shape, caustics::scene::Shape::Mesh(_))).unwrap();
    let t = Affine3A::from_scale_rotation_translation(
        Vec3::splat(0.9),
        Quat::from_rotation_y(0.8) * Quat::from_rotation_x(0.2),
        Vec3::new(0.1, 0.05, -0.15),
    );
    transform_matches_baked(scene, bunny, t);
}

/// `RenderSettings::shading_tiles` (`shade_receivers` skips the caustic lookups where the
/// light's caustic map is zero and the PCF where its shadow map decides, by the tiles made with
/// the light's maps) changes no bit of the image or of the caustic image: a glass ball with a
/// caustic under a spot light and a point light (six faces), a shadow map size that is not a
/// multiple of the tile, from three camera positions (camera-only frames of the same renderers).
#[test]
fn shading_tiles_change_no_bit() {
    let Some(ctx) = gpu() else { return };
    let mut scene = catalogue("glass_sphere");
    scene.lights.push(Light::Point { position: Vec3::new(0.9, 2.4, 0.7), intensity: Vec3::splat(15.0) });
    // Only the light refracted through the ball, so that the caustic is concentrated and most
    // tiles of the map are unlit (with the reflected branches the spot's whole cone gets some
    // light, and every tile of this small map is lit).
    let s = RenderSettings {
        photons: caustics::settings::PhotonSettings {
            caustic_map_size: 80,
            reflection: false,
            internal_reflection: false,
            residual: false,
            ..settings().photons
        },
        shading: caustics::settings::ShadingSettings { shadow_map_size: 250, ..settings().shading },
        ..settings()
    };
    assert!(s.testing.shading_tiles, "on by default");
    let mut on = Renderer::with_context(ctx.clone(), scene.clone(), s.clone()).unwrap();
    let mut off = Renderer::with_context(
        ctx,
        scene.clone(),
        RenderSettings { testing: caustics::settings::TestingSettings { shading_tiles: false, ..s.testing }, ..s },
    )
    .unwrap();
    let img_bits = |i: caustics::image_io::Image| i.pixels.iter().flat_map(|p| p.map(f32::to_bits)).collect::<Vec<_>>();
    for k in 0..3 {
        let mut cam = scene.camera.clone();
        cam.position += k as f32 * Vec3::new(0.5, -0.4, -0.6);
        on.set_camera(cam.clone()).unwrap();
        off.set_camera(cam).unwrap();
        let (stats, _) = frame(&mut on);
        assert_eq!(stats.lights_redone, [k == 0, k == 0]);
        frame(&mut off);
        assert!(img_bits(on.read_image().unwrap()) == img_bits(off.read_image().unwrap()), "image differs, camera {k}");
        let (c_on, c_off) = (on.read_caustic_image().unwrap(), off.read_caustic_image().unwrap());
        assert!(c_on.pixels.iter().any(|p| p[0] > 0.0), "no caustic in view, camera {k}");
        assert!(img_bits(c_on) == img_bits(c_off), "caustic image differs, camera {k}");
    }
    // Both answers of the caustic tiles occur: the spot light's map has tiles of 8 x 8 texels
    // with light and tiles without.
    let map = &on.read_caustic_maps(0).unwrap()[0];
    let m = 80usize;
    let lit = |tx: usize, ty: usize| {
        (ty * 8..(ty * 8 + 8).min(m)).any(|y| (tx * 8..(tx * 8 + 8).min(m)).any(|x| map.pixels[y * m + x][0] != 0.0))
    };
    let tiles: Vec<bool> =
        (0..m.div_ceil(8)).flat_map(|ty| (0..m.div_ceil(8)).map(move |tx| (tx, ty))).map(|(x, y)| lit(x, y)).collect();
    assert!(tiles.iter().any(|&t| t) && tiles.iter().any(|&t| !t));
}

/// `composite` lists the pixels whose nearest surface is specular and shades them in a second,
/// indirect dispatch over workgroups of 64. With the glass ball filling the frame, every pixel
/// is listed (37 × 29 = 16 × 64 + 49: the last workgroup is partial), and every one of them must
/// be shaded: through the ball each sees the lit floor or the sky, never the black a pixel the
/// second dispatch missed would keep.
#[test]
fn every_listed_specular_pixel_is_shaded() {
    let Some(ctx) = gpu() else { return };
    let mut scene = catalogue("glass_sphere_sky");
    scene.camera.width = 37;
    scene.camera.height = 29;
    scene.camera.position = Vec3::new(0.0, 0.5, 0.9);
    scene.camera.look_at = Vec3::new(0.0, 0.5, 0.0);
    let mut r = Renderer::with_context(ctx, scene, settings()).unwrap();
    frame(&mut r);
    let img = r.read_image().unwrap();
    assert_eq!(img.pixels.len(), 37 * 29);
    let dark: Vec<usize> = (0..img.pixels.len())
        .filter(|&i| !img.pixels[i].iter().all(|c| c.is_finite()) || img.pixels[i].iter().sum::<f32>() <= 0.0)
        .collect();
    assert!(dark.is_empty(), "{} pixels unshaded or not finite, first {:?}", dark.len(), &dark[..dark.len().min(8)]);
}
