//! The volume caustic of the GPU's own beams, integrated on the CPU by quadrature (diagnostic:
//! docs/benchmarks.md, "Beams: the GPU's beams integrated on the CPU"). Splits a volume
//! caustic's error into the beams' (where they put the light) and the per-pixel integral's
//! (`beam_scatter.wgsl`: how the GPU draws them).
//! `cargo run --release -p caustics-reference --example beam_splat -- SCENE WxH LINES STEPS OUT_DIR [REFERENCE.exr] [t]`
//! renders SCENE on the GPU at the defaults (`t`: the transmitted branch only), then splats
//! every beam on the CPU: LINES² lines of constant barycentrics per beam (the centroids of the
//! section's midpoint subdivision), each cut to the beam's clip and end planes and the medium's
//! box and integrated in STEPS stratified points, each point's single scattering toward the
//! camera (homogeneous media: analytic transmittance) added to the pixel it projects into where
//! it lies before the first surface (4 × 4 depth rays per pixel). Prints the energies of the
//! GPU image, the splat and the reference (caustic-only; a black floor keeps the surface caustic
//! out), by branch, layer and part, and writes OUT_DIR/{gpu,splat}.exr. With `PATHS=N` (and
//! `t`) also the transmitted branch's light paths (N² directions of the first light, a spot)
//! splatted the same way, by segment (OUT_DIR/paths.exr); `NO_END_OUT=1` ends the beams leaving
//! the scene at the medium's box instead of the plane through their edges' ends.
use caustics::image_io::Image;
use caustics::scene::{Phase, Scene};
use caustics_reference::ImageIo as _;
use caustics_reference::metrics::{energy, hdr_flip};
use caustics_reference::reference::geometry::Accel;
use glam::Vec3;
use rayon::prelude::*;

/// The length of segment a → b inside the box lo..hi.
fn in_box(a: Vec3, b: Vec3, lo: Vec3, hi: Vec3) -> f32 {
    let v = b - a;
    let (mut t0, mut t1) = (0.0f32, 1.0f32);
    for k in 0..3 {
        if v[k].abs() < 1e-30 {
            if a[k] < lo[k] || a[k] > hi[k] {
                return 0.0;
            }
            continue;
        }
        let (ta, tb) = ((lo[k] - a[k]) / v[k], (hi[k] - a[k]) / v[k]);
        t0 = t0.max(ta.min(tb));
        t1 = t1.min(ta.max(tb));
    }
    (t1 - t0).max(0.0) * v.length()
}

/// The height range of line o + y s on the beam's side of the plane through q (normal along
/// `along`): `beyond` keeps the heights past the plane, else those before it.
fn plane_cut(q: [Vec3; 3], along: Vec3, o: Vec3, s: Vec3, beyond: bool, r: &mut (f32, f32)) {
    let mut n = (q[1] - q[0]).cross(q[2] - q[0]);
    if n.length_squared() < 1e-30 {
        return;
    }
    if n.dot(along) < 0.0 {
        n = -n;
    }
    // f(y) = n . (o + y s - q0): beyond where f >= 0.
    let (f0, f1) = (n.dot(o - q[0]), n.dot(s));
    let (f0, f1) = if beyond { (f0, f1) } else { (-f0, -f1) };
    if f1 > 0.0 {
        r.0 = r.0.max(-f0 / f1);
    } else if f1 < 0.0 {
        r.1 = r.1.min(-f0 / f1);
    } else if f0 < 0.0 {
        *r = (1.0, 0.0);
    }
}

fn main() {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let mut scene = Scene::load(std::path::Path::new(&a[0])).unwrap_or_else(|e| panic!("{e}"));
    let (w, h) = a[1].split_once('x').map(|(x, y)| (x.parse().unwrap(), y.parse().unwrap())).unwrap();
    (scene.camera.width, scene.camera.height) = (w, h);
    let lines: usize = a[2].parse().unwrap();
    let steps: usize = a[3].parse().unwrap();
    let out = std::path::PathBuf::from(&a[4]);
    std::fs::create_dir_all(&out).unwrap();
    let transmitted = a.iter().skip(5).any(|x| x == "t");
    let ctx = caustics::gpu::GpuContext::new(None).unwrap();
    let mut s = caustics::render::RenderSettings::default();
    if transmitted {
        s.dielectric_reflection = false;
        s.beams.reflection = false;
    }
    // (BEAM_GRID, BEAM_LEVELS: the hierarchy's base grid and levels instead of the defaults)
    let env = |k: &str| std::env::var(k).ok().and_then(|v| v.parse::<u32>().ok());
    s.beams.grid = env("BEAM_GRID").unwrap_or(s.beams.grid);
    s.beams.levels = env("BEAM_LEVELS").unwrap_or(s.beams.levels);
    let t = std::time::Instant::now();
    let gpu = caustics::render::render(&ctx, &scene, &s).unwrap();
    println!("GPU: {:.1} s", t.elapsed().as_secs_f64());
    let beams: Vec<caustics::beams::Beam> = gpu.beams.iter().flat_map(|(_, b)| b.iter().copied()).collect();
    {
        let flux: f64 = beams.iter().map(|b| f64::from(b.flux.x)).sum();
        let mut keys: Vec<[u32; 3]> = beams
            .iter()
            .map(|b| [b.vertices[0].x.to_bits(), b.vertices[1].y.to_bits(), b.dirs[2].z.to_bits()])
            .collect();
        keys.sort_unstable();
        let dups = keys.windows(2).filter(|w| w[0] == w[1]).count();
        for (i, b) in beams.iter().enumerate() {
            let k = [b.vertices[0].x.to_bits(), b.vertices[1].y.to_bits(), b.dirs[2].z.to_bits()];
            if beams
                .iter()
                .filter(|c| [c.vertices[0].x.to_bits(), c.vertices[1].y.to_bits(), c.dirs[2].z.to_bits()] == k)
                .count()
                > 1
            {
                println!(
                    "  duplicate at {i}: level {} branch {} layer {} part {} flux {:.5} v0 {:?}",
                    b.level, b.branch, b.layer, b.part, b.flux.x, b.vertices[0]
                );
            }
        }
        println!(
            "beams: {} (per level {:?}), flux {flux:.5} W (first channel), {dups} duplicates",
            beams.len(),
            gpu.beams[0].0.kept_per_level
        );
    }
    let m = scene.medium.clone().expect("a scene with a medium");
    assert!(m.density.is_none(), "homogeneous media only");
    let (lo, hi) = (m.bounds_min, m.bounds_max);
    let g = match m.phase {
        Phase::Isotropic => 0.0,
        Phase::HenyeyGreenstein { g } => g,
    };
    let phase = |c: f32| {
        let den = (1.0 + g * g - 2.0 * g * c).max(1e-12);
        (1.0 - g * g) / (4.0 * std::f32::consts::PI * den * den.sqrt())
    };
    let st = m.sigma_s + m.sigma_a;
    let cam = scene.camera.clone();
    let (fwd, right, up) = (cam.forward(), cam.right(), cam.true_up());
    let tan_y = (cam.fov_y_deg.to_radians() * 0.5).tan();
    let tan_x = tan_y * cam.aspect();
    let pix_area = (2.0 * tan_x / w as f32) * (2.0 * tan_y / h as f32);
    // The first surface's distance along 4 x 4 rays per pixel.
    let accel = Accel::new(&scene);
    const SUB: u32 = 4;
    let depth: Vec<f32> = (0..w * h * SUB * SUB)
        .into_par_iter()
        .map(|i| {
            let (sx, sy) = (i % (w * SUB), i / (w * SUB));
            let d = cam.ray_dir((sx as f32 + 0.5) / SUB as f32, (sy as f32 + 0.5) / SUB as f32);
            accel.intersect(cam.position, d, f32::MAX).map_or(f32::INFINITY, |hit| hit.t)
        })
        .collect();
    // The lines: centroids of the midpoint subdivision into lines² triangles.
    let mut bary = Vec::new();
    for i in 0..lines {
        for j in 0..lines - i {
            let (a, b) = (i as f32, j as f32);
            let n = lines as f32;
            bary.push([(a + 1.0 / 3.0) / n, (b + 1.0 / 3.0) / n]);
            if i + j + 1 < lines {
                bary.push([(a + 2.0 / 3.0) / n, (b + 2.0 / 3.0) / n]);
            }
        }
    }
    assert_eq!(bary.len(), lines * lines);
    // Splat: per beam kind (branch, layer, part > 0) an image.
    // (kinds 0..24: branch, layer, part; 24, 25: layer 0 landing on an object or leaving the
    // scene, counted again)
    let kind = |b: &caustics::beams::Beam| (b.branch as usize) * 4 + (b.layer as usize) * 2 + usize::from(b.part > 0);
    let kinds = 6 * 4 + 2;
    let no_end_out = std::env::var_os("NO_END_OUT").is_some();
    let t = std::time::Instant::now();
    let imgs: Vec<f64> = beams
        .par_chunks(64)
        .map(|chunk| {
            let mut img = vec![0.0f64; kinds * (w * h) as usize];
            for b in chunk {
                let nrm = b.normal();
                let sc: [Vec3; 3] = b.dirs.map(|d| d / nrm.dot(d));
                let mean = (b.dirs[0] + b.dirs[1] + b.dirs[2]).normalize();
                let clip_q = [0, 1, 2].map(|i| b.vertices[i] + sc[i] * b.clip[i]);
                let end_q = [0, 1, 2].map(|i| b.vertices[i] + sc[i] * (b.ends[i] * nrm.dot(b.dirs[i])));
                let k = kind(b);
                for (li, wb) in bary.iter().enumerate() {
                    let wv = [wb[0], wb[1], 1.0 - wb[0] - wb[1]];
                    let o: Vec3 = (0..3).map(|i| b.vertices[i] * wv[i]).sum();
                    let sd: Vec3 = (0..3).map(|i| sc[i] * wv[i]).sum();
                    let pre: f32 = (0..3).map(|i| b.pre[i] * wv[i]).sum();
                    let mut r = (0.0f32, f32::INFINITY);
                    plane_cut(clip_q, mean, o, sd, true, &mut r);
                    // (NO_END_OUT: last segments leaving the scene end at the medium's box
                    // alone, not at the plane through their edges' ends on its walls)
                    if !(no_end_out && b.land == u32::MAX && b.layer == 0) {
                        plane_cut(end_q, mean, o, sd, false, &mut r);
                    } else {
                        r.1 = r.1.min(1e3);
                    }
                    if r.1 <= r.0 || r.0.is_nan() || !r.1.is_finite() {
                        continue;
                    }
                    let dl = sd.normalize();
                    let cos_t = nrm.dot(dl).max(1e-4);
                    let dy = (r.1 - r.0) / steps as f32;
                    for si in 0..steps {
                        // (stratified, jittered by a hash of the beam, line and step)
                        let hsh =
                            ((li * 7919 + si * 104729) as u32 ^ (b.vertices[0].x.to_bits())).wrapping_mul(2654435761);
                        let y = r.0 + dy * (si as f32 + (hsh >> 8) as f32 / (1u32 << 24) as f32);
                        let x = o + sd * y;
                        if x.cmplt(lo).any() || x.cmpgt(hi).any() {
                            continue;
                        }
                        let tv = x - cam.position;
                        let dist = tv.length();
                        let vd = tv / dist;
                        let z = vd.dot(fwd);
                        if z <= 1e-6 {
                            continue;
                        }
                        let px = (vd.dot(right) / z / tan_x + 1.0) * 0.5 * w as f32;
                        let py = (1.0 - vd.dot(up) / z / tan_y) * 0.5 * h as f32;
                        if !(px >= 0.0 && py >= 0.0 && px < w as f32 && py < h as f32) {
                            continue;
                        }
                        let (qx, qy) = ((px * SUB as f32) as u32, (py * SUB as f32) as u32);
                        if dist >= depth[(qy * w * SUB + qx) as usize] {
                            continue;
                        }
                        let tr = (-st * (pre + in_box(o, x, lo, hi) + in_box(cam.position, x, lo, hi))).exp();
                        let v = m.sigma_s.x * b.flux.x / (bary.len() as f32) * phase(dl.dot(-vd)) * tr.x
                            / (cos_t * dist * dist * z * z * z * pix_area)
                            * dy;
                        let pi = py as usize * w as usize + px as usize;
                        img[k * (w * h) as usize + pi] += f64::from(v);
                        if b.layer == 0 {
                            img[(24 + usize::from(b.land == u32::MAX)) * (w * h) as usize + pi] += f64::from(v);
                        }
                    }
                }
            }
            img
        })
        .reduce_with(|mut x, y| {
            x.iter_mut().zip(&y).for_each(|(a, b)| *a += b);
            x
        })
        .unwrap_or_default();
    let to_image = |px: &[f64]| {
        let mut img = Image::new(w, h);
        for (i, v) in px.iter().enumerate() {
            let v = *v as f32;
            img.set(i as u32 % w, i as u32 / w, [v, v, v]);
        }
        img
    };
    let n = (w * h) as usize;
    let total: Vec<f64> = (0..n).map(|i| (0..24).map(|k| imgs[k * n + i]).sum()).collect();
    let splat = to_image(&total);
    println!(
        "splat: {:.1} s ({} beams, {} lines x {steps} points each)",
        t.elapsed().as_secs_f64(),
        beams.len(),
        bary.len()
    );
    // The GPU's caustic image, first channel only (the splat's).
    let mut g_img = gpu.caustic.clone();
    g_img.pixels.iter_mut().for_each(|p| *p = [p[0]; 3]);
    let (eg, es) = (energy(&g_img, None), energy(&splat, None));
    println!(
        "GPU image / splat of its beams: energy {:.4}, HDR-FLIP {:.4}",
        eg / es,
        hdr_flip(&g_img, &splat, None).unwrap().mean
    );
    for k in 24..26 {
        let e: f64 = imgs[k * n..(k + 1) * n].iter().sum::<f64>() * 3.0;
        println!(
            "  layer 0 {}: splat energy {e:.4e}",
            if k == 24 { "landing on an object" } else { "leaving the scene" }
        );
    }
    for k in 0..24 {
        let e: f64 = imgs[k * n..(k + 1) * n].iter().sum::<f64>() * 3.0;
        let flux: f32 = beams.iter().filter(|b| kind(b) == k).map(|b| b.flux.x).sum();
        let count = beams.iter().filter(|b| kind(b) == k).count();
        if count > 0 {
            println!(
                "  branch {} layer {} {}: {count} beams, {flux:.4} W, splat energy {:.4} of all",
                k / 4,
                (k / 2) % 2,
                if k % 2 == 1 { "parts" } else { "whole" },
                e / es
            );
        }
    }
    if let Some(rp) = a.get(5).filter(|x| *x != "t") {
        let mut r = Image::read(std::path::Path::new(rp)).unwrap();
        r.pixels.iter_mut().for_each(|p| *p = [p[0]; 3]);
        let er = energy(&r, None);
        println!(
            "against the reference: GPU energy {:.4}, HDR-FLIP {:.4}; splat energy {:.4}, HDR-FLIP {:.4}",
            eg / er,
            hdr_flip(&g_img, &r, None).unwrap().mean,
            es / er,
            hdr_flip(&splat, &r, None).unwrap().mean
        );
    }
    // PATHS=N: the transmitted branch's light paths themselves (N² directions of the light's
    // cone, `reference::branch`), each of their segments in the medium after the first specular
    // interaction splatted the same way: the noise-free counterpart of the beams (compare with
    // `t`), the last segments (layer 0) and those before (layer 1 and earlier) apart.
    if let Some(np) = std::env::var("PATHS").ok().and_then(|v| v.parse::<u32>().ok()) {
        use caustics_reference::reference::branch::{Fate, trace_segments};
        use caustics_reference::reference::emit::Emitter;
        let em = Emitter::full(&scene.lights[0], Vec3::ZERO, 10.0);
        let ds = (hi - lo).length() / 2000.0;
        let t = std::time::Instant::now();
        let px_of = |x: Vec3| -> Option<(usize, f32, Vec3, f32)> {
            let tv = x - cam.position;
            let dist = tv.length();
            let vd = tv / dist;
            let z = vd.dot(fwd);
            if z <= 1e-6 {
                return None;
            }
            let px = (vd.dot(right) / z / tan_x + 1.0) * 0.5 * w as f32;
            let py = (1.0 - vd.dot(up) / z / tan_y) * 0.5 * h as f32;
            if !(px >= 0.0 && py >= 0.0 && px < w as f32 && py < h as f32) {
                return None;
            }
            let (qx, qy) = ((px * SUB as f32) as u32, (py * SUB as f32) as u32);
            if dist >= depth[(qy * w * SUB + qx) as usize] {
                return None;
            }
            Some((py as usize * w as usize + px as usize, dist, vd, z))
        };
        let img: Vec<f64> = (0..np)
            .into_par_iter()
            .map(|j| {
                let mut img = vec![0.0f64; 4 * n];
                let mut segs = Vec::new();
                for i in 0..np {
                    let u = glam::Vec2::new((i as f32 + 0.5) / np as f32, (j as f32 + 0.5) / np as f32);
                    let Some(e) = em.sample(u) else { continue };
                    segs.clear();
                    let path = trace_segments(&scene, &accel, e.origin, e.dir, 16, &mut segs);
                    if path.fate != Fate::Caustic {
                        continue;
                    }
                    let w0 = e.flux_n.x / (np * np) as f32;
                    let mut pre = 0.0f32;
                    let last = segs.len() - 1;
                    // (the segments outside dielectrics counted from the last: 0 the last, 1 the
                    // one before, 2 earlier)
                    let outside_after: Vec<usize> =
                        (0..segs.len()).map(|k| segs[k + 1..].iter().filter(|x| !x.inside).count()).collect();
                    for (k, sg) in segs.iter().enumerate() {
                        let len = sg.len.min((hi - lo).length() * 4.0);
                        if sg.inside {
                            continue;
                        }
                        if k > 0 {
                            // (0: the last segment, landing on an object; 1: before it; 2: the
                            // last, leaving the scene)
                            let layer = if k != last {
                                if outside_after[k] == 1 { 1 } else { 3 }
                            } else if path.land == u32::MAX {
                                2
                            } else {
                                0
                            };
                            let steps = (len / ds).ceil().max(1.0) as usize;
                            let dt = len / steps as f32;
                            let jit = ((i * 7919 + j * 104729 + k as u32) as f32 * 0.618034).fract();
                            for si in 0..steps {
                                let x = sg.o + sg.d * (dt * (si as f32 + jit));
                                if x.cmplt(lo).any() || x.cmpgt(hi).any() {
                                    continue;
                                }
                                let Some((pi, dist, vd, z)) = px_of(x) else { continue };
                                let tr =
                                    (-st.x * (pre + in_box(sg.o, x, lo, hi) + in_box(cam.position, x, lo, hi))).exp();
                                let v = m.sigma_s.x * w0 * sg.weight * phase(sg.d.dot(-vd)) * tr * dt
                                    / (dist * dist * z * z * z * pix_area);
                                img[layer * n + pi] += f64::from(v);
                            }
                        }
                        pre += in_box(sg.o, sg.o + sg.d * len, lo, hi);
                    }
                }
                img
            })
            .reduce_with(|mut x, y| {
                x.iter_mut().zip(&y).for_each(|(a, b)| *a += b);
                x
            })
            .unwrap_or_default();
        let paths =
            to_image(&(0..n).map(|i| img[i] + img[n + i] + img[2 * n + i] + img[3 * n + i]).collect::<Vec<_>>());
        let part = |k: usize| img[k * n..(k + 1) * n].iter().sum::<f64>() * 3.0;
        let bpart = |k: usize| imgs[k * n..(k + 1) * n].iter().sum::<f64>() * 3.0;
        println!(
            "  last segments landing on an object: paths {:.4e}, beams {:.4e} ({:.4}); leaving the scene: paths {:.4e}, beams {:.4e} ({:.4})",
            part(0),
            bpart(24),
            bpart(24) / part(0),
            part(2),
            bpart(25),
            bpart(25) / part(2)
        );
        let ep = energy(&paths, None);
        let l1: f64 = img[n..2 * n].iter().sum::<f64>() * 3.0;
        println!(
            "  segments before the one before the last (chains of three specular objects or more): paths {:.4e}",
            part(3)
        );
        let b1: f64 =
            (0..24).filter(|k| (k / 2) % 2 == 1).map(|k| imgs[k * n..(k + 1) * n].iter().sum::<f64>() * 3.0).sum();
        println!(
            "paths ({np}² directions, {:.1} s): energy {ep:.4e}; splat of the beams / paths {:.4} (HDR-FLIP {:.4}), GPU / paths {:.4}; layer 1: paths {:.4e}, beams {:.4e} ({:.4})",
            t.elapsed().as_secs_f64(),
            es / ep,
            hdr_flip(&splat, &paths, None).unwrap().mean,
            eg / ep,
            l1,
            b1,
            b1 / l1
        );
        paths.write(&out.join("paths.exr"), 1.0).unwrap();
    }
    g_img.write(&out.join("gpu.exr"), 1.0).unwrap();
    splat.write(&out.join("splat.exr"), 1.0).unwrap();
}
