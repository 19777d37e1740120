//! The beam pipeline's choices: the energy criterion and cutoff, hulls against the gather,
//! chunk sizes, determinism, the renderer's steady state and bad settings.

use super::*;

#[test]
fn beams_are_deterministic_create_nothing_after_the_first_frame_and_bad_settings_are_named() {
    use caustics::renderer::Renderer;
    let Some(ctx) = gpu() else { return };
    let sc = ball_in_fog(14.0, 16, 12);
    let s = render_settings(BeamSettings::default());
    // Same input, same bits (the beams are summed in hierarchy order, not atomics' order).
    let a = render(&ctx, &sc, &s).unwrap();
    let b = render(&ctx, &sc, &s).unwrap();
    assert!(a.caustic.pixels.iter().any(|p| p[0] > 0.0));
    assert_eq!(a.image.pixels, b.image.pixels);
    assert_eq!(a.beams[0].1, b.beams[0].1);
    // The renderer's steady state: nothing created after the first frame.
    let mut r = Renderer::with_context(ctx.clone(), sc.clone(), s.clone()).unwrap();
    let frame = common::created_by_a_frame;
    assert!(frame(&mut r) > 0);
    assert_eq!(frame(&mut r), 0);
    // Nor does the driver keep memory per frame: lavapipe (Mesa 22.3) compiled and kept a shader
    // variant at every bind of a chunk whose constants were uniforms, some 1.8 GB a frame at the
    // default capacity (docs/beams.md, "Beams: memory"). Four full frames must not add a
    // gigabyte (the binary's other tests, run alongside, peak at some 0.6 GB in all).
    match resident_mb() {
        Some(before) => {
            for _ in 0..4 {
                r.invalidate();
                assert_eq!(frame(&mut r), 0);
                ctx.device.poll(wgpu::PollType::wait_indefinitely()).unwrap();
            }
            let grown = resident_mb().unwrap().saturating_sub(before);
            assert!(grown < 1024, "four beam frames kept {grown} MB");
        }
        None => eprintln!("memory per frame not checked: no /proc/self/status"),
    }
    // Bad beam settings: an error naming the field.
    for (bad, field) in [
        (BeamSettings { grid: 0, ..Default::default() }, "beams.grid"),
        (BeamSettings { levels: 9, ..Default::default() }, "beams.levels"),
        (BeamSettings { chunk_scale: 1025, ..Default::default() }, "beams.chunk_scale"),
        (BeamSettings { energy_threshold: -1.0, ..Default::default() }, "beams.energy_threshold"),
        (BeamSettings { residual: 1.0, ..Default::default() }, "beams.residual"),
        (BeamSettings { residual: f32::NAN, ..Default::default() }, "beams.residual"),
        (BeamSettings { cutoff: -1e-4, ..Default::default() }, "beams.cutoff"),
        (BeamSettings { cutoff: f32::INFINITY, ..Default::default() }, "beams.cutoff"),
    ] {
        let Err(e) = render(&ctx, &sc, &render_settings(bad)) else { panic!("{field}: no error") };
        let e = e.to_string();
        assert!(e.contains(field), "{e}");
    }
    // A capacity whose beam records exceed the adapter's storage-binding limit: named, not a
    // validation panic (lavapipe's limit is 128 MiB; 2^22 beams need 576 MiB).
    let most = BeamSettings { capacity: 1 << 22, ..Default::default() };
    let need = u64::from(most.capacity) * std::mem::size_of::<caustics::gpu::types::BeamGpu>() as u64;
    if need > ctx.device.limits().max_storage_buffer_binding_size {
        let Err(e) = render(&ctx, &sc, &render_settings(most)) else { panic!("beams.capacity: no error") };
        assert!(e.to_string().contains("beams.capacity"), "{e}");
    }
}

/// Larger chunks (`BeamSettings::chunk_scale`, 16 by default on GPUs) change only the order of
/// the sums: the volume caustic (gathered, `BeamVolume::Gather`) and the surface caustic from
/// beams of chunks twice lavapipe's size (half the dispatches) match those of its size to float
/// rounding.
#[test]
fn larger_chunks_change_only_the_order_of_the_sums() {
    let Some(ctx) = gpu() else { return };
    // The volume caustic in fog, and the surface caustic from beams on a lit floor.
    let (fog, floor) = (ball_in_fog(14.0, 24, 20), ball_at_45(24, 20, true));
    let run = |sc: &Scene, scale: u32| {
        let volume = caustics::render::BeamVolume::Gather;
        let b = BeamSettings { levels: 2, chunk_scale: scale, volume, ..Default::default() };
        let s = RenderSettings { beams: b, ..surface_settings(caustics::settings::LocalSource::Beams) };
        let g = render(&ctx, sc, &s).unwrap();
        assert!(g.beams[0].0.beams > 1000, "{} beams: too few to fill several chunks", g.beams[0].0.beams);
        // Chunk passes recorded (each is timed where the adapter has timestamp queries).
        let passes = g.timings.iter().filter(|(n, _)| n == "beam_gather" || n == "beam_surface").count();
        (g.caustic, passes)
    };
    for sc in [&fog, &floor] {
        let ((a, p1), (b, p2)) = (&run(sc, 1), &run(sc, 2));
        if ctx.timestamps {
            assert!(*p2 > 0 && 2 * p2 <= p1 + 2, "{p1} chunk passes, then {p2} with chunks twice as large");
        }
        let (sa, sb) = (sum(a), sum(b));
        assert!(sa > 0.0);
        assert!((sa / sb - 1.0).abs() < 1e-5, "sums {sa} and {sb}");
        let peak = a.pixels.iter().map(|p| p[0]).fold(0.0f32, f32::max);
        let worst = a.pixels.iter().zip(&b.pixels).map(|(p, q)| (p[0] - q[0]).abs()).fold(0.0f32, f32::max);
        assert!(worst <= 1e-5 * peak, "a pixel differs by {worst} (peak {peak})");
    }
}

/// The beams' hulls (`BeamVolume::Hulls`: beam_hull, beam_raster) add, per pixel and beam, what
/// the gather adds: the same images to the rounding of the sums' order, from the side (the
/// footprint integral of thin beams, several rays per pixel), with the camera inside the cone
/// under the ball (beams reaching behind the camera: their hulls cut in front of it, or the
/// whole image; beams through the focus near the camera: their hulls split there), and close
/// up (beams crossing the image's edges); and enough of the hulls' fragments add light. A hull missing a pixel a beam reaches, or covering one twice, would
/// differ by that beam's light there. The surface caustic from beams likewise (beam_surface
/// against beam_surface_raster). The same bits from run to run, and nothing created after a
/// renderer's first frame.
#[test]
fn hulls_draw_what_the_gather_adds() {
    use caustics::render::BeamVolume;
    use caustics::renderer::{FrameRequest, Renderer};
    let Some(ctx) = gpu() else { return };
    if !ctx.device.features().contains(wgpu::Features::FLOAT32_BLENDABLE) {
        let e = render(
            &ctx,
            &ball_in_fog(14.0, 8, 6),
            &render_settings(BeamSettings { volume: BeamVolume::Hulls, ..Default::default() }),
        );
        assert!(e.is_err_and(|e| e.to_string().contains("beams.volume")));
        eprintln!("hulls not checked: {} has no float32 blending", ctx.info.name);
        return;
    }
    // (small: the gather's cost is pixels times beams, and lavapipe is slow)
    let side = ball_in_fog(14.0, 32, 24);
    // Inside the cone below the focus (y 0.75), looking across it and down at the floor.
    let mut inside = side.clone();
    inside.camera.position = Vec3::new(0.0, 0.5, 0.0);
    inside.camera.look_at = Vec3::new(1.0, 0.2, 0.3);
    // Close up: the cone fills and leaves the image.
    let mut close = side.clone();
    close.camera.position = Vec3::new(0.0, 0.7, 0.8);
    close.camera.look_at = Vec3::new(0.0, 0.6, 0.0);
    // The least fraction of the hulls' fragments that must add light (the hulls' tightness:
    // before hulls reaching behind the camera were cut at it, 0.21, 0.022 and 0.071; with the
    // cut 0.64, 0.14 and 0.60; with the hulls that would still cover the whole image split at
    // the beams' foci 0.64, 0.43 and 0.59: inside the cone the convex hulls of the beams
    // through the focus held the camera).
    for (name, sc, b, lit_fill) in [
        ("side, 2x2 rays", &side, BeamSettings { levels: 2, pixel_samples: 2, ..Default::default() }, 0.4),
        ("inside the cone", &inside, BeamSettings { levels: 1, ..Default::default() }, 0.3),
        ("close up", &close, BeamSettings { levels: 1, ..Default::default() }, 0.4),
    ] {
        let gather = render(&ctx, sc, &render_settings(BeamSettings { volume: BeamVolume::Gather, ..b })).unwrap();
        let hs = render_settings(BeamSettings { volume: BeamVolume::Hulls, ..b });
        let hulls = render(&ctx, sc, &hs).unwrap();
        let (a, h) = (&gather.caustic, &hulls.caustic);
        let (sa, sh) = (sum(a), sum(h));
        let peak = a.pixels.iter().map(|p| p[0]).fold(0.0f32, f32::max);
        let worst = a.pixels.iter().zip(&h.pixels).map(|(p, q)| (p[0] - q[0]).abs()).fold(0.0f32, f32::max);
        let lit = a.pixels.iter().filter(|p| p[0] > 1e-3 * peak).count();
        let st = &hulls.beams[0].0;
        println!(
            "{name}: {} beams, gather {sa:.6e}, hulls {sh:.6e} ({:+.2e}), worst pixel {:.2e} of the peak, {lit} lit pixels, {} hull fragments ({} lit)",
            gather.beams[0].0.beams,
            sh / sa - 1.0,
            worst / peak,
            st.hull_fragments,
            st.hull_lit_fragments
        );
        assert!(sa > 0.0 && lit > 300, "{name}: too little volume caustic to compare");
        assert!((sh / sa - 1.0).abs() < 1e-5, "{name}: sums {sa} (gather) and {sh} (hulls)");
        assert!(worst <= 1e-5 * peak, "{name}: a pixel differs by {worst} (peak {peak})");
        assert!(
            f64::from(st.hull_lit_fragments) >= lit_fill * f64::from(st.hull_fragments),
            "{name}: {} of {} hull fragments lit",
            st.hull_lit_fragments,
            st.hull_fragments
        );
        // The full image too (the volume caustic is added to both).
        let full = gather.image.pixels.iter().zip(&hulls.image.pixels).map(|(p, q)| (p[0] - q[0]).abs());
        assert!(full.fold(0.0f32, f32::max) <= 1e-5 * peak, "{name}: the full images differ");
        let again = render(&ctx, sc, &hs).unwrap();
        assert_eq!(again.image.pixels, hulls.image.pixels, "{name}: hulls are not the same bits twice");
    }
    // The surface caustic from beams (beam_surface against beam_surface_raster), on a floor
    // under a tilted spot, with a table the beams stop at, and in the fog.
    let surf =
        |b: BeamSettings| RenderSettings { beams: b, ..surface_settings(caustics::settings::LocalSource::Beams) };
    let mut fog = side.clone();
    fog.camera.position = Vec3::new(0.0, 2.5, 2.2);
    fog.camera.look_at = Vec3::new(0.0, 0.0, 0.0);
    let floor = ball_at_45(32, 24, true);
    let mut white = floor.clone();
    white.medium = fog.medium.clone();
    for (name, sc) in [("floor and table", &floor), ("floor in fog", &white), ("fog from above", &fog)] {
        let b = BeamSettings { levels: 1, ..Default::default() };
        let gather = render(&ctx, sc, &surf(BeamSettings { volume: BeamVolume::Gather, ..b })).unwrap();
        let hulls = render(&ctx, sc, &surf(BeamSettings { volume: BeamVolume::Hulls, ..b })).unwrap();
        let (a, h) = (&gather.caustic, &hulls.caustic);
        let (sa, sh) = (sum(a), sum(h));
        let peak = a.pixels.iter().map(|p| p[0]).fold(0.0f32, f32::max);
        let worst = a.pixels.iter().zip(&h.pixels).map(|(p, q)| (p[0] - q[0]).abs()).fold(0.0f32, f32::max);
        println!(
            "surface, {name}: {} beams, gather {sa:.6e}, hulls {sh:.6e} ({:+.2e}), worst pixel {:.2e} of the peak, {} hull fragments ({} lit)",
            gather.beams[0].0.beams,
            sh / sa - 1.0,
            worst / peak,
            hulls.beams[0].0.hull_fragments,
            hulls.beams[0].0.hull_lit_fragments
        );
        assert!(sa > 0.0 && hulls.beams[0].0.hull_fragments > 0 && gather.beams[0].0.hull_fragments == 0);
        assert!((sh / sa - 1.0).abs() < 1e-5, "surface, {name}: sums {sa} (gather) and {sh} (hulls)");
        assert!(worst <= 1e-5 * peak, "surface, {name}: a pixel differs by {worst} (peak {peak})");
        // (the hulls of the beams' ends: 0.18, 0.51 and 0.42 of the fragments lit; of the whole
        // beams 0.09, 0.33 and 0.29; before the cut at the camera 0.09, 0.033 and 0.028)
        let st = &hulls.beams[0].0;
        assert!(
            f64::from(st.hull_lit_fragments) >= 0.12 * f64::from(st.hull_fragments),
            "surface, {name}: {} of {} hull fragments lit",
            st.hull_lit_fragments,
            st.hull_fragments
        );
    }
    // The renderer's steady state with hulls: nothing created after the first frame.
    let hs = render_settings(BeamSettings { levels: 2, volume: BeamVolume::Hulls, ..Default::default() });
    let mut r = Renderer::with_context(ctx.clone(), side.clone(), hs).unwrap();
    let mut frame = || {
        let before = r.created();
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        r.encode(&mut enc, FrameRequest { stats: false }).unwrap();
        let created = (r.created() - before).total();
        ctx.queue.submit([enc.finish()]);
        r.invalidate();
        created
    };
    assert!(frame() > 0);
    assert_eq!(frame(), 0);
}

/// This process's resident memory in MB (Linux only).
fn resident_mb() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let kb = status.lines().find_map(|l| l.strip_prefix("VmRSS:"))?.trim().trim_end_matches("kB").trim();
    Some(kb.parse::<u64>().ok()? / 1024)
}

/// The energy criterion's convergence (the beam's base over its smallest section before its
/// end, capped at 100) sees every focus. A ball lens focuses all its transmitted light onto the
/// axis; a beam whose corners lie at different distances from the axis has two focal lines
/// (its sections change orientation in between), and between them its section can be as large
/// as its base: the ends and the extremum of the section's quadratic alone made its convergence
/// 1 to 3, and at low energy thresholds a ring of 32² beams about the axis (exit points 0.16 to
/// 0.18 m from it) was never split (16² + 3 kept 578 beams at level 1 at a threshold of 0.005,
/// 384 at 0.001). Their relative flux (4.4e-4 of the face's at level 1) times the capped
/// convergence is 0.044: at 0.005 every such beam is split, at levels 0 and 1 none is kept
/// (lavapipe: 16² + 2 keeps 0, 0 and 4732 beams; before, 106, 272 and 1948).
#[test]
fn the_energy_criterion_sees_a_focal_line_inside_a_beam() {
    let Some(ctx) = gpu() else { return };
    let sc = ball_in_fog(14.0, 16, 16);
    let b = BeamSettings {
        grid: 16,
        levels: 2,
        energy_threshold: 0.005,
        linearity_threshold: 0.0,
        reflection: false,
        ..BeamSettings::default()
    };
    let out = render(&ctx, &sc, &render_settings(b)).unwrap();
    let kept = &out.beams[0].0.kept_per_level;
    println!("beams kept per level: {kept:?}");
    assert!(kept[2] > 1000, "{kept:?}");
    assert_eq!(kept[0] + kept[1], 0, "beams kept at levels 0 and 1: {kept:?}");
}

/// The energy cutoff (`BeamSettings::cutoff`, the paper's section 4.3): on the ball in fog
/// (every branch, 24 × 20), against the same render without it, beam by beam (the base and
/// directions identify a beam; a cut changes only its ends): a cut beam ends at one section
/// above its last focus, all three edges shortened, and the light of the part it lost, seen
/// along the beam (σs p flux ∫ dy / (cos A(y)) from the new end to the farthest old one, by
/// quadrature on the CPU), is at most the cutoff; a dropped beam's light along all of it is too.
/// Only beams whose section grows are cut (none of the thin prisms), the image loses light and
/// gains none (every pixel within 0.6 % above its uncut value: the midpoint rule on the shortened
/// pieces of the camera rays, 0.28 % measured), the caustic's energy within 1 % at 10⁻⁴
/// W/(m² sr) (0.11 % measured; the largest lost tail 0.835 of the cutoff), and the hulls shade
/// fewer fragments. With surface caustics from beams no beam landing on an object is cut (its
/// end lights it).
#[test]
fn the_energy_cutoff_drops_only_diverging_tails_below_it() {
    let Some(ctx) = gpu() else { return };
    let sc = ball_in_fog(14.0, 24, 20);
    let cutoff = 1e-4f32;
    let full = render(&ctx, &sc, &render_settings(BeamSettings::default())).unwrap();
    let cut = render(&ctx, &sc, &render_settings(BeamSettings { cutoff, ..BeamSettings::default() })).unwrap();
    let key = |b: &Beam| [b.vertices, b.dirs].map(|vs| vs.map(|v| v.to_array().map(f32::to_bits)));
    let by_key: std::collections::HashMap<_, &Beam> = full.beams[0].1.iter().map(|b| (key(b), b)).collect();
    // (σs of the scene, the isotropic phase function)
    let sigma_p = 0.3 / (4.0 * std::f64::consts::PI);
    let tail = |b: &Beam, from: f64| -> f64 {
        let n = b.normal();
        let cos = b.dirs.iter().map(|d| f64::from(n.dot(*d))).fold(1.0, f64::min);
        let to = (0..3).map(|k| f64::from(b.ends[k] * n.dot(b.dirs[k]))).fold(0.0, f64::max);
        let steps = 4000;
        let dy = (to - from) / steps as f64;
        let integral: f64 =
            (0..steps).map(|i| dy / f64::from(b.area((from + (i as f64 + 0.5) * dy) as f32)).max(1e-30)).sum();
        sigma_p * f64::from(b.flux.max_element()) * integral / cos
    };
    let (mut shortened, mut worst) = (0, 0.0f64);
    let mut kept = std::collections::HashSet::new();
    for b in &cut.beams[0].1 {
        let f = by_key.get(&key(b)).unwrap_or_else(|| panic!("a beam of the cut render is not in the full one"));
        kept.insert(key(b));
        if b.ends == f.ends {
            continue;
        }
        shortened += 1;
        let n = b.normal();
        let h = [0, 1, 2].map(|k| b.ends[k] * n.dot(b.dirs[k]));
        assert!(b.ends.iter().zip(&f.ends).all(|(c, u)| c < u), "not all edges cut: {:?} of {:?}", b.ends, f.ends);
        assert!((h[1] - h[0]).abs() < 1e-4 * h[0] && (h[2] - h[0]).abs() < 1e-4 * h[0], "end heights {h:?}");
        assert!(f.area(h[0]) > f.area(0.0), "a cut beam that does not diverge: {:?}", f);
        let lost = tail(f, f64::from(h[0]));
        worst = worst.max(lost / f64::from(cutoff));
        assert!(lost <= f64::from(cutoff) * 1.001, "a cut tail holds {lost} W/(m² sr), cutoff {cutoff}");
    }
    let dropped: Vec<&&Beam> = by_key.iter().filter(|(k, _)| !kept.contains(*k)).map(|(_, b)| b).collect();
    for b in &dropped {
        let lost = tail(b, 0.0);
        worst = worst.max(lost / f64::from(cutoff));
        assert!(lost <= f64::from(cutoff) * 1.001, "a dropped beam holds {lost} W/(m² sr)");
    }
    let stats = &cut.beams[0].0;
    let (e_full, e_cut) = (sum(&full.caustic), sum(&cut.caustic));
    let brightest = full.caustic.pixels.iter().map(|p| p[0]).fold(0.0f32, f32::max);
    // (a shortened piece of a camera ray inside a beam gets the midpoint rule's points closer
    // together: its quadrature differs from that of the longer piece by up to 0.28 % of a pixel)
    let over = full
        .caustic
        .pixels
        .iter()
        .zip(&cut.caustic.pixels)
        .map(|(u, c)| (c[0] - u[0]) / (u[0] + 1e-6 * brightest))
        .fold(0.0f32, f32::max);
    println!(
        "cutoff {cutoff}: {shortened} beams shortened, {} dropped ({} counted), the largest lost tail {worst:.3} of the cutoff; caustic energy {:.5}; fragments {} -> {}",
        dropped.len(),
        stats.cut,
        e_cut / e_full,
        full.beams[0].0.hull_fragments,
        stats.hull_fragments
    );
    assert_eq!(stats.cut as usize, shortened + dropped.len());
    assert!(shortened > 100, "{shortened} beams cut");
    assert!(over <= 0.006, "a pixel gained {over} of its light");
    assert!(e_cut < e_full && e_cut > 0.99 * e_full, "caustic energy {e_cut} against {e_full}");
    assert!(stats.hull_fragments < full.beams[0].0.hull_fragments);
    // Surface caustics from beams: a beam landing on an object keeps its end.
    let s = |c: f32| RenderSettings {
        sources: caustics::settings::SourceSettings {
            local: caustics::settings::LocalSource::Beams,
            ..Default::default()
        },
        ..render_settings(BeamSettings { cutoff: c, ..BeamSettings::default() })
    };
    let (sf, sc_cut) = (render(&ctx, &sc, &s(0.0)).unwrap(), render(&ctx, &sc, &s(cutoff)).unwrap());
    let landing: std::collections::HashMap<_, &Beam> =
        sf.beams[0].1.iter().filter(|b| b.land != u32::MAX && b.layer == 0).map(|b| (key(b), b)).collect();
    let mut landed_kept = 0;
    for b in sc_cut.beams[0].1.iter().filter(|b| b.land != u32::MAX && b.layer == 0) {
        assert_eq!(Some(&b.ends), landing.get(&key(b)).map(|f| &f.ends), "a beam lighting the floor was cut");
        landed_kept += 1;
    }
    assert_eq!(landed_kept, landing.len());
    assert!(sc_cut.beams[0].0.cut > 0, "no beam leaving the scene was cut");
}
