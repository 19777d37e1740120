//! Multiple scattering in the medium (`medium_ms_*`, src/medium_multiple/) against the CPU
//! reference in its full mode (every scattering order, every bounce): a dense fog room, where
//! single scattering is a sixth of the light, and a density grid; the grid kept across
//! camera-only frames; the same bits every run; off, the frame is the single-scattering one.

use super::*;

/// A small spot over a fog room (σs 1 /m, σa 0.05 /m, a 4 × 3 × 4 m box; the spot 0.3 m above
/// it: a point light inside fog gives the reference's camera paths 1/r² spikes that take minutes
/// to average) over a floor of albedo 0.8, at `w` × `h`; with `ball`, a glass ball (R 0.4) under the spot. (The tests leave the ball
/// out: the reference's light through glass into dense fog comes from photon beams whose rare
/// bright pixels would need minutes of reference to average; docs/benchmarks.md measures it.)
fn dense_fog_room(w: u32, h: u32, ball: bool) -> Scene {
    let ball =
        if ball { r#"{ "type": "sphere", "center": [0, 0.8, 0], "radius": 0.4, "material": "glass" },"# } else { "" };
    scene(&format!(
        r#"{{ "schema_version": 1, "name": "dense_fog_room",
  "camera": {{ "position": [0.0, 1.5, 1.9], "look_at": [0.0, 0.6, 0.0], "fov_y_deg": 50.0, "width": {w}, "height": {h} }},
  "lights": [ {{ "type": "spot", "position": [0, 2.8, 0], "direction": [0, -1, 0], "cone_angle_deg": 20, "falloff_start_deg": 20, "intensity": [40, 40, 40] }} ],
  "materials": {{ "floor": {{ "type": "diffuse", "albedo": 0.8 }}, "glass": {{ "type": "dielectric", "ior": 1.5 }} }},
  "objects": [ {ball}
               {{ "type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [4, 4], "material": "floor" }} ],
  "medium": {{ "sigma_s": [1.0, 1.0, 1.0], "sigma_a": [0.05, 0.05, 0.05], "phase": {{ "type": "isotropic" }},
              "bounds": {{ "min": [-2, -0.5, -2], "max": [2, 2.5, 2] }} }} }}"#
    ))
}

/// The test's GPU settings with multiple scattering at `photons` per light (0: off).
fn ms_settings(photons: u32) -> RenderSettings {
    RenderSettings {
        medium: caustics::settings::MediumSettings { multiple_photons: photons, steps: 32, ..settings().medium },
        ..settings()
    }
}

/// The CPU reference in its full mode, its paths cut at 256 interactions (the dense fog's albedo
/// 0.95 leaves 0.95^256 of the light there; at the default 16 it would drop light the GPU has).
fn full_reference(sc: &Scene, spp: u32, seed: u64) -> caustics::image_io::Image {
    let s = reference::ReferenceSettings {
        medium_single_scattering_only: false,
        max_depth: 256,
        ..common::single_scattering_reference(1 << 16, spp, seed)
    };
    reference::render(sc, &s).unwrap().image
}

/// Sum over the image's rows `rows` (all channels).
fn band(img: &caustics::image_io::Image, rows: std::ops::Range<u32>) -> f64 {
    let w = img.width;
    rows.flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| img.get(x, y).iter().map(|&c| f64::from(c)).sum::<f64>())
        .sum()
}

#[test]
fn multiple_scattering_in_a_dense_fog_room_matches_the_full_reference() {
    let Some(ctx) = gpu() else { return };
    let (w, h) = (24, 24);
    let sc = dense_fog_room(w, h, false);
    // The reference's noise: two seeds (measured: the halves' energies within 1 % of each
    // other's, the whole within 0.7 %).
    let (r1, r2) = (full_reference(&sc, 256, 3), full_reference(&sc, 256, 4));
    let g = render(&ctx, &sc, &ms_settings(1 << 18)).unwrap();
    let single = render(&ctx, &sc, &ms_settings(0)).unwrap();
    for (name, rows) in [("top", 0..h / 2), ("bottom", h / 2..h), ("all", 0..h)] {
        let (a, b) = (band(&r1, rows.clone()), band(&r2, rows.clone()));
        let r = 0.5 * (a + b);
        let noise = (a - b).abs() / r;
        let (gm, gs) = (band(&g.image, rows.clone()) / r, band(&single.image, rows) / r);
        println!(
            "{name}: GPU / reference {gm:.4} (single scattering only {gs:.4}; the reference's seeds differ by {noise:.4})"
        );
        // Measured (lavapipe): top 0.961, bottom 1.003, all 0.978; single scattering only
        // 0.18, 0.16, 0.17. Bound: the issue's 5 % per band (3 % for the whole) plus the
        // reference's own spread.
        let bound = if name == "all" { 0.03 } else { 0.05 } + noise;
        assert!((gm - 1.0).abs() < bound, "{name}: GPU / reference {gm} (bound {bound})");
        assert!(gs < 0.3, "{name}: single scattering alone is {gs} of the reference: the scene is not dense");
    }
    // The same bits every run.
    let again = render(&ctx, &sc, &ms_settings(1 << 18)).unwrap();
    assert!(again.image.pixels == g.image.pixels, "a second render differs");
}

#[test]
fn multiple_scattering_in_a_density_grid_matches_the_full_reference() {
    let Some(ctx) = gpu() else { return };
    // The dense room with fog thinning upward (density 1.6 at the floor to 0.2 under the
    // ceiling): the photons' free flights against the majorant, the camera's march through it.
    let (w, h) = (16, 16);
    let dims = [4u32, 8, 4];
    let mut v = Vec::new();
    for _z in 0..dims[2] {
        for y in 0..dims[1] {
            for _x in 0..dims[0] {
                v.push(1.6 - 0.2 * y as f32);
            }
        }
    }
    let sc = with_grid(dense_fog_room(w, h, false), DensityGrid::new(dims, v).unwrap());
    let (r1, r2) = (full_reference(&sc, 256, 5), full_reference(&sc, 256, 6));
    let g = render(&ctx, &sc, &ms_settings(1 << 18)).unwrap();
    let (a, b) = (band(&r1, 0..h), band(&r2, 0..h));
    let r = 0.5 * (a + b);
    let (gm, noise) = (band(&g.image, 0..h) / r, (a - b).abs() / r);
    println!("density grid: GPU / reference {gm:.4} (the reference's seeds differ by {noise:.4})");
    // Measured (lavapipe): 1.009 (the reference's seeds 0.001 apart).
    assert!((gm - 1.0).abs() < 0.03 + noise, "GPU / reference {gm}");
}

#[test]
fn a_camera_move_keeps_the_grid_and_matches_a_fresh_renderer() {
    let Some(ctx) = gpu() else { return };
    // A frame, the spot moved (the grid made again), the camera moved (the grid kept: its
    // passes not recorded). The image is a fresh renderer's, bit for bit.
    let sc = dense_fog_room(12, 12, false);
    let s = ms_settings(1 << 14);
    let frame = |r: &mut Renderer| frame_stats(&ctx, r);
    let mut light = sc.lights[0].clone();
    if let caustics::scene::Light::Spot { position, .. } = &mut light {
        *position += Vec3::new(0.3, 0.0, -0.2);
    }
    let mut cam = sc.camera.clone();
    cam.position += Vec3::new(-0.4, 0.2, 0.1);
    let mut r = Renderer::with_context(ctx.clone(), sc.clone(), s.clone()).unwrap();
    frame(&mut r);
    r.set_light(0, light.clone()).unwrap();
    let moved = frame(&mut r);
    r.set_camera(cam.clone()).unwrap();
    let kept = frame(&mut r);
    let timed = |f: &caustics::renderer::FrameStats, pass: &str| f.timings.iter().any(|(n, _)| n == pass);
    if !moved.timings.is_empty() {
        let names: Vec<&str> = moved.timings.iter().map(|(n, _)| n.as_str()).collect();
        println!("passes timed: {names:?}");
        assert!(timed(&moved, "medium_ms_trace") && timed(&moved, "medium_ms_view"));
        assert!(!timed(&kept, "medium_ms_trace") && timed(&kept, "medium_ms_view"));
    }
    let image = r.read_image().unwrap();
    let mut fresh = Renderer::with_context(ctx.clone(), sc, s).unwrap();
    fresh.set_light(0, light).unwrap();
    fresh.set_camera(cam).unwrap();
    frame(&mut fresh);
    assert!(image.pixels == fresh.read_image().unwrap().pixels, "the image differs from a fresh renderer's");
}

#[test]
fn fog_without_absorption_under_a_uniform_sky_keeps_the_skys_radiance() {
    let Some(ctx) = gpu() else { return };
    // Sunlight and sky through media: a fog box (σs 1 /m, no absorption) around the camera
    // under a uniform sky, nothing else. Every camera ray must see the sky's radiance (the
    // closed form: a medium that only scatters leaves a uniform field as it is), four fifths of
    // it from the higher orders, which here come from the environment's directional lights'
    // photons (each light a share of one light's).
    let mut sc = scene(
        r#"{ "schema_version": 1, "name": "uniform_sky_fog",
  "camera": { "position": [0, 0, 0], "look_at": [0, 0.3, -3], "fov_y_deg": 70, "width": 12, "height": 12 },
  "lights": [ { "type": "environment", "path": "../../scenes/envmaps/city.exr" } ],
  "materials": { "black": { "type": "diffuse", "albedo": 0 } },
  "objects": [ { "type": "rectangle", "center": [0, -30, 0], "normal": [0, 1, 0], "size": [0.1, 0.1], "material": "black" } ],
  "medium": { "sigma_s": [1, 1, 1], "sigma_a": [0, 0, 0], "phase": { "type": "isotropic" },
              "bounds": { "min": [-2, -2, -2], "max": [2, 2, 2] } } }"#,
    );
    let l = Vec3::new(1.0, 0.5, 0.25);
    sc.environment = Some(Arc::new(caustics::scene::Environment::from_texels(64, 32, vec![l; 64 * 32], 17.0).unwrap()));
    let mean = |img: &caustics::image_io::Image| {
        img.pixels.iter().fold(glam::DVec3::ZERO, |a, p| a + Vec3::from_array(*p).as_dvec3())
            / img.pixels.len() as f64
            / l.as_dvec3()
    };
    let full = mean(&render(&ctx, &sc, &ms_settings(1 << 18)).unwrap().image);
    let single = mean(&render(&ctx, &sc, &ms_settings(0)).unwrap().image);
    println!("mean / sky radiance: with multiple scattering {full}, single scattering {single}");
    // Measured (lavapipe): 0.965, single scattering 0.216 (the CPU reference: 0.996 and 0.221,
    // `reference_environment`; at 32 × 32 from the command line the GPU gives 0.995). Bound: the
    // grid's noise over 144 pixels and the higher orders' few per cent low (docs/media.md).
    assert!((full - 1.0).abs().max_element() < 0.04, "with multiple scattering: {full}");
    assert!(single.max_element() < 0.4, "single scattering: {single}");
}
