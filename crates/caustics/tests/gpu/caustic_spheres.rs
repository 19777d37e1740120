//! Caustic spheres on the GPU (`sphere_gather`): the eye-space pass against the CPU evaluation
//! of the same tables, linearity in the lights, a moved object, and no photons traced for the
//! directional lights the spheres handle. Small sizes for lavapipe.

use crate::common;
use caustics::Scene;
use caustics::caustic_spheres::{Blend, CausticSpheres, DirectionLayout, SphereSettings};
use caustics::image_io::Image;
use caustics::render::RenderSettings;
use caustics::renderer::Renderer;
use caustics::scene::Light;
use caustics_reference::reference::Progress;
use caustics_reference::reference::spheres;
use common::gpu;
use glam::Vec3;
use std::path::Path;
use std::sync::{Arc, OnceLock};

fn settings() -> SphereSettings {
    SphereSettings { directions: 5, spheres: 8, width: 32, height: 32, photons: 1 << 15, max_depth: 16 }
}

fn scene(lights: &[(Vec3, [f32; 3])]) -> Scene {
    scene_with(lights, "")
}

fn scene_with(lights: &[(Vec3, [f32; 3])], extra: &str) -> Scene {
    let lights: Vec<String> = lights
        .iter()
        .map(|(d, e)| {
            format!(
                r#"{{ "type": "directional", "direction": [{}, {}, {}], "irradiance": [{}, {}, {}] }}"#,
                d.x, d.y, d.z, e[0], e[1], e[2]
            )
        })
        .collect();
    let json = format!(
        r#"{{ "schema_version": 1, "name": "spheres_gpu",
        "camera": {{ "position": [0, 3.2, 2.4], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov_y_deg": 40, "width": 64, "height": 64 }},
        "lights": [ {} ],
        "materials": {{ "floor": {{ "type": "diffuse", "albedo": 0.8 }}, "glass": {{ "type": "dielectric", "ior": 1.5 }} }},
        "objects": [
          {{ "type": "sphere", "center": [0, 1, 0], "radius": 0.5, "material": "glass" }},
          {{ "type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [8, 8], "material": "floor" }}
          {}
        ] }}"#,
        lights.join(", "),
        extra
    );
    Scene::from_json(&json, "spheres_gpu.json", Path::new(".")).unwrap()
}

fn table() -> Arc<CausticSpheres> {
    static T: OnceLock<Arc<CausticSpheres>> = OnceLock::new();
    T.get_or_init(|| {
        let s = scene(&[(Vec3::NEG_Y, [1.0; 3])]);
        Arc::new(spheres::precompute(&s, 0, &settings(), None, &Progress::new()).unwrap())
    })
    .clone()
}

fn render(
    ctx: &caustics::gpu::GpuContext,
    scene: &Scene,
    transform: Option<glam::Affine3A>,
) -> caustics::render::GpuRender {
    render_samples(ctx, scene, transform, 1)
}

/// [`render`] with `samples` × `samples` lookups per pixel (`render` takes the pixel's centre,
/// as the CPU evaluation with one ray per pixel).
fn render_samples(
    ctx: &caustics::gpu::GpuContext,
    scene: &Scene,
    transform: Option<glam::Affine3A>,
    samples: u32,
) -> caustics::render::GpuRender {
    let s = RenderSettings {
        photons: caustics::settings::PhotonSettings { count: 64, caustic_map_size: 128, ..Default::default() },
        sources: caustics::settings::SourceSettings {
            distant: caustics::settings::DistantSource::Spheres,
            ..Default::default()
        },
        shading: caustics::settings::ShadingSettings { shadow_map_size: 256, ..Default::default() },
        ..Default::default()
    };
    let mut r = Renderer::with_context(ctx.clone(), scene.clone(), s).unwrap();
    r.set_caustic_spheres(vec![(0, table())], Blend::Triangle, false).unwrap();
    r.set_caustic_sphere_samples(samples).unwrap();
    if let Some(t) = transform {
        r.set_object_transform(0, t).unwrap();
    }
    r.render_once().unwrap()
}

fn rel_l1(a: &Image, b: &Image) -> f64 {
    let (mut d, mut s) = (0.0f64, 0.0f64);
    for (x, y) in a.pixels.iter().zip(&b.pixels) {
        for c in 0..3 {
            d += (x[c] - y[c]).abs() as f64;
            s += y[c].abs() as f64;
        }
    }
    d / s.max(1e-30)
}

#[test]
fn gather_matches_cpu_evaluation() {
    let Some(ctx) = gpu() else { return };
    let lights = [
        (Vec3::new(0.3, -1.0, 0.2).normalize(), [2.0, 0.3, 0.3]),
        (Vec3::new(-0.4, -1.0, 0.1).normalize(), [0.3, 2.0, 0.3]),
        (Vec3::new(0.05, -1.0, -0.45).normalize(), [0.3, 0.3, 2.0]),
    ];
    let sc = scene(&lights);
    let out = render(&ctx, &sc, None);
    // The directional lights' passes trace no photons: their caustics are the spheres'.
    assert_eq!(out.photons_traced, 0);
    let t = table();
    let cpu =
        spheres::render_caustic(&sc, &[(0, &t)], &DirectionLayout::new(settings().directions), Blend::Triangle, 1);
    let e = rel_l1(&out.caustic, &cpu);
    eprintln!("GPU vs CPU evaluation: relative L1 {e}, sums {} {}", out.caustic.sum(), cpu.sum());
    // The same table, lookup and blend in f32 on both sides; the pixels' receiver points come
    // from the rasterizer on the GPU and from ray casting on the CPU (measured: 2e-4).
    assert!(e < 2e-3, "relative L1 {e}");
    assert!(cpu.sum() > 0.0);
}

#[test]
fn box_filter_over_the_pixel_matches_cpu_supersampling() {
    // A light straight down focuses the ball's caustic into a spot a few pixels wide: the GPU's
    // 4 × 4 points per pixel on the receiver's tangent plane against the CPU evaluation with
    // 4 × 4 camera rays per pixel (the box filter), and against one point per pixel.
    let Some(ctx) = gpu() else { return };
    let sc = scene(&[(Vec3::new(0.05, -1.0, 0.1).normalize(), [1.0; 3])]);
    let box4 = render_samples(&ctx, &sc, None, 4).caustic;
    let t = table();
    let layout = DirectionLayout::new(settings().directions);
    let cpu4 = spheres::render_caustic(&sc, &[(0, &t)], &layout, Blend::Triangle, 4);
    let cpu1 = spheres::render_caustic(&sc, &[(0, &t)], &layout, Blend::Triangle, 1);
    let (e4, e1) = (rel_l1(&box4, &cpu4), rel_l1(&cpu1, &cpu4));
    let sums = (box4.sum() / cpu4.sum(), cpu1.sum() / cpu4.sum());
    eprintln!("box filter 4 x 4: relative L1 {e4}, energy {} (one point per pixel: {e1}, {})", sums.0, sums.1);
    // The footprint from the neighbouring receiver points is the pixel's up to perspective
    // across one pixel and the ball's silhouette. Measured: 0.0049 (one point per pixel 0.035),
    // energy 1.002 (one point 0.973).
    assert!(e4 < 0.02 && e4 < 0.5 * e1, "relative L1 {e4} (one point: {e1})");
    assert!((sums.0 - 1.0).abs() < 0.02, "energy {}", sums.0);
}

#[test]
fn two_lights_add_on_the_gpu() {
    let Some(ctx) = gpu() else { return };
    let a = (Vec3::new(0.3, -1.0, 0.1).normalize(), [3.0, 1.0, 0.5]);
    let b = (Vec3::new(-0.4, -1.0, -0.3).normalize(), [0.5, 2.0, 4.0]);
    let ab = render(&ctx, &scene(&[a, b]), None).caustic;
    let ia = render(&ctx, &scene(&[a]), None).caustic;
    let ib = render(&ctx, &scene(&[b]), None).caustic;
    let mut lit = 0;
    for ((x, y), z) in ab.pixels.iter().zip(&ia.pixels).zip(&ib.pixels) {
        for c in 0..3 {
            // f32 sums in another order: a few ulps.
            assert!((x[c] - (y[c] + z[c])).abs() <= 1e-5 * x[c].abs().max(1e-6), "{x:?} vs {y:?} + {z:?}");
        }
        lit += (x[0] > 0.0) as u32;
    }
    assert!(lit > 50, "{lit} lit pixels");
}

#[test]
fn moved_object_moves_its_caustic() {
    let Some(ctx) = gpu() else { return };
    // The ball moved by (0.6, 0, -0.3) and rotated about y: the GPU looks the table up in the
    // object's frame, as the CPU evaluation of the moved scene does.
    let l = Vec3::new(0.2, -1.0, 0.1).normalize();
    let t = glam::Affine3A::from_rotation_translation(glam::Quat::from_rotation_y(0.7), Vec3::ZERO);
    let shift = glam::Affine3A::from_translation(Vec3::new(0.6, 0.0, -0.3))
        * glam::Affine3A::from_translation(Vec3::new(0.0, 1.0, 0.0))
        * t
        * glam::Affine3A::from_translation(Vec3::new(0.0, -1.0, 0.0));
    let moved = render(&ctx, &scene(&[(l, [1.0; 3])]), Some(shift)).caustic;
    // CPU evaluation of the moved scene: same table, object at its new place.
    let mut sc = scene(&[(l, [1.0; 3])]);
    sc.objects[0].shape = sc.objects[0].shape.transformed(&shift).unwrap();
    let t = table();
    let cpu = spheres::render_caustic_moved(&sc, &[(0, &t)], &[shift], &DirectionLayout::new(5), Blend::Triangle, 1);
    let e = rel_l1(&moved, &cpu);
    eprintln!("moved: relative L1 {e}");
    // Measured: 1e-5.
    assert!(e < 2e-3, "relative L1 {e}");
    // And it did move: the unmoved caustic is elsewhere.
    let still = render(&ctx, &scene(&[(l, [1.0; 3])]), None).caustic;
    assert!(rel_l1(&still, &cpu) > 0.5);
}

#[test]
fn steady_frames_create_nothing() {
    let Some(ctx) = gpu() else { return };
    let l = Vec3::new(0.2, -1.0, 0.1).normalize();
    let s = RenderSettings {
        photons: caustics::settings::PhotonSettings { count: 64, caustic_map_size: 128, ..Default::default() },
        sources: caustics::settings::SourceSettings {
            distant: caustics::settings::DistantSource::Spheres,
            ..Default::default()
        },
        shading: caustics::settings::ShadingSettings { shadow_map_size: 256, ..Default::default() },
        ..Default::default()
    };
    let mut r = Renderer::with_context(ctx.clone(), scene(&[(l, [1.0; 3])]), s).unwrap();
    r.set_caustic_spheres(vec![(0, table())], Blend::Triangle, false).unwrap();
    let frame = |r: &mut Renderer| {
        let before = r.created();
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        r.encode(&mut enc, caustics::renderer::FrameRequest { stats: true }).unwrap();
        let created = (r.created() - before).total();
        ctx.queue.submit([enc.finish()]);
        r.wait_stats().unwrap();
        created
    };
    assert!(frame(&mut r) > 0);
    assert_eq!(frame(&mut r), 0, "a steady frame");
    // A light turned: the sphere records change, nothing is created.
    r.set_light(
        0,
        caustics::scene::Light::Directional {
            direction: Vec3::new(-0.3, -1.0, 0.2).normalize(),
            irradiance: Vec3::ONE,
        },
    )
    .unwrap();
    assert_eq!(frame(&mut r), 0, "a turned light");
    r.set_object_transform(0, glam::Affine3A::from_translation(Vec3::new(0.3, 0.0, 0.0))).unwrap();
    assert_eq!(frame(&mut r), 0, "a moved object");
    // The compiled variant: its table and records come from the pool too.
    r.set_caustic_spheres_compiled(true);
    assert!(frame(&mut r) > 0);
    assert_eq!(frame(&mut r), 0, "a steady compiled frame");
    r.set_light(0, caustics::scene::Light::Directional { direction: l, irradiance: Vec3::ONE }).unwrap();
    assert_eq!(frame(&mut r), 0, "a turned light, compiled");
}

#[test]
fn closed_box_around_the_object_gives_no_caustic() {
    let Some(ctx) = gpu() else { return };
    let l = Vec3::new(0.2, -1.0, 0.1).normalize();
    let open = render(&ctx, &scene(&[(l, [1.0; 3])]), None).caustic;
    assert!(open.pixels.iter().any(|p| p[0] > 0.0));
    // Six diffuse walls around the ball (half-size 0.7 about its centre (0, 1, 0)).
    let mut walls = String::new();
    for (n, u) in [([1.0f32, 0.0, 0.0], [0, 1, 0]), ([0.0, 1.0, 0.0], [0, 0, 1]), ([0.0, 0.0, 1.0], [1, 0, 0])] {
        for sgn in [-1.0f32, 1.0] {
            let c = Vec3::from(n) * 0.7 * sgn + Vec3::Y;
            walls += &format!(
                r#", {{ "type": "rectangle", "center": [{}, {}, {}], "normal": [{}, {}, {}], "u_axis": [{}, {}, {}], "size": [1.4, 1.4], "material": "floor" }}"#,
                c.x,
                c.y,
                c.z,
                n[0] * sgn,
                n[1] * sgn,
                n[2] * sgn,
                u[0],
                u[1],
                u[2]
            );
        }
    }
    let boxed = render(&ctx, &scene_with(&[(l, [1.0; 3])], &walls), None).caustic;
    // The camera sees the box's outside and the floor: the caustic cannot get out.
    assert!(boxed.pixels.iter().all(|p| p[0] == 0.0 && p[1] == 0.0 && p[2] == 0.0));
}

#[test]
fn half_float_table_matches_f32() {
    let Some(ctx) = gpu() else { return };
    let sc = scene(&[(Vec3::new(0.3, -1.0, 0.2).normalize(), [2.0, 1.0, 0.5])]);
    let s = RenderSettings {
        photons: caustics::settings::PhotonSettings { count: 64, caustic_map_size: 128, ..Default::default() },
        sources: caustics::settings::SourceSettings {
            distant: caustics::settings::DistantSource::Spheres,
            ..Default::default()
        },
        shading: caustics::settings::ShadingSettings { shadow_map_size: 256, ..Default::default() },
        ..Default::default()
    };
    let run = |half: bool| {
        let mut r = Renderer::with_context(ctx.clone(), sc.clone(), s.clone()).unwrap();
        r.set_caustic_spheres(vec![(0, table())], Blend::Triangle, half).unwrap();
        (r.render_once().unwrap().caustic, r.caustic_sphere_bytes())
    };
    let (full, full_bytes) = run(false);
    let (half, half_bytes) = run(true);
    assert_eq!(half_bytes * 2, full_bytes);
    let e = rel_l1(&half, &full);
    eprintln!("half vs f32: relative L1 {e}");
    // f16 keeps 11 significant bits: 2^-11 relative per value, averaged over a lookup.
    assert!(e < 1e-3, "relative L1 {e}");
}

/// `Technique::CausticSpheres` (what `--caustic-spheres` was): directional lights through the
/// spheres, a spot light through basic caustic maps, in one frame: its caustic image is the
/// basic technique's caustic of the spot light alone plus the spheres' of the directional
/// light alone.
#[test]
fn technique_adds_spheres_to_basic_caustic_maps_of_spot_lights() {
    let Some(ctx) = gpu() else { return };
    let dir = (Vec3::new(0.2, -1.0, 0.1).normalize(), [2.0, 1.5, 1.0]);
    let spot = Light::Spot {
        position: Vec3::new(0.4, 3.0, 0.3),
        direction: Vec3::new(-0.4, -2.0, -0.3).normalize(),
        cone_angle: 0.35,
        falloff_start: 0.25,
        intensity: Vec3::splat(20.0),
        profile: Default::default(),
    };
    let mut both = scene(&[dir]);
    both.lights.push(spot.clone());
    let mut spot_only = scene(&[dir]);
    spot_only.lights = vec![spot];
    let out = render(&ctx, &both, None);
    let s = RenderSettings {
        photons: caustics::settings::PhotonSettings { count: 64, caustic_map_size: 128, ..Default::default() },
        shading: caustics::settings::ShadingSettings { shadow_map_size: 256, ..Default::default() },
        ..Default::default()
    };
    let basic = caustics::render::render(&ctx, &spot_only, &s).unwrap();
    let gather = render(&ctx, &scene(&[dir]), None).caustic;
    // The spot light's photons are the basic technique's, the directional light's none.
    assert_eq!(out.photons_traced, basic.photons_traced);
    assert!(basic.photons_traced > 0);
    assert_eq!(out.technique.technique, caustics::settings::Emission::Basic);
    let mut sum = basic.caustic.clone();
    for (p, g) in sum.pixels.iter_mut().zip(&gather.pixels) {
        for c in 0..3 {
            p[c] += g[c];
        }
    }
    let e = rel_l1(&out.caustic, &sum);
    eprintln!("spheres + spot vs basic(spot) + spheres(directional): relative L1 {e}");
    assert!(basic.caustic.sum() > 0.0 && gather.sum() > 0.0);
    // The same passes add the same terms (measured: the same bits, relative L1 0); the bound
    // leaves room for a different order of the f32 additions.
    assert!(e < 1e-5, "relative L1 {e}");
}

/// The technique without tables is refused with a message saying what is missing.
#[test]
fn technique_without_tables_is_refused() {
    let Some(ctx) = gpu() else { return };
    let s = RenderSettings {
        photons: caustics::settings::PhotonSettings { count: 64, ..Default::default() },
        sources: caustics::settings::SourceSettings {
            distant: caustics::settings::DistantSource::Spheres,
            ..Default::default()
        },
        ..Default::default()
    };
    let mut r = Renderer::with_context(ctx.clone(), scene(&[(Vec3::NEG_Y, [1.0; 3])]), s).unwrap();
    let Err(e) = r.render_once() else { panic!("no tables: an error expected") };
    assert!(e.to_string().contains("set_caustic_spheres"), "{e}");
}

/// An occlusion ray that overflows the BVH stack is counted and reported: with the stack
/// lowered to one entry, rays past a tessellated (BVH) occluder overflow and the frame says so;
/// with the full stack, none do.
#[test]
fn occlusion_stack_overflows_are_reported() {
    let Some(ctx) = gpu() else { return };
    let l = Vec3::new(0.2, -1.0, 0.1).normalize();
    let extra = r#", { "type": "sphere", "center": [0.7, 0.3, 0.4], "radius": 0.25, "material": "floor" }"#;
    let mut sc = scene_with(&[(l, [1.0; 3])], extra);
    let k = sc.objects.len() - 1;
    let tess = caustics::scene::Tessellation { sphere_segments: 64, cylinder_segments: 64 };
    sc.objects[k].shape = caustics::scene::Shape::Mesh(Arc::new(sc.objects[k].shape.tessellate(&tess)));
    let s = RenderSettings {
        photons: caustics::settings::PhotonSettings { count: 64, caustic_map_size: 128, ..Default::default() },
        sources: caustics::settings::SourceSettings {
            distant: caustics::settings::DistantSource::Spheres,
            ..Default::default()
        },
        shading: caustics::settings::ShadingSettings { shadow_map_size: 256, ..Default::default() },
        ..Default::default()
    };
    let mut r = Renderer::with_context(ctx.clone(), sc, s).unwrap();
    r.set_caustic_spheres(vec![(0, table())], Blend::Triangle, false).unwrap();
    let full = r.render_once().expect("no overflow with the full stack");
    assert!(full.caustic.sum() > 0.0);
    r.set_caustic_sphere_stack_limit(1).unwrap();
    r.invalidate();
    let Err(e) = r.render_once() else { panic!("a one-entry stack overflows") };
    assert!(e.to_string().contains("caustic-sphere occlusion rays overflowed"), "{e}");
    assert!(r.set_caustic_sphere_stack_limit(0).is_err());
}

/// The compiled variant (section 6): every light summed into one table per object, one lookup
/// per object, against the direct variant (a lookup per light and blended direction). Three
/// coloured lights from above the ball: every light reaching the floor comes from its front,
/// so the vector sum loses nothing and the difference is the compiled table's resampling of
/// the blended caustic at its own cells.
#[test]
fn compiled_variant_matches_the_direct_one() {
    let Some(ctx) = gpu() else { return };
    let lights = [
        (Vec3::new(0.3, -1.0, 0.2).normalize(), [2.0, 0.3, 0.3]),
        (Vec3::new(-0.4, -1.0, 0.1).normalize(), [0.3, 2.0, 0.3]),
        (Vec3::new(0.05, -1.0, -0.45).normalize(), [0.3, 0.3, 2.0]),
    ];
    let sc = scene(&lights);
    let s = RenderSettings {
        photons: caustics::settings::PhotonSettings { count: 64, caustic_map_size: 128, ..Default::default() },
        sources: caustics::settings::SourceSettings {
            distant: caustics::settings::DistantSource::Spheres,
            ..Default::default()
        },
        shading: caustics::settings::ShadingSettings { shadow_map_size: 256, ..Default::default() },
        ..Default::default()
    };
    let mut r = Renderer::with_context(ctx.clone(), sc, s).unwrap();
    r.set_caustic_spheres(vec![(0, table())], Blend::Triangle, false).unwrap();
    let direct = r.render_once().unwrap();
    r.set_caustic_spheres_compiled(true);
    let compiled = r.render_once().unwrap();
    let ms = |o: &caustics::render::GpuRender, pass: &str| -> f64 {
        o.timings.iter().filter(|(p, _)| p == pass).map(|(_, m)| m).sum()
    };
    let e = rel_l1(&compiled.caustic, &direct.caustic);
    eprintln!(
        "compiled vs direct: relative L1 {e}, energy {}; gather {:.3} ms direct, {:.3} ms compiled (+ compile {:.3} ms)",
        compiled.caustic.sum() / direct.caustic.sum(),
        ms(&direct, "sphere_gather"),
        ms(&compiled, "sphere_gather"),
        ms(&compiled, "sphere_compile")
    );
    assert!(direct.caustic.sum() > 0.0);
    assert!((compiled.caustic.sum() / direct.caustic.sum() - 1.0).abs() < 0.05);
    assert!(e < 0.1, "relative L1 {e}");
}

/// The scene of `scene_with` lit by an environment map black but for `bright` texels
/// (x, y, radiance) of a 64 × 32 map, and the directional light standing for texel `k` of
/// `bright` (its direction, L·Ω).
fn env_scene(bright: &[(u32, u32, Vec3)], extra: &str) -> (Scene, Vec<Light>) {
    let (w, h) = (64u32, 32u32);
    let mut t = vec![Vec3::ZERO; (w * h) as usize];
    for &(x, y, v) in bright {
        t[(y * w + x) as usize] = v;
    }
    let env = caustics::scene::Environment::from_texels(w, h, t, 0.0).unwrap();
    let mut sc = scene_with(&[(Vec3::NEG_Y, [1.0; 3])], extra);
    sc.lights.clear();
    sc.environment = Some(Arc::new(env.clone()));
    let lights = bright
        .iter()
        .map(|&(x, y, v)| {
            let dir = env.direction(glam::Vec2::new((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32));
            Light::Directional { direction: -dir, irradiance: v * env.texel_solid_angle(y) }
        })
        .collect();
    (sc, lights)
}

/// The texel of the 64 × 32 map whose direction is nearest `want`.
fn texel_toward(want: Vec3) -> (u32, u32) {
    let env = caustics::scene::Environment::from_texels(64, 32, vec![Vec3::ZERO; 64 * 32], 0.0).unwrap();
    let mut best = (0, 0, -2.0f32);
    for y in 0..32 {
        for x in 0..64 {
            let d = env.direction(glam::Vec2::new((x as f32 + 0.5) / 64.0, (y as f32 + 0.5) / 32.0));
            if d.dot(want.normalize()) > best.2 {
                best = (x, y, d.dot(want.normalize()));
            }
        }
    }
    (best.0, best.1)
}

fn assert_same_caustic(a: &Image, b: &Image, what: &str) {
    let sum = |i: &Image| i.pixels.iter().map(|p| Vec3::from_array(*p)).sum::<Vec3>();
    let (sa, sb) = (sum(a), sum(b));
    let mut worst = 0.0f32;
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        worst = worst.max((Vec3::from_array(*p) - Vec3::from_array(*q)).abs().max_element());
    }
    let peak = b.pixels.iter().map(|p| p[0].max(p[1]).max(p[2])).fold(0.0f32, f32::max);
    eprintln!("{what}: caustic sums {sa} vs {sb}, worst pixel difference {worst} (peak {peak})");
    assert!(sb.min_element() > 0.0, "{what}: the directional light casts a caustic");
    // The region light of a one-texel region is the texel's direction and L·Ω, up to the f32
    // rounding of its segmentation (facing = L Ω (ω·ĉ)): a few ulps of each record.
    assert!(((sa / sb) - Vec3::ONE).abs().max_element() < 1e-4, "{what}: {sa} vs {sb}");
    assert!(worst <= 1e-4 * peak, "{what}: {worst} vs peak {peak}");
}

/// The environment through caustic spheres (the paper's method for its D region lights): a map
/// black but for one texel casts, through the spheres, the caustic of the directional light of
/// that texel's direction and L·Ω through the spheres.
#[test]
fn environment_texel_through_spheres_is_its_directional_light() {
    let Some(ctx) = gpu() else { return };
    let (x, y) = texel_toward(Vec3::new(0.4, 1.0, 0.25));
    let (env, lights) = env_scene(&[(x, y, Vec3::new(3000.0, 2000.0, 1000.0))], "");
    let r = render(&ctx, &env, None);
    assert_eq!(r.photons_traced, 0, "the region light's caustic comes from the spheres");
    let mut dir = env.clone();
    dir.environment = None;
    dir.lights = lights;
    let d = render(&ctx, &dir, None);
    assert_same_caustic(&r.caustic, &d.caustic, "one texel");
}

/// The region lights' visibility from the object (`Renderer::region_visibility`, the paper's
/// 32 × 32 render of each region with the occluders black) scales each region's caustic through
/// the spheres: two bright texels, one straight above the ball behind a diffuse plate (seen
/// from the ball's centre), one at 45° in the open; the caustic is the open texel's directional
/// light's alone, the plate in both scenes.
#[test]
fn region_visibility_scales_each_regions_caustic_through_spheres() {
    let Some(ctx) = gpu() else { return };
    let above = texel_toward(Vec3::Y);
    let open = texel_toward(Vec3::new(0.5, 0.7, 0.3));
    // A 0.6 m plate 1.5 m above the ball's centre: it hides the texel above (within 11° of
    // the zenith) from the centre, not the one at 45°, nor the floor from the centre or camera.
    let plate = r#", { "type": "rectangle", "center": [0, 2.5, 0], "normal": [0, -1, 0], "size": [0.6, 0.6], "material": "floor" }"#;
    let bright = [(above.0, above.1, Vec3::splat(2500.0)), (open.0, open.1, Vec3::new(1000.0, 3000.0, 2000.0))];
    let (env, lights) = env_scene(&bright, plate);
    let s = RenderSettings {
        photons: caustics::settings::PhotonSettings { count: 64, caustic_map_size: 128, ..Default::default() },
        sources: caustics::settings::SourceSettings {
            distant: caustics::settings::DistantSource::Spheres,
            ..Default::default()
        },
        shading: caustics::settings::ShadingSettings { shadow_map_size: 256, ..Default::default() },
        ..Default::default()
    };
    let mut r = Renderer::with_context(ctx.clone(), env.clone(), s).unwrap();
    r.set_caustic_spheres(vec![(0, table())], Blend::Triangle, false).unwrap();
    // One point per pixel, as `render`.
    r.set_caustic_sphere_samples(1).unwrap();
    // The two texels are two region lights, one hidden from the ball, one seen.
    let regions = r.environment_lights();
    let vis = r.region_visibility(0).unwrap();
    let seen: Vec<(Vec3, f32)> =
        regions.iter().zip(&vis).filter(|(l, _)| l.facing.max_element() > 0.0).map(|(l, v)| (l.centre, *v)).collect();
    assert_eq!(seen.len(), 2, "{seen:?}");
    for (c, v) in &seen {
        let want = if c.y > 0.95 { 0.0 } else { 1.0 };
        assert_eq!(*v, want, "region toward {c}: visibility {v}");
    }
    let both = r.render_once().unwrap().caustic;
    let mut only = env.clone();
    only.environment = None;
    only.lights = vec![lights[1].clone()];
    let d = render(&ctx, &only, None);
    assert_same_caustic(&both, &d.caustic, "the open texel");
    // Without the plate both regions are seen: the caustic is both directional lights'.
    let (free, _) = env_scene(&bright, "");
    let unoccluded = render(&ctx, &free, None).caustic;
    let mut two = free.clone();
    two.environment = None;
    two.lights = lights;
    let d2 = render(&ctx, &two, None);
    assert_same_caustic(&unoccluded, &d2.caustic, "both texels, no plate");
    assert!(unoccluded.sum() > both.sum() * 1.05, "{} vs {}", unoccluded.sum(), both.sum());
}

/// The visibility of the environment's regions from a caustic object, computed on the GPU
/// inside the frame (`sphere_visibility`, `sphere_visibility_sum`: f64 sums emulated), is the
/// CPU's `region_visibility` bit for bit, under a sky of varying texels (every region's sum
/// rounds) partly hidden by a plate off to one side (fractions strictly between 0 and 1), and
/// again after the plate moves (the values are redone when an object moves).
#[test]
fn gpu_region_visibility_is_the_cpus_bits() {
    let Some(ctx) = gpu() else { return };
    let (w, h) = (64u32, 32u32);
    let texels: Vec<Vec3> = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f32, (i / w) as f32);
            Vec3::new(1.0 + 0.37 * (x * 0.31).sin().abs(), 0.5 + 0.013 * y * x.cos().abs(), 0.1 + 0.007 * (x + 3.0 * y))
        })
        .collect();
    let env = caustics::scene::Environment::from_texels(w, h, texels, 0.0).unwrap();
    let plate = r#", { "type": "rectangle", "center": [0.9, 2.2, 0.3], "normal": [0, -1, 0], "size": [1.2, 0.9], "material": "floor" }"#;
    let mut sc = scene_with(&[(Vec3::NEG_Y, [1.0; 3])], plate);
    sc.lights.clear();
    sc.environment = Some(Arc::new(env));
    let mut s = RenderSettings {
        photons: caustics::settings::PhotonSettings { count: 64, caustic_map_size: 64, ..Default::default() },
        sources: caustics::settings::SourceSettings {
            distant: caustics::settings::DistantSource::Spheres,
            ..Default::default()
        },
        shading: caustics::settings::ShadingSettings { shadow_map_size: 128, ..Default::default() },
        ..Default::default()
    };
    // One part per region, as `region_visibility` sees them.
    s.environment.lights = 16;
    s.environment.taps = 1;
    let mut r = Renderer::with_context(ctx.clone(), sc, s).unwrap();
    r.set_caustic_spheres(vec![(0, table())], Blend::Triangle, false).unwrap();
    let mut fractions = 0;
    for step in 0..2 {
        if step == 1 {
            r.set_object_transform(2, glam::Affine3A::from_translation(Vec3::new(-0.5, 0.2, -0.4))).unwrap();
        }
        r.render_once().unwrap();
        let gpu = r.sphere_visibility_read().unwrap();
        let cpu: Vec<f32> = r
            .environment_lights()
            .iter()
            .zip(r.region_visibility(0).unwrap())
            .filter(|(l, _)| l.facing.max_element() > 0.0)
            .map(|(_, v)| v)
            .collect();
        assert_eq!(gpu.len(), 1);
        assert_eq!(gpu[0].0, 0);
        eprintln!("step {step}: GPU {:?}\n        CPU {cpu:?}", gpu[0].1);
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&gpu[0].1), bits(&cpu), "step {step}");
        fractions += cpu.iter().filter(|v| **v > 0.0 && **v < 1.0).count();
    }
    assert!(fractions >= 2, "the plate hides parts of regions ({fractions} fractions)");
}
