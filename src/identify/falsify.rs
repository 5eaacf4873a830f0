//! Error-domain model falsification (paper §2.2, MODEL.md §8) and the paper's baselines.
//!
//! An instance survives only if `T_low,i ≤ g_i(θ) − y_i ≤ T_high,i` at every comparison point
//! i; the survivors are the candidate model set (CMS).

use super::uncertainty::uniform;
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
}

/// Instances that no point falsifies (indices into the prediction vectors).
pub fn falsify(points: &[Point]) -> Vec<u32> {
    let n = points.first().map_or(0, |p| p.predictions.len());
    // Check the points one at a time over shrinking survivor lists: most instances fall at the
    // first points, and each pass reads one contiguous column.
    let mut alive: Vec<u32> = (0..n as u32).collect();
    for p in points {
        let (lo, hi) = (p.measured_kn + p.low_kn, p.measured_kn + p.high_kn);
        alive.retain(|&k| {
            let g = p.predictions[k as usize] as f64;
            g >= lo && g <= hi
        });
        if alive.is_empty() {
            break;
        }
    }
    alive
}

/// Number of survivors only (no allocation per instance; for the random-subset baseline).
pub fn survivors_count(points: &[Point]) -> usize {
    let n = points.first().map_or(0, |p| p.predictions.len());
    let bounds: Vec<(f64, f64)> = points
        .iter()
        .map(|p| (p.measured_kn + p.low_kn, p.measured_kn + p.high_kn))
        .collect();
    (0..n)
        .filter(|&k| {
            points.iter().zip(&bounds).all(|(p, &(lo, hi))| {
                let g = p.predictions[k] as f64;
                g >= lo && g <= hi
            })
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
            survivors_count(&chosen)
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
            },
            Point {
                predictions: &b,
                measured_kn: 20.0,
                low_kn: -0.2,
                high_kn: 0.6,
            },
        ];
        assert_eq!(falsify(&pts), vec![1, 2]);
        assert_eq!(survivors_count(&pts), 2);
        assert_eq!(residual_minimisation(&pts), 1);
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
            })
            .collect();
        let a = random_subset_counts(&pts, 3, 50, 7);
        assert_eq!(a, random_subset_counts(&pts, 3, 50, 7));
        assert_eq!(a.len(), 50);
    }
}
