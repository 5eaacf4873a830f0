//! The combined uncertainty at a comparison point and its falsification thresholds
//! (docs/model.md §7–8, paper §2.2 and Table 2).
//!
//! Every source is uniform. With `y` the force at the point, model sources give `e_model =
//! y·Σ relative + Σ absolute` (prediction minus truth) and measurement sources `e_meas` the same
//! way (measurement minus truth), so the residual `g − y` of the true parameters is
//! `U_c = e_model − e_meas = y·S − T` with `S`, `T` independent of the point. (Relative errors
//! are taken on the measured force, which equals the prediction up to the errors themselves.)
//!
//! `S` and `T` are drawn once by Monte Carlo (seeded). For a point with force `y` and target
//! probability `p` the thresholds are the *shortest* interval holding a fraction `p` of the
//! samples of `U_c` (Šídák: `p = φ^(1/m)` for m points). Sorted samples of `U_c` are kept on a
//! geometric grid of |y| and the thresholds interpolated between grid values, so a
//! measurement costs two O(M) scans per point instead of a sort.
//!
//! A grid row is built the first time a force near it is asked for (a measurement touches a
//! dozen of the ~90 rows; sorting all of them took 90 ms of every cold start), and each row's
//! interval is remembered per probability (a measurement asks for two or three). A row keeps
//! only its two sorted *tails*: every probability identification asks for is at least the
//! settings' φ (Šídák's `φ^(1/m)` is larger), and the shortest interval holding a fraction
//! `p ≥ φ` of M samples starts among the lowest `M − ⌈φM⌉ + 1` and ends among as many highest,
//! so two partial selections and two short sorts give exactly the interval a full sort gives,
//! in a tenth of the time. A smaller probability falls back to a full sort.

use crate::model::calibration::{IdentificationParams, UncertaintyGroup, UncertaintyKind};
use std::collections::HashMap;
use std::sync::{Mutex, OnceLock};

/// Sorted Monte Carlo samples of the combined uncertainty on a grid of force magnitudes.
#[derive(Debug)]
pub struct CombinedUncertainty {
    s: Vec<f64>,
    t: Vec<f64>,
    grid_kn: Vec<f64>,
    /// The smallest probability the tails serve (the settings' φ).
    p_floor: f64,
    /// Each grid row's sorted tails of `U_c`, built on first use.
    tails: Vec<OnceLock<Tails>>,
    /// Each grid row's fully sorted samples, for a probability below `p_floor`.
    sorted: Vec<OnceLock<Vec<f64>>>,
    /// Shortest intervals already found: (row, probability bits) → interval.
    intervals: Mutex<HashMap<(usize, u64), (f64, f64)>>,
    /// The smallest and largest sample of S.
    s_range: (f64, f64),
    /// The largest sample of −T.
    minus_t_max: f64,
    /// The good-wheel-relative sources' widening per kN of flat-free force, `(low, high)`.
    good_wheel: (f64, f64),
    /// The bounded sources' widening (kN), `(low, high)`.
    bound: (f64, f64),
}

/// The thresholds of one point as a function of the force the relative sources scale with.
///
/// Model errors are fractions of the *predicted* force (paper Eq. 1: `g − ε_model` = truth),
/// measurement errors of the measured one. Thresholds taken at the measured force `y` are too
/// narrow for a prediction `g` larger than `y` (by up to a third where the model error is at
/// the table's edge), so an instance whose prediction exceeds the measurement is judged with
/// the thresholds at its own force, `thresholds(g)` — the rule the train's good-wheel check
/// uses (the larger of the two). The curve holds the grid rows from `|y|` up to the force
/// beyond which no prediction can pass even the hard bounds of U_c, so that falsification
/// evaluates it without locks, with the same interpolation as
/// [`CombinedUncertainty::thresholds`]; further out it extends the last interval by the
/// extreme slopes of S, which encloses at least the probability asked for (each sample of
/// `U_c` moves by `Δb·S`).
#[derive(Debug, Clone, PartialEq)]
pub struct ThresholdCurve {
    from_kn: f64,
    reach_kn: f64,
    /// (grid force, low, high) of the rows covering [from, reach].
    rows: Vec<(f64, f64, f64)>,
    /// The smallest and largest sample of S.
    slopes: (f64, f64),
    /// The interval at `reach_kn` (kept: most predictions falsification asks about lie beyond).
    at_reach: (f64, f64),
    /// The point's good-wheel-relative widening `(low, high)` (kN), added to every interval
    /// ([`CombinedUncertainty::good_wheel_widening`]).
    widen: (f64, f64),
}

impl ThresholdCurve {
    /// Thresholds `[low, high]` on `g − y` for a prediction of magnitude above the measured
    /// one; `g` carries its sign as in [`CombinedUncertainty::thresholds`].
    #[inline]
    pub fn at(&self, g_kn: f64) -> (f64, f64) {
        let a = g_kn.abs().max(self.from_kn);
        let (lo, hi) = if a > self.reach_kn {
            let (l, h) = self.at_reach;
            let d = a - self.reach_kn;
            (
                l + d * self.slopes.0.min(0.0),
                h + d * self.slopes.1.max(0.0),
            )
        } else {
            self.interpolate(a)
        };
        let (lo, hi) = if g_kn < 0.0 { (-hi, -lo) } else { (lo, hi) };
        (lo + self.widen.0, hi + self.widen.1)
    }

    /// The same curve at a point whose good-wheel-relative widening is `widen` (kN).
    pub fn widened(mut self, widen: (f64, f64)) -> ThresholdCurve {
        self.widen = widen;
        self
    }

    fn interpolate(&self, a: f64) -> (f64, f64) {
        let i = self
            .rows
            .partition_point(|r| r.0 <= a)
            .clamp(1, self.rows.len() - 1);
        let ((g0, l0, h0), (g1, l1, h1)) = (self.rows[i - 1], self.rows[i]);
        let w = if g1 > g0 { (a - g0) / (g1 - g0) } else { 0.0 };
        (l0 + w * (l1 - l0), h0 + w * (h1 - h0))
    }
}

pub(crate) use crate::bank::population::uniform;

/// The lowest and highest `m` of `n` samples, each sorted ascending.
#[derive(Debug)]
struct Tails {
    n: usize,
    low: Vec<f64>,
    high: Vec<f64>,
}

impl Tails {
    /// The tails of `u` long enough for any probability `≥ p_floor` (`u` is reordered).
    fn new(u: &mut [f64], p_floor: f64) -> Tails {
        let n = u.len();
        let m = n - window(n, p_floor) + 1;
        let (low, high) = if 2 * m >= n {
            u.sort_by(f64::total_cmp);
            (u[..m].to_vec(), u[n - m..].to_vec())
        } else {
            u.select_nth_unstable_by(m - 1, f64::total_cmp);
            let mut low = u[..m].to_vec();
            u.select_nth_unstable_by(n - m, f64::total_cmp);
            let mut high = u[n - m..].to_vec();
            low.sort_by(f64::total_cmp);
            high.sort_by(f64::total_cmp);
            (low, high)
        };
        Tails { n, low, high }
    }

    /// [`shortest_interval`] of the full sorted samples, from the tails; `None` when `p` needs
    /// more than the tails hold.
    fn shortest_interval(&self, p: f64) -> Option<(f64, f64)> {
        let (n, m) = (self.n, self.low.len());
        let k = window(n, p);
        if n - k + 1 > m {
            return None;
        }
        // Sorted position j of the top tail is high[j − (n − m)].
        Some(narrowest(n, k, |i| self.low[i], |j| self.high[j - (n - m)]))
    }
}

/// Samples a window must hold to hold a fraction `p` of `n`.
fn window(n: usize, p: f64) -> usize {
    ((p * n as f64).ceil() as usize).clamp(1, n)
}

/// The narrowest window of `k` of `n` sorted samples, `lo(i)` and `hi(j)` being the values of
/// sorted samples i and j where a window can start and end; the first of equally narrow ones.
fn narrowest(
    n: usize,
    k: usize,
    lo: impl Fn(usize) -> f64,
    hi: impl Fn(usize) -> f64,
) -> (f64, f64) {
    let mut best = (lo(0), hi(k - 1));
    for i in 1..=n - k {
        let (l, h) = (lo(i), hi(i + k - 1));
        if h - l < best.1 - best.0 {
            best = (l, h);
        }
    }
    best
}

/// Shortest interval `[lo, hi]` holding a fraction `p` of sorted samples.
pub(crate) fn shortest_interval(sorted: &[f64], p: f64) -> (f64, f64) {
    let n = sorted.len();
    narrowest(n, window(n, p), |i| sorted[i], |j| sorted[j])
}

impl CombinedUncertainty {
    /// Draws the Monte Carlo samples for an uncertainty table. The absolute sources are drawn
    /// once a point even where the series are compared through an average
    /// (`B₅`, [`crate::identify::input::compare`]): a bound on a raw sample bounds an average of samples, and
    /// the averaged draw (narrower) lost coverage on converged passes (docs/detection.md,
    /// "Rough wheels": variants).
    pub fn new(params: &IdentificationParams) -> CombinedUncertainty {
        let mut state = params.seed ^ 0x0005_EED0_F0C0_FFEE;
        let m = params.monte_carlo_samples;
        let mut s = Vec::with_capacity(m);
        let mut t = Vec::with_capacity(m);
        // The bounded per-point sources: (low, high) per kN of flat-free force, and in kN.
        let (mut good_wheel, mut bound) = ((0.0, 0.0), (0.0, 0.0));
        for src in &params.uncertainty {
            let slot = match src.kind {
                UncertaintyKind::GoodWheelRelative => &mut good_wheel,
                UncertaintyKind::BoundKn => &mut bound,
                _ => continue,
            };
            match src.group {
                UncertaintyGroup::Model => {
                    slot.0 += src.min;
                    slot.1 += src.max;
                }
                UncertaintyGroup::Measurement => {
                    slot.0 -= src.max;
                    slot.1 -= src.min;
                }
            }
        }
        for _ in 0..m {
            let (mut rel, mut abs) = (0.0, 0.0);
            // The bounded sources are applied per point, not drawn.
            for src in params.uncertainty.iter().filter(|u| u.kind.is_drawn()) {
                let sign = match src.group {
                    UncertaintyGroup::Model => 1.0,
                    UncertaintyGroup::Measurement => -1.0,
                };
                let u = src.min + (src.max - src.min) * uniform(&mut state);
                match src.kind {
                    UncertaintyKind::Relative => rel += sign * u,
                    UncertaintyKind::AbsoluteKn => abs += sign * u,
                    UncertaintyKind::GoodWheelRelative | UncertaintyKind::BoundKn => {}
                }
            }
            s.push(rel);
            t.push(abs);
        }
        // |y| grid: 0, then geometric from 0.05 kN to 2000 kN, ratio 1.15.
        let mut grid_kn = vec![0.0];
        let mut g = 0.05;
        while g < 2000.0 {
            grid_kn.push(g);
            g *= 1.15;
        }
        grid_kn.push(2000.0);
        CombinedUncertainty {
            p_floor: params.phi.clamp(0.0, 1.0),
            tails: grid_kn.iter().map(|_| OnceLock::new()).collect(),
            sorted: grid_kn.iter().map(|_| OnceLock::new()).collect(),
            s_range: (
                s.iter().copied().fold(f64::INFINITY, f64::min),
                s.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            ),
            minus_t_max: t.iter().map(|t| -t).fold(f64::NEG_INFINITY, f64::max),
            good_wheel,
            bound,
            s,
            t,
            grid_kn,
            intervals: Mutex::new(HashMap::new()),
        }
    }

    /// The samples of `U_c = y·S − T` at force `y_kn`, unsorted.
    fn samples_at(&self, y_kn: f64) -> Vec<f64> {
        self.s
            .iter()
            .zip(&self.t)
            .map(|(s, t)| y_kn * s + t)
            .collect()
    }

    /// The samples of `U_c` at force `y_kn`, sorted.
    fn sorted_at(&self, y_kn: f64) -> Vec<f64> {
        let mut u = self.samples_at(y_kn);
        u.sort_by(f64::total_cmp);
        u
    }

    /// The shortest interval of row `i` holding probability `p`.
    fn interval(&self, i: usize, p: f64) -> (f64, f64) {
        let key = (i, p.to_bits());
        if let Some(&v) = self.lock().get(&key) {
            return v;
        }
        let tails = self.tails[i]
            .get_or_init(|| Tails::new(&mut self.samples_at(self.grid_kn[i]), self.p_floor));
        let v = tails.shortest_interval(p).unwrap_or_else(|| {
            shortest_interval(
                self.sorted[i].get_or_init(|| self.sorted_at(self.grid_kn[i])),
                p,
            )
        });
        self.lock().insert(key, v);
        v
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, HashMap<(usize, u64), (f64, f64)>> {
        self.intervals.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Thresholds from a direct sort of the samples at `y_kn` (no grid interpolation): slower,
    /// for audits and for checking the grid.
    pub fn thresholds_exact(&self, y_kn: f64, p: f64) -> (f64, f64) {
        shortest_interval(&self.sorted_at(y_kn), p)
    }

    /// The thresholds at a point measured at `y_kn`, as a function of the force they scale
    /// with, for predictions larger than the measurement ([`ThresholdCurve`]).
    pub fn curve(&self, y_kn: f64, p: f64) -> ThresholdCurve {
        let last = *self.grid_kn.last().expect("grid is not empty");
        let a0 = y_kn.abs().min(last);
        // Beyond `reach` no prediction can pass even the hard bounds of U_c at its own force:
        // g − y > g·max S + max(−T) ⇔ g > (y + max(−T)) / (1 − max S).
        let (s_lo, s_hi) = self.s_range;
        let reach = if s_hi < 1.0 {
            ((a0 + self.minus_t_max) / (1.0 - s_hi)).min(last)
        } else {
            last
        };
        let first = self
            .grid_kn
            .partition_point(|&g| g <= a0)
            .clamp(1, self.grid_kn.len() - 1)
            - 1;
        let end = self
            .grid_kn
            .partition_point(|&g| g < reach)
            .clamp(first + 1, self.grid_kn.len() - 1);
        let rows = (first..=end)
            .map(|i| {
                let (lo, hi) = self.interval(i, p);
                (self.grid_kn[i], lo, hi)
            })
            .collect();
        let mut c = ThresholdCurve {
            from_kn: a0,
            reach_kn: reach,
            rows,
            slopes: (s_lo, s_hi),
            at_reach: (0.0, 0.0),
            widen: (0.0, 0.0),
        };
        c.at_reach = c.interpolate(reach);
        c
    }

    /// The widening `(low, high)` (kN) the bounded sources (a rough tread or rail,
    /// [`UncertaintyKind::GoodWheelRelative`] and [`UncertaintyKind::BoundKn`]) add to the
    /// thresholds at a point whose flat-free predicted force is `flat_free_kn`:
    /// `[Σ min, Σ max]·|g_ff|` plus the bounds in kN, added to the interval of the drawn
    /// sources.
    pub fn good_wheel_widening(&self, flat_free_kn: f64) -> (f64, f64) {
        let g = flat_free_kn.abs();
        (
            self.good_wheel.0 * g + self.bound.0,
            self.good_wheel.1 * g + self.bound.1,
        )
    }

    /// [`CombinedUncertainty::thresholds`] at a point whose flat-free predicted force is
    /// `flat_free_kn`, widened by [`CombinedUncertainty::good_wheel_widening`].
    pub fn thresholds_at(&self, y_kn: f64, flat_free_kn: f64, p: f64) -> (f64, f64) {
        let (lo, hi) = self.thresholds(y_kn, p);
        let (a, b) = self.good_wheel_widening(flat_free_kn);
        (lo + a, hi + b)
    }

    /// [`CombinedUncertainty::curve`] at a point whose flat-free predicted force is
    /// `flat_free_kn`, widened alike.
    pub fn curve_at(&self, y_kn: f64, flat_free_kn: f64, p: f64) -> ThresholdCurve {
        self.curve(y_kn, p)
            .widened(self.good_wheel_widening(flat_free_kn))
    }

    /// Thresholds `[low, high]` on `prediction − measurement` (kN) at a point where the force
    /// is `y_kn`, holding probability `p`.
    pub fn thresholds(&self, y_kn: f64, p: f64) -> (f64, f64) {
        let a = y_kn
            .abs()
            .min(*self.grid_kn.last().expect("grid is not empty"));
        let i = self
            .grid_kn
            .partition_point(|&g| g <= a)
            .clamp(1, self.grid_kn.len() - 1);
        let (g0, g1) = (self.grid_kn[i - 1], self.grid_kn[i]);
        let w = if g1 > g0 { (a - g0) / (g1 - g0) } else { 0.0 };
        let (l0, h0) = self.interval(i - 1, p);
        let (l1, h1) = self.interval(i, p);
        let (lo, hi) = (l0 + w * (l1 - l0), h0 + w * (h1 - h0));
        if y_kn < 0.0 {
            // U(−y) = −(y·S) + T: mirror the magnitude's interval (T is symmetric by default;
            // for an asymmetric T this is the interval of −U, an approximation stated here).
            (-hi, -lo)
        } else {
            (lo, hi)
        }
    }
}

/// One draw of every uncertainty source of `group` and `kind`, summed (the resolution left
/// out when asked: it is applied as quantisation).
pub(crate) fn draw_sources(
    id: &IdentificationParams,
    group: UncertaintyGroup,
    kind: UncertaintyKind,
    skip_resolution: bool,
    state: &mut u64,
) -> f64 {
    id.uncertainty
        .iter()
        .filter(|u| {
            u.group == group
                && u.kind == kind
                && !(skip_resolution && u.name.contains("resolution"))
        })
        .map(|u| u.min + (u.max - u.min) * uniform(state))
        .sum()
}

/// The quantisation step of the sensors (kN): a resolution of ±r is a step of 2r.
pub(crate) fn resolution_step_kn(id: &IdentificationParams) -> f64 {
    id.uncertainty
        .iter()
        .filter(|u| u.group == UncertaintyGroup::Measurement && u.name.contains("resolution"))
        .map(|u| u.max - u.min)
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shortest_interval_of_a_uniform_sample_is_its_central_part_or_any() {
        let s: Vec<f64> = (0..1000).map(|i| i as f64 / 1000.0).collect();
        let (lo, hi) = shortest_interval(&s, 0.9);
        assert!((hi - lo - 0.899).abs() < 1e-9);
    }

    #[test]
    fn a_threshold_curve_is_the_thresholds_at_the_prediction_and_encloses_them_beyond() {
        let cu = CombinedUncertainty::new(&IdentificationParams::default());
        let p = 0.95f64.powf(1.0 / 40.0);
        for y in [0.0, 0.3, 4.0, 12.5, 40.0, 180.0] {
            let c = cu.curve(y, p);
            // Inside its reach: the same interpolation as `thresholds` at the prediction's force.
            let mut g = y.max(0.01);
            while g <= c.reach_kn {
                let (a, b) = (c.at(g), cu.thresholds(g, p));
                assert!(
                    (a.0 - b.0).abs() < 1e-12 && (a.1 - b.1).abs() < 1e-12,
                    "{y} {g}"
                );
                let (a, b) = (c.at(-g), cu.thresholds(-g, p));
                assert!(
                    (a.0 - b.0).abs() < 1e-12 && (a.1 - b.1).abs() < 1e-12,
                    "{y} -{g}"
                );
                g = g * 1.07 + 0.05;
            }
            // Beyond it: an interval at least as wide as the one at the prediction's force, on
            // both sides (so an instance there is never judged more strictly).
            for g in [c.reach_kn * 1.5, c.reach_kn * 3.0 + 10.0] {
                let (a, b) = (c.at(g), cu.thresholds_exact(g, p));
                assert!(
                    a.0 <= b.0 + 1e-9 && a.1 >= b.1 - 1e-9,
                    "{y} {g}: {a:?} {b:?}"
                );
            }
            // A prediction above the measurement gets thresholds at least as wide as the
            // measurement's own (model errors are fractions of the prediction).
            let (lo_y, hi_y) = cu.thresholds(y, p);
            let (lo_g, hi_g) = c.at(1.3 * y + 1.0);
            assert!(hi_g >= hi_y && lo_g <= lo_y, "{y}");
        }
    }

    #[test]
    fn thresholds_hold_the_target_probability_of_fresh_samples() {
        // Fresh draws of U at y = 40 kN fall inside [low, high] with probability p (±0.5 %).
        let params = IdentificationParams::default();
        let cu = CombinedUncertainty::new(&params);
        let p = 0.95;
        let (lo, hi) = cu.thresholds(40.0, p);
        let mut state = 99u64;
        let mut inside = 0;
        let n = 40_000;
        for _ in 0..n {
            let (mut u, y) = (0.0, 40.0);
            for src in &params.uncertainty {
                let x = src.min + (src.max - src.min) * uniform(&mut state);
                let sign = if src.group == UncertaintyGroup::Model {
                    1.0
                } else {
                    -1.0
                };
                u += sign
                    * if src.kind == UncertaintyKind::Relative {
                        y * x
                    } else {
                        x
                    };
            }
            if (lo..=hi).contains(&u) {
                inside += 1;
            }
        }
        let frac = inside as f64 / n as f64;
        assert!((frac - p).abs() < 0.005, "{frac}");
        // The model under-predicts more than it over-predicts: the interval leans negative.
        assert!(lo < -hi, "{lo} {hi}");
    }

    #[test]
    fn the_tails_give_exactly_the_interval_of_a_full_sort() {
        let cu = CombinedUncertainty::new(&IdentificationParams::default());
        for y in [0.0, 3.1, 47.0, 190.0] {
            let mut u = cu.samples_at(y);
            let tails = Tails::new(&mut u.clone(), 0.95);
            u.sort_by(f64::total_cmp);
            for p in [0.95, 0.96, 0.99, 0.999, 0.99995, 1.0] {
                assert_eq!(
                    tails.shortest_interval(p),
                    Some(shortest_interval(&u, p)),
                    "y {y} p {p}"
                );
            }
            // Below the floor the tails do not hold the interval; the table sorts in full.
            assert_eq!(tails.shortest_interval(0.9), None);
        }
        let low_phi = CombinedUncertainty::new(&IdentificationParams::default());
        let (lo, hi) = low_phi.thresholds(40.0, 0.5);
        assert!(lo < hi && lo < 0.0, "{lo} {hi}");
    }

    #[test]
    fn interpolation_between_grid_values_is_close_to_a_direct_sort() {
        let cu = CombinedUncertainty::new(&IdentificationParams::default());
        for (y, p) in [(33.3, 0.99), (2.7, 0.95), (181.0, 0.9972)] {
            let (lo, hi) = cu.thresholds(y, p);
            let (dlo, dhi) = cu.thresholds_exact(y, p);
            // Tolerance: 1 % of the interval width.
            let w = dhi - dlo;
            assert!(
                (lo - dlo).abs() < 0.01 * w && (hi - dhi).abs() < 0.01 * w,
                "y {y}: [{lo}, {hi}] vs [{dlo}, {dhi}]"
            );
        }
        let (a_lo, a_hi) = cu.thresholds(33.3, 0.99);
        let (n_lo, n_hi) = cu.thresholds(-33.3, 0.99);
        assert!((n_lo + a_hi).abs() < 1e-12 && (n_hi + a_lo).abs() < 1e-12);
    }
}
