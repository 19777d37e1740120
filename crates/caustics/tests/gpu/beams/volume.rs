//! The volume caustic's image against references: the CPU reference, the CPU's quadrature of the
//! same beams, the noise-free line integral (the linearity criterion), density grids.

use super::*;
use crate::shared::ball_mask;

// The target (mean HDR-FLIP 0.1, energy within 5 %) on this scene (48 x 40, the ball
// masked), default settings (adaptive 16² + 3, the footprint integral, every branch's
// silhouette shrunk, the reflected branches' Fresnel quadrature), against the single-scattering
// reference at 2^27 photons (REF_PHOTONS to change; itself HDR-FLIP 0.043, energy +0.02 % from
// the noise-free line integral `line_integral_reference`): measured 2026-12-03 HDR-FLIP
// 0.0698, energy -1.17 % (against the line integral 0.0644) with the linearity criterion
// (12674 beams). Before it 0.0882, -1.47 % (line integral 0.0806), once every path of a shrunk
// silhouette triangle was kept (0.0951, -1.56 % before that; 0.0983, -1.86 % before the gather took
// the beam's flux direction); 2026-12-05, the pixels ending at their surface's tangent plane:
// 0.0566, -0.23 % (line integral 0.0485), 13583 beams. At 2^25 photons the reference's
// own noise (0.056 from the line integral) adds to the comparison: 0.102. Regular 64²
// (BEAM_CONFIGS=all): 0.0967 against the line integral before that change (0.092 after). Ignored for its time (the reference,
// some 70 s on two cores; the beams some 25 s on lavapipe); run it with `--ignored` (it prints
// the figures; BEAM_DUMP=DIR writes the images).
#[test]
#[ignore = "slow (a 2^27-photon CPU reference): volume caustic against the reference, HDR-FLIP 0.057, energy -0.2 % (target 0.1, 5 %)"]
fn gpu_beams_match_the_cpu_reference_in_fog() {
    use caustics_reference::metrics::{energy, hdr_flip};
    use caustics_reference::reference;
    let Some(ctx) = gpu() else { return };
    let (w, h) = (48, 40);
    let sc = ball_in_fog(14.0, w, h);
    // Pixels that see the ball (dilated by a pixel's width): the reference does not render
    // a volume caustic seen through glass.
    let mask = ball_mask(&sc);
    // 2^27 photons (at 2^25 the reference against itself with another seed gave HDR-FLIP
    // 0.066: its noise is a floor under the comparison).
    let photons = std::env::var("REF_PHOTONS").ok().and_then(|v| v.parse().ok()).unwrap_or(1u64 << 27);
    let rs = common::single_scattering_reference(photons, 1, 5);
    let t = std::time::Instant::now();
    let r = reference::render(&sc, &rs).unwrap();
    // The reference's own error: against the noise-free line integral.
    let lines = line_integral_reference(&sc, 100);
    let line = to_image(&(0..(w * h) as usize).map(|i| lines.iter().map(|c| c[i]).sum()).collect::<Vec<f64>>(), w, h);
    println!(
        "reference ({photons} photons): {:.1} s; against the line integral HDR-FLIP {:.4}, energy {:+.2} %",
        t.elapsed().as_secs_f64(),
        hdr_flip(&r.caustic, &line, Some(&mask)).unwrap().mean,
        (energy(&r.caustic, Some(&mask)) / energy(&line, Some(&mask)) - 1.0) * 100.0
    );
    let configs: Vec<(&str, BeamSettings)> = match std::env::var("BEAM_CONFIGS") {
        Ok(f) if f == "all" => {
            vec![("adaptive 16+3", BeamSettings::default()), ("regular 64", BeamSettings::regular(64))]
        }
        _ => vec![("adaptive 16+3", BeamSettings::default())],
    };
    for (name, b) in configs {
        let t = std::time::Instant::now();
        let g = render(&ctx, &sc, &render_settings(b)).unwrap();
        let ms = t.elapsed().as_secs_f64() * 1e3;
        let flip = hdr_flip(&g.caustic, &r.caustic, Some(&mask)).unwrap().mean;
        let (eg, er) = (energy(&g.caustic, Some(&mask)), energy(&r.caustic, Some(&mask)));
        println!(
            "{name}: {} beams, HDR-FLIP {flip:.4}, energy GPU {eg:.5} reference {er:.5} ({:+.2} %), {ms:.0} ms; against the line integral HDR-FLIP {:.4}",
            g.beams[0].0.beams,
            (eg / er - 1.0) * 100.0,
            hdr_flip(&g.caustic, &line, Some(&mask)).unwrap().mean
        );
        if std::env::var_os("BEAM_DUMP").is_some() {
            let dir = std::path::PathBuf::from(std::env::var_os("BEAM_DUMP").unwrap());
            caustics_reference::io::ImageIo::write(&g.caustic, &dir.join(format!("gpu_{}.exr", b.levels)), 1.0)
                .unwrap();
            caustics_reference::io::ImageIo::write(&r.caustic, &dir.join("reference.exr"), 1.0).unwrap();
        }
        assert!(flip < 0.1, "{name}: HDR-FLIP {flip}");
        assert!((eg / er - 1.0).abs() < 0.05, "{name}: energy {eg} vs {er}");
    }
}

/// `beam_raster` draws the beams it is given as an independent integrator does: the CPU's
/// quadrature of the same beams (`reference::beam_splat`: 8² lines per beam, 64 points each,
/// the first surfaces from 4 × 4 rays per pixel) on the ball in fog (every branch, the ball
/// masked), row by row: energy within 0.5 %, rows within 1 %. Measured: energy 1.0001, rows within 0.5 %; with the sub-pixel rays and
/// footprint ending at the plane facing the camera (before 2026-12-05) the row where the shaft
/// meets the floor has 0.917 of the light and fails.
#[test]
fn beam_raster_draws_its_beams_as_the_cpu_integrates_them() {
    use caustics_reference::reference::beam_splat::{BeamSplat, lines};
    let Some(ctx) = gpu() else { return };
    let (w, h) = (48, 40);
    let sc = ball_in_fog(14.0, w, h);
    let mask = ball_mask(&sc);
    let out = render(&ctx, &sc, &render_settings(BeamSettings::default())).unwrap();
    let beams = &out.beams[0].1;
    let splat = BeamSplat::new(&sc).unwrap().beams(beams, &lines(8), 64, false);
    let row =
        |y: u32, f: &dyn Fn(u32) -> f64| -> f64 { (0..w).filter(|&x| mask.include[(y * w + x) as usize]).map(f).sum() };
    let (mut gpu_all, mut cpu_all, mut worst) = (0.0, 0.0, (0u32, 1.0f64));
    let total: f64 = splat.iter().sum();
    for y in 0..h {
        let g = row(y, &|x| f64::from(out.caustic.get(x, y)[0]));
        let c = row(y, &|x| splat[(y * w + x) as usize]);
        (gpu_all, cpu_all) = (gpu_all + g, cpu_all + c);
        // (rows that hold at least 1 % of the light)
        if c > 0.01 * total && (g / c - 1.0).abs() > (worst.1 - 1.0).abs() {
            worst = (y, g / c);
        }
    }
    println!("{} beams: GPU / CPU energy {:.4}, worst row {} {:.4}", beams.len(), gpu_all / cpu_all, worst.0, worst.1);
    assert!((gpu_all / cpu_all - 1.0).abs() < 0.005, "energy {}", gpu_all / cpu_all);
    assert!((worst.1 - 1.0).abs() < 0.01, "row {}: {}", worst.0, worst.1);
}

/// Path classes of the light leaving the glass ball: reflected at the first surface (R),
/// refracted in and out (TT), with one internal reflection (TRT), with more (T R..R T).
const PATH_CLASSES: [&str; 4] = ["R", "TT", "TRT", "TR+RT"];

/// The single-scattered volume caustic of [`ball_in_fog`], integrated on the CPU independently
/// of the reference's random photons and of the beams: `rings` x `4 rings` stratified light
/// rays onto the ball (equal solid angle), every branch of the exact Fresnel split followed
/// (weights, not sampling) up to 6 interactions, and each ray leaving the ball integrated
/// along its length (midpoint steps of 5 mm) into the pixel it projects to: σs Φ ds T phase /
/// (d² A_pix cos³ θc), T the transmittance from the light along the path and to the camera,
/// points hidden from the camera by the ball dropped. One image per path class.
fn line_integral_reference(sc: &Scene, rings: usize) -> Vec<Vec<f64>> {
    let cam = &sc.camera;
    let (w, h) = (cam.width as usize, cam.height as usize);
    let (lp, centre, r, n) = (glam::DVec3::new(0.0, 4.0, 0.0), glam::DVec3::new(0.0, 1.5, 0.0), 0.5f64, 1.5f64);
    let (ss, st, i0) = (0.3f64, 0.35f64, 20.0f64);
    let (lo, hi) = (glam::DVec3::new(-4.0, -0.1, -4.0), glam::DVec3::new(4.0, 4.5, 4.0));
    let tan_y = (f64::from(cam.fov_y_deg).to_radians() * 0.5).tan();
    let tan_x = tan_y * f64::from(cam.aspect());
    let pix_area = (2.0 * tan_x / w as f64) * (2.0 * tan_y / h as f64);
    let (cp, fwd, right, up) =
        (cam.position.as_dvec3(), cam.forward().as_dvec3(), cam.right().as_dvec3(), cam.true_up().as_dvec3());
    let hit_sphere = |o: glam::DVec3, d: glam::DVec3| -> Option<(f64, f64)> {
        let oc = o - centre;
        let b = oc.dot(d);
        let disc = b * b - (oc.length_squared() - r * r);
        (disc > 0.0).then(|| (-b - disc.sqrt(), -b + disc.sqrt()))
    };
    let mut imgs = vec![vec![0.0f64; w * h]; PATH_CLASSES.len()];
    let splat = |imgs: &mut Vec<Vec<f64>>, class: usize, o: glam::DVec3, d: glam::DVec3, pre: f64, flux: f64| {
        // To the floor (y = 0) or the box's side.
        let mut t_end = f64::INFINITY;
        for k in 0..3 {
            if d[k] != 0.0 {
                t_end = t_end.min(((if d[k] > 0.0 { hi[k] } else { lo[k] }) - o[k]) / d[k]);
            }
        }
        if d.y < 0.0 {
            t_end = t_end.min(-o.y / d.y);
        }
        let ds = 0.005;
        let steps = (t_end / ds).ceil() as usize;
        let ds = t_end / steps as f64;
        for s in 0..steps {
            let t = (s as f64 + 0.5) * ds;
            let x = o + d * t;
            let to = cp - x;
            let dist = to.length();
            let dir = to / dist;
            if let Some((a, b)) = hit_sphere(x, dir)
                && b > 0.0
                && a < dist
            {
                continue;
            }
            let v = -dir;
            let z = v.dot(fwd);
            if z <= 1e-9 {
                continue;
            }
            let sx = v.dot(right) / z / tan_x;
            let sy = v.dot(up) / z / tan_y;
            let px = (sx + 1.0) * 0.5 * w as f64;
            let py = (1.0 - sy) * 0.5 * h as f64;
            if !(px >= 0.0 && py >= 0.0 && px < w as f64 && py < h as f64) {
                continue;
            }
            let tr = (-st * (pre + t + dist)).exp();
            let val = ss * flux * ds * tr * 0.25 / std::f64::consts::PI / (dist * dist * pix_area * z * z * z);
            imgs[class][py as usize * w + px as usize] += val;
        }
    };
    // The light's rays onto the ball: cos α uniform in [cos αmax, 1], φ uniform.
    let amax = (r / (lp - centre).length()).asin();
    let (na, nphi) = (rings, 4 * rings);
    let domega = 2.0 * std::f64::consts::PI * (1.0 - amax.cos()) / (na * nphi) as f64;
    for ia in 0..na {
        let ca = 1.0 - (1.0 - amax.cos()) * (ia as f64 + 0.5) / na as f64;
        let sa = (1.0 - ca * ca).sqrt();
        for ip in 0..nphi {
            let phi = (ip as f64 + 0.5) / nphi as f64 * std::f64::consts::TAU;
            let d = glam::DVec3::new(sa * phi.cos(), -ca, sa * phi.sin());
            let Some((t0, _)) = hit_sphere(lp, d) else { continue };
            // Branches: (origin, direction, inside, weight, internal reflections, interactions).
            let mut stack = vec![(lp + d * t0, d, false, i0 * domega, 0u32, 0u32)];
            let pre = t0;
            while let Some((p, d, inside, wgt, refl, depth)) = stack.pop() {
                if depth >= 6 || wgt < 1e-12 {
                    continue;
                }
                let nrm = (p - centre).normalize() * if inside { -1.0 } else { 1.0 };
                let cos_i = -d.dot(nrm);
                let eta = if inside { 1.0 / n } else { n };
                let f = fresnel(cos_i, eta);
                let rd = d + nrm * (2.0 * cos_i);
                // Reflected.
                if inside {
                    let (_, t1) = hit_sphere(p, rd).unwrap_or((0.0, 0.0));
                    stack.push((p + rd * t1, rd, true, wgt * f, refl + 1, depth + 1));
                } else {
                    splat(&mut imgs, 0, p, rd, pre, wgt * f);
                }
                // Transmitted.
                if f < 1.0 {
                    let k = 1.0 / eta;
                    let ct = (1.0 - k * k * (1.0 - cos_i * cos_i)).sqrt();
                    let td = (d * k + nrm * (k * cos_i - ct)).normalize();
                    if inside {
                        let class = match refl {
                            0 => 1,
                            1 => 2,
                            _ => 3,
                        };
                        splat(&mut imgs, class, p, td, pre, wgt * (1.0 - f));
                    } else {
                        let (_, t1) = hit_sphere(p, td).unwrap_or((0.0, 0.0));
                        stack.push((p + td * t1, td, true, wgt * (1.0 - f), refl, depth + 1));
                    }
                }
            }
        }
    }
    imgs
}

/// The mean absolute error of `a` against `b` over the mask's pixels, relative to `b`'s mean
/// (first channel).
fn rel_l1(
    a: &caustics::image_io::Image,
    b: &caustics::image_io::Image,
    mask: &caustics_reference::metrics::Mask,
) -> f64 {
    let (mut d, mut t) = (0.0f64, 0.0f64);
    for (i, (p, q)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        if mask.include[i] {
            d += (f64::from(p[0]) - f64::from(q[0])).abs();
            t += f64::from(q[0]);
        }
    }
    d / t
}

fn to_image(px: &[f64], w: u32, h: u32) -> caustics::image_io::Image {
    let mut img = caustics::image_io::Image::new(w, h);
    for y in 0..h {
        for x in 0..w {
            let v = px[(y * w + x) as usize] as f32;
            img.set(x, y, [v, v, v]);
        }
    }
    img
}

/// Diagnostic (run with `--ignored --nocapture`): the volume caustic's error split by path
/// class, by image row and by beam and pixel sampling.
#[test]
#[ignore = "diagnostic: prints the error decomposition"]
fn beam_error_decomposition() {
    use caustics_reference::metrics::{energy, hdr_flip};
    use caustics_reference::reference::{self, ReferenceSettings};
    let Some(ctx) = gpu() else { return };
    let k: u32 = std::env::var("SIZE_K").ok().and_then(|v| v.parse().ok()).unwrap_or(1);
    let (w, h) = (48 * k, 40 * k);
    let sc = ball_in_fog(14.0, w, h);
    let mask = ball_mask(&sc);
    let t = std::time::Instant::now();
    let rings: usize = std::env::var("RINGS").ok().and_then(|v| v.parse().ok()).unwrap_or(100);
    let lines = line_integral_reference(&sc, rings);
    println!("line reference ({rings} rings): {:.1} s", t.elapsed().as_secs_f64());
    let total: Vec<f64> = (0..(w * h) as usize).map(|i| lines.iter().map(|c| c[i]).sum()).collect();
    let line_all = to_image(&total, w, h);
    let el = energy(&line_all, Some(&mask));
    for (c, name) in PATH_CLASSES.iter().enumerate() {
        let e = energy(&to_image(&lines[c], w, h), Some(&mask));
        println!("class {name}: energy {e:.5} ({:.2} % of all)", e / el * 100.0);
    }
    // LINE_CHECK: the line integral against itself at twice the rings (its own convergence).
    if std::env::var_os("LINE_CHECK").is_some() {
        let fine = line_integral_reference(&sc, 2 * rings);
        let fine: Vec<f64> = (0..(w * h) as usize).map(|i| fine.iter().map(|c| c[i]).sum()).collect();
        let fine = to_image(&fine, w, h);
        println!(
            "line integral {rings} rings vs {} rings: HDR-FLIP {:.4}, energy {:+.3} %",
            2 * rings,
            hdr_flip(&line_all, &fine, Some(&mask)).unwrap().mean,
            (el / energy(&fine, Some(&mask)) - 1.0) * 100.0
        );
    }
    let tt = to_image(&lines[1], w, h);
    let r_only: Vec<f64> = (0..(w * h) as usize).map(|i| lines[0][i] + lines[2][i] + lines[3][i]).collect();
    let r_only = to_image(&r_only, w, h);
    if std::env::var_os("NO_REF").is_none() {
        let rs = common::single_scattering_reference(
            std::env::var("REF_PHOTONS").ok().and_then(|v| v.parse().ok()).unwrap_or(1 << 22),
            1,
            5,
        );
        let r = reference::render(&sc, &rs).unwrap();
        let r2 = reference::render(&sc, &ReferenceSettings { seed: 6, ..rs }).unwrap();
        let er = energy(&r.caustic, Some(&mask));
        println!(
            "reference vs line integral: energy {:+.2} %, HDR-FLIP {:.4}; reference seed 5 vs 6: HDR-FLIP {:.4}, energy {:+.2} %",
            (er / el - 1.0) * 100.0,
            hdr_flip(&r.caustic, &line_all, Some(&mask)).unwrap().mean,
            hdr_flip(&r2.caustic, &r.caustic, Some(&mask)).unwrap().mean,
            (energy(&r2.caustic, Some(&mask)) / er - 1.0) * 100.0
        );
        let row = |img: &caustics::image_io::Image, y: u32| -> f64 {
            (0..w).filter(|&x| mask.include[(y * w + x) as usize]).map(|x| f64::from(img.get(x, y)[0])).sum()
        };
        let rows: Vec<String> = (0..h)
            .filter(|&y| row(&line_all, y) > 0.0)
            .map(|y| format!("{y}:{:.2}", row(&r.caustic, y) / row(&line_all, y)))
            .collect();
        println!("  rows (reference / line): {}", rows.join(" "));
        if std::env::var_os("ONLY_REF").is_some() {
            return;
        }
    }
    // PIXEL_SAMPLES=n: only the regular 32² grid with n x n rays per pixel (the pixel
    // footprint's convergence at a small cost).
    let only_px: Option<u32> = std::env::var("PIXEL_SAMPLES").ok().and_then(|v| v.parse().ok());
    let configs: Vec<(&str, BeamSettings)> = if let Some(n) = only_px {
        vec![("regular 32, PIXEL_SAMPLES rays", BeamSettings { pixel_samples: n, ..BeamSettings::regular(32) })]
    } else {
        let rays = |b: BeamSettings, n: u32| BeamSettings { footprint: 0.0, pixel_samples: n, ..b };
        let foot = |b: BeamSettings, k: f32, lines: u32| BeamSettings { footprint: k, footprint_lines: lines, ..b };
        let ad = BeamSettings::default();
        vec![
            ("adaptive 16+3", ad),
            ("adaptive 16+3 foot1 l2", foot(ad, 1.0, 2)),
            ("adaptive 16+4", BeamSettings { levels: 4, ..ad }),
            ("adaptive 16+3 foot4 l4", foot(ad, 4.0, 4)),
            ("adaptive 16+3 rays1", rays(ad, 1)),
            ("adaptive 16+3 rays3", rays(ad, 3)),
            ("regular 64", BeamSettings::regular(64)),
            ("regular 32", BeamSettings::regular(32)),
            ("regular 16", BeamSettings::regular(16)),
            ("regular 128", BeamSettings::regular(128)),
            ("adaptive 16+3 lin0", BeamSettings { linearity_threshold: 0.0, ..ad }),
            ("adaptive 16+3 lin0.05", BeamSettings { linearity_threshold: 0.05, ..ad }),
            ("adaptive 16+3 lin0.2", BeamSettings { linearity_threshold: 0.2, ..ad }),
            ("adaptive 16+3 lin0.3", BeamSettings { linearity_threshold: 0.3, ..ad }),
            ("adaptive 16+2 lin0.1", BeamSettings { levels: 2, ..ad }),
            ("adaptive 16+2 lin0.05", BeamSettings { levels: 2, linearity_threshold: 0.05, ..ad }),
            ("adaptive 24+2", BeamSettings { grid: 24, levels: 2, ..ad }),
            ("adaptive 12+3", BeamSettings { grid: 12, levels: 3, ..ad }),
            ("adaptive 32+2", BeamSettings { grid: 32, levels: 2, ..ad }),
            ("regular 64 rays3", rays(BeamSettings::regular(64), 3)),
            ("regular 32 rays3", rays(BeamSettings::regular(32), 3)),
        ]
    };
    // SWEEP=grid:levels:linearity:energy[:reflection[:cutoff]],...: these configurations instead.
    let sweep: Vec<(String, BeamSettings)> = std::env::var("SWEEP")
        .ok()
        .map(|v| {
            v.split(',')
                .map(|c| {
                    let f: Vec<f32> = c.split(':').map(|x| x.parse().unwrap()).collect();
                    let b = BeamSettings {
                        grid: f[0] as u32,
                        levels: f[1] as u32,
                        linearity_threshold: f[2],
                        energy_threshold: f[3],
                        reflection: f.get(4).is_none_or(|&r| r != 0.0),
                        cutoff: f.get(5).copied().unwrap_or(0.0),
                        ..BeamSettings::default()
                    };
                    (format!("sweep {c}"), b)
                })
                .collect()
        })
        .unwrap_or_default();
    let configs: Vec<(&str, BeamSettings)> =
        if sweep.is_empty() { configs } else { sweep.iter().map(|(n, b)| (n.as_str(), *b)).collect() };
    // BEAM_CONFIGS=a,b: only the configurations whose names contain one of these (=name: is it).
    let configs: Vec<(&str, BeamSettings)> = match std::env::var("BEAM_CONFIGS") {
        Ok(f) => configs
            .into_iter()
            .filter(|(n, _)| f.split(',').any(|p| p.strip_prefix('=').map_or(n.contains(p), |p| *n == p)))
            .collect(),
        Err(_) => configs,
    };
    for (name, b) in configs {
        let t = std::time::Instant::now();
        let on = render(&ctx, &sc, &render_settings(b)).unwrap();
        let ms = t.elapsed().as_secs_f64() * 1e3;
        // NO_SPLIT: all classes only (no second render without the reflected branches).
        if std::env::var_os("NO_SPLIT").is_some() {
            // (without the reflected branches: against the transmitted class)
            let line_all = if b.reflection { line_all.clone() } else { tt.clone() };
            println!(
                "{name}: {} beams {:?} ({} cut, {} fragments), {ms:.0} ms; all vs line all: L1 {:.4} FLIP {:.4} energy {:+.2} %",
                on.beams[0].0.beams,
                on.beams[0].0.kept_per_level,
                on.beams[0].0.cut,
                on.beams[0].0.hull_fragments,
                rel_l1(&on.caustic, &line_all, &mask),
                hdr_flip(&on.caustic, &line_all, Some(&mask)).unwrap().mean,
                (energy(&on.caustic, Some(&mask)) / energy(&line_all, Some(&mask)) - 1.0) * 100.0
            );
            if let Some(dir) = std::env::var_os("BEAM_DUMP") {
                let dir = std::path::PathBuf::from(dir);
                let tag = name.replace(' ', "_");
                caustics_reference::io::ImageIo::write(&on.caustic, &dir.join(format!("all_{tag}.exr")), 1.0).unwrap();
                // Raw little-endian f32 (red channel; the mask as 0 / 1) for scripts.
                let raw = |img: &caustics::image_io::Image| -> Vec<u8> {
                    img.pixels.iter().flat_map(|p| p[0].to_le_bytes()).collect()
                };
                std::fs::write(dir.join(format!("all_{tag}.f32")), raw(&on.caustic)).unwrap();
                std::fs::write(dir.join("all_line.f32"), raw(&line_all)).unwrap();
                let m: Vec<u8> =
                    mask.include.iter().flat_map(|&i| (if i { 1.0f32 } else { 0.0 }).to_le_bytes()).collect();
                std::fs::write(dir.join("mask.f32"), m).unwrap();
                caustics_reference::io::ImageIo::write(&line_all, &dir.join("all_line.exr"), 1.0).unwrap();
            }
            continue;
        }
        let off = render(&ctx, &sc, &render_settings(BeamSettings { reflection: false, ..b })).unwrap();
        let mut refl = off.caustic.clone();
        for (o, (a, t)) in refl.pixels.iter_mut().zip(on.caustic.pixels.iter().zip(&off.caustic.pixels)) {
            *o = [a[0] - t[0], a[1] - t[1], a[2] - t[2]];
        }
        let e = |a: &caustics::image_io::Image, b: &caustics::image_io::Image| {
            (energy(a, Some(&mask)) / energy(b, Some(&mask)) - 1.0) * 100.0
        };
        println!(
            "{name}: {} beams, {ms:.0} ms; all vs line all: FLIP {:.4} energy {:+.2} %; TT beams vs TT: FLIP {:.4} energy {:+.2} %; reflected beams vs R + TRT + rest: energy {:+.2} %",
            on.beams[0].0.beams,
            hdr_flip(&on.caustic, &line_all, Some(&mask)).unwrap().mean,
            e(&on.caustic, &line_all),
            hdr_flip(&off.caustic, &tt, Some(&mask)).unwrap().mean,
            e(&off.caustic, &tt),
            e(&refl, &r_only),
        );
        // Per-row energy of the transmitted light (masked), beams / line integral.
        let row = |img: &caustics::image_io::Image, y: u32| -> f64 {
            (0..w).filter(|&x| mask.include[(y * w + x) as usize]).map(|x| f64::from(img.get(x, y)[0])).sum()
        };
        let rows: Vec<String> = (0..h)
            .filter(|&y| row(&tt, y) > 0.0)
            .map(|y| format!("{y}:{:.2}", row(&off.caustic, y) / row(&tt, y)))
            .collect();
        println!("  TT rows (beams / line): {}", rows.join(" "));
        if let Some(dir) = std::env::var_os("BEAM_DUMP") {
            let dir = std::path::PathBuf::from(dir);
            let tag = name.replace(' ', "_");
            caustics_reference::io::ImageIo::write(&off.caustic, &dir.join(format!("tt_{tag}.exr")), 1.0).unwrap();
            caustics_reference::io::ImageIo::write(&refl, &dir.join(format!("refl_{tag}.exr")), 1.0).unwrap();
            caustics_reference::io::ImageIo::write(&r_only, &dir.join("refl_line.exr"), 1.0).unwrap();
            caustics_reference::io::ImageIo::write(&tt, &dir.join("tt_line.exr"), 1.0).unwrap();
            caustics_reference::io::ImageIo::write(&line_all, &dir.join("all_line.exr"), 1.0).unwrap();
        }
    }
}

/// The linearity criterion (`BeamSettings::linearity_threshold`): without it the adaptive
/// hierarchy kept coarse beams near the ball's rim whose light lands up to a section's width
/// off its true place. Against the noise-free line integral (`ball_in_fog`, 48 x 40, ball
/// masked), the relative mean absolute error per pixel measured on lavapipe: 0.0392 without it
/// (10838 beams), 0.0243 with the default 0.05 (12674 beams), regular 64² 0.0203 (13858).
/// With every branch and the residual (13583 beams), 0.0231; since beams with an oblique base
/// are rebased across their edges from a cosine of 0.95 (`make_beam`, 2026-12-05), 0.0169
/// (0.0346 without the criterion; regular 64²: 0.0164); since the pixels end at their first
/// surface's tangent plane (2026-12-05), 0.0139 (0.0324 without).
/// Bounds: with it below 0.016 (the plane facing the camera, 0.0169, fails it) and below 0.75
/// of the error without it, with no more beams than regular 64² has (13858); the rows where the
/// shaft meets the floor within 1.5 % of the line integral (0.993 … 0.998; with the plane
/// facing the camera row 35 has 0.914).
#[test]
fn the_linearity_criterion_puts_the_rims_light_in_place() {
    let Some(ctx) = gpu() else { return };
    let k: u32 = std::env::var("SIZE_K").ok().and_then(|v| v.parse().ok()).unwrap_or(1);
    let (w, h) = (48 * k, 40 * k);
    let sc = ball_in_fog(14.0, w, h);
    let mask = ball_mask(&sc);
    let lines = line_integral_reference(&sc, 100);
    let line = to_image(&(0..(w * h) as usize).map(|i| lines.iter().map(|c| c[i]).sum()).collect::<Vec<f64>>(), w, h);
    let ad = BeamSettings::default();
    assert!(ad.linearity_threshold > 0.0);
    let on = render(&ctx, &sc, &render_settings(ad)).unwrap();
    let off = render(&ctx, &sc, &render_settings(BeamSettings { linearity_threshold: 0.0, ..ad })).unwrap();
    let (e_on, e_off) = (rel_l1(&on.caustic, &line, &mask), rel_l1(&off.caustic, &line, &mask));
    let (n_on, n_off) = (on.beams[0].0.beams, off.beams[0].0.beams);
    println!(
        "per-pixel error against the line integral: {e_on:.4} ({n_on} beams) with it, {e_off:.4} ({n_off} beams) without"
    );
    assert!(e_on < 0.016 && e_on < 0.75 * e_off, "{e_on} vs {e_off}");
    assert!(n_on > n_off && n_on <= 13858, "{n_on} beams ({n_off} without)");
    // Where the shaft meets the floor (seen 17° from above), each pixel row's light against the
    // line integral's: the pixels end at their floor point's tangent plane.
    let floor_row = project(&sc, Vec3::ZERO).unwrap().1 as u32;
    let row = |img: &caustics::image_io::Image, y: u32| -> f64 {
        (0..w).filter(|&x| mask.include[(y * w + x) as usize]).map(|x| f64::from(img.get(x, y)[0])).sum()
    };
    for y in floor_row.saturating_sub(2 * k)..(floor_row + 2 * k).min(h) {
        let r = row(&on.caustic, y) / row(&line, y);
        println!("row {y} (the floor under the ball at {floor_row}): beams / line integral {r:.4}");
        assert!((r - 1.0).abs() < 0.015, "row {y}: {r}");
    }
}

/// The "three beam budgets" (run with `--ignored --nocapture`; BUDGET_IMAGE=PATH writes
/// the images side by side, BUDGET_REPS=n renders each n times for the timings): adaptive
/// 16² + 2, 3, 4 levels against regular 32², 64², 128² on `ball_in_fog` (48 × 40, the ball
/// masked), error against the line integral and against the CPU reference (2^25 photons,
/// single scattering), host ms per render in one run.
#[test]
#[ignore = "measurement: the three beam budgets (docs/benchmarks.md)"]
fn beam_budgets() {
    use caustics_reference::metrics::{energy, hdr_flip};
    use caustics_reference::reference;
    let Some(ctx) = gpu() else { return };
    let k: u32 = std::env::var("SIZE_K").ok().and_then(|v| v.parse().ok()).unwrap_or(1);
    let (w, h) = (48 * k, 40 * k);
    let sc = ball_in_fog(14.0, w, h);
    let mask = ball_mask(&sc);
    let lines = line_integral_reference(&sc, 100);
    let total: Vec<f64> = (0..(w * h) as usize).map(|i| lines.iter().map(|c| c[i]).sum()).collect();
    let line = to_image(&total, w, h);
    let photons = std::env::var("REF_PHOTONS").ok().and_then(|v| v.parse().ok()).unwrap_or(1 << 25);
    let rs = common::single_scattering_reference(photons, 1, 5);
    let r = reference::render(&sc, &rs).unwrap();
    let (el, er) = (energy(&line, Some(&mask)), energy(&r.caustic, Some(&mask)));
    println!(
        "reference ({photons} photons) vs line integral: HDR-FLIP {:.4}, energy {:+.2} %",
        hdr_flip(&r.caustic, &line, Some(&mask)).unwrap().mean,
        (er / el - 1.0) * 100.0
    );
    let reps: usize = std::env::var("BUDGET_REPS").ok().and_then(|v| v.parse().ok()).unwrap_or(1);
    let ad = BeamSettings::default();
    let configs = [
        ("adaptive 16+2", BeamSettings { levels: 2, ..ad }),
        ("adaptive 16+3", ad),
        ("adaptive 16+4", BeamSettings { levels: 4, ..ad }),
        ("regular 32", BeamSettings::regular(32)),
        ("regular 64", BeamSettings::regular(64)),
        ("regular 128", BeamSettings::regular(128)),
        // (base grids of 24 and 12: docs/benchmarks.md, "Beams: the speed target")
        ("adaptive 24+1", BeamSettings { grid: 24, levels: 1, ..ad }),
        ("adaptive 24+2", BeamSettings { grid: 24, levels: 2, ..ad }),
        ("adaptive 12+3", BeamSettings { grid: 12, levels: 3, ..ad }),
    ];
    // BUDGET_CONFIGS=a,b: only the configurations whose names contain one of these (no image).
    let only = std::env::var("BUDGET_CONFIGS").ok();
    let configs: Vec<(&str, BeamSettings)> = configs
        .into_iter()
        .filter(|(n, _)| only.as_ref().is_none_or(|f| f.split(',').any(|p| n.contains(p))))
        .collect();
    let mut images = Vec::new();
    println!(
        "| grid | beams | HDR-FLIP vs line | energy vs line | HDR-FLIP vs reference | energy vs reference | ms (each run) | GPU ms refine / volume (last run) |"
    );
    println!("| --- | ---: | ---: | ---: | ---: | ---: | --- | --- |");
    for (name, b) in configs {
        let mut ms = Vec::new();
        let mut out = None;
        for _ in 0..reps {
            let t = std::time::Instant::now();
            let g = render(&ctx, &sc, &render_settings(b)).unwrap();
            ms.push(format!("{:.0}", t.elapsed().as_secs_f64() * 1e3));
            out = Some(g);
        }
        let g = out.unwrap();
        let eg = energy(&g.caustic, Some(&mask));
        // GPU ms of the beam passes (timestamp queries, all dispatches; "-" without them).
        // (the volume caustic: the gather, or the hulls' three passes)
        let pass = |ps: &[&str]| {
            let v: Vec<f64> = g.timings.iter().filter(|(n, _)| ps.contains(&n.as_str())).map(|(_, ms)| *ms).collect();
            if v.is_empty() { "-".to_string() } else { format!("{:.0}", v.iter().sum::<f64>()) }
        };
        println!(
            "| {name} | {} | {:.3} | {:+.1} % | {:.3} | {:+.1} % | {} | {} / {} |",
            g.beams[0].0.beams,
            hdr_flip(&g.caustic, &line, Some(&mask)).unwrap().mean,
            (eg / el - 1.0) * 100.0,
            hdr_flip(&g.caustic, &r.caustic, Some(&mask)).unwrap().mean,
            (eg / er - 1.0) * 100.0,
            ms.join(", "),
            pass(&["beam_refine"]),
            pass(&["beam_gather", "beam_hull", "beam_raster", "beam_resolve"])
        );
        images.push(g.caustic);
    }
    if let Some(path) = std::env::var_os("BUDGET_IMAGE").filter(|_| images.len() >= 6) {
        // Top row: line integral, adaptive 16+2, 16+3, 16+4; bottom row: reference, regular
        // 32², 64², 128²; one exposure (the line integral's 98th percentile to white), the
        // ball's pixels dark.
        let mut v: Vec<f32> = line.pixels.iter().map(|p| p[0]).collect();
        v.sort_by(f32::total_cmp);
        let scale = 1.0 / v[v.len() * 98 / 100].max(1e-12);
        let tiles = [&line, &images[0], &images[1], &images[2], &r.caustic, &images[3], &images[4], &images[5]];
        let mut out = caustics::image_io::Image::new(4 * w + 3, 2 * h + 1);
        for (k, t) in tiles.iter().enumerate() {
            let (ox, oy) = ((k as u32 % 4) * (w + 1), (k as u32 / 4) * (h + 1));
            for y in 0..h {
                for x in 0..w {
                    let c = if mask.include[(y * w + x) as usize] { t.get(x, y)[0] * scale } else { 0.0 };
                    out.set(ox + x, oy + y, [c, c, c]);
                }
            }
        }
        for y in 0..out.height {
            for x in 0..out.width {
                if x % (w + 1) == w || y % (h + 1) == h {
                    out.set(x, y, [1.0, 1.0, 1.0]);
                }
            }
        }
        caustics_reference::io::write_display_png(&out, std::path::Path::new(&path)).unwrap();
    }
}

/// The ball in fog with the medium's density grid `g` over its box.
fn with_grid(mut sc: Scene, g: caustics::scene::DensityGrid) -> Scene {
    sc.medium.as_mut().unwrap().density = Some(std::sync::Arc::new(g));
    sc
}

/// Sum of the red channel and the relative L1 difference of `a` against `b` over the pixels
/// where `b` exceeds 2 % of its peak.
fn l1_over_region(a: &caustics::image_io::Image, b: &caustics::image_io::Image) -> (f64, f64, f64) {
    let peak = b.pixels.iter().map(|p| p[0]).fold(0.0f32, f32::max);
    let r: Vec<usize> = (0..b.pixels.len()).filter(|&i| b.pixels[i][0] > 0.02 * peak).collect();
    let sb: f64 = r.iter().map(|&i| f64::from(b.pixels[i][0])).sum();
    let l1: f64 = r.iter().map(|&i| f64::from((a.pixels[i][0] - b.pixels[i][0]).abs())).sum::<f64>() / sb;
    let sum = |im: &caustics::image_io::Image| im.pixels.iter().map(|p| f64::from(p[0])).sum::<f64>();
    (sum(a), sum(b), l1)
}

/// Heterogeneous media in the beams (issue 14 item 5): with a density grid, the beams scatter
/// with the density times sigma_s and attenuate by the grid's optical depths (toward the base,
/// up to it through the light's path, and toward the camera). Two closed cases:
/// - a constant grid of density 0.5 is the homogeneous medium of half the coefficients;
/// - a grid that is 1 above the ball lens' focus and 0 below it is the homogeneous medium in
///   the box cut at the focus (up to the grid's trilinear ramp over one voxel, 0.05 m).
///
/// And the grid is not ignored: the cut grid removes the cone below the focus.
#[test]
fn beams_in_a_density_grid_match_the_equivalent_homogeneous_media() {
    use caustics::scene::DensityGrid;
    let Some(ctx) = gpu() else { return };
    // Two levels (some 5000 beams): the grid's march makes every beam cost a pixel some 32
    // lookups, and lavapipe is slow.
    let s = render_settings(BeamSettings { levels: 2, ..Default::default() });
    let caustic = |sc: &Scene| render(&ctx, sc, &s).unwrap().caustic;
    // (24 x 20: the gather's cost is pixels times beams; the cases compare two renders of the
    // same image, pixel for pixel. At 48 x 40 (before 2026-12-07): relative L1 3.0e-9 and
    // cut grid / cut box 1.0021, relative L1 0.003.)
    let base = ball_in_fog(14.0, 24, 20);
    // Constant density 0.5 against half the coefficients.
    let half_grid = caustic(&with_grid(base.clone(), DensityGrid::new([2, 2, 2], vec![0.5; 8]).unwrap()));
    let mut half = base.clone();
    {
        let m = half.medium.as_mut().unwrap();
        m.sigma_s *= 0.5;
        m.sigma_a *= 0.5;
    }
    let half_h = caustic(&half);
    let (a, b, l1) = l1_over_region(&half_grid, &half_h);
    println!("constant grid 0.5: volume caustic {a:.5e} vs homogeneous half {b:.5e}, relative L1 {l1:.2e}");
    assert!(b > 0.0);
    assert!((a / b - 1.0).abs() < 1e-3 && l1 < 1e-3, "constant grid: {a} vs {b}, L1 {l1}");
    // The cut: the focus of the ball lens (R 0.5, n 1.5, centre y 1.5) at y = 0.75; the box
    // spans y -0.1 .. 4.5 in 92 voxels of 0.05 m.
    let (y0, y1, n) = (-0.1f32, 4.5f32, 92u32);
    let cut = 0.75f32;
    let data: Vec<f32> = (0..n)
        .map(|j| {
            let y = y0 + (j as f32 + 0.5) / n as f32 * (y1 - y0);
            if y > cut { 1.0 } else { 0.0 }
        })
        .collect();
    let cut_grid = caustic(&with_grid(base.clone(), DensityGrid::new([1, n, 1], data).unwrap()));
    let mut cut_box = base.clone();
    cut_box.medium.as_mut().unwrap().bounds_min.y = cut;
    let cut_h = caustic(&cut_box);
    let full = caustic(&base);
    let (a, b, l1) = l1_over_region(&cut_grid, &cut_h);
    let (_, f, _) = l1_over_region(&full, &full);
    println!("grid cut at the focus: {a:.5e} vs the box cut there {b:.5e} (uncut {f:.5e}), relative L1 {l1:.3}");
    assert!((a / b - 1.0).abs() < 0.03, "cut grid {a} vs cut box {b}");
    assert!(l1 < 0.1, "cut grid vs cut box: relative L1 {l1}");
    assert!(a < 0.8 * f, "the grid must remove the cone below the focus: {a} vs uncut {f}");
}
