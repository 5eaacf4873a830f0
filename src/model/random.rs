//! The seeded random stream every part of wheelflat draws from: the population shift, the
//! uncertainty Monte Carlo, the random subsets, synthetic errors and synthetic roughness.

/// SplitMix64: one step of the stream `state`.
pub(crate) fn splitmix64(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// An index below `n` from [`splitmix64`] (a bootstrap's resample of `n` items).
pub(crate) fn index(state: &mut u64, n: usize) -> usize {
    (splitmix64(state) % n as u64) as usize
}

/// Uniform [0, 1) with 53 random bits from [`splitmix64`].
pub(crate) fn uniform(state: &mut u64) -> f64 {
    (splitmix64(state) >> 11) as f64 / (1u64 << 53) as f64
}

/// A standard normal draw (Box–Muller on two uniforms; the second of the pair is discarded,
/// so each call consumes exactly two draws of the stream).
pub(crate) fn gaussian(state: &mut u64) -> f64 {
    let u1 = uniform(state).max(1e-300);
    let u2 = uniform(state);
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaussian_draws_have_unit_variance_and_zero_mean() {
        // 200,000 draws: mean within 4 standard errors (4/√n ≈ 0.009), variance within 2 %.
        let mut s = 7u64;
        let n = 200_000;
        let draws: Vec<f64> = (0..n).map(|_| gaussian(&mut s)).collect();
        let mean = draws.iter().sum::<f64>() / n as f64;
        let var = draws.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / n as f64;
        assert!(mean.abs() < 0.009, "{mean}");
        assert!((var - 1.0).abs() < 0.02, "{var}");
    }
}
