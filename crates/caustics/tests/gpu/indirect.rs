//! Diffuse interreflection (`indirect`, src/indirect/): the light that reaches a diffuse surface
//! after bouncing off another, from the world-space cache fed by photons.
//!
//! - a furnace: inside a closed diffuse sphere (albedo a) every bounce after the first spreads
//!   its light evenly (a sphere's form factor is its area's share), so the light that bounced
//!   is exactly a/(1 − a) of the mean of the first bounce's: I / R² · a / (1 − a) of irradiance
//!   everywhere, whatever the light's place;
//! - a Cornell-style room against the CPU reference in full mode (every bounce);
//! - determinism, and the cache kept by frames that only move the camera.

use crate::water::boxed;
use crate::{common, temp_scene};
use caustics::Scene;
use caustics::render::RenderSettings;
use caustics::renderer::{FrameRequest, FrameStats, Renderer};
use caustics_reference::metrics::{Mask, energy_ratio, hdr_flip};
use caustics_reference::reference::{self, DiffuseOrders, ReferenceSettings};
use common::gpu;
use glam::Vec3;

/// The defaults with `photons` interreflection photons per light, at a caustic map size that
/// a point light's six faces fit in the tests' 128 MiB storage bindings and a photon grid of
/// 128² per face (the glass ball's caustic is not what these tests measure).
fn with_indirect(photons: u32) -> RenderSettings {
    let mut s = RenderSettings::default();
    s.photons.caustic_map_size = 256;
    s.photons.count = 128;
    s.indirect.photons = photons;
    s
}

/// A diffuse sphere of radius 1 m and albedo 0.5 around the camera, a point light of 1 W/sr off
/// its centre.
fn furnace() -> Scene {
    temp_scene::load(
        "furnace",
        &[],
        r#"{
  "schema_version": 1,
  "name": "furnace",
  "camera": {"position": [0, 0, 0], "look_at": [0, 0, -1], "up": [0, 1, 0], "fov_y_deg": 60, "width": 64, "height": 64},
  "lights": [{"type": "point", "position": [0, 0.3, 0.2], "intensity": [1, 1, 1]}],
  "materials": {"white": {"type": "diffuse", "albedo": 0.5}},
  "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "white"}]
}"#,
    )
}

/// The furnace: the image with the cache minus the image without it is the light that bounced,
/// a/π · I/R² · a/(1 − a) = 0.5/π W/(m² sr) of radiance everywhere. Measured on lavapipe with
/// 2^18 photons: the mean 1.003 of it, 8 × 8 blocks 0.89 to 1.12 (the photons' noise in a
/// kernel of radius two cells), pixels 0.80 to 1.25. The statistics' flux per order: the
/// light's 4π W times a^(k − 1) at order k (every photon lands on the sphere).
#[test]
fn a_furnace_sphere_gets_the_geometric_series() {
    let Some(ctx) = gpu() else { return };
    let sc = furnace();
    let mut r = Renderer::with_context(ctx.clone(), sc.clone(), with_indirect(1 << 18)).unwrap();
    let stats = frame(&mut r);
    let on = r.read_image().unwrap();
    let orders = &stats.indirect_order_flux;
    assert_eq!(orders.len(), 8);
    for (k, f) in orders.iter().enumerate().take(4) {
        let expected = 4.0 * std::f64::consts::PI * 0.5f64.powi(k as i32 + 1);
        eprintln!("furnace: order {} flux {:.4} W, expected {expected:.4} W", k + 2, f[1]);
        // Russian roulette's noise: ~2^18 * 0.5^(k+1) photons reach order k + 2.
        assert!((f[1] / expected - 1.0).abs() < 0.01 * 2f64.powi(k as i32 / 2 + 1), "order {}: {:.4} W", k + 2, f[1]);
    }
    let off = caustics::render::render(&ctx, &sc, &with_indirect(0)).unwrap().image;
    let expected = 0.5 / std::f64::consts::PI;
    let (w, h) = (on.width as usize, on.height as usize);
    let bounced = |x: usize, y: usize| f64::from(on.pixels[y * w + x][1] - off.pixels[y * w + x][1]);
    let mean =
        (0..h).flat_map(|y| (0..w).map(move |x| (x, y))).map(|(x, y)| bounced(x, y)).sum::<f64>() / (w * h) as f64;
    let mut blocks = Vec::new();
    for by in 0..h / 8 {
        for bx in 0..w / 8 {
            let s: f64 = (0..64).map(|k| bounced(bx * 8 + k % 8, by * 8 + k / 8)).sum();
            blocks.push(s / 64.0 / expected);
        }
    }
    let (lo, hi) = blocks.iter().fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    eprintln!(
        "furnace: bounced light {:.4} of a/(1-a) times the first bounce's mean; 8x8 blocks {lo:.3}..{hi:.3}",
        mean / expected
    );
    // The mean: the photons' total flux, exact in expectation (2^18 photons: 0.3 % measured).
    assert!((mean / expected - 1.0).abs() < 0.02, "bounced light {:.4} of the series", mean / expected);
    // Blocks: the noise of ~2^18 / 250 photons per kernel, no pattern.
    assert!(lo > 0.85 && hi < 1.15, "8x8 blocks {lo:.3}..{hi:.3} of the series");
    // Without the cache the same surfaces show the first bounce only (bit for bit the default).
    assert!(off.pixels.iter().all(|p| f64::from(p[1]) < 0.8 * expected * 2.0));
}

fn cornell() -> Scene {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let mut sc = Scene::load(&dir.join("cornell_glass.json")).unwrap();
    sc.camera.width = 64;
    sc.camera.height = 64;
    sc
}

/// The Cornell-style room (scenes/cornell_glass.json) at 64 × 64 against the CPU reference in
/// full mode (every bounce; 256 camera paths per pixel, its energy's noise under 0.5 %).
/// Measured on lavapipe: without the cache 0.38 of the reference's energy (8 × 8 HDR-FLIP
/// 0.75); with 2^18 photons 0.992 and 0.054, every 16-row band within 5 % (at 128 × 96 the
/// energy 0.995, 24-row bands 1.004, 1.002, 0.976, 0.984 from the top). Before the gather's
/// coverage correction the kernel darkened within two cells of the room's corners: 0.975 and
/// 0.088, the bottom band 0.92.
#[test]
fn the_cornell_room_matches_the_reference_with_its_bounce_light() {
    let Some(ctx) = gpu() else { return };
    let sc = cornell();
    let rs = ReferenceSettings { photons_per_light: 1_000_000, camera_spp: 256, ..Default::default() };
    let cpu = reference::render(&sc, &rs).unwrap();
    let on = caustics::render::render(&ctx, &sc, &with_indirect(1 << 18)).unwrap().image;
    let off = caustics::render::render(&ctx, &sc, &with_indirect(0)).unwrap().image;
    let flip = |img: &caustics::image_io::Image| hdr_flip(&boxed(img), &boxed(&cpu.image), None::<&Mask>).unwrap().mean;
    let (e_on, e_off) = (energy_ratio(&on, &cpu.image, None).unwrap(), energy_ratio(&off, &cpu.image, None).unwrap());
    let (f_on, f_off) = (flip(&on), flip(&off));
    eprintln!("cornell: energy {e_off:.3} -> {e_on:.3}, 8x8 HDR-FLIP {f_off:.3} -> {f_on:.3} (GPU vs CPU full)");
    assert!(e_off < 0.5, "without the cache the room should miss most of its light ({e_off:.3})");
    assert!((e_on - 1.0).abs() < 0.03, "energy {e_on:.3} of the reference");
    assert!(f_on < 0.08, "8x8 HDR-FLIP {f_on:.3}");
    let band = |img: &caustics::image_io::Image, b: usize| -> f64 {
        let w = img.width as usize;
        img.pixels[b * 16 * w..(b + 1) * 16 * w].iter().map(|p| f64::from(p[0] + p[1] + p[2])).sum()
    };
    let bands: Vec<f64> = (0..4).map(|b| band(&on, b) / band(&cpu.image, b)).collect();
    eprintln!("cornell: 16-row bands from the top {bands:.3?}");
    assert!(bands.iter().all(|r| (r - 1.0).abs() < 0.05), "bands {bands:.3?}");
}

/// A closed box of water (2 × 0.32 × 2 m, its bottom 2 cm below the floor) on a floor, a wall
/// behind it, a spot light above; the camera sees the wall above the water.
fn slab() -> Scene {
    let (x0, x1, y0, y1, z0, z1) = (-1.0, 1.0, -0.02, 0.3, -1.0, 1.0);
    let mut obj = String::new();
    for x in [x0, x1] {
        for y in [y0, y1] {
            for z in [z0, z1] {
                obj += &format!("v {x} {y} {z}\n");
            }
        }
    }
    // Vertex (i, j, k) of the corners (x, y, z each low 0 / high 1) is 1 + 4i + 2j + k; each
    // side two triangles wound outward.
    let v = |i: u32, j: u32, k: u32| 1 + 4 * i + 2 * j + k;
    let quads = [
        [v(0, 0, 0), v(0, 0, 1), v(0, 1, 1), v(0, 1, 0)],
        [v(1, 0, 0), v(1, 1, 0), v(1, 1, 1), v(1, 0, 1)],
        [v(0, 0, 0), v(1, 0, 0), v(1, 0, 1), v(0, 0, 1)],
        [v(0, 1, 0), v(0, 1, 1), v(1, 1, 1), v(1, 1, 0)],
        [v(0, 0, 0), v(0, 1, 0), v(1, 1, 0), v(1, 0, 0)],
        [v(0, 0, 1), v(1, 0, 1), v(1, 1, 1), v(0, 1, 1)],
    ];
    for [a, b, c, d] in quads {
        obj += &format!("f {a} {b} {c}\nf {a} {c} {d}\n");
    }
    temp_scene::load(
        "slab",
        &[("slab.obj", obj)],
        r#"{
  "schema_version": 1,
  "name": "slab",
  "camera": {"position": [0.0, 1.3, 2.6], "look_at": [0.0, 1.1, -1.2], "up": [0, 1, 0], "fov_y_deg": 45, "width": 64, "height": 64},
  "lights": [{"type": "spot", "position": [0.0, 2.6, 0.3], "direction": [0, -1, -0.1], "cone_angle_deg": 35, "falloff_start_deg": 35, "intensity": [20, 20, 20]}],
  "materials": {"floor": {"type": "diffuse", "albedo": 0.8}, "wall": {"type": "diffuse", "albedo": 0.7}, "water": {"type": "dielectric", "ior": 1.33, "ext_ior": 1.0}},
  "objects": [
    {"type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [2.4, 2.4], "material": "floor"},
    {"type": "rectangle", "center": [0, 1.0, -1.2], "normal": [0, 0, 1], "size": [2.4, 2.0], "material": "wall"},
    {"type": "mesh", "path": "slab.obj", "smooth_normals": false, "material": "water"}
  ]
}"#,
    )
}

/// The wall above the water slab (rows 0–39 of 64) is lit after a diffuse bounce by the floor
/// outside the water and by the floor under it (through the water's surface: a caustic lit by
/// a caustic); the floor the camera sees through the water (rows 40–63) by the light the
/// water's surface traps and sends back down. The GPU's bounced light in each (the image with
/// the cache minus without) against the CPU reference's orders 2 and up
/// (`DiffuseOrders { min: 2 }`, 256 paths per pixel), and each region's energy against the
/// reference's full mode. Before 2026-12-08 the reference had no light of order 2 and up on
/// surfaces seen through the water (`docs/reference-renderer.md`); now it has 0.29 of the
/// floor's light there. Measured on lavapipe: the wall's bounced light 0.990, energy 0.240 ->
/// 0.995 (without -> with the cache); the floor's bounced light 0.630, energy 0.407 -> 0.592.
/// The floor falls short in its first-hit light too (0.58 of the reference's order 1): the
/// camera sees it through the slab's flat top at grazing angles, where the composite's
/// image-space search loses rays (a known gap, `docs/status.md`); there only the cache's
/// added light is asserted.
#[test]
fn bounce_light_through_a_water_slab_matches_the_reference() {
    let Some(ctx) = gpu() else { return };
    let sc = slab();
    let rows = |img: &caustics::image_io::Image, r: std::ops::Range<u32>| -> f64 {
        let w = img.width as usize;
        img.pixels[r.start as usize * w..r.end as usize * w].iter().map(|p| f64::from(p[0] + p[1] + p[2])).sum()
    };
    let mut rs = ReferenceSettings { photons_per_light: 1_000_000, camera_spp: 256, ..Default::default() };
    let full = reference::render(&sc, &rs).unwrap().image;
    rs.diffuse_orders = DiffuseOrders { min: 2, max: None };
    let bounced_cpu = reference::render(&sc, &rs).unwrap().image;
    let on = caustics::render::render(&ctx, &sc, &with_indirect(1 << 18)).unwrap().image;
    let off = caustics::render::render(&ctx, &sc, &with_indirect(0)).unwrap().image;
    for (name, r, min_share, exact) in
        [("the wall", 0..40, 0.5, true), ("the floor under the water", 40..64, 0.1, false)]
    {
        let (f, b, on, off) =
            (rows(&full, r.clone()), rows(&bounced_cpu, r.clone()), rows(&on, r.clone()), rows(&off, r));
        let (bounce, energy) = ((on - off) / b, on / f);
        eprintln!(
            "slab, {name}: bounced light {bounce:.3} of the reference's orders 2- ({:.3} of its light), energy {:.3} -> {energy:.3}",
            b / f,
            off / f
        );
        assert!(b > min_share * f, "{name}: too little bounced light to compare ({:.3})", b / f);
        if !exact {
            assert!(bounce > 0.5, "{name}: the cache adds {bounce:.3} of the reference's bounced light");
            continue;
        }
        assert!((bounce - 1.0).abs() < 0.06, "{name}: bounced light {bounce:.3} of the reference's");
        assert!((energy - 1.0).abs() < 0.05, "{name}: energy {energy:.3} of the reference's");
    }
}

fn frame(r: &mut Renderer) -> FrameStats {
    let ctx = r.context().clone();
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    r.encode(&mut enc, FrameRequest { stats: true }).unwrap();
    ctx.queue.submit([enc.finish()]);
    r.wait_stats().unwrap().expect("the frame asked for statistics")
}

fn image_bits(r: &Renderer) -> Vec<u32> {
    r.read_image().unwrap().pixels.iter().flat_map(|p| p.map(f32::to_bits)).collect()
}

/// The same frame twice gives the same bits (the cache's sums are fixed point, added in any
/// order); a frame that only moves the camera keeps the cache (no `indirect_trace`) and gives
/// a fresh renderer's bits at that camera; a full cache reports no lost deposit.
#[test]
fn the_cache_is_deterministic_and_kept_by_camera_frames() {
    let Some(ctx) = gpu() else { return };
    let mut sc = cornell();
    sc.camera.width = 48;
    sc.camera.height = 48;
    let s = with_indirect(1 << 16);
    let mut r = Renderer::with_context(ctx.clone(), sc.clone(), s.clone()).unwrap();
    let first = frame(&mut r);
    assert_eq!(first.indirect_lost_deposits, 0);
    assert!(first.timings.is_empty() || first.timings.iter().any(|(n, _)| n == "indirect_trace"));
    let a = image_bits(&r);
    r.invalidate();
    frame(&mut r);
    assert!(image_bits(&r) == a, "the same frame gave other bits");
    let mut cam = sc.camera.clone();
    cam.position += Vec3::new(0.2, -0.1, -0.1);
    r.set_camera(cam.clone()).unwrap();
    let moved = frame(&mut r);
    assert!(moved.timings.iter().all(|(n, _)| n != "indirect_trace" && n != "indirect_resolve"));
    assert!(moved.timings.is_empty() || moved.timings.iter().any(|(n, _)| n == "indirect_gather"));
    let mut fresh_scene = sc;
    fresh_scene.camera = cam;
    let mut fresh = Renderer::with_context(ctx, fresh_scene, s).unwrap();
    frame(&mut fresh);
    assert!(image_bits(&r) == image_bits(&fresh), "a camera-only frame differs from a fresh renderer");
}

/// A cache too small for the room's surfaces reports the deposits it lost.
#[test]
fn a_full_cache_reports_what_it_lost() {
    let Some(ctx) = gpu() else { return };
    let mut sc = cornell();
    sc.camera.width = 32;
    sc.camera.height = 32;
    let mut s = with_indirect(1 << 14);
    s.indirect.capacity = 1024;
    s.indirect.grid = 200;
    let mut r = Renderer::with_context(ctx, sc, s).unwrap();
    let st = frame(&mut r);
    assert!(st.indirect_lost_deposits > 0);
    assert!(st.overflow.as_deref().is_some_and(|m| m.contains("indirect.capacity")), "{:?}", st.overflow);
}

/// The bounced light alone: the frame's image minus the same frame without the cache (the
/// rest of the frame is the same), as rgb sums over 8 × 8 blocks (the photons' noise averaged
/// down, the bounced light's shape kept).
fn bounced(r: &Renderer, off: &[[f32; 3]]) -> Vec<f64> {
    let img = r.read_image().unwrap();
    let (w, h) = (img.width as usize, img.height as usize);
    let mut blocks = vec![0.0; w.div_ceil(8) * h.div_ceil(8)];
    for (i, (p, o)) in img.pixels.iter().zip(off).enumerate() {
        let (x, y) = (i % w, i / w);
        blocks[y / 8 * w.div_ceil(8) + x / 8] += f64::from(p[0] + p[1] + p[2]) - f64::from(o[0] + o[1] + o[2]);
    }
    blocks
}

fn render_off(ctx: &caustics::gpu::GpuContext, sc: &Scene, s: &RenderSettings) -> Vec<[f32; 3]> {
    let mut s = s.clone();
    s.indirect.photons = 0;
    let mut r = Renderer::with_context(ctx.clone(), sc.clone(), s).unwrap();
    frame(&mut r);
    r.read_image().unwrap().pixels
}

/// A progressive cache (`indirect.history` = 4): it refines for 6 × 4 frames and stops (a
/// camera-only frame then traces nothing); settled, its bounced light has the energy of a cache
/// built at once from as many photons; after the light moves, the old light's share of the
/// bounced light is (1 − 1/4)^k after k frames (measured by projecting the image's change onto
/// the difference of the two settled caches, over 8 × 8 blocks: the references' noise would
/// otherwise add its own variance to the share).
#[test]
fn a_progressive_cache_settles_and_follows_a_moved_light() {
    let Some(ctx) = gpu() else { return };
    let mut sc = cornell();
    sc.camera.width = 32;
    sc.camera.height = 32;
    // 2^15 photons a batch: one batch's bounced energy scatters by about 2 %, the settled
    // cache's (variance 1/7 of a batch's) by about 0.7 %.
    let mut s = with_indirect(1 << 15);
    s.indirect.history = 4;
    let mut r = Renderer::with_context(ctx.clone(), sc.clone(), s.clone()).unwrap();
    let mut frames = 0;
    loop {
        frame(&mut r);
        frames += 1;
        if !r.refining() {
            break;
        }
        assert!(frames < 100, "never settles");
    }
    assert_eq!(frames, 24, "frames of refinement");
    let mut cam = sc.camera.clone();
    cam.position += Vec3::new(0.05, 0.0, 0.0);
    r.set_camera(cam).unwrap();
    let still = frame(&mut r);
    assert!(still.timings.iter().all(|(n, _)| n != "indirect_trace"), "a settled cache traced photons");
    r.set_camera(sc.camera.clone()).unwrap();
    frame(&mut r);
    let off_old = render_off(&ctx, &sc, &s);
    let b_old = bounced(&r, &off_old);
    let at_once = |sc: &Scene| {
        let mut s1 = s.clone();
        s1.indirect.history = 1;
        s1.indirect.photons = 1 << 17;
        let mut r1 = Renderer::with_context(ctx.clone(), sc.clone(), s1).unwrap();
        frame(&mut r1);
        r1
    };
    let once_old = bounced(&at_once(&sc), &off_old);
    let (e_prog, e_once) = (b_old.iter().sum::<f64>(), once_old.iter().sum::<f64>());
    eprintln!("progressive: settled bounced energy {:.4} of a cache built at once", e_prog / e_once);
    assert!((e_prog / e_once - 1.0).abs() < 0.02, "settled energy {:.4}", e_prog / e_once);

    // Move the light 0.6 m sideways.
    let mut moved = sc.clone();
    let light = match &sc.lights[0] {
        caustics::scene::Light::Point { position, intensity } => {
            caustics::scene::Light::Point { position: *position + Vec3::new(0.6, 0.0, 0.0), intensity: *intensity }
        }
        l => panic!("the room's light is a point light: {l:?}"),
    };
    moved.lights[0] = light.clone();
    let off_new = render_off(&ctx, &moved, &s);
    let b_new = bounced(&at_once(&moved), &off_new);
    let d_old: Vec<f64> = b_old.iter().zip(&b_new).map(|(a, b)| a - b).collect();
    let norm: f64 = d_old.iter().map(|d| d * d).sum();
    r.set_light(0, light).unwrap();
    let mut shares = Vec::new();
    for _ in 0..8 {
        frame(&mut r);
        let bk = bounced(&r, &off_new);
        shares.push(bk.iter().zip(&b_new).zip(&d_old).map(|((a, b), d)| (a - b) * d).sum::<f64>() / norm);
    }
    eprintln!("progressive: the old light's share after 1..8 frames {shares:.3?}");
    for (k, w) in shares.iter().enumerate() {
        let expected = 0.75f64.powi(k as i32 + 1);
        assert!(
            (w - expected).abs() < 0.08,
            "after {} frames the old light's share {w:.3}, expected {expected:.3}",
            k + 1
        );
    }
    assert!(r.refining(), "a moved light refines again");
}

/// `scenes/pool_walls.json`: a narrow spot on a pool's wavy water; the walls above the water
/// are lit almost only by the floor's caustic coming back out through the surface, and the
/// floor under the water outside the spot by the light the surface traps and sends back down.
/// At 64 × 48, GPU with the cache against the CPU reference in full mode (256 paths per pixel),
/// on the walls above y = 0.5 m and on the floor under the water (pixels found by straight
/// camera rays, 5 cm inside the water's sides). Measured on lavapipe: walls 1.024 of the
/// reference's energy (0.002 without the cache), floor 0.982 (0.775 without); at 128 × 96
/// (`docs/indirect.md`) 1.013 and 1.002.
#[test]
fn a_pools_floor_pattern_lights_the_walls_above_the_water() {
    let Some(ctx) = gpu() else { return };
    let path = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/pool_walls.json"));
    let mut sc = Scene::load(path).unwrap();
    (sc.camera.width, sc.camera.height) = (64, 48);
    let cam = sc.camera.clone();
    // Per pixel: 1 a wall above the water, 2 the floor under it, 0 anything else.
    let walls = [
        (Vec3::new(0.0, 0.6, -1.01), Vec3::Z),
        (Vec3::new(-1.01, 0.6, 0.0), Vec3::X),
        (Vec3::new(1.01, 0.6, 0.0), -Vec3::X),
    ];
    let mut region = Vec::new();
    for y in 0..cam.height {
        for x in 0..cam.width {
            let d = cam.ray_dir(x as f32 + 0.5, y as f32 + 0.5);
            let mut best: Option<(f32, Vec3)> = None;
            for (c, n) in walls {
                let t = (c - cam.position).dot(n) / d.dot(n);
                let p = cam.position + d * t;
                let q = (p - c).abs();
                let inside = q.y <= 0.6 && (if n.x != 0.0 { q.z } else { q.x }) <= 1.01;
                if t > 0.0 && inside && best.is_none_or(|(bt, _)| t < bt) {
                    best = Some((t, p));
                }
            }
            let floor = (d.y < 0.0).then(|| cam.position + d * (-cam.position.y / d.y));
            region.push(match (best, floor) {
                (Some((_, p)), _) if p.y > 0.5 => 1u8,
                (None, Some(p)) if p.x.abs() < 0.95 && p.z.abs() < 0.95 => 2,
                _ => 0,
            });
        }
    }
    let sum = |img: &caustics::image_io::Image, k: u8| -> f64 {
        img.pixels.iter().zip(&region).filter(|(_, r)| **r == k).map(|(p, _)| f64::from(p[0] + p[1] + p[2])).sum()
    };
    let rs = ReferenceSettings { photons_per_light: 1_000_000, camera_spp: 256, ..Default::default() };
    let cpu = reference::render(&sc, &rs).unwrap().image;
    let mut s = with_indirect(1 << 18);
    s.photons.count = 512;
    let on = caustics::render::render(&ctx, &sc, &s).unwrap().image;
    s.indirect.photons = 0;
    let off = caustics::render::render(&ctx, &sc, &s).unwrap().image;
    for (k, name) in [(1, "the walls above the water"), (2, "the floor under the water")] {
        let n = region.iter().filter(|r| **r == k).count();
        let (e_on, e_off) = (sum(&on, k) / sum(&cpu, k), sum(&off, k) / sum(&cpu, k));
        eprintln!(
            "pool_walls, {name} ({n} pixels): energy {e_off:.3} -> {e_on:.3} of the reference's (without -> with the cache)"
        );
        assert!(n > 300, "{name}: {n} pixels");
        assert!((e_on - 1.0).abs() < 0.05, "{name}: energy {e_on:.3} of the reference's");
    }
    assert!(sum(&off, 1) < 0.05 * sum(&cpu, 1), "the walls above the water have little light but the bounced");
}
