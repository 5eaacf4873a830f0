//! Perceptually important points (PIP), top-down (paper §3.1; Chung et al.): start with the
//! first and last points, then repeatedly add the point farthest from the line joining its
//! two neighbouring PIPs.

pub(crate) use crate::model::calibration::PipDistance;

/// A candidate comparison point: a PIP of one measured series.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Candidate {
    /// The series (index into the pass's measured series).
    pub(crate) series: usize,
    /// Its sample on the bank's window.
    pub(crate) sample: usize,
    /// Its order among the series' PIPs (0: the first found).
    pub(crate) order: usize,
}

/// Indices of the `j` most important points of `y`, in the order found (first two: the ends).
pub(crate) fn perceptually_important_points(
    y: &[f64],
    j: usize,
    distance: PipDistance,
) -> Vec<usize> {
    let n = y.len();
    if n == 0 {
        return Vec::new();
    }
    let j = j.min(n);
    let (lo, hi) = y
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    let sy = if hi > lo { 1.0 / (hi - lo) } else { 1.0 };
    let sx = if n > 1 { 1.0 / (n - 1) as f64 } else { 1.0 };
    let mut chosen = vec![0];
    if j >= 2 && n >= 2 {
        chosen.push(n - 1);
    }
    let mut is_pip = vec![false; n];
    for &c in &chosen {
        is_pip[c] = true;
    }
    while chosen.len() < j {
        // Scan the gaps between consecutive PIPs.
        let mut best: Option<(usize, f64)> = None;
        let mut left = 0;
        for right in 1..n {
            if !is_pip[right] {
                continue;
            }
            let (x1, y1, x2, y2) = (left as f64, y[left], right as f64, y[right]);
            let slope = (y2 - y1) / (x2 - x1);
            for (k, &yk) in y.iter().enumerate().take(right).skip(left + 1) {
                let xk = k as f64;
                let d = match distance {
                    PipDistance::Vertical => (yk - (y1 + slope * (xk - x1))).abs(),
                    PipDistance::Perpendicular => {
                        let (dx, dy) = ((x2 - x1) * sx, (y2 - y1) * sy);
                        let (px, py) = ((xk - x1) * sx, (yk - y1) * sy);
                        (dx * py - dy * px).abs() / (dx * dx + dy * dy).sqrt()
                    }
                    PipDistance::Euclidean => {
                        let d1 = (((xk - x1) * sx).powi(2) + ((yk - y1) * sy).powi(2)).sqrt();
                        let d2 = (((x2 - xk) * sx).powi(2) + ((y2 - yk) * sy).powi(2)).sqrt();
                        d1 + d2
                    }
                };
                if best.is_none_or(|(_, b)| d > b) {
                    best = Some((k, d));
                }
            }
            left = right;
        }
        let Some((k, _)) = best else { break };
        is_pip[k] = true;
        chosen.push(k);
    }
    chosen
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_triangle_is_found_by_its_apex() {
        let y: Vec<f64> = (0..101).map(|i| 50.0 - (i as f64 - 50.0).abs()).collect();
        for d in [
            PipDistance::Vertical,
            PipDistance::Perpendicular,
            PipDistance::Euclidean,
        ] {
            let p = perceptually_important_points(&y, 3, d);
            assert_eq!(p, vec![0, 100, 50], "{d:?}");
        }
    }

    #[test]
    fn points_are_distinct_and_peaks_come_early() {
        let y: Vec<f64> = (0..400)
            .map(|i| {
                let t = i as f64;
                20.0 * (-((t - 120.0) / 15.0).powi(2)).exp()
                    + 45.0 * (-((t - 300.0) / 5.0).powi(2)).exp()
            })
            .collect();
        let p = perceptually_important_points(&y, 30, PipDistance::Vertical);
        assert_eq!(p.len(), 30);
        let mut s = p.clone();
        s.sort_unstable();
        s.dedup();
        assert_eq!(s.len(), 30);
        assert_eq!(p[2], 300, "the tallest peak is the first interior PIP");
        assert!(p[..6].contains(&120));
    }

    #[test]
    fn short_series_give_at_most_their_length() {
        assert_eq!(
            perceptually_important_points(&[1.0, 2.0], 30, PipDistance::Vertical),
            vec![0, 1]
        );
        assert!(perceptually_important_points(&[], 5, PipDistance::Vertical).is_empty());
    }
}
