//! The medium seen through glass (the segments `composite` keeps beyond specular surfaces): the
//! fog behind a glass ball, a volume caustic seen through glass, and the floor a volume caustic
//! lights, against the CPU reference.

use super::*;

/// A spot's shaft in fog behind a glass ball, clear of it (the cone passes 0.17 m behind the
/// ball), over a black floor: the camera sees the shaft beside the ball and, magnified, through
/// it.
fn behind_glass_scene() -> Scene {
    scene(
        r#"{ "schema_version": 1, "name": "shaft_behind_glass",
  "camera": { "position": [0, 1, 3], "look_at": [0, 1, 0], "fov_y_deg": 30, "width": 32, "height": 32 },
  "lights": [ { "type": "spot", "position": [0, 4, -1.3], "direction": [0, -1, 0], "cone_angle_deg": 10, "falloff_start_deg": 10, "intensity": [30, 30, 30] } ],
  "materials": { "black": { "type": "diffuse", "albedo": 0 }, "glass": { "type": "dielectric", "ior": 1.5 } },
  "objects": [ { "type": "sphere", "center": [0, 1, 0], "radius": 0.5, "material": "glass" },
               { "type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [8, 8], "material": "black" } ],
  "medium": { "sigma_s": [0.3, 0.25, 0.2], "sigma_a": [0.05, 0.05, 0.1], "phase": { "type": "isotropic" },
              "bounds": { "min": [-3, -1, -3], "max": [3, 5, 4] } } }"#,
    )
}

/// Sums of the pixels within 8 pixels of the image's centre (inside the ball's disk, which is
/// about 10 pixels in radius) and of the others.
fn disk_and_rest(img: &caustics::image_io::Image) -> (f64, f64) {
    let (mut disk, mut rest) = (0.0, 0.0);
    for y in 0..img.height {
        for x in 0..img.width {
            let (dx, dy) = (x as f32 + 0.5 - 16.0, y as f32 + 0.5 - 16.0);
            let v: f64 = img.get(x, y).iter().map(|&c| f64::from(c)).sum();
            if dx * dx + dy * dy < 64.0 { disk += v } else { rest += v }
        }
    }
    (disk, rest)
}

#[test]
fn the_fog_behind_a_glass_ball_is_seen_through_it() {
    let Some(ctx) = gpu() else { return };
    // `composite` keeps the segments its refracted and reflected rays travel in the medium
    // beyond the ball and attenuates what they see; `medium_scatter` adds the shaft's single
    // scattering along them. In even fog and in fog thickening with height (a density grid:
    // the transmittances and the scattering marched through it).
    let dims = [4u32, 12, 4];
    let mut v = Vec::new();
    for _z in 0..dims[2] {
        for y in 0..dims[1] {
            for _x in 0..dims[0] {
                v.push(0.4 + 0.15 * y as f32);
            }
        }
    }
    let layered = with_grid(behind_glass_scene(), DensityGrid::new(dims, v).unwrap());
    for (label, sc) in [("even fog", behind_glass_scene()), ("layered fog", layered)] {
        let r = reference::render(&sc, &common::single_scattering_reference(1, 1024, 7)).unwrap();
        let g = render(&ctx, &sc, &settings()).unwrap();
        let ((gd, gr), (rd, rr)) = (disk_and_rest(&g.image), disk_and_rest(&r.image));
        println!("{label}: GPU / reference: through the ball {:.4}, beside it {:.4}", gd / rd, gr / rr);
        // Measured (lavapipe): even fog 0.997 through the ball, 0.994 beside it; layered
        // 0.992, 1.003. Before the segments were kept (and with them off) the ball showed the
        // black floor behind it, 0.000 of the reference's light through it (0.663 beside it:
        // the ring of the ball's disk outside the 8 pixels).
        assert!((gd / rd - 1.0).abs() < 0.03, "{label}: through the ball {}", gd / rd);
        assert!((gr / rr - 1.0).abs() < 0.03, "{label}: beside the ball {}", gr / rr);
        let again = render(&ctx, &sc, &settings()).unwrap();
        assert!(again.image.pixels == g.image.pixels, "{label}: a second render differs");
        // Switched off, the test fails: the ball shows the black floor behind it.
        let off = render(
            &ctx,
            &sc,
            &RenderSettings {
                medium: caustics::settings::MediumSettings { beyond_specular: false, ..settings().medium },
                ..settings()
            },
        )
        .unwrap();
        let off_ratio = disk_and_rest(&off.image).0 / rd;
        println!("{label}: without the segments, through the ball {off_ratio:.4}");
        assert!(off_ratio < 0.1, "{label}: {off_ratio}");
    }
}

/// A volume caustic seen through glass: a narrow spot whose light all meets a glass ball
/// focuses into fog; a second, smaller glass ball between it and the camera shows the cone
/// upside down (light -> glass -> fog -> glass -> camera). Black floor.
fn volume_caustic_through_glass_scene() -> Scene {
    scene(
        r#"{ "schema_version": 1, "name": "volume_caustic_through_glass",
  "camera": { "position": [0, 0.45, 3.2], "look_at": [0, 0.45, 0], "fov_y_deg": 30, "width": 32, "height": 32 },
  "lights": [ { "type": "spot", "position": [0, 4, 0], "direction": [0, -1, 0], "cone_angle_deg": 8, "falloff_start_deg": 8, "intensity": [400, 400, 400] } ],
  "materials": { "black": { "type": "diffuse", "albedo": 0 }, "glass": { "type": "dielectric", "ior": 1.5 } },
  "objects": [ { "type": "sphere", "center": [0, 0.9, 0], "radius": 0.5, "material": "glass" },
               { "type": "sphere", "center": [0, 0.45, 1.6], "radius": 0.35, "material": "glass" },
               { "type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [8, 8], "material": "black" } ],
  "medium": { "sigma_s": [0.3, 0.3, 0.3], "sigma_a": [0.02, 0.02, 0.02], "phase": { "type": "isotropic" },
              "bounds": { "min": [-4, -1, -4], "max": [4, 4.5, 4.5] } } }"#,
    )
}

#[test]
fn the_volume_caustic_seen_through_glass_matches_the_reference() {
    let Some(ctx) = gpu() else { return };
    // `beam_gather` adds the beams' light along the segments `composite` keeps beyond the
    // small ball; the reference gathers its photon beams along its camera paths through it
    // (`reference::photon_beams`). Caustic-only images over the cone's image (rows 6..15,
    // columns 11..21: the cone seen through the small ball only; below it the cone is seen
    // through both balls, where the GPU keeps too few segments), and row by row.
    let sc = volume_caustic_through_glass_scene();
    let r = reference::render(&sc, &common::single_scattering_reference(1 << 12, 16, 5)).unwrap();
    let g = render(&ctx, &sc, &settings()).unwrap();
    let region = |img: &caustics::image_io::Image, y: u32| -> f64 {
        (11..21).map(|x| img.get(x, y).iter().map(|&v| f64::from(v)).sum::<f64>()).sum()
    };
    let (mut gs, mut rs) = (0.0, 0.0);
    for y in 6..15 {
        let (a, b) = (region(&g.caustic, y), region(&r.caustic, y));
        println!("row {y}: GPU {a:.4}, reference {b:.4}");
        gs += a;
        rs += b;
    }
    println!("the cone through the ball, GPU / reference: {:.4}", gs / rs);
    // Measured (lavapipe): 0.988 (rows 0.42 to 1.36 of the reference's: the GPU gathers along
    // one ray per pixel, the reference over the pixel; at 64 x 64 the rows agree better).
    assert!((gs / rs - 1.0).abs() < 0.05, "{}", gs / rs);
    // Without the segments the cone is not seen through the ball.
    let off = render(
        &ctx,
        &sc,
        &RenderSettings {
            medium: caustics::settings::MediumSettings { beyond_specular: false, ..settings().medium },
            ..settings()
        },
    )
    .unwrap();
    let off_sum: f64 = (6..15).map(|y| region(&off.caustic, y)).sum();
    assert!(off_sum < 0.05 * rs, "{off_sum} vs {rs}");
}

#[test]
fn the_volume_caustic_lights_the_floor_around_it_as_the_reference_does() {
    let Some(ctx) = gpu() else { return };
    // `medium_bounce_beams` bins the light the beams scatter into point emitters that
    // `medium_bounce_surfaces` lights the floor with. The floor's share of each image is the
    // image less the same scene's with a black floor (the GPU's: less its image without the
    // emitters, `medium_bounce_grid` 0, which is the same there: nothing else lights the white
    // floor). Rows 8.. (the ball is above them: the reference does not render the floor seen
    // through it, light -> glass -> fog -> floor -> glass -> camera).
    let rows = |img: &caustics::image_io::Image| rows_sum(img, 8..32);
    let rs = common::single_scattering_reference(1 << 22, 64, 11);
    // Even fog, and fog thinning with height (a density grid over the box's y in [-1, 0.35]:
    // 0.84 at the floor, 0.5 at the box's top; the beams' transmittances and the emitters'
    // flux read it).
    let dims = [2u32, 9, 2];
    let mut v = Vec::new();
    for _z in 0..dims[2] {
        for y in 0..dims[1] {
            for _x in 0..dims[0] {
                v.push(2.0 - 1.5 * y as f32 / 8.0);
            }
        }
    }
    let grid = DensityGrid::new(dims, v).unwrap();
    for label in ["even fog", "layered fog"] {
        let with = |sc: Scene| if label == "even fog" { sc } else { with_grid(sc, grid.clone()) };
        let (lit, dark) = (with(volume_caustic_floor_scene(0.8)), with(volume_caustic_floor_scene(0.0)));
        let want =
            rows(&reference::render(&lit, &rs).unwrap().image) - rows(&reference::render(&dark, &rs).unwrap().image);
        let g = render(&ctx, &lit, &settings()).unwrap();
        let without = render(
            &ctx,
            &lit,
            &RenderSettings {
                medium: caustics::settings::MediumSettings { bounce_grid: 0, ..settings().medium },
                ..settings()
            },
        )
        .unwrap();
        let got = rows(&g.image) - rows(&without.image);
        println!("{label}: the floor's light from the volume caustic, GPU / reference: {:.4}", got / want);
        // Measured (lavapipe): even fog 1.033 (at 64 x 64 with 2^24 photons, 256 paths per
        // pixel: 1.025), layered 1.009. Without the emitters the floor is black: 0 of the
        // reference's.
        assert!((got / want - 1.0).abs() < 0.06, "{label}: {}", got / want);
        // The emitters' sums are fixed-point: the same bits in a second render.
        let again = render(&ctx, &lit, &settings()).unwrap();
        assert!(again.image.pixels == g.image.pixels, "{label}: a second render differs");
    }
}
