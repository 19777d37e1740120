//! The time-budget controller on synthetic cost models (CPU only, fast).

use caustics::budget::{BudgetController, BudgetSettings, Level, ladder};
use caustics::render::RenderSettings;
use caustics::settings::Emission;

/// A small deterministic generator (xorshift64*), uniform in [-1, 1).
struct Noise(u64);
impl Noise {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let x = self.0.wrapping_mul(0x2545_f491_4f6c_dd1d);
        (x >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }
}

/// Run `frames` frames of `cost(frame, level) -> ms`; returns the level index per frame and the
/// frames on which the settings changed.
fn simulate(
    c: &mut BudgetController,
    s: &mut RenderSettings,
    frames: usize,
    mut cost: impl FnMut(usize, &RenderSettings) -> f64,
) -> (Vec<usize>, Vec<usize>, Vec<f64>) {
    let mut levels = Vec::new();
    let mut changed = Vec::new();
    let mut ms = Vec::new();
    for f in 0..frames {
        let t = cost(f, s);
        ms.push(t);
        if c.update(t, s) {
            changed.push(f);
        }
        levels.push(c.level_index());
    }
    (levels, changed, ms)
}

/// The best level whose noiseless cost meets the target.
fn optimum(levels: &[Level], target: f64, cost: impl Fn(&Level) -> f64) -> usize {
    (0..levels.len()).rev().find(|&j| cost(&levels[j]) <= target).unwrap_or(0)
}

fn settings(t: Emission, photons: u32) -> RenderSettings {
    RenderSettings {
        photons: caustics::settings::PhotonSettings { emission: t, count: photons, ..Default::default() },
        ..Default::default()
    }
}

/// `overhead + k · work`, with the work of the controller's prior (N², over sqrt(1 + tolerance)
/// for maximal caustic map error).
fn grid_cost(s: &RenderSettings, k: f64, overhead: f64) -> f64 {
    let tol = if s.photons.emission == Emission::AdaptiveError { Some(s.adaptive.error_tolerance) } else { None };
    overhead + k * Level { photons: s.photons.count, tolerance: tol }.work()
}

#[test]
fn ladders_are_valid_settings() {
    let b = BudgetSettings { min_photons: 16, max_photons: 65536, ..BudgetSettings::new(10.0) };
    for t in Emission::ALL {
        let l = ladder(t, &b);
        assert!(!l.is_empty());
        for w in l.windows(2) {
            assert!(w[0].photons <= w[1].photons, "{t}: {:?}", l);
            assert!(w[0].work() < w[1].work(), "{t}: work must grow along the ladder: {:?}", l);
        }
        for lv in &l {
            assert!(lv.photons <= t.max_photons());
            if t == Emission::Basic {
                assert!(lv.photons >= 16 && lv.photons % 16 == 0, "{lv:?}");
            } else {
                assert!(lv.photons >= 32 && lv.photons.is_power_of_two(), "{t}: {lv:?}");
            }
            assert_eq!(lv.tolerance.is_some(), t == Emission::AdaptiveError);
        }
    }
    // Basic steps are quarter octaves (about 1.41x in cost) once rounding to 16 allows.
    let basic = ladder(Emission::Basic, &BudgetSettings::new(10.0));
    for w in basic.windows(2).filter(|w| w[0].photons >= 128) {
        let r = w[1].work() / w[0].work();
        assert!(r > 1.1 && r < 1.9, "{:?}", w);
    }
}

/// Quadratic cost with ±5 % noise: converges in a few frames to the best grid (or the one below
/// it when noise straddles the target), then stays within the band.
#[test]
fn converges_on_quadratic_cost_with_noise() {
    for (t, target) in [
        (Emission::AdaptiveLevel, 25.0),
        (Emission::Basic, 25.0),
        (Emission::Basic, 7.0),
        (Emission::AdaptiveError, 25.0),
    ] {
        let b = BudgetSettings::new(target);
        let band = b.band;
        let mut c = BudgetController::new(b);
        let mut s = settings(t, 32);
        let mut noise = Noise(0x9e37_79b9_7f4a_7c15);
        let k = 1e-5;
        let (levels, changed, ms) =
            simulate(&mut c, &mut s, 60, |_, s| grid_cost(s, k, 0.0) * (1.0 + 0.05 * noise.next()));
        let lad = c.levels().to_vec();
        // Tolerance levels' true cost follows the controller's prior here.
        let opt = optimum(&lad, target, |l| k * l.work());
        let last = *levels.last().unwrap();
        assert!(last == opt || last + 1 == opt, "{t}: settled at {:?}, optimum {:?}", lad[last], lad[opt]);
        let conv = changed.last().copied().unwrap_or(0);
        assert!(conv <= 15, "{t}: last change at frame {conv} ({changed:?})");
        let tail = &ms[conv + 2..];
        let mean = tail.iter().sum::<f64>() / tail.len() as f64;
        assert!(mean <= target * (1.0 + band), "{t}: mean {mean} over the band");
        println!("{t} target {target}: level {:?}, changes {changed:?}, mean {mean:.2} ms", lad[last]);
    }
}

/// 200 frames of a static scene after convergence: no settings change at all.
#[test]
fn no_oscillation_on_a_static_scene() {
    for (t, target, overhead) in
        [(Emission::AdaptiveLevel, 20.0, 0.0), (Emission::Basic, 12.0, 3.0), (Emission::AdaptiveError, 20.0, 5.0)]
    {
        let mut c = BudgetController::new(BudgetSettings::new(target));
        let mut s = settings(t, 4096.min(t.max_photons()));
        let mut noise = Noise(42);
        let (_, changed, _) =
            simulate(&mut c, &mut s, 260, |_, s| grid_cost(s, 1e-5, overhead) * (1.0 + 0.08 * noise.next()));
        let late: Vec<_> = changed.iter().filter(|&&f| f >= 60).collect();
        assert!(late.is_empty(), "{t}: changes after convergence at frames {late:?} (all: {changed:?})");
        assert!(c.quality().settled, "{t}");
        println!("{t}: {} changes, all in the first {} frames", changed.len(), changed.last().unwrap_or(&0) + 1);
    }
}

/// A level whose cost straddles the band edge (noise ±12 % around 1.08 × target): even then the
/// number of changes stays small (back-off doubles), no sustained oscillation.
#[test]
fn bounded_changes_when_a_level_straddles_the_band() {
    let target = 10.0;
    let mut c = BudgetController::new(BudgetSettings::new(target));
    let mut s = settings(Emission::AdaptiveLevel, 64);
    let mut noise = Noise(7);
    // 1024² costs 1.08 × target: predicted over target from 512², never entered from below; to
    // make it straddle, the model is made to under-predict it: cost jumps past 512².
    let (_, changed, _) = simulate(&mut c, &mut s, 400, |_, s| {
        let n = s.photons.count as f64;
        let base = if s.photons.count >= 1024 { 1.08 * target * (n / 1024.0).powi(2) } else { 2e-6 * n * n };
        base * (1.0 + 0.12 * noise.next())
    });
    assert!(changed.len() <= 12, "{} changes: {changed:?}", changed.len());
    println!("changes: {changed:?}");
}

/// Cost triples at frame 100 and drops back at frame 200: re-converges within 15 frames each.
#[test]
fn follows_a_step_change_of_cost() {
    let target = 25.0;
    let b = BudgetSettings::new(target);
    let band = b.band;
    let mut c = BudgetController::new(b);
    let mut s = settings(Emission::Basic, 64);
    let mut noise = Noise(3);
    let k = |f: usize| if (100..200).contains(&f) { 3e-5 } else { 1e-5 };
    let (levels, changed, ms) =
        simulate(&mut c, &mut s, 300, |f, s| grid_cost(s, k(f), 2.0) * (1.0 + 0.04 * noise.next()));
    let lad = c.levels().to_vec();
    for (start, end) in [(0usize, 100usize), (100, 200), (200, 300)] {
        let kk = k(start);
        let opt = optimum(&lad, target, |l| 2.0 + kk * l.work());
        let seg: Vec<_> = changed.iter().filter(|&&f| f >= start && f < end).copied().collect();
        let conv = seg.last().copied().unwrap_or(start);
        assert!(conv - start <= 15, "segment {start}: last change at {conv} ({seg:?})");
        let l = levels[end - 1];
        assert!(l == opt || l + 1 == opt, "segment {start}: at {:?}, optimum {:?}", lad[l], lad[opt]);
        let tail = &ms[(conv + 2).min(end - 1)..end];
        let mean = tail.iter().sum::<f64>() / tail.len() as f64;
        assert!(mean <= target * (1.0 + band), "segment {start}: mean {mean}");
        println!("segment {start}..{end}: {:?}, changes {seg:?}, mean {mean:.2} ms", lad[l]);
    }
}

/// A large fixed overhead (20 ms of a 30 ms budget): the model learns it from two levels.
#[test]
fn learns_a_fixed_overhead() {
    for t in [Emission::AdaptiveLevel, Emission::Basic] {
        let target = 30.0;
        let b = BudgetSettings::new(target);
        let band = b.band;
        let mut c = BudgetController::new(b);
        let mut s = settings(t, 32);
        let mut noise = Noise(11);
        let (levels, changed, ms) =
            simulate(&mut c, &mut s, 80, |_, s| grid_cost(s, 4e-6, 20.0) * (1.0 + 0.03 * noise.next()));
        let lad = c.levels().to_vec();
        let opt = optimum(&lad, target, |l| 20.0 + 4e-6 * l.work());
        let last = *levels.last().unwrap();
        assert!(last == opt || last + 1 == opt, "{t}: at {:?}, optimum {:?} ({changed:?})", lad[last], lad[opt]);
        let conv = changed.last().copied().unwrap_or(0);
        assert!(conv <= 50, "{t}: last change at {conv} ({changed:?})");
        let tail = &ms[conv + 2..];
        assert!(tail.iter().sum::<f64>() / (tail.len() as f64) <= target * (1.0 + band));
        println!("{t}: {:?}, changes {changed:?}", lad[last]);
    }
}

#[test]
fn respects_limits_and_reports_quality() {
    // A budget nothing meets: the smallest grid; a budget everything meets: the largest.
    let b = BudgetSettings { min_photons: 64, max_photons: 1024, ..BudgetSettings::new(1.0) };
    let mut c = BudgetController::new(b.clone());
    let mut s = settings(Emission::Hierarchical, 512);
    simulate(&mut c, &mut s, 20, |_, s| grid_cost(s, 1e-3, 5.0));
    assert_eq!(s.photons.count, 64);
    let mut c = BudgetController::new(BudgetSettings { target_ms: 1e6, ..b });
    let mut s = settings(Emission::Hierarchical, 64);
    simulate(&mut c, &mut s, 20, |_, s| grid_cost(s, 1e-6, 0.0));
    assert_eq!(s.photons.count, 1024);
    // The error model: one pair assumes error ∝ 1/N; two grids fit the exponent.
    let q = c.quality();
    assert_eq!((q.grid, q.photons, q.estimated_error), (1024, 1 << 20, None));
    c.observe_error(256, 0.04);
    assert!((c.estimate_error(1024).unwrap() - 0.01).abs() < 1e-9);
    c.observe_error(512, 0.04 / 2f64.powf(0.5));
    let e = c.estimate_error(1024).unwrap();
    assert!((e - 0.02).abs() < 1e-6, "{e}");
    assert!((c.quality().estimated_error.unwrap() - e).abs() < 1e-12);
    c.clear_errors();
    assert_eq!(c.quality().estimated_error, None);
    // Adaptive-error: the tolerance is set along with the grid.
    let mut c = BudgetController::new(BudgetSettings::new(1e6));
    let mut s = settings(Emission::AdaptiveError, 64);
    s.adaptive.error_tolerance = 3.0;
    simulate(&mut c, &mut s, 20, |_, s| grid_cost(s, 1e-9, 0.0));
    assert_eq!((s.photons.count, s.adaptive.error_tolerance), (4096, 0.0));
}

/// Single-frame spikes (5× the frame's cost, as a page fault or another process gives) do not
/// move the controller: it settles on the optimum as without them and makes no change after
/// converging. The spikes fall on the first measured frame after each change (where one spike
/// used to send the controller down and block the level it left, seen in CI on lavapipe) and
/// on every 23rd frame.
#[test]
fn single_frame_spikes_do_not_move_the_controller() {
    for (t, target, overhead) in [(Emission::AdaptiveLevel, 20.0, 0.0), (Emission::Basic, 12.0, 3.0)] {
        let run = |spikes: bool| {
            let b = BudgetSettings { window: 3, ..BudgetSettings::new(target) };
            let mut c = BudgetController::new(b);
            let mut s = settings(t, 64);
            let mut noise = Noise(5);
            // Frames rendered with the current grid (the first after a change is not measured).
            let (mut grid, mut at_grid) = (0, 0);
            let (levels, changed, _) = simulate(&mut c, &mut s, 200, |f, s| {
                (grid, at_grid) = if s.photons.count == grid { (grid, at_grid + 1) } else { (s.photons.count, 1) };
                let spike = if spikes && (at_grid == 2 || f % 23 == 22) { 5.0 } else { 1.0 };
                spike * grid_cost(s, 1e-5, overhead) * (1.0 + 0.05 * noise.next())
            });
            (c.levels().to_vec(), levels, changed)
        };
        let (lad, calm, calm_changes) = run(false);
        let (_, spiky, spiky_changes) = run(true);
        let opt = optimum(&lad, target, |l| overhead + 1e-5 * l.work());
        let last = *spiky.last().unwrap();
        assert_eq!(last, *calm.last().unwrap(), "{t}: spikes changed the settled level ({spiky_changes:?})");
        assert!(last == opt || last + 1 == opt, "{t}: at {:?}, optimum {:?}", lad[last], lad[opt]);
        // From a grid far under the budget every move is up: no spike sent the controller down.
        assert!(calm.windows(2).all(|w| w[1] >= w[0]), "{t}: the calm run moved down: {calm_changes:?}");
        let down = spiky.windows(2).position(|w| w[1] < w[0]);
        assert!(down.is_none(), "{t}: a spike sent the controller down at frame {down:?}: {spiky:?}");
        let late: Vec<_> = spiky_changes.iter().filter(|&&f| f >= 60).collect();
        assert!(late.is_empty(), "{t}: changes after convergence at {late:?} (calm: {calm_changes:?})");
        println!("{t}: calm changes {calm_changes:?}, spiky changes {spiky_changes:?}");
    }
}
