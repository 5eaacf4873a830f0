//! The paper's baselines beside the entropy-selected points (§3): random PIP subsets of the
//! same size, equidistant points (with the thresholds and cell rule of the method).

use crate::identify::answer::result::{Falsification, MeasuredSeries, Method, RandomSubsets};
use crate::identify::domain::falsify::{falsify, random_subset_counts, Point};
use crate::identify::domain::uncertainty::ThresholdCurve;
use crate::identify::error::IdentifyError;
use crate::identify::identifier::Identifier;

impl Identifier {
    /// CMS sizes of the settings' random subsets of `m` points drawn from `all_points`: the
    /// summary and its row of the comparison table.
    pub(in crate::identify) fn random_subsets(
        &self,
        all_points: &[Point],
        m: usize,
    ) -> (RandomSubsets, Falsification) {
        let s = &self.settings;
        let counts =
            random_subset_counts(all_points, m, s.random_subsets, s.seed, self.resolution());
        let mut sorted = counts.clone();
        sorted.sort_unstable();
        let median = if sorted.is_empty() {
            0.0
        } else if sorted.len() % 2 == 1 {
            sorted[sorted.len() / 2] as f64
        } else {
            (sorted[sorted.len() / 2 - 1] + sorted[sorted.len() / 2]) as f64 / 2.0
        };
        let mean = counts.iter().sum::<usize>() as f64 / counts.len().max(1) as f64;
        let row = Falsification {
            method: Method::RandomSubsets {
                subsets: s.random_subsets,
            },
            points: m,
            cms_count: mean.round() as usize,
            ranges: None,
        };
        let summary = RandomSubsets {
            subsets: counts.len(),
            size: m,
            cms_counts: counts,
            mean,
            median,
            seed: s.seed,
        };
        (summary, row)
    }

    /// Falsification at `m` points spread evenly over the series (bank axes `used`), equally
    /// spaced in each, with the thresholds at per-point probability `p` of a pass judged with
    /// `roughness`.
    pub(in crate::identify) fn equidistant(
        &self,
        series: &[MeasuredSeries],
        used: &[(usize, usize)],
        m: usize,
        (p, roughness): (f64, &crate::identify::detect::roughness::RoughnessUse),
    ) -> Result<Falsification, IdentifyError> {
        let mut eq: Vec<(usize, usize)> = Vec::new();
        for (si, ser) in series.iter().enumerate() {
            let share = m / series.len() + usize::from(si < m % series.len());
            let len = ser.values_kn.len();
            for j in 0..share {
                eq.push((si, ((j as f64 + 0.5) * len as f64 / share as f64) as usize));
            }
        }
        let c = roughness.comparison();
        let points: Vec<(usize, usize)> = eq.iter().map(|&(si, k)| (used[si].1, k)).collect();
        let n = self.bank.instances();
        let mut flat = vec![0.0f32; points.len() * n];
        self.read_compared(&points, c, &mut flat)?;
        let eq_pred: Vec<&[f32]> = flat.chunks(n.max(1)).collect();
        let flat_free: Vec<f64> = points
            .iter()
            .map(|&(a, k)| f64::from(self.flat_free(a, c)[k]))
            .collect();
        let eq_curves: Vec<ThresholdCurve> = eq
            .iter()
            .zip(&flat_free)
            .map(|(&(si, k), &ff)| self.point_curve(roughness, series[si].values_kn[k], ff, p))
            .collect();
        let eq_points: Vec<Point> = eq
            .iter()
            .zip(eq_pred.iter().zip(eq_curves.iter().zip(&flat_free)))
            .map(|(&(si, k), (g, (curve, &ff)))| {
                let y = series[si].values_kn[k];
                let (lo, hi) = self.point_thresholds(roughness, y, ff, p);
                Point {
                    predictions: g,
                    measured_kn: y,
                    low_kn: lo,
                    high_kn: hi,
                    curve: Some(curve),
                    discretisation: None,
                }
            })
            .collect();
        let eq_cms = falsify(&eq_points, self.resolution());
        Ok(Falsification {
            method: Method::Equidistant,
            points: eq_points.len(),
            cms_count: eq_cms.len(),
            ranges: self.ranges(eq_cms.iter().map(|&k| k as usize)),
        })
    }
}
