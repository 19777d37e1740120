//! Time-budget mode: a controller that picks the photon grid (and, for maximal caustic map error,
//! the error tolerance) each frame so that frames take a target time.
//!
//! ```no_run
//! # fn f(r: &mut caustics::renderer::Renderer, frame_ms: f64) -> caustics::Result<()> {
//! use caustics::budget::{BudgetController, BudgetSettings};
//! let mut budget = BudgetController::new(BudgetSettings::new(16.0));
//! // Every frame, after measuring it (host clock, submission to completion):
//! let mut s = r.settings().clone();
//! if budget.update(frame_ms, &mut s) {
//!     r.set_settings(s)?;
//! }
//! let q = budget.quality(); // photons now, and the estimated error if errors were fed
//! # let _ = q; Ok(()) }
//! ```
//!
//! **Which frames to feed.** The renderer keeps the caustic maps of lights that nothing moved,
//! so a frame that only moved the camera (or moved nothing) does no photon work and its cost
//! does not depend on the grid. Feed the controller the frames that redid a light
//! ([`crate::renderer::FrameStats::lights_redone`] has a `true`), or every frame while
//! something that lights see moves; feeding camera-only frames would let it climb to the
//! largest grid on a static scene and make the next light drag slow.
//!
//! # Algorithm
//!
//! The controller moves along a **ladder of levels** ordered by quality, each a valid setting
//! of the technique ([`ladder`]): basic caustic maps, grids in quarter-octave steps rounded to
//! multiples of 16 (cost steps of about 1.41×); hierarchical and adaptive caustic maps, powers
//! of two (their plans need them: `techniques::adaptive::AdaptivePlan`), and for
//! maximal caustic map error each grid preceded by coarser error tolerances
//! ([`BudgetSettings::tolerances`]), which fill the 4× cost gap between two grids.
//!
//! **Measurement.** The first frame after a change is discarded (it may build pipelines or
//! resources). The cost of the current level is the median of its last
//! [`BudgetSettings::window`] kept frames, robust to single spikes. A decision needs that many
//! frames, except when the cost is far off the target: under 0.5× on one frame, or over 1.5× on
//! two frames that both are (one spike is not enough), so the controller converges in a few
//! frames from a bad start.
//!
//! **Cost model.** `ms = a + b·w`, with `w` the level's work: N² for a grid N (cost ∝ photons),
//! times `1/sqrt(1 + tolerance)` for tolerance levels (a prior: coarser tolerances merge more
//! clusters; wrong priors are corrected by the back-off below). `b` comes from the current
//! level's measured cost, so a change of scene cost is followed at once; the fixed overhead
//! `a` (passes that do not depend on the photons) is fitted by least squares over the most
//! recent cost of each level visited in the last [`BudgetSettings::memory_frames`] frames
//! (clamped to `[0, 0.95 × the cheapest]`; the last fit is kept when too few recent levels
//! remain), or [`BudgetSettings::overhead_ms`] until a fit exists. A level's prediction is never
//! below the cost measured there since the scene last got cheaper (a measured level beats the
//! model). While no overhead fit exists, a level whose cost is under `T·(1 − band)` probes up
//! to the best level that would fit if the overhead were as large as possible (95 % of the
//! cost), which gives the second point of the fit.
//!
//! **Decision (the band).** With `t` the current cost and `T` the target:
//! - `t > T·(1 + band)`: over budget: go down to the best level predicted to cost ≤ T, and block
//!   the current level and all above it for a back-off time ([`BudgetSettings::backoff_frames`],
//!   doubled each time the same level fails, up to 32×).
//! - otherwise, if a better level that is not blocked is predicted to cost ≤ T: go up to the best
//!   such level.
//! - otherwise keep the settings.
//! - when the settled level's cost later drops by more than `2·band` (the scene got cheaper),
//!   the blocks and the other levels' measurements are forgotten, so the controller climbs
//!   back at once.
//!
//! So the controller settles on the best level whose cost is at most `T·(1 + band)` while the
//! next one up is predicted over `T`: the **band** is `[cost of that level, T·(1 + band)]`;
//! with a well predicted cost the settled level is the best that meets `T` (tests:
//! `crates/caustics/tests/cpu/budget.rs`).
//!
//! # Why it is stable
//!
//! - *Hysteresis.* A move up needs a prediction ≤ T; a move down needs a measured median over
//!   T·(1 + band). A level reached by a correct prediction costs ≤ T, `band` below the
//!   threshold that would send it back, so measurement noise under `band` (after the median)
//!   cannot make it oscillate.
//! - *Measured, not predicted, levels win.* After a move down, the level left is blocked: a
//!   wrong model cannot send the controller back up until the back-off expires, and each
//!   further failure doubles the back-off, so on a static scene the number of changes grows
//!   at most logarithmically with time even under a bad model (no sustained oscillation).
//! - *Model-based steps.* Moves jump straight to the predicted level (cost ∝ photons), not
//!   one step at a time, so convergence takes a few decisions, not a search.
//!
//! # Quality
//!
//! [`BudgetController::quality`] reports the grid, the photons (N² per light-view face, the
//! finest equivalent grid for the adaptive techniques), the tolerance, and an estimated error
//! against the last converged reference when the caller feeds measured pairs through
//! [`BudgetController::observe_error`] (for instance the relative RMSE of the caustic map against
//! a CPU reference of the current view, computed in the background). The model is
//! `error = c · N^(−p)`: with one pair `p = 1` (Monte Carlo: error ∝ 1/√photons = 1/N), with two
//! grids or more `p` is fitted in log-log space (clamped to [0.25, 4]). Call
//! [`BudgetController::clear_errors`] when the reference changes (the view moved). Tolerances
//! are not part of the error model.

use crate::settings::Emission;
use crate::settings::RenderSettings;

/// What the time-budget controller aims at and within which limits.
#[derive(Debug, Clone, PartialEq)]
pub struct BudgetSettings {
    /// The frame time to meet, milliseconds.
    pub target_ms: f64,
    /// Smallest photon grid N (per side); clamped to what the technique supports (16 or 32 to
    /// 8192 or 65536).
    pub min_photons: u32,
    /// Largest photon grid N (per side), clamped likewise.
    pub max_photons: u32,
    /// Maximal caustic map error: tolerances (caustic-map texels) the controller may use below
    /// each grid, coarsest first; empty: the grid alone (tolerance as in the settings).
    pub tolerances: Vec<f32>,
    /// Relative dead band over the target: a level is only left downward when its measured
    /// cost exceeds `target_ms × (1 + band)`.
    pub band: f64,
    /// Frames of the current level whose median is its cost.
    pub window: usize,
    /// Frames after a settings change that are not measured.
    pub settle_frames: usize,
    /// Frames a level that failed is blocked from (doubled on each failure of the same level).
    pub backoff_frames: u64,
    /// How long a level's measured cost is used to fit the fixed overhead, frames.
    pub memory_frames: u64,
    /// The fixed overhead assumed before two levels have been measured, milliseconds.
    pub overhead_ms: f64,
}

impl BudgetSettings {
    /// Defaults around a target: grids 32 to 4096, band 15 %, median of 5 frames, one frame
    /// settled, back-off 32 frames, tolerances 4, 2, 1 texels (maximal caustic map error).
    pub fn new(target_ms: f64) -> BudgetSettings {
        BudgetSettings {
            target_ms,
            min_photons: 32,
            max_photons: 4096,
            tolerances: vec![4.0, 2.0, 1.0],
            band: 0.15,
            window: 5,
            settle_frames: 1,
            backoff_frames: 32,
            memory_frames: 120,
            overhead_ms: 0.0,
        }
    }
}

/// One rung of the ladder: a photon grid and, for maximal caustic map error, a tolerance
/// (`None`: leave the settings' tolerance).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Level {
    /// Photon grid N per light-view face.
    pub photons: u32,
    /// The maximal-error tolerance in caustic-map texels (`None`: the settings' own).
    pub tolerance: Option<f32>,
}

impl Level {
    /// Relative work: N², over `sqrt(1 + tolerance)` for tolerance levels (a prior).
    pub fn work(&self) -> f64 {
        let n2 = (self.photons as f64).powi(2);
        match self.tolerance {
            Some(t) if t > 0.0 => n2 / (1.0 + t as f64).sqrt(),
            _ => n2,
        }
    }
}

/// The levels the controller moves on for `technique`, worst quality first (module docs).
pub fn ladder(technique: Emission, s: &BudgetSettings) -> Vec<Level> {
    let lo_limit = if technique == Emission::Basic { 16 } else { 32 };
    let lo = s.min_photons.clamp(lo_limit, technique.max_photons());
    let hi = s.max_photons.clamp(lo, technique.max_photons());
    let mut grids: Vec<u32> = Vec::new();
    if technique == Emission::Basic {
        // Quarter octaves from the smallest grid, rounded to multiples of 16, up to the largest.
        grids.push(lo);
        let mut k = 1;
        loop {
            let n = ((lo as f64 * 2f64.powf(k as f64 / 4.0) / 16.0).round() as u32 * 16).min(hi);
            k += 1;
            if grids.last().is_some_and(|&l| n > l) {
                grids.push(n);
            }
            if n >= hi {
                break;
            }
        }
        if grids.last() != Some(&hi) {
            grids.push(hi);
        }
    } else {
        let mut n = lo.next_power_of_two();
        while n <= hi {
            grids.push(n);
            n *= 2;
        }
        if grids.is_empty() {
            grids.push(hi.next_power_of_two() / 2);
        }
    }
    let mut out = Vec::new();
    for n in grids {
        if technique == Emission::AdaptiveError && !s.tolerances.is_empty() {
            for &t in &s.tolerances {
                if t > 0.0 {
                    out.push(Level { photons: n, tolerance: Some(t) });
                }
            }
            out.push(Level { photons: n, tolerance: Some(0.0) });
        } else {
            out.push(Level { photons: n, tolerance: None });
        }
    }
    out
}

/// The quality the budget reached.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BudgetQuality {
    /// Photon grid N per light-view face.
    pub grid: u32,
    /// N² (the finest equivalent grid's photons for the adaptive techniques).
    pub photons: u64,
    /// The maximal-error tolerance in texels, when the controller sets it.
    pub tolerance: Option<f32>,
    /// The current level's measured cost (median), milliseconds, once measured.
    pub frame_ms: Option<f64>,
    /// Estimated error against the last converged reference (`observe_error`'s units).
    pub estimated_error: Option<f64>,
    /// Whether the controller has settled: measured within the band and no move pending.
    pub settled: bool,
}

/// The time-budget controller (module documentation).
#[derive(Debug, Clone)]
pub struct BudgetController {
    settings: BudgetSettings,
    technique: Option<Emission>,
    levels: Vec<Level>,
    current: usize,
    /// Frames measured at the current level (after the settle frames).
    samples: Vec<f64>,
    since_change: usize,
    frame: u64,
    /// Per level: last measured cost and the frame it was measured in.
    seen: Vec<Option<(f64, u64)>>,
    /// Per level: blocked until this frame, and the next back-off.
    blocked_until: Vec<u64>,
    backoff: Vec<u64>,
    errors: Vec<(u32, f64)>,
    changes: u64,
    settled: bool,
    /// The last fitted overhead (kept when too few recent levels allow a new fit).
    overhead_fit: Option<f64>,
    /// The cost measured when the controller settled on the current level.
    settled_cost: Option<f64>,
}

impl BudgetController {
    /// A controller aiming at `settings`, nothing measured yet.
    pub fn new(settings: BudgetSettings) -> BudgetController {
        BudgetController {
            settings,
            technique: None,
            levels: Vec::new(),
            current: 0,
            samples: Vec::new(),
            since_change: 0,
            frame: 0,
            seen: Vec::new(),
            blocked_until: Vec::new(),
            backoff: Vec::new(),
            errors: Vec::new(),
            changes: 0,
            settled: false,
            overhead_fit: None,
            settled_cost: None,
        }
    }

    /// What it aims at, within which limits.
    pub fn settings(&self) -> &BudgetSettings {
        &self.settings
    }

    /// Change the target (or limits); the ladder is rebuilt on the next update, measurements
    /// are kept when the ladder is unchanged.
    pub fn set_settings(&mut self, settings: BudgetSettings) {
        let relimit = settings.min_photons != self.settings.min_photons
            || settings.max_photons != self.settings.max_photons
            || settings.tolerances != self.settings.tolerances;
        self.settings = settings;
        if relimit {
            self.technique = None;
        }
        for b in &mut self.blocked_until {
            *b = 0;
        }
        self.settled = false;
    }

    /// The ladder in use (empty before the first update).
    pub fn levels(&self) -> &[Level] {
        &self.levels
    }

    /// Index of the current level in [`BudgetController::levels`].
    pub fn level_index(&self) -> usize {
        self.current
    }

    /// Settings changes made so far.
    pub fn changes(&self) -> u64 {
        self.changes
    }

    /// Feed the time of the frame just rendered with `settings`, in milliseconds; sets the
    /// photon grid (and tolerance) for the next frame. Returns true when it changed `settings`.
    pub fn update(&mut self, measured_ms: f64, settings: &mut RenderSettings) -> bool {
        self.frame += 1;
        if self.technique != Some(settings.photons.emission) {
            self.reset_ladder(settings);
            // The frame measured was rendered with settings the ladder may not contain.
            return self.apply(settings);
        }
        if !measured_ms.is_finite() || measured_ms < 0.0 {
            return false;
        }
        // Settings changed behind the controller's back: follow them.
        if !self.matches(settings) {
            self.current = self.nearest(settings);
            self.samples.clear();
            self.since_change = 0;
            self.settled = false;
        }
        self.since_change += 1;
        if self.since_change <= self.settings.settle_frames {
            return false;
        }
        self.samples.push(measured_ms);
        let w = self.settings.window.max(1);
        if self.samples.len() > w {
            self.samples.remove(0);
        }
        let t = median(&self.samples);
        self.seen[self.current] = Some((t, self.frame));
        let target = self.settings.target_ms;
        // Far off the target, decide before the window is full: under 0.5× on one frame (frames
        // are not cheaper by accident); over 1.5× only on two frames that both are (one spike,
        // a page fault or another process, must not send the controller down and block the
        // level it left).
        let lo_ms = self.samples.iter().copied().fold(f64::INFINITY, f64::min);
        let hi_ms = self.samples.iter().copied().fold(0.0, f64::max);
        let far = (self.samples.len() >= 2 && lo_ms > 1.5 * target) || hi_ms < 0.5 * target;
        if self.samples.len() < w && !far {
            return false;
        }
        // The scene got cheaper since the controller settled here: lift the blocks.
        if self.settled_cost.is_some_and(|c| t < c * (1.0 - 2.0 * self.settings.band)) {
            let cur = self.current;
            self.seen.iter_mut().enumerate().filter(|(j, _)| *j != cur).for_each(|(_, s)| *s = None);
            self.blocked_until.iter_mut().for_each(|b| *b = 0);
            self.backoff.iter_mut().for_each(|b| *b = self.settings.backoff_frames.max(1));
            self.settled_cost = None;
        }
        let fit = self.fit_overhead();
        if fit.is_some() {
            self.overhead_fit = fit;
        }
        let a = self.overhead_fit.unwrap_or(self.settings.overhead_ms.max(0.0)).min(0.95 * t);
        let b = (t - a).max(1e-9) / self.levels[self.current].work();
        // The model, but never below what a level measured since the scene last got cheaper.
        let seen = &self.seen;
        let levels = &self.levels;
        let predict = |j: usize| {
            let m = a + b * levels[j].work();
            seen[j].map_or(m, |(c, _)| m.max(c))
        };
        let mut next;
        if t > target * (1.0 + self.settings.band) {
            // Over budget: the best level predicted to fit, below the current one.
            next = (0..self.current).rev().find(|&j| predict(j) <= target).unwrap_or(0);
            if next != self.current {
                let until = self.frame + self.backoff[self.current];
                for j in self.current..self.levels.len() {
                    self.blocked_until[j] = self.blocked_until[j].max(until);
                }
                self.backoff[self.current] =
                    (self.backoff[self.current] * 2).min(self.settings.backoff_frames.max(1) * 32);
            }
        } else {
            // Within budget: the best level above, not blocked, predicted to fit.
            let mut best = self.current;
            for j in self.current + 1..self.levels.len() {
                if self.blocked_until[j] > self.frame {
                    break;
                }
                if predict(j) <= target {
                    best = j;
                }
            }
            next = best;
            // The overhead is unknown (fewer than two levels measured, or no positive slope
            // yet): probe up to the best level that fits if the overhead were the largest
            // possible (95 % of the cost).
            if next == self.current && self.overhead_fit.is_none() && t < target * (1.0 - self.settings.band) {
                let w0 = self.levels[self.current].work();
                for j in self.current + 1..self.levels.len() {
                    if self.blocked_until[j] > self.frame {
                        break;
                    }
                    if 0.95 * t + 0.05 * t * self.levels[j].work() / w0 <= target
                        && self.seen[j].is_none_or(|(c, _)| c <= target)
                    {
                        next = j;
                    }
                }
            }
        }
        if next == self.current {
            self.settled = t <= target * (1.0 + self.settings.band);
            if self.settled && self.samples.len() >= w && self.settled_cost.is_none() {
                self.settled_cost = Some(t);
            }
            return false;
        }
        self.settled_cost = None;
        self.current = next;
        self.samples.clear();
        self.since_change = 0;
        self.settled = false;
        self.apply(settings)
    }

    /// The quality reached (module documentation, "Quality").
    pub fn quality(&self) -> BudgetQuality {
        let l = self.levels.get(self.current).copied().unwrap_or(Level { photons: 0, tolerance: None });
        BudgetQuality {
            grid: l.photons,
            photons: (l.photons as u64).pow(2),
            tolerance: l.tolerance,
            frame_ms: (!self.samples.is_empty()).then(|| median(&self.samples)),
            estimated_error: self.estimate_error(l.photons),
            settled: self.settled,
        }
    }

    /// A measured error (any metric, e.g. relative RMSE of the caustic map) of a frame rendered
    /// with photon grid `grid`, against the last converged reference.
    pub fn observe_error(&mut self, grid: u32, error: f64) {
        if grid > 0 && error.is_finite() && error > 0.0 {
            self.errors.push((grid, error));
            if self.errors.len() > 64 {
                self.errors.remove(0);
            }
        }
    }

    /// Forget the measured errors (the reference changed).
    pub fn clear_errors(&mut self) {
        self.errors.clear();
    }

    /// The error model `c · N^(−p)` at grid `grid` (module documentation), if errors were fed.
    pub fn estimate_error(&self, grid: u32) -> Option<f64> {
        if self.errors.is_empty() || grid == 0 {
            return None;
        }
        let pts: Vec<(f64, f64)> = self.errors.iter().map(|&(n, e)| ((n as f64).ln(), e.ln())).collect();
        let mx = pts.iter().map(|p| p.0).sum::<f64>() / pts.len() as f64;
        let my = pts.iter().map(|p| p.1).sum::<f64>() / pts.len() as f64;
        let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
        let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
        let p = if sxx > 1e-6 { (-sxy / sxx).clamp(0.25, 4.0) } else { 1.0 };
        // ln e = ln c − p ln N, through the mean point.
        Some((my - p * ((grid as f64).ln() - mx)).exp())
    }

    fn reset_ladder(&mut self, settings: &RenderSettings) {
        self.technique = Some(settings.photons.emission);
        self.levels = ladder(settings.photons.emission, &self.settings);
        let n = self.levels.len();
        self.seen = vec![None; n];
        self.blocked_until = vec![0; n];
        self.backoff = vec![self.settings.backoff_frames.max(1); n];
        self.current = self.nearest(settings);
        self.samples.clear();
        self.since_change = 0;
        self.settled = false;
    }

    /// The best level not above the settings' grid (and tolerance), or the lowest.
    fn nearest(&self, s: &RenderSettings) -> usize {
        let own = Level {
            photons: s.photons.count,
            tolerance: self.levels.first().and_then(|l| l.tolerance).map(|_| s.adaptive.error_tolerance),
        };
        let mut best = 0;
        for (j, l) in self.levels.iter().enumerate() {
            if l.photons < s.photons.count || (l.photons == s.photons.count && l.work() <= own.work() * (1.0 + 1e-9)) {
                best = j;
            }
        }
        best
    }

    fn matches(&self, s: &RenderSettings) -> bool {
        let l = self.levels[self.current];
        l.photons == s.photons.count && l.tolerance.is_none_or(|t| t == s.adaptive.error_tolerance)
    }

    fn apply(&mut self, s: &mut RenderSettings) -> bool {
        let l = self.levels[self.current];
        let mut changed = false;
        if s.photons.count != l.photons {
            s.photons.count = l.photons;
            changed = true;
        }
        if let Some(t) = l.tolerance
            && s.adaptive.error_tolerance != t
        {
            s.adaptive.error_tolerance = t;
            changed = true;
        }
        if changed {
            self.changes += 1;
            self.samples.clear();
            self.since_change = 0;
        }
        changed
    }

    /// The fixed overhead: least squares over the recent costs of the levels visited (`None`
    /// with fewer than two).
    fn fit_overhead(&self) -> Option<f64> {
        let recent: Vec<(f64, f64)> = self
            .seen
            .iter()
            .zip(&self.levels)
            .filter_map(|(s, l)| {
                s.filter(|&(_, f)| self.frame - f <= self.settings.memory_frames).map(|(t, _)| (l.work(), t))
            })
            .collect();
        let cheapest = recent.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
        if recent.len() < 2 {
            return None;
        }
        let k = recent.len() as f64;
        let mx = recent.iter().map(|p| p.0).sum::<f64>() / k;
        let my = recent.iter().map(|p| p.1).sum::<f64>() / k;
        let sxx: f64 = recent.iter().map(|p| (p.0 - mx).powi(2)).sum();
        let sxy: f64 = recent.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
        if sxx <= 0.0 || sxy <= 0.0 {
            return None;
        }
        Some((my - sxy / sxx * mx).clamp(0.0, 0.95 * cheapest))
    }
}

fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    if n == 0 {
        return 0.0;
    }
    if n % 2 == 1 { s[n / 2] } else { 0.5 * (s[n / 2 - 1] + s[n / 2]) }
}
