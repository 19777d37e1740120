//! The volume caustic of the GPU's own beams, integrated on the CPU by quadrature (diagnostic:
//! docs/benchmarks.md, "Beams: the GPU's beams integrated on the CPU"). Splits a volume
//! caustic's error into the beams' (where they put the light) and the per-pixel integral's
//! (`beam_scatter.wgsl`: how the GPU draws them).
//! `cargo run --release -p caustics-reference --example beam_splat -- SCENE WxH LINES STEPS OUT_DIR [REFERENCE.exr] [t]`
//! renders SCENE on the GPU at the defaults (`t`: the transmitted branch only; `BEAM_GRID`,
//! `BEAM_LEVELS`: another hierarchy; `BEAM_CUTOFF`: the energy cutoff), checks the beams' list (no beam listed twice), then splats
//! every beam on the CPU (`reference::beam_splat`: LINES² lines of constant barycentrics per
//! beam, STEPS stratified points each). Prints the energies of the GPU image, the splat and the
//! reference (caustic-only; a black floor keeps the surface caustic out), by branch, layer and
//! part, and writes OUT_DIR/{gpu,splat,beams_layer1}.exr. With `PATHS=N` (and `t`) also the transmitted
//! branch's light paths (N² directions of the first light, a spot) splatted the same way, by
//! segment (OUT_DIR/paths.exr, the segments before the last in OUT_DIR/paths_layer1.exr); `NO_END_OUT=1` ends the beams leaving the scene at the medium's
//! box instead of the plane through their edges' ends. `SUBSETS=1` splats the thin beams (prisms:
//! degenerate parts and orphans' beams; by part, branch, layer, leaving the scene or not), the
//! narrow ones and the rest apart (OUT_DIR/sub_*.exr).
use caustics::beams::Beam;
use caustics::image_io::Image;
use caustics::scene::Scene;
use caustics_reference::ImageIo as _;
use caustics_reference::metrics::{energy, hdr_flip};
use caustics_reference::reference::beam_splat::{BeamSplat, lines};
use caustics_reference::reference::geometry::Accel;
use glam::Vec3;
use rayon::prelude::*;

fn main() {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let mut scene = Scene::load(std::path::Path::new(&a[0])).unwrap_or_else(|e| panic!("{e}"));
    let (w, h) = a[1].split_once('x').map(|(x, y)| (x.parse().unwrap(), y.parse().unwrap())).unwrap();
    (scene.camera.width, scene.camera.height) = (w, h);
    let bary = lines(a[2].parse().unwrap());
    let steps: usize = a[3].parse().unwrap();
    let out = std::path::PathBuf::from(&a[4]);
    std::fs::create_dir_all(&out).unwrap();
    let transmitted = a.iter().skip(5).any(|x| x == "t");
    let ctx = caustics::gpu::GpuContext::new(None).unwrap();
    let mut s = caustics::render::RenderSettings::default();
    if transmitted {
        s.photons.reflection = false;
        s.beams.reflection = false;
    }
    let env = |k: &str| std::env::var(k).ok().and_then(|v| v.parse::<u32>().ok());
    s.beams.grid = env("BEAM_GRID").unwrap_or(s.beams.grid);
    s.beams.levels = env("BEAM_LEVELS").unwrap_or(s.beams.levels);
    s.beams.cutoff = std::env::var("BEAM_CUTOFF").ok().and_then(|v| v.parse().ok()).unwrap_or(0.0);
    let t = std::time::Instant::now();
    let gpu = caustics::render::render(&ctx, &scene, &s).unwrap();
    println!("GPU: {:.1} s", t.elapsed().as_secs_f64());
    let beams: Vec<Beam> = gpu.beams.iter().flat_map(|(_, b)| b.iter().copied()).collect();
    // The list: every beam once.
    // (geometry and flux: two triangles that share a corner can each make a thin beam along its
    // edge, the same geometry with another flux)
    let key = |b: &Beam| [b.vertices[0], b.dirs[1], b.flux].map(|v| v.to_array().map(f32::to_bits));
    let mut keys: Vec<_> = beams.iter().map(key).collect();
    keys.sort_unstable();
    let repeated = keys.windows(2).filter(|w| w[0] == w[1]).count();
    if repeated > 0 && std::env::var_os("SHOW_REPEATS").is_some() {
        let mut count = std::collections::HashMap::new();
        for b in &beams {
            *count.entry(key(b)).or_insert(0) += 1;
        }
        for (i, b) in beams.iter().enumerate() {
            if count[&key(b)] > 1 {
                println!(
                    "  repeated at {i}: level {} branch {} layer {} part {} flux {:.6} land {} ends {:?} clip {:?}",
                    b.level, b.branch, b.layer, b.part, b.flux.x, b.land, b.ends, b.clip
                );
            }
        }
    }
    let flux: f64 = beams.iter().map(|b| f64::from(b.flux.x)).sum();
    println!(
        "beams: {} (per level {:?}), flux {flux:.5} W (first channel), {repeated} listed more than once",
        beams.len(),
        gpu.beams.first().map(|b| b.0.kept_per_level.clone())
    );
    let sp = BeamSplat::new(&scene).unwrap_or_else(|e| panic!("{e}"));
    let end_at_box = std::env::var_os("NO_END_OUT").is_some();
    let splat_of = |f: &dyn Fn(&Beam) -> bool| {
        let some: Vec<Beam> = beams.iter().filter(|b| f(b)).copied().collect();
        sp.beams(&some, &bary, steps, end_at_box)
    };
    let t = std::time::Instant::now();
    let all = splat_of(&|_| true);
    let to_image = |px: &[f64]| {
        let mut img = Image::new(w, h);
        for (i, v) in px.iter().enumerate() {
            let v = *v as f32;
            img.set(i as u32 % w, i as u32 / w, [v, v, v]);
        }
        img
    };
    let sum = |px: &[f64]| px.iter().sum::<f64>() * 3.0;
    let splat = to_image(&all);
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
    if std::env::var_os("SUBSETS").is_some() {
        let thin = |b: &Beam| (b.dirs[0] - b.dirs[1]).length() < 1e-6 && (b.dirs[0] - b.dirs[2]).length() < 1e-6;
        // (a section below a square millimetre at both ends)
        let narrow = |b: &Beam| {
            let y = b.ends[0] * b.normal().dot(b.dirs[0]);
            !thin(b) && b.area(y).max(b.area(0.0)) < 1e-6
        };
        let mut by = std::collections::BTreeMap::new();
        for b in beams.iter().filter(|b| thin(b)) {
            let e = by.entry((b.part, b.branch, b.layer, b.land == u32::MAX)).or_insert((0, 0.0f32));
            e.0 += 1;
            e.1 += b.flux.x;
        }
        for (k, v) in &by {
            println!("thin (part, branch, layer, leaving) {k:?}: {} beams, {:.4} W", v.0, v.1);
        }
        for (name, f) in [
            ("thin", &thin as &dyn Fn(&Beam) -> bool),
            ("narrow", &|b: &Beam| narrow(b)),
            ("rest_leaving", &|b: &Beam| !thin(b) && !narrow(b) && b.land == u32::MAX && b.layer == 0),
            ("rest_landing", &|b: &Beam| !thin(b) && !narrow(b) && (b.land != u32::MAX || b.layer == 1)),
        ] {
            let n = beams.iter().filter(|b| f(b)).count();
            let img = to_image(&splat_of(f));
            println!("subset {name}: {n} beams, energy {:.4} of all", energy(&img, None) / es);
            img.write(&out.join(format!("sub_{name}.exr")), 1.0).unwrap();
        }
    }
    let on_object = sum(&splat_of(&|b| b.layer == 0 && b.land != u32::MAX));
    let leaving = sum(&splat_of(&|b| b.layer == 0 && b.land == u32::MAX));
    let layer1_px = splat_of(&|b| b.layer == 1);
    let layer1 = sum(&layer1_px);
    to_image(&layer1_px).write(&out.join("beams_layer1.exr"), 1.0).unwrap();
    for branch in 0..6 {
        for layer in 0..2 {
            for parts in [false, true] {
                let f = |b: &Beam| b.branch == branch && b.layer == layer && (b.part > 0) == parts;
                let (count, flux) = beams.iter().filter(|b| f(b)).fold((0, 0.0f32), |(c, x), b| (c + 1, x + b.flux.x));
                if count > 0 {
                    println!(
                        "  branch {branch} layer {layer} {}: {count} beams, {flux:.4} W, splat energy {:.4} of all",
                        if parts { "parts" } else { "whole" },
                        sum(&splat_of(&f)) / es
                    );
                }
            }
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
    // `t`), by segment: 0 the last landing on an object, 1 the one before the last (layer 1),
    // 2 the last leaving the scene, 3 earlier ones (chains of three specular objects or more).
    if let Some(np) = env("PATHS") {
        use caustics_reference::reference::branch::{Fate, trace_segments};
        use caustics_reference::reference::emit::Emitter;
        let accel = Accel::new(&scene);
        let em = Emitter::full(&scene.lights[0], Vec3::ZERO, 10.0);
        let (lo, hi) = sp.bounds();
        let ds = (hi - lo).length() / 2000.0;
        let n = (w * h) as usize;
        let t = std::time::Instant::now();
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
                    for (k, sg) in segs.iter().enumerate() {
                        let len = sg.len.min((hi - lo).length() * 4.0);
                        if sg.inside {
                            continue;
                        }
                        if k > 0 {
                            let outside_after = segs[k + 1..].iter().filter(|x| !x.inside).count();
                            let class = match (k == last, path.land == u32::MAX, outside_after) {
                                (true, false, _) => 0,
                                (true, true, _) => 2,
                                (false, _, 1) => 1,
                                _ => 3,
                            };
                            let jitter = ((i * 7919 + j * 104729 + k as u32) as f32 * 0.618034).fract();
                            let px = &mut img[class * n..(class + 1) * n];
                            sp.segment((sg.o, sg.d, len), w0 * sg.weight, pre, (ds, jitter), px);
                        }
                        pre += sp.in_medium(sg.o, sg.o + sg.d * len);
                    }
                }
                img
            })
            .reduce(
                || vec![0.0; 4 * n],
                |mut x, y| {
                    x.iter_mut().zip(&y).for_each(|(a, b)| *a += b);
                    x
                },
            );
        let class = |k: usize| sum(&img[k * n..(k + 1) * n]);
        let paths = to_image(&(0..n).map(|i| (0..4).map(|k| img[k * n + i]).sum()).collect::<Vec<f64>>());
        let ep = energy(&paths, None);
        println!(
            "paths ({np}² directions, {:.1} s): energy {ep:.4e}; splat of the beams / paths {:.4} (HDR-FLIP {:.4}), GPU / paths {:.4}",
            t.elapsed().as_secs_f64(),
            es / ep,
            hdr_flip(&splat, &paths, None).unwrap().mean,
            eg / ep
        );
        for (name, p, b) in [
            ("last segments landing on an object", class(0), on_object),
            ("last segments leaving the scene", class(2), leaving),
            ("the segments before the last (layer 1)", class(1), layer1),
            ("earlier segments (chains of three specular objects or more)", class(3), 0.0),
        ] {
            println!("  {name}: paths {p:.4e}, beams {b:.4e} ({:.4})", b / p);
        }
        paths.write(&out.join("paths.exr"), 1.0).unwrap();
        to_image(&img[n..2 * n]).write(&out.join("paths_layer1.exr"), 1.0).unwrap();
    }
    g_img.write(&out.join("gpu.exr"), 1.0).unwrap();
    splat.write(&out.join("splat.exr"), 1.0).unwrap();
}
