//! The residual of a site's passes against the good wheel (`super::fit`): each sensor's
//! amplitude profiled out, sums of squares per pass, the normal equations, and the rule that
//! keeps a void.

use super::passes::SitePass;
use nalgebra::{DMatrix, DVector};

/// Standard errors by which the passes' mean drop in the sum of squares must clear zero for
/// a void to be kept.
pub const VOID_T: f64 = 4.0;

/// The residual of every pass against its load bin's good wheel.
pub(super) struct Evaluation {
    /// Concatenated residuals (kN), pass after pass, sensor after sensor.
    pub(super) residual: Vec<f64>,
    /// Each pass's range in `residual`.
    pub(super) ranges: Vec<std::ops::Range<usize>>,
    /// Per pass, per sensor, the amplitude.
    pub(super) amplitudes: Vec<Vec<f64>>,
    /// Sum of squares.
    pub(super) sse: f64,
}

pub(super) fn evaluate<'t>(
    passes: &[SitePass],
    bins: &[i64],
    template: impl Fn(i64) -> &'t Vec<Vec<f64>>,
) -> Evaluation {
    let mut residual = Vec::new();
    let mut ranges = Vec::with_capacity(passes.len());
    let mut amps = Vec::with_capacity(passes.len());
    for (p, &b) in passes.iter().zip(bins) {
        let g = template(b);
        let a = amplitudes(&p.series_kn, g);
        let from = residual.len();
        for ((y, g), c) in p.series_kn.iter().zip(g).zip(&a) {
            residual.extend(y.iter().zip(g).map(|(y, g)| y - c * g));
        }
        ranges.push(from..residual.len());
        amps.push(a);
    }
    let sse = residual.iter().map(|r| r * r).sum();
    Evaluation {
        residual,
        ranges,
        amplitudes: amps,
        sse,
    }
}

/// The sorted distinct values of `bins`.
pub(super) fn distinct(bins: &[i64]) -> Vec<i64> {
    let mut d = bins.to_vec();
    d.sort_unstable();
    d.dedup();
    d
}

/// Whether `after` fits the passes better than `before`: the mean of the per-pass drops in
/// the sum of squares at least [`VOID_T`] standard errors above zero.
pub(super) fn clearly_better(before: &Evaluation, after: &Evaluation) -> bool {
    let sse = |e: &Evaluation, r: &std::ops::Range<usize>| -> f64 {
        e.residual[r.clone()].iter().map(|x| x * x).sum()
    };
    let drops: Vec<f64> = before
        .ranges
        .iter()
        .zip(&after.ranges)
        .map(|(a, b)| sse(before, a) - sse(after, b))
        .collect();
    let n = drops.len() as f64;
    let mean = drops.iter().sum::<f64>() / n;
    let var = drops.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    mean > 0.0 && mean > VOID_T * (var / n).sqrt()
}

/// The sum of squares of `y` less each sensor's fitted amplitude of `g`.
pub(super) fn pass_sse(y: &[Vec<f64>], g: &[Vec<f64>]) -> f64 {
    y.iter()
        .zip(g)
        .zip(amplitudes(y, g))
        .map(|((y, g), c)| {
            y.iter()
                .zip(g)
                .map(|(y, g)| (y - c * g).powi(2))
                .sum::<f64>()
        })
        .sum()
}

/// Per sensor, the least-squares amplitude of `g` in `y`.
pub fn amplitudes(y: &[Vec<f64>], g: &[Vec<f64>]) -> Vec<f64> {
    y.iter()
        .zip(g)
        .map(|(y, g)| {
            let (yg, gg) = y
                .iter()
                .zip(g)
                .fold((0.0, 0.0), |(a, b), (y, g)| (a + y * g, b + g * g));
            if gg > 0.0 {
                yg / gg
            } else {
                0.0
            }
        })
        .collect()
}

/// `JᵀJ` and `Jᵀr` over the residual's rows `rows`.
pub(super) fn normal_equations(
    jac: &[Vec<f64>],
    r: &[f64],
    rows: std::ops::Range<usize>,
) -> (DMatrix<f64>, DVector<f64>) {
    let n = jac.len();
    let mut a = DMatrix::zeros(n, n);
    let mut g = DVector::zeros(n);
    for i in 0..n {
        g[i] = jac[i][rows.clone()]
            .iter()
            .zip(&r[rows.clone()])
            .map(|(x, y)| x * y)
            .sum();
        for j in i..n {
            let v: f64 = jac[i][rows.clone()]
                .iter()
                .zip(&jac[j][rows.clone()])
                .map(|(x, y)| x * y)
                .sum();
            a[(i, j)] = v;
            a[(j, i)] = v;
        }
    }
    (a, g)
}
