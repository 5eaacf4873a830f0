//! The short centred average a rough pass is compared through, and the high-frequency part it
//! leaves out (docs/detection.md, "Rough wheels").
//!
//! A rough tread or rail moves the pad forces most at high frequency: a pass judged as rough
//! compares the measurement and the bank's predictions through the 5-sample binomial average
//! `B₅x_k = (x_{k−2} + 4x_{k−1} + 6x_k + 4x_{k+1} + x_{k+2})/16` (its response `cos⁴(πf/f_s)`:
//! 0.82 at 250 Hz, 0.43 at 500 Hz, 0.009 at 1 kHz for 2.5 kHz sampling), and the record's
//! high-frequency part `x − B₅x` tells how rough its treads are.

/// The 5-sample binomial weights.
pub const BINOMIAL5: [f64; 5] = [0.0625, 0.25, 0.375, 0.25, 0.0625];

/// The centred average of `x` with `weights` (odd length `2h + 1`), renormalised over the
/// samples that exist within `h` of either end.
pub fn centred_average(x: &[f64], weights: &[f64]) -> Vec<f64> {
    let h = weights.len() / 2;
    if h == 0 || x.is_empty() {
        return x.to_vec();
    }
    let n = x.len();
    (0..n)
        .map(|k| {
            let (mut sum, mut total) = (0.0, 0.0);
            for (j, &w) in weights.iter().enumerate() {
                if let Some(i) = (k + j).checked_sub(h).filter(|&i| i < n) {
                    sum += w * x[i];
                    total += w;
                }
            }
            sum / total
        })
        .collect()
}

/// The weights of [`centred_average`] at sample `k` of a series of `n`: `(first sample,
/// weights renormalised over the samples that exist)`.
pub fn weights_at(k: usize, n: usize, weights: &[f64]) -> (usize, Vec<f64>) {
    let h = weights.len() / 2;
    let first = k.saturating_sub(h);
    let last = (k + h).min(n.saturating_sub(1));
    let w: Vec<f64> = (first..=last).map(|i| weights[i + h - k]).collect();
    let total: f64 = w.iter().sum();
    (first, w.into_iter().map(|x| x / total).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_average_keeps_a_line_and_its_weights_sum_to_one() {
        // A straight line is its own average inside, and at either end where the renormalised
        // weights lean inwards the average is a point of the line further in.
        let x: Vec<f64> = (0..10).map(|k| 2.0 + 0.5 * k as f64).collect();
        let a = centred_average(&x, &BINOMIAL5);
        for k in 2..8 {
            assert!((a[k] - x[k]).abs() < 1e-12);
        }
        assert!((BINOMIAL5.iter().sum::<f64>() - 1.0).abs() < 1e-15);
        // A sinusoid at 500 Hz sampled at 2.5 kHz keeps cos⁴(π/5) = 0.428 of its amplitude.
        let s: Vec<f64> = (0..100)
            .map(|k| (std::f64::consts::TAU * 500.0 * k as f64 / 2500.0).cos())
            .collect();
        let a = centred_average(&s, &BINOMIAL5);
        let amp = a[10..90].iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let expected = (std::f64::consts::PI / 5.0).cos().powi(4);
        assert!((amp - expected).abs() < 1e-9, "{amp} vs {expected}");
        // The weights at a sample are the ones the average used there.
        for k in [0, 1, 5, 9] {
            let (first, w) = weights_at(k, 10, &BINOMIAL5);
            let v: f64 = w.iter().enumerate().map(|(j, w)| w * x[first + j]).sum();
            assert!((v - centred_average(&x, &BINOMIAL5)[k]).abs() < 1e-12);
        }
    }
}
