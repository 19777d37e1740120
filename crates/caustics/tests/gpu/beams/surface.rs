//! Surface caustics from beams (`LocalSource::Beams`): the beams' flux onto a floor, the
//! photon caustic map on the same frame, no double counting, shadowed receivers, determinism,
//! energy against the CPU reference.

use super::*;
use caustics::render::GpuRender;
use caustics::settings::LocalSource;
use std::sync::OnceLock;

/// `ball_at_45(48, 48, false)` under `surface_settings(source)`, rendered once for the tests
/// that look at it (a render is the same bits every time: `gpu_bits`, and
/// `surface_caustic_from_beams_is_deterministic_and_creates_nothing_after_the_first_frame`).
fn floor_render(ctx: &caustics::gpu::GpuContext, source: LocalSource) -> &'static GpuRender {
    static BEAMS: OnceLock<GpuRender> = OnceLock::new();
    static PHOTONS: OnceLock<GpuRender> = OnceLock::new();
    let cell = match source {
        LocalSource::Beams => &BEAMS,
        LocalSource::Photons => &PHOTONS,
    };
    cell.get_or_init(|| render(ctx, &ball_at_45(48, 48, false), &surface_settings(source)).unwrap())
}

/// The floor area (y = 0) pixel (x, y) sees: its corner rays' quad (shoelace in x, z).
fn floor_footprint(sc: &Scene, x: u32, y: u32) -> f64 {
    let cam = &sc.camera;
    let corner = |dx: f32, dy: f32| {
        let d = cam.ray_dir(x as f32 + dx, y as f32 + dy);
        let p = cam.position + d * (-cam.position.y / d.y);
        glam::DVec2::new(f64::from(p.x), f64::from(p.z))
    };
    let q = [corner(0.0, 0.0), corner(1.0, 0.0), corner(1.0, 1.0), corner(0.0, 1.0)];
    0.5 * (0..4).map(|i| q[i].perp_dot(q[(i + 1) % 4])).sum::<f64>().abs()
}

#[test]
fn surface_caustic_from_beams_carries_the_beams_flux_onto_the_floor() {
    let Some(ctx) = gpu() else { return };
    let sc = ball_at_45(48, 48, false);
    let out = floor_render(&ctx, LocalSource::Beams);
    let (stats, list) = &out.beams[0];
    println!("{stats:?}");
    assert!(stats.beams > 100 && stats.overflow == 0);
    // The irradiance the image shows (L = albedo / π E on the floor), over the floor area each
    // pixel sees.
    let cam = &sc.camera;
    let mut shown = 0.0f64;
    for y in 0..cam.height {
        for x in 0..cam.width {
            let l = f64::from(out.caustic.get(x, y)[0]);
            shown += l * std::f64::consts::PI / 0.5 * floor_footprint(&sc, x, y);
        }
    }
    // The flux of the beams that land on the floor (object 1) inside the camera's view: the
    // beams whose three edge ends it sees, and of those it sees in part, the fraction of their
    // end triangle (on the floor, where their light lands) that projects into the image
    // (32 x 32 points spread evenly over the triangle).
    let in_view = |p: Vec3| {
        project(&sc, p).is_some_and(|(px, py)| px > 0.0 && py > 0.0 && px < cam.width as f32 && py < cam.height as f32)
    };
    let (mut inside, mut partial, mut floor) = (0.0f64, 0.0f64, 0.0f64);
    for b in list.iter().filter(|b| b.land == 1) {
        floor += f64::from(b.flux.x);
        let ends: [Vec3; 3] = std::array::from_fn(|i| b.vertices[i] + b.dirs[i] * b.ends[i]);
        let seen = ends.iter().filter(|&&e| in_view(e)).count();
        if seen == 3 {
            inside += f64::from(b.flux.x);
        } else if seen > 0 {
            let n = 32;
            let (mut hit, mut all) = (0, 0);
            for i in 0..n {
                for j in 0..n - i {
                    let (u, v) = ((i as f32 + 1.0 / 3.0) / n as f32, (j as f32 + 1.0 / 3.0) / n as f32);
                    let p = ends[0] + (ends[1] - ends[0]) * u + (ends[2] - ends[0]) * v;
                    all += 1;
                    hit += usize::from(in_view(p));
                }
            }
            partial += f64::from(b.flux.x) * hit as f64 / all as f64;
        }
    }
    let want = inside + partial;
    println!(
        "beams onto the floor {floor:.5} W, in view {want:.5} W ({inside:.5} W of beams seen whole); the image shows {shown:.5} W ({:+.2} %)",
        (shown / want - 1.0) * 100.0
    );
    // Most of the caustic lies in view (the test would say little otherwise).
    assert!(inside > 0.6 * floor, "{inside} {partial} {floor}");
    // Flux conservation: Φ / A(y) · cos_r / cos_b over a beam's footprint is its flux where the
    // beam is thin (its edges nearly parallel over the footprint); the 4 × 4 points per pixel
    // sample the beams' edges. Bound: 2 %.
    assert!((shown / want - 1.0).abs() < 0.02, "{shown} vs {want}");
    // Counted twice, it would be off by 100 %: the bound catches that.
    assert!((2.0 * shown / want - 1.0).abs() > 0.02);
}

#[test]
fn surface_caustic_from_beams_matches_the_photon_map_and_replaces_it() {
    let Some(ctx) = gpu() else { return };
    let photons = floor_render(&ctx, LocalSource::Photons);
    let from_beams = floor_render(&ctx, LocalSource::Beams);
    // No double counting: with beams the light's photon stage traces nothing (its map is not
    // added), and the direct light is the same bits.
    println!("photons traced: {} (photons), {} (beams)", photons.photons_traced, from_beams.photons_traced);
    assert!(photons.photons_traced > 0);
    assert_eq!(from_beams.photons_traced, 0);
    let direct = |o: &caustics::render::GpuRender| -> Vec<f32> {
        o.image.pixels.iter().zip(&o.caustic.pixels).map(|(a, c)| a[0] - c[0]).collect()
    };
    let (dp, db) = (direct(photons), direct(from_beams));
    let worst_direct = dp.iter().zip(&db).map(|(a, b)| (a - b).abs() / a.abs().max(1e-3)).fold(0.0f32, f32::max);
    println!("direct light (image - caustic): worst relative difference {worst_direct:.2e}");
    assert!(worst_direct < 1e-4);
    // The caustic region: pixels where either is above 2 % of the photon map's peak.
    let (p, b) = (&photons.caustic.pixels, &from_beams.caustic.pixels);
    let peak = p.iter().map(|v| v[0]).fold(0.0f32, f32::max);
    let region: Vec<usize> = (0..p.len()).filter(|&i| p[i][0].max(b[i][0]) > 0.02 * peak).collect();
    let sp: f64 = region.iter().map(|&i| f64::from(p[i][0])).sum();
    let sb: f64 = region.iter().map(|&i| f64::from(b[i][0])).sum();
    let l1: f64 = region.iter().map(|&i| f64::from((p[i][0] - b[i][0]).abs())).sum::<f64>() / sp;
    // The bright core (above 20 % of the peak) apart: there both are smooth.
    let core: Vec<usize> = region.iter().copied().filter(|&i| p[i][0] > 0.2 * peak).collect();
    let cp: f64 = core.iter().map(|&i| f64::from(p[i][0])).sum();
    let l1_core: f64 = core.iter().map(|&i| f64::from((p[i][0] - b[i][0]).abs())).sum::<f64>() / cp;
    println!(
        "caustic region {} pixels: beams / photons {:.4}, relative L1 difference {l1:.4}; core {} pixels: L1 {l1_core:.4}",
        region.len(),
        sb / sp,
        core.len()
    );
    assert!(region.len() > 50 && core.len() > 10);
    // Bounds: the two estimate the same light (the photon map also has the paths beams do not
    // follow, reflected inside more than once: under 1 % here); sums within 3 % (measured
    // -2.8 % with the spot's spill face, which gives the photon map the light past the spot's
    // view; +0.8 % without it: surface_caustic_energy_against_the_cpu_reference has both
    // against the CPU reference). Per pixel (relative L1, measured 0.19 over the region): the beams' affine model
    // turns the ball's rim light, spread far over the floor, into long thin beams (radial
    // streaks, docs/beams.md "Surface caustics from beams"), so the bound over the
    // region is 0.25, and over the core, where the mapping is smooth, tighter (0.15).
    assert!((sb / sp - 1.0).abs() < 0.03, "sums {sb} {sp}");
    assert!(l1 < 0.25, "L1 {l1}");
    assert!(l1_core < 0.15, "core L1 {l1_core}");
    // Both at once would double the caustic: 100 % off, far outside the bound.
    assert!(((sb + sp) / sp - 1.0).abs() > 0.5);
}

#[test]
fn surface_caustic_from_beams_stops_at_the_receiver_the_beams_land_on() {
    let Some(ctx) = gpu() else { return };
    // A small table under the caustic: the beams that land on it light it, not the floor
    // under it (the floor there is in the table's shadow), and the same holds for photons.
    let sc = ball_at_45(48, 48, true);
    let out = render(&ctx, &sc, &surface_settings(LocalSource::Beams)).unwrap();
    let photons = render(&ctx, &sc, &surface_settings(LocalSource::Photons)).unwrap();
    let on_table = out.beams[0].1.iter().filter(|b| b.land == 2).count();
    println!("beams landing on the table: {on_table}");
    assert!(on_table > 10);
    // The floor in the table's shadow that the camera sees (the table hides x 1.21 to 1.75):
    // from the ball's focus near (0.64, 0.86, 0) through the table's edges, the shadow spans
    // x 1.58 to 2.34 on the floor; sample x 1.95 to 2.2, |z| < 0.12, which the caustic lights
    // without the table.
    let bare = floor_render(&ctx, LocalSource::Beams);
    let cam = &sc.camera;
    let (mut shadowed, mut lit_table) = (Vec::new(), 0.0f32);
    for y in 0..cam.height {
        for x in 0..cam.width {
            let d = cam.ray_dir(x as f32 + 0.5, y as f32 + 0.5);
            let pt = cam.position + d * ((0.3 - cam.position.y) / d.y);
            let pf = cam.position + d * (-cam.position.y / d.y);
            if (pt.x - 1.5).abs() < 0.25 && pt.z.abs() < 0.25 {
                lit_table = lit_table.max(out.caustic.get(x, y)[0]);
            } else if (pf.x - 2.075).abs() < 0.125 && pf.z.abs() < 0.12 {
                shadowed.push((out.caustic.get(x, y)[0], photons.caustic.get(x, y)[0], bare.caustic.get(x, y)[0]));
            }
        }
    }
    let worst_beams = shadowed.iter().map(|v| v.0).fold(0.0f32, f32::max);
    let worst_photons = shadowed.iter().map(|v| v.1).fold(0.0f32, f32::max);
    let least_bare = shadowed.iter().map(|v| v.2).fold(f32::MAX, f32::min);
    println!(
        "table's brightest caustic pixel {lit_table:.4}; {} floor pixels in its shadow: brightest {worst_beams:.2e} (beams), {worst_photons:.2e} (photons); without the table at least {least_bare:.2e}",
        shadowed.len()
    );
    assert!(lit_table > 0.0 && shadowed.len() >= 4);
    // The region is lit without the table (else the test would show nothing), dark with it.
    assert!(least_bare > 0.05 * lit_table, "{least_bare} vs {lit_table}");
    assert!(worst_beams < 1e-3 * lit_table, "{worst_beams} vs {lit_table}");
}

#[test]
fn surface_caustic_from_beams_is_deterministic_and_creates_nothing_after_the_first_frame() {
    use caustics::renderer::Renderer;
    let Some(ctx) = gpu() else { return };
    // In fog: the surface caustic and the volume caustic from the same beams.
    let sc = ball_in_fog(14.0, 16, 12);
    let s = RenderSettings {
        sources: caustics::settings::SourceSettings { local: LocalSource::Beams, ..Default::default() },
        ..render_settings(BeamSettings::default())
    };
    let a = render(&ctx, &sc, &s).unwrap();
    let b = render(&ctx, &sc, &s).unwrap();
    assert!(a.caustic.pixels.iter().any(|p| p[0] > 0.0));
    assert_eq!(a.image.pixels, b.image.pixels);
    assert_eq!(a.caustic.pixels, b.caustic.pixels);
    // The floor's surface caustic is there (the black floor of ball_in_fog has albedo 0: a
    // white one here).
    let mut white = sc.clone();
    for m in white.materials.iter_mut() {
        if let caustics::scene::Material::Diffuse { albedo } = m {
            *albedo = Vec3::splat(0.5);
        }
    }
    let with_floor = render(&ctx, &white, &s).unwrap();
    let without = render(
        &ctx,
        &white,
        &RenderSettings {
            sources: caustics::settings::SourceSettings { volume: caustics::settings::VolumeSource::None, ..s.sources },
            ..s.clone()
        },
    )
    .unwrap();
    let (sw, so) = (sum(&with_floor.caustic), sum(&without.caustic));
    println!("caustic image sum: surface + volume {sw:.4}, surface only (--no-beams) {so:.4}");
    assert!(so > 0.0 && sw > so);
    let mut r = Renderer::with_context(ctx.clone(), sc.clone(), s.clone()).unwrap();
    let frame = common::created_by_a_frame;
    assert!(frame(&mut r) > 0);
    assert_eq!(frame(&mut r), 0);
}

/// The surface caustic's energy on the floor against the CPU reference (first-diffuse caustic
/// paths, 4 M photons), for the photon map with and without the spot's spill face and for the
/// beams. Measured on lavapipe (16 M reference photons): photons with the spill face 0.991 of
/// the reference, without it 0.951 (light refracted and reflected past the spot's view), beams
/// 0.963 (they land anywhere, but lack 3.7 %: not located yet; the flux test finds about 1.5 %
/// of it in the silhouettes and the untraced internal reflections). Bounds: the photon map
/// within 2 % with the spill face and short by more than 2 % without it; the beams within 5 %
/// (issue 14's energy bound for the volume caustic).
#[test]
fn surface_caustic_energy_against_the_cpu_reference() {
    let Some(ctx) = gpu() else { return };
    let sc = ball_at_45(48, 48, false);
    let rs = caustics_reference::reference::ReferenceSettings {
        photons_per_light: 4_000_000,
        camera_spp: 1,
        caustic_map_size: 8,
        caustic_paths: caustics_reference::reference::CausticPaths::FirstDiffuse,
        ..Default::default()
    };
    let cpu = caustics_reference::reference::render(&sc, &rs).unwrap();
    let total = |img: &caustics::image_io::Image| -> f64 { img.pixels.iter().map(|p| f64::from(p[0])).sum() };
    let reference = total(&cpu.caustic);
    assert!(reference > 0.0);
    let ratio = |s: RenderSettings| total(&render(&ctx, &sc, &s).unwrap().caustic) / reference;
    let spill = total(&floor_render(&ctx, LocalSource::Photons).caustic) / reference;
    let no_spill = ratio(RenderSettings {
        shading: caustics::settings::ShadingSettings {
            spill_faces: caustics::render::SpillFaces::Off,
            ..surface_settings(LocalSource::Photons).shading
        },
        ..surface_settings(LocalSource::Photons)
    });
    let beams = total(&floor_render(&ctx, LocalSource::Beams).caustic) / reference;
    println!(
        "caustic energy / CPU reference: photons {spill:.4}, without the spill face {no_spill:.4}, beams {beams:.4}"
    );
    assert!((spill - 1.0).abs() < 0.02, "photon map with the spill face: {spill}");
    assert!(no_spill < 0.98, "without the spill face the light past the spot's view is lost: {no_spill}");
    assert!((beams - 1.0).abs() < 0.05, "beams: {beams}");
}
