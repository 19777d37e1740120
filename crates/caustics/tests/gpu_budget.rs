//! The time-budget controller on a real scene (lavapipe in CI): the built-in scene at 160x120,
//! a budget between the measured costs of two photon grids; the controller must settle on a
//! grid between them whose cost lies within the band. The light moves a little every frame, so
//! every frame redoes its photon stage (a renderer that keeps unchanged maps makes a static
//! frame's cost independent of the grid: the budget is about frames where something moves).
//! One device for the whole binary.

mod common;

use caustics::budget::{BudgetController, BudgetSettings};
use caustics::render::{Emission, RenderSettings};
use caustics::renderer::{FrameRequest, Renderer};

/// Host milliseconds of one frame: `encode` to the GPU's completion. The spot light first
/// moves on a small circle (a new position every frame).
fn frame_ms(r: &mut Renderer) -> f64 {
    use std::sync::atomic::{AtomicU32, Ordering};
    static FRAME: AtomicU32 = AtomicU32::new(0);
    let phi = FRAME.fetch_add(1, Ordering::Relaxed) as f32 * 0.1;
    let mut light = r.scene().lights[0].clone();
    if let caustics::scene::Light::Spot { position, direction, .. } = &mut light {
        let (u, v) = direction.any_orthonormal_pair();
        *position += 0.002 * (phi.cos() * u + phi.sin() * v);
    }
    r.set_light(0, light).unwrap();
    let t0 = std::time::Instant::now();
    let mut enc = r.context().device.create_command_encoder(&Default::default());
    r.encode(&mut enc, FrameRequest { stats: false }).unwrap();
    let ctx = r.context();
    ctx.queue.submit([enc.finish()]);
    ctx.device.poll(wgpu::PollType::Wait { submission_index: None, timeout: None }).unwrap();
    t0.elapsed().as_secs_f64() * 1e3
}

fn cost(r: &mut Renderer, photons: u32) -> f64 {
    let s = RenderSettings {
        photons: caustics::settings::PhotonSettings { count: photons, ..r.settings().photons },
        ..r.settings().clone()
    };
    r.set_settings(s).unwrap();
    frame_ms(r); // settles (pipelines, resources)
    let mut v: Vec<f64> = (0..3).map(|_| frame_ms(r)).collect();
    v.sort_by(f64::total_cmp);
    v[1]
}

#[test]
fn budget_settles_on_a_real_scene() {
    let Some(ctx) = common::gpu() else { return };
    let mut scene = caustics::Scene::default_scene();
    (scene.camera.width, scene.camera.height) = (160, 120);
    let settings = RenderSettings {
        photons: caustics::settings::PhotonSettings {
            emission: Emission::AdaptiveLevel,
            count: 128,
            caustic_map_size: 128,
            ..Default::default()
        },
        shading: caustics::settings::ShadingSettings { shadow_map_size: 512, ..Default::default() },
        ..Default::default()
    };
    let mut r = Renderer::with_context(ctx, scene, settings).unwrap();
    frame_ms(&mut r); // the first frame builds the pipelines
    let lo = cost(&mut r, 128);
    let hi = cost(&mut r, 1024);
    println!("measured: 128^2 {lo:.1} ms, 1024^2 {hi:.1} ms");
    assert!(hi > 1.3 * lo, "the photon grid must matter here: 128^2 {lo:.1} ms, 1024^2 {hi:.1} ms");
    // The optimum under cost = a + b·N² is 512² (256² if the machine is noisy).
    let target = 0.5 * (lo + hi);
    let b = BudgetSettings { min_photons: 64, max_photons: 1024, window: 3, ..BudgetSettings::new(target) };
    let band = b.band;
    let mut c = BudgetController::new(b);
    let mut s = RenderSettings {
        photons: caustics::settings::PhotonSettings { count: 64, ..r.settings().photons },
        ..r.settings().clone()
    };
    r.set_settings(s.clone()).unwrap();
    let mut last_change = 0;
    let mut trace = Vec::new();
    for f in 1..=40 {
        let t = frame_ms(&mut r);
        trace.push((s.photons.count, t));
        if c.update(t, &mut s) {
            r.set_settings(s.clone()).unwrap();
            last_change = f;
        }
        if f - last_change >= 8 {
            break;
        }
    }
    println!("target {target:.1} ms; frames (grid, ms): {trace:?}");
    let q = c.quality();
    assert!(trace.len() - last_change >= 8, "not settled after 40 frames: {trace:?}");
    assert!(q.grid == 256 || q.grid == 512, "settled on {}^2, expected 256^2 or 512^2: {trace:?}", q.grid);
    let tail: Vec<f64> = trace[last_change + 1..].iter().map(|&(_, t)| t).collect();
    let mut sorted = tail.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    assert!(median <= target * (1.0 + band), "settled cost {median:.1} ms over the band of {target:.1} ms");
    assert!(c.changes() <= 4, "{} changes: {trace:?}", c.changes());
}
