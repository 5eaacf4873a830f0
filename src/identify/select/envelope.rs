//! Envelope points: the heights of the impact spikes, compared without resolving the impact
//! position to the millimetre.
//!
//! The entropy-selected points sit where the bank resolves the predictions, which is on the
//! slow parts of the record: there a short deep flat and a long shallow one that end at the
//! same place give the same pad forces (docs/decisions.md, "Cells in a stretched metric").
//! What tells them apart is how high the impact spikes reach, and a spike's sampled value
//! moves with the impact position by more than a threshold per millimetre. The maximum (and
//! the minimum) of the series over a short window moves far less: the spike stays inside the
//! window when the impact moves by a few millimetres.
//!
//! For each sensor the windows are centred on the `k` samples where the measurement departs
//! most from the bank's flat-free signature, at least `2w + 1` samples apart. At each window
//! the feature `max_{|j| ≤ w} f(t + j)` (and the same with `min`) of the measurement and of
//! every instance is a comparison point like any other: the thresholds of the measured
//! feature (the prediction's own where it is larger), the instance's cell widening from its
//! neighbours' features. The window's maximum moves by no more than the largest error of its
//! samples, so a feature holds the truth whenever its samples do.

use crate::identify::domain::falsify::Point;
use crate::identify::domain::uncertainty::ThresholdCurve;
use crate::identify::input::measurement::MeasuredSeries;
use serde::{Deserialize, Serialize};

/// Which extreme of its window an envelope point compares. Written as `max` or `min`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Extreme {
    /// The window's maximum.
    Max,
    /// The window's minimum.
    Min,
}

impl std::fmt::Display for Extreme {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.pad(match self {
            Extreme::Max => "max",
            Extreme::Min => "min",
        })
    }
}

/// One envelope comparison point, as reported.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EnvelopePoint {
    /// Index into the identification's measured series.
    pub series: usize,
    /// Centre sample of the window.
    pub sample: usize,
    /// Half-width of the window (samples).
    pub half_width: usize,
    /// The window's maximum or minimum.
    pub kind: Extreme,
    /// The measured feature (kN).
    pub measured_kn: f64,
    /// Thresholds on feature − measured feature at the measured force (kN).
    pub threshold_low_kn: f64,
    /// Upper threshold (kN).
    pub threshold_high_kn: f64,
}

/// The window centres of every series: (series, centre sample). `template` gives each
/// series' flat-free signature on the same samples.
pub fn windows(
    series: &[MeasuredSeries],
    template: &[&[f32]],
    per_series: usize,
    half_width: usize,
) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    for (si, ser) in series.iter().enumerate() {
        let n = ser.values_kn.len().min(template[si].len());
        if per_series == 0 || n < 2 * half_width + 1 {
            continue;
        }
        let mut dev: Vec<(f64, usize)> = (half_width..n - half_width)
            .map(|k| ((ser.values_kn[k] - template[si][k] as f64).abs(), k))
            .collect();
        // Largest departure first; ties to the earlier sample (reproducible).
        dev.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        let mut chosen: Vec<usize> = Vec::with_capacity(per_series);
        for &(_, k) in &dev {
            if chosen.len() == per_series {
                break;
            }
            if chosen.iter().all(|&c| c.abs_diff(k) > 2 * half_width) {
                chosen.push(k);
            }
        }
        chosen.sort_unstable();
        out.extend(chosen.into_iter().map(|k| (si, k)));
    }
    out
}

/// The window maximum (`max = true`) or minimum of every instance, from the window's columns.
pub fn feature(columns: &[&[f32]], max: bool) -> Vec<f32> {
    let n = columns.first().map_or(0, |c| c.len());
    let mut out = columns.first().map_or_else(Vec::new, |c| c.to_vec());
    for col in &columns[1.min(columns.len())..] {
        for (o, &v) in out.iter_mut().zip(col.iter()).take(n) {
            *o = if max { o.max(v) } else { o.min(v) };
        }
    }
    out
}

/// The maximum (`max = true`) or minimum of some values.
pub fn extreme(values: impl Iterator<Item = f64>, max: bool) -> f64 {
    if max {
        values.fold(f64::NEG_INFINITY, f64::max)
    } else {
        values.fold(f64::INFINITY, f64::min)
    }
}

/// The measured feature of a window.
pub fn measured_feature(values: &[f64], centre: usize, half_width: usize, max: bool) -> f64 {
    extreme(
        values[centre - half_width..=centre + half_width]
            .iter()
            .copied(),
        max,
    )
}

/// The envelope points of a measurement with their features, thresholds and threshold curves:
/// `(reported, instance features, curves)`, two per window (max, then min). `columns` holds
/// the window's `2w + 1` bank columns, window after window; `flat_free` the bank's largest
/// flat-free force over each window, and `judge(y, ff)` the thresholds and threshold curve of
/// a point measured at `y` where the flat-free force is `ff`.
#[allow(clippy::type_complexity)]
pub fn points(
    series: &[MeasuredSeries],
    centres: &[(usize, usize)],
    half_width: usize,
    (judge, flat_free): (&dyn Fn(f64, f64) -> ((f64, f64), ThresholdCurve), &[f64]),
    columns: &[&[f32]],
) -> (Vec<EnvelopePoint>, Vec<Vec<f32>>, Vec<ThresholdCurve>) {
    let mut reported = Vec::with_capacity(2 * centres.len());
    let mut features = Vec::with_capacity(2 * centres.len());
    let mut curves = Vec::with_capacity(2 * centres.len());
    let per = 2 * half_width + 1;
    for (c, &(si, k)) in centres.iter().enumerate() {
        let cols = &columns[c * per..(c + 1) * per];
        for max in [true, false] {
            let y = measured_feature(&series[si].values_kn, k, half_width, max);
            let ((lo, hi), curve) = judge(y, flat_free[c]);
            reported.push(EnvelopePoint {
                series: si,
                sample: k,
                half_width,
                kind: if max { Extreme::Max } else { Extreme::Min },
                measured_kn: y,
                threshold_low_kn: lo,
                threshold_high_kn: hi,
            });
            features.push(feature(cols, max));
            curves.push(curve);
        }
    }
    (reported, features, curves)
}

/// Falsification points of the envelope (borrowing the features and curves).
pub fn as_points<'a>(
    reported: &[EnvelopePoint],
    features: &'a [Vec<f32>],
    curves: &'a [ThresholdCurve],
) -> Vec<Point<'a>> {
    reported
        .iter()
        .zip(features.iter().zip(curves))
        .map(|(r, (f, c))| Point {
            predictions: f,
            measured_kn: r.measured_kn,
            low_kn: r.threshold_low_kn,
            high_kn: r.threshold_high_kn,
            curve: Some(c),
            discretisation: None,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series(v: Vec<f64>) -> MeasuredSeries {
        MeasuredSeries {
            sensor: "rps1".into(),
            t0_s: 0.0,
            sample_rate_hz: 2500.0,
            values_kn: v,
        }
    }

    #[test]
    fn windows_sit_on_the_largest_departures_and_do_not_overlap() {
        let tpl = vec![10.0f32; 40];
        let mut v = vec![10.0; 40];
        v[12] = 30.0; // the largest spike
        v[13] = 25.0; // inside its window: not a window of its own
        v[30] = 2.0; // a dip
        v[5] = 14.0;
        let s = [series(v)];
        assert_eq!(windows(&s, &[&tpl], 3, 2), vec![(0, 5), (0, 12), (0, 30)]);
        assert_eq!(windows(&s, &[&tpl], 2, 2), vec![(0, 12), (0, 30)]);
        assert!(windows(&s, &[&tpl], 0, 2).is_empty());
    }

    #[test]
    fn features_are_the_window_extremes_of_every_instance() {
        let a = [1.0f32, 5.0, -2.0];
        let b = [3.0f32, 4.0, -1.0];
        let c = [2.0f32, 6.0, -3.0];
        let cols: Vec<&[f32]> = vec![&a, &b, &c];
        assert_eq!(feature(&cols, true), vec![3.0, 6.0, -1.0]);
        assert_eq!(feature(&cols, false), vec![1.0, 4.0, -3.0]);
        let y = [0.0, 1.0, 7.0, 2.0, 0.5];
        // The extremes are samples of the window, returned exactly.
        assert_eq!(measured_feature(&y, 2, 2, true).to_bits(), 7.0f64.to_bits());
        assert_eq!(
            measured_feature(&y, 2, 1, false).to_bits(),
            1.0f64.to_bits()
        );
    }

    #[test]
    fn a_window_maximum_stays_within_the_thresholds_its_samples_stay_within() {
        // The dilation bound the envelope relies on: if every sample of the measurement lies
        // within [g + lo, g + hi] of the prediction, so does the window's maximum and minimum.
        let mut state = 3u64;
        for _ in 0..200 {
            let g: Vec<f64> = (0..5)
                .map(|_| 50.0 * crate::bank::population::uniform(&mut state))
                .collect();
            let (lo, hi) = (-2.0, 1.5);
            let y: Vec<f64> = g
                .iter()
                .map(|v| v - hi + (hi - lo) * crate::bank::population::uniform(&mut state))
                .collect();
            for max in [true, false] {
                let (fy, fg) = (
                    measured_feature(&y, 2, 2, max),
                    measured_feature(&g, 2, 2, max),
                );
                assert!(fg - fy >= lo - 1e-12 && fg - fy <= hi + 1e-12);
            }
        }
    }
}
