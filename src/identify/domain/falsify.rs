//! Error-domain model falsification (paper §2.2, docs/model.md §8) and the paper's baselines.
//!
//! An instance survives only if `T_low,i ≤ g_i(θ) − y_i ≤ T_high,i` at every comparison point
//! i; the survivors are the candidate model set (CMS).

use crate::identify::domain::cells::Cells;
use crate::identify::domain::uncertainty::{uniform, ThresholdCurve};
use rayon::prelude::*;

/// One comparison point: the bank's predictions there, the measurement and the thresholds.
#[derive(Debug, Clone, Copy)]
pub struct Point<'a> {
    /// Predictions of every instance (kN).
    pub predictions: &'a [f32],
    /// Measured force (kN).
    pub measured_kn: f64,
    /// Lower threshold on prediction − measurement (kN).
    pub low_kn: f64,
    /// Upper threshold (kN).
    pub high_kn: f64,
    /// The thresholds at a prediction's own force, for predictions larger than the
    /// measurement (`None`: the measured force's thresholds for every instance).
    pub curve: Option<&'a ThresholdCurve>,
    /// The bank mesh's discretisation error allowed at the point (None: none).
    pub discretisation: Option<Discretisation<'a>>,
}

/// The bank mesh's discretisation error at one point (docs/identification.md,
/// "Discretisation error"): against a converged reference, the error around a landing impact
/// is a shift in time of a steep front, bounded by a share of the prediction's step between
/// adjacent samples there. Instance `k`'s band is widened by `shares[k] · steps[k]`.
#[derive(Debug, Clone, Copy)]
pub struct Discretisation<'a> {
    /// Each instance's share (0 for a flat that keeps contact).
    pub shares: &'a [f32],
    /// Each instance's largest step between adjacent samples the point reads, one sample
    /// either side included (kN).
    pub steps: &'a [f32],
}

impl<'a> Discretisation<'a> {
    /// The allowance of point `j` from per-point `steps`, when there are `shares`.
    pub fn of(shares: Option<&'a [f32]>, steps: &'a [Vec<f32>], j: usize) -> Option<Self> {
        shares.map(|shares| Discretisation {
            shares,
            steps: &steps[j],
        })
    }

    /// Instance `k`'s allowance (kN).
    #[inline]
    pub fn allowance(&self, k: usize) -> f64 {
        self.shares[k] as f64 * self.steps[k] as f64
    }
}

/// The largest step between adjacent values of one series' consecutive samples (0 for fewer
/// than two): one instance's step, as [`steps`] gives it for every instance at once.
pub fn largest_step(values: impl IntoIterator<Item = f32>) -> f32 {
    let mut it = values.into_iter();
    let Some(mut prev) = it.next() else {
        return 0.0;
    };
    it.fold(0.0f32, |m, v| {
        let d = (v - prev).abs();
        prev = v;
        m.max(d)
    })
}

/// Each instance's largest step between adjacent columns of `columns` (consecutive samples).
pub fn steps(columns: &[&[f32]]) -> Vec<f32> {
    let n = columns.first().map_or(0, |c| c.len());
    let mut out = vec![0.0f32; n];
    for pair in columns.windows(2) {
        for ((o, a), b) in out.iter_mut().zip(pair[0]).zip(pair[1]) {
            *o = o.max((b - a).abs());
        }
    }
    out
}

/// The bank's resolution as used by falsification (see [`crate::identify::domain::cells`]): instance i passes a
/// point when the measured value lies within the thresholds widened by `κ·spread_i`, the
/// largest prediction difference to a neighbour times κ.
#[derive(Debug, Clone, Copy)]
pub struct Resolution<'a> {
    /// The neighbour graph.
    pub cells: &'a Cells,
    /// κ: 0.5 is half-way to the farthest neighbour, about the edge of the instance's cell.
    pub kappa: f64,
}

/// Whether instance `k` passes point `p` (bounds already shifted by the measurement).
#[inline]
fn passes(p: &Point, lo: f64, hi: f64, k: usize, res: Option<Resolution>) -> bool {
    let g = p.predictions[k] as f64;
    if g >= lo && g <= hi {
        return true;
    }
    // Model errors are fractions of the predicted force: a prediction larger than the
    // measurement is judged with the thresholds at its own force (wider).
    let (lo, hi) = match p.curve {
        Some(c) if g.abs() > p.measured_kn.abs() => {
            let (l, h) = c.at(g);
            (p.measured_kn + l, p.measured_kn + h)
        }
        _ => (lo, hi),
    };
    if g >= lo && g <= hi {
        return true;
    }
    // The bank mesh's own error at a landing's steep front (a bounded source added to the band).
    let need =
        if g > hi { g - hi } else { lo - g } - p.discretisation.map_or(0.0, |d| d.allowance(k));
    if need <= 0.0 {
        return true;
    }
    // The neighbours cost K gathers: only looked at where the plain test fails, and only
    // until one differs by enough (|g_j − g_k| ≥ distance to the band / κ).
    res.is_some_and(|r| r.kappa > 0.0 && r.cells.spread_reaches(p.predictions, k, need / r.kappa))
}

/// Instances that no point falsifies (indices into the prediction vectors).
pub fn falsify(points: &[Point], res: Option<Resolution>) -> Vec<u32> {
    let n = points.first().map_or(0, |p| p.predictions.len());
    // Check the points one at a time over shrinking survivor lists: most instances fall at the
    // first points, and each pass reads one contiguous column.
    let mut alive: Vec<u32> = (0..n as u32).collect();
    for p in points {
        let (lo, hi) = (p.measured_kn + p.low_kn, p.measured_kn + p.high_kn);
        if alive.len() > 8192 {
            // Large lists in parallel (order kept); the neighbour gathers dominate.
            alive = alive
                .par_iter()
                .copied()
                .filter(|&k| passes(p, lo, hi, k as usize, res))
                .collect();
        } else {
            alive.retain(|&k| passes(p, lo, hi, k as usize, res));
        }
        if alive.is_empty() {
            break;
        }
    }
    alive
}

/// Number of survivors only (no allocation per instance; for the random-subset baseline).
pub fn survivors_count(points: &[Point], res: Option<Resolution>) -> usize {
    let n = points.first().map_or(0, |p| p.predictions.len());
    let bounds: Vec<(f64, f64)> = points
        .iter()
        .map(|p| (p.measured_kn + p.low_kn, p.measured_kn + p.high_kn))
        .collect();
    (0..n)
        .filter(|&k| {
            points
                .iter()
                .zip(&bounds)
                .all(|(p, &(lo, hi))| passes(p, lo, hi, k, res))
        })
        .count()
}

/// Residual minimisation without uncertainties (paper §4.4): the instance minimising
/// `sqrt(Σ (g_i − y_i)²)` over the points. Ties go to the lowest instance.
pub fn residual_minimisation(points: &[Point]) -> usize {
    let n = points.first().map_or(0, |p| p.predictions.len());
    (0..n)
        .map(|k| {
            let r: f64 = points
                .iter()
                .map(|p| (p.predictions[k] as f64 - p.measured_kn).powi(2))
                .sum();
            (k, r)
        })
        .fold(
            (0, f64::MAX),
            |(bk, br), (k, r)| if r < br { (k, r) } else { (bk, br) },
        )
        .0
}

/// CMS sizes for `subsets` random subsets of `size` points drawn from `points` (paper §4.5),
/// seeded; subsets run in parallel, results in draw order.
pub fn random_subset_counts(
    points: &[Point],
    size: usize,
    subsets: usize,
    seed: u64,
    res: Option<Resolution>,
) -> Vec<usize> {
    let mut state = seed ^ 0x00AB_CDEF_1234_5678;
    let draws: Vec<Vec<usize>> = (0..subsets)
        .map(|_| {
            // Partial Fisher–Yates.
            let mut idx: Vec<usize> = (0..points.len()).collect();
            for i in 0..size.min(points.len()) {
                let j = i + (uniform(&mut state) * (points.len() - i) as f64) as usize;
                idx.swap(i, j.min(points.len() - 1));
            }
            idx.truncate(size.min(points.len()));
            idx
        })
        .collect();
    draws
        .par_iter()
        .map(|d| {
            let chosen: Vec<Point> = d.iter().map(|&i| points[i]).collect();
            survivors_count(&chosen, res)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn falsification_keeps_exactly_the_instances_inside_every_band() {
        let a = [1.0f32, 2.0, 3.0, 4.0];
        let b = [10.0f32, 20.0, 20.5, 30.0];
        let pts = [
            Point {
                predictions: &a,
                measured_kn: 2.5,
                low_kn: -1.0,
                high_kn: 1.0,
                curve: None,
                discretisation: None,
            },
            Point {
                predictions: &b,
                measured_kn: 20.0,
                low_kn: -0.2,
                high_kn: 0.6,
                curve: None,
                discretisation: None,
            },
        ];
        assert_eq!(falsify(&pts, None), vec![1, 2]);
        assert_eq!(survivors_count(&pts, None), 2);
        assert_eq!(residual_minimisation(&pts), 1);
    }

    #[test]
    fn resolution_widens_each_instance_by_its_own_neighbour_spread() {
        use crate::identify::domain::cells::Cells;
        // Four instances on a line in L; the predictions jump between instances 1 and 2.
        let unit: Vec<[f64; 4]> = (0..4).map(|i| [i as f64 / 3.0, 0.5, 0.5, 0.5]).collect();
        let cells = Cells::from_points(&unit, &unit);
        let g = [0.0f32, 0.0, 8.0, 8.0];
        let pts = [Point {
            predictions: &g,
            measured_kn: 5.0,
            low_kn: -1.0,
            high_kn: 1.0,
            curve: None,
            discretisation: None,
        }];
        assert!(falsify(&pts, None).is_empty(), "nothing within ±1 kN of 5");
        // With four instances everyone neighbours everyone, so every spread is 8 kN.
        let res = Resolution {
            cells: &cells,
            kappa: 0.5,
        };
        // Widening 4 kN: the band [4, 6] becomes [0, 10] and holds every instance.
        assert_eq!(falsify(&pts, Some(res)), vec![0, 1, 2, 3]);
        let tight = Resolution {
            cells: &cells,
            kappa: 0.25,
        };
        // Widening 2 kN: band [2, 8] holds the 8 kN instances only.
        assert_eq!(falsify(&pts, Some(tight)), vec![2, 3]);
        assert_eq!(survivors_count(&pts, Some(tight)), 2);
    }

    #[test]
    fn a_prediction_above_the_measurement_is_judged_at_its_own_force() {
        use crate::identify::domain::uncertainty::CombinedUncertainty;
        use crate::model::calibration::IdentificationParams;
        let cu = CombinedUncertainty::new(&IdentificationParams::default());
        let (y, p) = (10.0, 0.999);
        let (lo, hi) = cu.thresholds(y, p);
        let curve = cu.curve(y, p);
        // Just above the measured force's band, but inside the band at its own force; far
        // above both; below the band (judged at the measured force, as before).
        let g = [
            (y + hi + 0.3) as f32,
            (3.0 * y) as f32,
            (y + lo - 0.1) as f32,
        ];
        assert!(y + hi + 0.3 - y <= curve.at(y + hi + 0.3).1);
        let point = |curve| Point {
            predictions: &g,
            measured_kn: y,
            low_kn: lo,
            high_kn: hi,
            curve,
            discretisation: None,
        };
        assert!(falsify(&[point(None)], None).is_empty());
        assert_eq!(falsify(&[point(Some(&curve))], None), vec![0]);
    }

    #[test]
    fn the_discretisation_allowance_widens_by_each_instance_share_of_its_step() {
        // Three instances 2 kN above the band's top; steps 1, 4 and 8 kN; shares 0.5, 0.5, 0.
        let g = [12.0f32, 12.0, 12.0];
        let prev = [11.0f32, 8.0, 4.0];
        let steps = steps(&[&prev, &g]);
        assert_eq!(steps, vec![1.0, 4.0, 8.0]);
        assert!((largest_step([11.0, 12.0, 8.0, 8.5]) - 4.0).abs() < 1e-6);
        assert!(largest_step([3.0]).abs() < 1e-6, "one value has no step");
        let shares = [0.5f32, 0.5, 0.0];
        let point = |d| Point {
            predictions: &g,
            measured_kn: 5.0,
            low_kn: -5.0,
            high_kn: 5.0,
            curve: None,
            discretisation: d,
        };
        assert!(falsify(&[point(None)], None).is_empty());
        let d = Discretisation {
            shares: &shares,
            steps: &steps,
        };
        // 0.5 kN and 2 kN of allowance: only the second reaches the 2 kN; the third has none.
        assert_eq!(falsify(&[point(Some(d))], None), vec![1]);
    }

    #[test]
    fn random_subsets_are_reproducible() {
        let cols: Vec<Vec<f32>> = (0..10)
            .map(|i| (0..100).map(|k| ((k * (i + 3)) % 17) as f32).collect())
            .collect();
        let pts: Vec<Point> = cols
            .iter()
            .map(|c| Point {
                predictions: c,
                measured_kn: 8.0,
                low_kn: -4.0,
                high_kn: 4.0,
                curve: None,
                discretisation: None,
            })
            .collect();
        let a = random_subset_counts(&pts, 3, 50, 7, None);
        assert_eq!(a, random_subset_counts(&pts, 3, 50, 7, None));
        assert_eq!(a.len(), 50);
    }
}
