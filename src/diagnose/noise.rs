//! The noise model from the data: the standard deviation σ and lag-1 correlation ρ
//! of an AR(1) noise, estimated from the flat-free parts of the record, so that field noise
//! larger or more coloured than the uncertainty table's is not taken for a missing effect.
//!
//! **Estimator.** On the residual `r = y − a·g` of the flat-only fit, away from the flat's
//! strikes (where the model-form error of the impact transients lives), a local quadratic over
//! 21 samples is removed (Savitzky–Golay), which takes out what varies slowly — a missing
//! effect's gap, a gain error, out-of-roundness — so that the estimate is of the noise, not of
//! the gap the diagnosis looks for (the idea of difference-based variance estimation: Rice
//! 1984; Gasser, Sroka & Jennen-Steinmetz 1986). The variance and lag-1 autocovariance of what
//! is left are matched to those of AR(1) noise through the same filter ([`estimate`]).
//!
//! **Use.** The fits use `σ = max(σ_table, σ̂)` (never less noise than the table states) and
//! `ρ̂`; the χ² is of the whitened residual: `w_0 = r_0/σ`,
//! `w_k = (r_k − ρ·r_{k−1})/(σ·√(1 − ρ²))`, independent and of unit variance under the model.

use serde::{Deserialize, Serialize};

/// Largest lag-1 correlation used (the whitening divides by `√(1 − ρ²)`).
pub const MAX_RHO: f64 = 0.95;
/// Fewest filtered samples an estimate is made from; fewer leave the table's noise.
pub const MIN_SAMPLES: usize = 100;
/// Samples from this long before a strike of the flat…
pub const STRIKE_BEFORE_S: f64 = 0.002;
/// …to this long after its end are left out of the estimate (the impact's transient).
pub const STRIKE_AFTER_S: f64 = 0.030;

/// What was estimated, and what the fits used.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct NoiseEstimate {
    /// σ of the uncertainty table's absolute sources (kN).
    pub sigma_table_kn: f64,
    /// σ estimated from the record (kN); None when too few flat-free samples.
    pub sigma_estimated_kn: Option<f64>,
    /// ρ estimated (0 when not estimated).
    pub rho: f64,
    /// Filtered samples the estimate rests on.
    pub samples: usize,
    /// σ the fits use: `max(σ_table, σ̂)` (kN).
    pub sigma_used_kn: f64,
}

/// The record's noise counts as above the uncertainty table when its σ exceeds the table's
/// absolute sources' σ by this factor (the estimator is within 10 % of the truth on 1,000
/// samples, docs/diagnosis.md; set before measuring, not tuned).
pub const ABOVE_TABLE: f64 = 1.25;

/// The half-width of the table entry that holds a site's noise, in its σ ([`CLIP_SD`]): a
/// Gaussian value exceeds it with probability 6·10⁻⁵.
pub const BOUND_SD: f64 = CLIP_SD;

/// The site's noise against the table, and the table entry that would hold it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NoiseAboveTable {
    /// σ estimated (kN).
    pub sigma_kn: f64,
    /// Lag-1 correlation estimated.
    pub rho: f64,
    /// σ of the table's absolute sources (kN).
    pub sigma_table_kn: f64,
    /// The table entry to change (the largest absolute measurement source).
    pub entry: String,
    /// Its bounds today (kN).
    pub bounds_kn: [f64; 2],
    /// Its bounds for the estimated σ: ±[`BOUND_SD`]·σ about its centre (kN).
    pub suggested_kn: [f64; 2],
}

impl NoiseAboveTable {
    /// The finding when `sigma_kn` is at least [`ABOVE_TABLE`] times the table's σ; None when
    /// the table holds it (or has no absolute measurement source to change).
    pub fn of(
        sigma_kn: f64,
        rho: f64,
        table: &[crate::model::calibration::UncertaintySource],
    ) -> Option<NoiseAboveTable> {
        use crate::model::calibration::{UncertaintyGroup, UncertaintyKind};
        let absolute: Vec<&crate::model::calibration::UncertaintySource> = table
            .iter()
            .filter(|u| u.kind == UncertaintyKind::AbsoluteKn)
            .collect();
        let sigma_table = absolute.iter().map(|u| u.variance()).sum::<f64>().sqrt();
        if sigma_kn.is_nan() || sigma_kn < ABOVE_TABLE * sigma_table {
            return None;
        }
        let entry = absolute
            .iter()
            .filter(|u| u.group == UncertaintyGroup::Measurement)
            .max_by(|a, b| a.variance().total_cmp(&b.variance()))?;
        let centre = entry.mean();
        // The table's sources are uniform, the site's noise is not bounded (coloured noise is
        // near Gaussian): the entry is made to bound ±[`BOUND_SD`]·σ̂ about its centre, the
        // level beyond which [`estimate`] calls a value a transient, not noise.
        let width = 2.0 * BOUND_SD * sigma_kn;
        Some(NoiseAboveTable {
            sigma_kn,
            rho,
            sigma_table_kn: sigma_table,
            entry: entry.name.clone(),
            bounds_kn: [entry.min, entry.max],
            suggested_kn: [centre - 0.5 * width, centre + 0.5 * width],
        })
    }

    /// `table` with the entry widened to the suggested bounds.
    pub fn apply(&self, table: &mut [crate::model::calibration::UncertaintySource]) {
        for u in table.iter_mut().filter(|u| u.name == self.entry) {
            u.min = self.suggested_kn[0];
            u.max = self.suggested_kn[1];
        }
    }

    /// The finding in words.
    pub fn words(&self) -> String {
        format!(
            "noise above the uncertainty table: σ = {:.2} kN, lag-1 correlation ρ = {:.2} estimated from the record's flat-free parts (the table's absolute sources: σ = {:.2} kN, independent); widen the table's \"{}\" from [{:.2}, {:.2}] to [{:.2}, {:.2}] kN, or measure the site's noise with `wheelflat calibration --noise-from`",
            self.sigma_kn,
            self.rho,
            self.sigma_table_kn,
            self.entry,
            self.bounds_kn[0],
            self.bounds_kn[1],
            self.suggested_kn[0],
            self.suggested_kn[1]
        )
    }
}

/// One pass's residuals from the flat-free template at each sensor's fitted gain
/// (detection's, [`crate::identify::detect`]), one series per sensor: with every sample
/// kept, [`estimate`] measures the site's noise from them, its clipping leaving out the
/// strikes of a flat.
pub fn pass_residuals(
    identifier: &crate::identify::Identifier,
    m: &crate::identify::Measurement,
) -> Result<Vec<Vec<f64>>, crate::identify::IdentifyError> {
    let id = identifier.identify(m, None, crate::identify::Extras::AS_RECORDED)?;
    let Some(det) = id.detection.as_ref() else {
        return Ok(Vec::new());
    };
    // The noise of the record itself: its samples as taken, not the comparison's average.
    let raw = identifier.series_as_recorded(m, &id)?;
    Ok(det
        .sensors
        .iter()
        .filter_map(|test| {
            let ser = raw.iter().find(|s| s.sensor == test.sensor)?;
            Some(
                ser.values_kn
                    .iter()
                    .zip(&test.flat_free_kn)
                    .map(|(y, g)| y - test.gain * g)
                    .collect(),
            )
        })
        .collect())
}

/// Half-width m of the local quadratic removed before the noise is measured (a window of
/// 2m + 1 = 21 samples, 8.4 ms at 2.5 kHz): what varies over longer than that — a missing
/// effect's gap, out-of-roundness up to about 50 Hz — is not noise.
pub const SMOOTH_HALF: usize = 10;

/// The high-pass filter `h = δ − SG`: the sample minus the centre value of a least-squares
/// quadratic over the 2m + 1 samples around it (Savitzky–Golay smoothing weights
/// `c_j = (3(3m² + 3m − 1) − 15j²) / ((2m − 1)(2m + 1)(2m + 3))`).
pub fn high_pass() -> Vec<f64> {
    let m = SMOOTH_HALF as f64;
    let norm = (2.0 * m - 1.0) * (2.0 * m + 1.0) * (2.0 * m + 3.0);
    (0..=2 * SMOOTH_HALF)
        .map(|i| {
            let j = i as f64 - m;
            let c = (3.0 * (3.0 * m * m + 3.0 * m - 1.0) - 15.0 * j * j) / norm;
            if i == SMOOTH_HALF {
                1.0 - c
            } else {
                -c
            }
        })
        .collect()
}

/// `Σ_i Σ_j h_i h_j ρ^|i − j + lag|`: the lag-`lag` autocovariance of `h` applied to AR(1)
/// noise of unit variance and correlation ρ.
fn filtered_autocovariance(h: &[f64], rho: f64, lag: i64) -> f64 {
    let mut s = 0.0;
    for (i, hi) in h.iter().enumerate() {
        for (j, hj) in h.iter().enumerate() {
            s += hi * hj * rho.powi((i as i64 - j as i64 + lag).unsigned_abs() as i32);
        }
    }
    s
}

/// Rounds of clipping.
const CLIP_ROUNDS: usize = 4;
/// A filtered value beyond this many standard deviations is a transient, not noise (an
/// impact no strike window covers: a dip's, a second flat's); it is left out with
/// [`CLIP_SPAN`] values either side. Noise reaches it with probability 6·10⁻⁵ if Gaussian,
/// never if uniform (the table's: 1.7 standard deviations at most).
pub const CLIP_SD: f64 = 4.0;
/// Filtered values left out either side of a clipped one.
pub const CLIP_SPAN: usize = 25;

/// σ and ρ of the AR(1) noise in `residuals` (one series per sensor) from the samples `keep`
/// marks; None when fewer than [`MIN_SAMPLES`] samples have their whole window kept.
///
/// Each residual is high-passed ([`high_pass`]) where its whole window is kept; the variance
/// `C₀` and lag-1 autocovariance `C₁` of what is left (mean squares: unbiased whatever the
/// noise's distribution) are matched to those of filtered AR(1) noise, `σ²·G₀(ρ)` and
/// `σ²·G₁(ρ)`: `ρ` solves `G₁/G₀ = C₁/C₀` (bisection) and `σ² = C₀/G₀(ρ)`. Values beyond
/// [`CLIP_SD`] are clipped first, in rounds.
pub fn estimate(residuals: &[Vec<f64>], keep: &[Vec<bool>]) -> Option<(f64, f64, usize)> {
    let h = high_pass();
    let w = h.len();
    let mut series: Vec<Vec<Option<f64>>> = Vec::new();
    for (r, k) in residuals.iter().zip(keep) {
        let n = r.len().min(k.len());
        if n < w + 1 {
            continue;
        }
        series.push(
            (0..n)
                .map(|c| {
                    let a = c.checked_sub(SMOOTH_HALF)?;
                    let window = a..a + w;
                    if window.end > n || !k[window.clone()].iter().all(|&b| b) {
                        return None;
                    }
                    Some(h.iter().zip(&r[window]).map(|(hi, v)| hi * v).sum())
                })
                .collect(),
        );
    }
    let mut moments = moments(&series)?;
    for _ in 0..CLIP_ROUNDS {
        let limit = CLIP_SD * moments.0.sqrt();
        let mut clipped = false;
        for f in &mut series {
            let out: Vec<usize> = (0..f.len())
                .filter(|&i| f[i].is_some_and(|v| v.abs() > limit))
                .collect();
            for i in out {
                let (a, b) = (
                    i.saturating_sub(CLIP_SPAN),
                    (i + CLIP_SPAN).min(f.len() - 1),
                );
                f[a..=b].iter_mut().for_each(|v| *v = None);
                clipped = true;
            }
        }
        if !clipped {
            break;
        }
        moments = self::moments(&series)?;
    }
    let (c0, c1, samples) = moments;
    let ratio =
        |rho: f64| filtered_autocovariance(&h, rho, 1) / filtered_autocovariance(&h, rho, 0);
    let target = c1 / c0;
    let rho = if target <= ratio(0.0) {
        0.0
    } else if target >= ratio(MAX_RHO) {
        MAX_RHO
    } else {
        let (mut lo, mut hi) = (0.0, MAX_RHO);
        for _ in 0..50 {
            let mid = 0.5 * (lo + hi);
            if ratio(mid) < target {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    };
    Some((
        (c0 / filtered_autocovariance(&h, rho, 0)).sqrt(),
        rho,
        samples,
    ))
}

/// Mean square, mean lag-1 product and count of the filtered values present.
fn moments(series: &[Vec<Option<f64>>]) -> Option<(f64, f64, usize)> {
    let (mut s0, mut n0, mut s1, mut n1) = (0.0, 0usize, 0.0, 0usize);
    for f in series {
        for v in f.iter().flatten() {
            s0 += v * v;
            n0 += 1;
        }
        for p in f.windows(2) {
            if let [Some(a), Some(b)] = p {
                s1 += a * b;
                n1 += 1;
            }
        }
    }
    if n0 < MIN_SAMPLES
        || n1 < MIN_SAMPLES
        || s0.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
    {
        return None;
    }
    Some((s0 / n0 as f64, s1 / n1 as f64, n0))
}

/// Which samples of series starting at bank sample `first_samples` (each `lengths` long, at
/// `rate_hz`) lie outside every strike window `[t_from, t_to]` (s).
pub fn flat_free(
    first_samples: &[usize],
    lengths: &[usize],
    rate_hz: f64,
    strikes_s: &[(f64, f64)],
) -> Vec<Vec<bool>> {
    first_samples
        .iter()
        .zip(lengths)
        .map(|(&first, &n)| {
            (0..n)
                .map(|k| {
                    let t = (first + k) as f64 / rate_hz;
                    !strikes_s.iter().any(|&(a, b)| (a..=b).contains(&t))
                })
                .collect()
        })
        .collect()
}

/// `x` whitened for AR(1) noise of σ `sigma` and correlation `rho`, in units of σ:
/// `x_0/σ`, then `(x_k − ρ·x_{k−1})/(σ·√(1 − ρ²))`.
pub fn whiten(x: &[f64], sigma: f64, rho: f64) -> Vec<f64> {
    let innovation = sigma * (1.0 - rho * rho).sqrt();
    x.iter()
        .enumerate()
        .map(|(k, &v)| {
            if k == 0 {
                v / sigma
            } else {
                (v - rho * x[k - 1]) / innovation
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_above_the_table_names_the_entry_and_the_bounds_that_hold_it() {
        let table = crate::model::Calibration::default()
            .identification
            .uncertainty;
        // The table's absolute sources: ±1 kN noise and ±0.05 kN resolution, σ = 0.578 kN.
        assert!(
            NoiseAboveTable::of(0.6, 0.0, &table).is_none(),
            "within 1.25×"
        );
        let f = NoiseAboveTable::of(1.0, 0.8, &table).expect("1.73× the table");
        assert_eq!(f.entry, "environment noise");
        assert!(
            (f.sigma_table_kn - 0.5781).abs() < 1e-3,
            "{}",
            f.sigma_table_kn
        );
        // The widened entry bounds ±4σ about its centre.
        let mut wider = table.clone();
        f.apply(&mut wider);
        let e = wider
            .iter()
            .find(|u| u.name == "environment noise")
            .unwrap();
        assert_eq!((e.min, e.max), (-4.0, 4.0));
        assert!(f.words().contains("σ = 1.00 kN") && f.words().contains("ρ = 0.80"));
    }

    /// A seeded AR(1) series of Gaussian innovations (Box–Muller on splitmix).
    fn ar1(n: usize, sigma: f64, rho: f64, seed: u64) -> Vec<f64> {
        let mut state = seed;
        let mut u = || crate::bank::population::uniform(&mut state).max(1e-300);
        let mut e = 0.0;
        (0..n)
            .map(|k| {
                let z = (-2.0 * u().ln()).sqrt() * (std::f64::consts::TAU * u()).cos();
                e = if k == 0 {
                    sigma * z
                } else {
                    rho * e + sigma * (1.0 - rho * rho).sqrt() * z
                };
                e
            })
            .collect()
    }

    #[test]
    fn the_difference_estimator_recovers_sigma_and_rho_of_ar1_noise_under_a_smooth_gap() {
        // 10 series of 2,000 samples at 2.5 kHz: σ 1.2 kN, ρ ∈ {0, 0.6}, Gaussian, plus a
        // smooth residual of 3 kN at 15 Hz (a missing effect's gap). Tolerance: 6 % on σ, 0.06
        // on ρ, three standard deviations of the estimate at this size (measured over 8 seeds
        // at a quarter of it: ρ̂ 0.525–0.646 around 0.6, σ̂ within ± 6 %, so sd 0.04 and 4 %
        // there, half that here).
        // Also 2.7 kN at 50 Hz (out-of-roundness of order 9 at 50 km/h): ρ̂ below 0.08.
        for (rho, hz, amp) in [(0.0, 15.0, 3.0), (0.6, 15.0, 3.0), (0.0, 50.0, 2.7)] {
            let residuals: Vec<Vec<f64>> = (0..10)
                .map(|s| {
                    ar1(2000, 1.2, rho, 17 + s)
                        .into_iter()
                        .enumerate()
                        .map(|(k, e)| {
                            e + amp * (std::f64::consts::TAU * hz * k as f64 / 2500.0).sin()
                        })
                        .collect()
                })
                .collect();
            let keep: Vec<Vec<bool>> = residuals.iter().map(|r| vec![true; r.len()]).collect();
            let (sigma, r, samples) = estimate(&residuals, &keep).unwrap();
            // Every whole window, less what a rare Gaussian excursion beyond 4 sd clips.
            let windows = 10 * (2000 - 2 * SMOOTH_HALF);
            assert!(
                samples <= windows && samples * 100 >= windows * 98,
                "{samples}"
            );
            assert!(
                (sigma / 1.2 - 1.0).abs() < 0.06,
                "ρ {rho}, {hz} Hz: σ̂ {sigma}"
            );
            assert!((r - rho).abs() < 0.06, "ρ {rho}, {hz} Hz: ρ̂ {r}");
        }
    }

    #[test]
    fn samples_left_out_do_not_count_and_too_few_give_no_estimate() {
        let r = vec![ar1(2000, 1.0, 0.0, 3)];
        let mut keep = vec![vec![false; 2000]];
        assert_eq!(estimate(&r, &keep), None);
        // A spike where the strike is, left out: the estimate does not see it.
        let mut spiked = r.clone();
        spiked[0][1000] += 500.0;
        for (k, kk) in keep[0].iter_mut().enumerate() {
            *kk = !(990..=1010).contains(&k);
        }
        let (a, _, _) = estimate(&r, &keep).unwrap();
        let (b, _, _) = estimate(&spiked, &keep).unwrap();
        assert_eq!(a.to_bits(), b.to_bits());
        // A spike no window covers (a second flat's strike) is clipped: within 3 % of the
        // estimate without it (the clipped span's samples are missing from it).
        let all = vec![vec![true; 2000]];
        let (c, _, _) = estimate(&r, &all).unwrap();
        let (d, _, _) = estimate(&spiked, &all).unwrap();
        assert!((d / c - 1.0).abs() < 0.03, "{c} vs {d}");
    }

    #[test]
    fn a_transient_over_a_few_percent_of_the_samples_moves_the_estimate_little() {
        // White Gaussian noise σ 0.6 kN, 4 series of 1,000; in each, 40 samples (4 %) carry a
        // ringing of 4 kN at 300 Hz (a dip's or a second flat's transient, no window over
        // it). Unclipped, σ would grow about 3×; clipped, it stays within 8 % and ρ below
        // 0.08.
        let residuals: Vec<Vec<f64>> = (0..4)
            .map(|s| {
                let mut r = ar1(1000, 0.6, 0.0, 40 + s);
                for (k, v) in r.iter_mut().enumerate().skip(500).take(40) {
                    *v += 4.0 * (std::f64::consts::TAU * 300.0 * k as f64 / 2500.0).sin();
                }
                r
            })
            .collect();
        let keep: Vec<Vec<bool>> = residuals.iter().map(|r| vec![true; r.len()]).collect();
        let (sigma, rho, _) = estimate(&residuals, &keep).unwrap();
        assert!((sigma / 0.6 - 1.0).abs() < 0.08, "σ̂ {sigma}");
        assert!(rho < 0.08, "ρ̂ {rho}");
    }

    #[test]
    fn uniform_noise_like_the_tables_is_estimated_without_bias() {
        // The table's noise: uniform ±1 kN (σ 0.577), independent; 10 series of 2,000.
        // Tolerance 3 %: the mean square of 20,000 nearly-uniform values has a sampling
        // error near 0.6 % on σ; ρ̂ ≤ 0.05.
        let mut state = 5u64;
        let residuals: Vec<Vec<f64>> = (0..10)
            .map(|_| {
                (0..2000)
                    .map(|_| 2.0 * crate::bank::population::uniform(&mut state) - 1.0)
                    .collect()
            })
            .collect();
        let keep: Vec<Vec<bool>> = residuals.iter().map(|r| vec![true; r.len()]).collect();
        let (sigma, rho, _) = estimate(&residuals, &keep).unwrap();
        assert!(
            (sigma / (1.0 / 3f64.sqrt()) - 1.0).abs() < 0.03,
            "σ̂ {sigma}"
        );
        assert!(rho <= 0.05, "ρ̂ {rho}");
    }

    #[test]
    fn strike_windows_mark_their_samples() {
        // Two series at 10 Hz from samples 10 and 0; one window 1.15–1.45 s.
        let keep = flat_free(&[10, 0], &[6, 3], 10.0, &[(1.15, 1.45)]);
        assert_eq!(keep[0], vec![true, true, false, false, false, true]);
        assert_eq!(keep[1], vec![true, true, true]);
    }

    #[test]
    fn whitening_makes_ar1_noise_independent_of_unit_variance() {
        // 20,000 samples, σ 0.8, ρ 0.7: whitened variance 1 ± 3 %, lag-1 correlation |·| < 0.03.
        let e = ar1(20_000, 0.8, 0.7, 9);
        let w = whiten(&e, 0.8, 0.7);
        let n = w.len() as f64;
        let var = w.iter().map(|x| x * x).sum::<f64>() / n;
        let lag1 = w.windows(2).map(|p| p[0] * p[1]).sum::<f64>() / (n - 1.0);
        assert!((var - 1.0).abs() < 0.03, "variance {var}");
        assert!(lag1.abs() < 0.03, "lag-1 {lag1}");
        // ρ = 0: plain scaling.
        let plain = whiten(&[2.0, -4.0], 2.0, 0.0);
        assert_eq!(plain, vec![1.0, -2.0]);
    }
}
