//! The temporal filter on a short animation: the spot light of a scene (default
//! `scenes/glass_sphere.json`) moves along a small arc (about 11 mm a frame, under half a texel of
//! the 128² caustic map), then jumps 0.8 m sideways and goes on, rendered with and without
//! `caustics::temporal::TemporalFilter`. MOTION `orbit` (default): the arc is centred on the
//! casters and the spot stays aimed at them, so the ball's focal caustic stays in place in the
//! light's map (a static region seen by a moving light); `arc`: a 0.3 m arc, the spot's direction
//! kept, so the caustic drifts by about 0.4 texel a frame.
//!
//! `cargo run --release --example temporal -- OUT_DIR [FRAMES] [SPLAT] [MOTION] [SCENE] [MAP]`
//! (defaults: 12 frames, `triangles`, `orbit`, `scenes/glass_sphere.json`, 128² map; 128²
//! photons, 128-pixel-wide image).
//!
//! Writes per frame `image_raw_NN.png`, `image_filtered_NN.png` (camera) and `map_raw_NN.png`,
//! `map_filtered_NN.png` (light-space caustic map, one exposure for the whole sequence), and
//! prints per frame:
//! - flicker: mean absolute frame-to-frame difference of the caustic map (r + g + b, W/m²) over
//!   the texels lit in both raw frames, raw and filtered;
//! - vanished: the texels where the previous raw map had light and the current raw map is ~0
//!   (below 1e-3 of the previous): their share of the previous raw map's light (r + g + b);
//! - ghost: the filtered map's light in those texels, as a share of the previous raw map's light
//!   there (0 = no ghost; it includes the current raw map's own, at most 1e-3);
//! - the share of texels whose history was rejected.
use caustics::Scene;
use caustics::image_io::Image;
use caustics::render::{RenderSettings, SplatMode, render};
use caustics::scene::Light;
use caustics::temporal::{TemporalFilter, TemporalSettings};
use caustics_reference::ImageIo as _;
use glam::Vec3;
use std::path::Path;

fn lum(p: [f32; 3]) -> f64 {
    p.iter().map(|&c| c as f64).sum()
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let out = Path::new(args.get(1).map_or("temporal_out", |s| s.as_str()));
    let frames: usize = args.get(2).map_or(12, |x| x.parse().expect("FRAMES"));
    let splat = args.get(3).map_or(SplatMode::Triangles, |x| SplatMode::parse(x).expect("SPLAT"));
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let orbit = args.get(4).is_none_or(|m| m == "orbit");
    let scene_path = args.get(5).map_or(root.join("scenes/glass_sphere.json"), |s| s.into());
    let map: u32 = args.get(6).map_or(128, |x| x.parse().expect("MAP"));
    std::fs::create_dir_all(out).unwrap();
    let mut base = Scene::load(&scene_path).unwrap();
    base.camera.height = base.camera.height * 128 / base.camera.width;
    base.camera.width = 128;
    let Some(Light::Spot { position: p0, direction: d0, .. }) = base.lights.first().cloned() else {
        panic!("the scene's first light must be a spot light")
    };
    let s = RenderSettings {
        photons: caustics::settings::PhotonSettings { count: 128, caustic_map_size: map, splat, ..Default::default() },
        shading: caustics::settings::ShadingSettings { shadow_map_size: 512, ..Default::default() },
        ..Default::default()
    };
    let ctx = caustics::gpu::GpuContext::new(None).unwrap();
    let mut filter = TemporalFilter::new(TemporalSettings::default());
    let jump = frames * 3 / 4;
    let (mut raw, mut filtered, mut rejected, mut lights) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    // Warm-up: build every pipeline once, so that the timings below compare frames only.
    TemporalFilter::new(TemporalSettings::default()).render(&ctx, &base, &s).unwrap();
    let (mut wall_raw, mut wall_filtered) = (0.0, 0.0);
    // The spot orbits the casters' centre in the x-y plane, aimed at it (0.2° a frame: about 11 mm
    // at 3.1 m), or (`arc`) moves on an arc of radius 0.3 m, 2° a frame (10.5 mm), keeping its
    // direction. From frame `jump` on, it is 0.8 m further in x, with the direction it would have
    // had without the jump.
    let pivot = base.caster_bounds().map_or(Vec3::ZERO, |(a, b)| (a + b) * 0.5);
    for k in 0..frames {
        let (mut p, mut d) = (p0, d0);
        if orbit {
            p = pivot + glam::Quat::from_rotation_z((0.2 * k as f32).to_radians()) * (p0 - pivot);
            d = (pivot - p).normalize();
        } else {
            let a = (2.0 * k as f32).to_radians();
            p += Vec3::new(0.3 * a.cos() - 0.3, 0.0, 0.3 * a.sin());
        }
        if k >= jump {
            p.x += 0.8;
        }
        let mut scene = base.clone();
        if let Light::Spot { position, direction, .. } = &mut scene.lights[0] {
            *position = p;
            *direction = d;
        }
        let t = std::time::Instant::now();
        let f = filter.render(&ctx, &scene, &s).unwrap();
        wall_filtered += t.elapsed().as_secs_f64();
        let t = std::time::Instant::now();
        let r = render(&ctx, &scene, &s).unwrap();
        wall_raw += t.elapsed().as_secs_f64();
        r.image.write(&out.join(format!("image_raw_{k:02}.png")), scene.exposure).unwrap();
        f.image.write(&out.join(format!("image_filtered_{k:02}.png")), scene.exposure).unwrap();
        let st = filter.stats(&ctx).unwrap()[0];
        rejected.push(st.rejected as f64 / (st.rejected + st.blended) as f64);
        raw.push(r.caustic_maps[0][0].clone());
        filtered.push(f.caustic_maps[0][0].clone());
        lights.push(p);
    }
    // One exposure for every map: the 99th percentile of the first raw map to white.
    let mut l: Vec<f32> = raw[0].luminance().into_iter().filter(|x| *x > 0.0).collect();
    l.sort_by(f32::total_cmp);
    let exposure = 2.0 / l.get(l.len().saturating_sub(1 + l.len() / 100)).copied().unwrap_or(1.0).max(1e-9);
    for k in 0..frames {
        raw[k].write(&out.join(format!("map_raw_{k:02}.png")), exposure).unwrap();
        filtered[k].write(&out.join(format!("map_filtered_{k:02}.png")), exposure).unwrap();
    }

    println!(
        "{} frames, {} motion, {splat} splats, 128² photons, {map}² map; wall ms per frame: {:.0} raw, {:.0} filtered",
        frames,
        if orbit { "orbit" } else { "arc" },
        1e3 * wall_raw / frames as f64,
        1e3 * wall_filtered / frames as f64
    );
    println!(
        "| frame | light x, y, z (m) | flicker raw | flicker filtered | ratio | vanished | ghost | rejected | map sum filtered / raw |"
    );
    println!("| ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |");
    let (mut sum_r, mut sum_f, mut n_arc) = (0.0, 0.0, 0);
    for k in 0..frames {
        let (mut fr, mut ff, mut ghost, mut vanished) = (f64::NAN, f64::NAN, f64::NAN, f64::NAN);
        if k > 0 {
            let (rp, rc, fp, fc) = (&raw[k - 1], &raw[k], &filtered[k - 1], &filtered[k]);
            let lit: Vec<usize> =
                (0..rc.pixels.len()).filter(|&i| lum(rc.pixels[i]) > 0.0 && lum(rp.pixels[i]) > 0.0).collect();
            let mad = |a: &Image, b: &Image| {
                lit.iter().map(|&i| (lum(a.pixels[i]) - lum(b.pixels[i])).abs()).sum::<f64>() / lit.len() as f64
            };
            fr = mad(rc, rp);
            ff = mad(fc, fp);
            let (mut gone, mut ghost_light) = (0.0, 0.0);
            for i in 0..rc.pixels.len() {
                let (o, n) = (lum(rp.pixels[i]), lum(rc.pixels[i]));
                if o > 0.0 && n <= 1e-3 * o {
                    gone += o;
                    ghost_light += lum(fc.pixels[i]);
                }
            }
            vanished = gone / rp.pixels.iter().map(|&p| lum(p)).sum::<f64>();
            ghost = if gone > 0.0 { ghost_light / gone } else { 0.0 };
            if k != jump && k != jump + 1 {
                sum_r += fr;
                sum_f += ff;
                n_arc += 1;
            }
        }
        println!(
            "| {k} | {:.3}, {:.3}, {:.3} | {fr:.4} | {ff:.4} | {:.3} | {vanished:.2e} | {ghost:.2e} | {:.1} % | {:.4} |",
            lights[k].x,
            lights[k].y,
            lights[k].z,
            ff / fr,
            100.0 * rejected[k],
            filtered[k].sum() / raw[k].sum()
        );
    }
    println!(
        "mean flicker over the moving frames (without the jump and the frame after it): raw {:.4}, filtered {:.4}, ratio {:.3}",
        sum_r / n_arc as f64,
        sum_f / n_arc as f64,
        sum_f / sum_r
    );
    let mean = |v: &[Image]| v.iter().map(|i| i.sum()).sum::<f64>() / v.len() as f64;
    println!("mean map sum: raw {:.4e}, filtered {:.4e}", mean(&raw), mean(&filtered));
}
