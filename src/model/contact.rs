//! Nonlinear Hertz wheel–rail contact (docs/model.md §4) and the per-step contact solve.

/// Hertz law `F = C_H·δ^1.5` for `δ > 0`, `F = 0` otherwise (loss of contact).
#[inline]
pub(crate) fn hertz_force(c_h: f64, delta_m: f64) -> f64 {
    if delta_m > 0.0 {
        c_h * delta_m * delta_m.sqrt()
    } else {
        0.0
    }
}

/// Static compression under force `F`: `δ = (F/C_H)^(2/3)`.
pub(crate) fn hertz_compression(c_h: f64, force_n: f64) -> f64 {
    (force_n / c_h).powf(2.0 / 3.0)
}

/// Solves the two coupled contact equations of one implicit step:
///
/// `δ_i = δ*_i − Σ_j G_ij·F_j(δ_j)`, `F_j = C_H·max(δ_j, 0)^1.5`,
///
/// where `δ*` is the compression the step would end with if both contact forces were zero
/// and `G` is the (symmetric, positive) compliance of wheel and rail over the step.
/// Newton's method on δ; the residual is monotone and convex for δ > 0, so starting from δ*
/// (the right of the root) it converges without damping. Returns the forces.
pub(crate) fn solve_contact_pair(c_h: f64, delta_free: [f64; 2], g: [[f64; 2]; 2]) -> [f64; 2] {
    let mut d = delta_free;
    for _ in 0..60 {
        let f = [hertz_force(c_h, d[0]), hertz_force(c_h, d[1])];
        let df = [
            if d[0] > 0.0 {
                1.5 * c_h * d[0].sqrt()
            } else {
                0.0
            },
            if d[1] > 0.0 {
                1.5 * c_h * d[1].sqrt()
            } else {
                0.0
            },
        ];
        let r = [
            d[0] - delta_free[0] + g[0][0] * f[0] + g[0][1] * f[1],
            d[1] - delta_free[1] + g[1][0] * f[0] + g[1][1] * f[1],
        ];
        // Jacobian J = I + G·diag(F').
        let j00 = 1.0 + g[0][0] * df[0];
        let j01 = g[0][1] * df[1];
        let j10 = g[1][0] * df[0];
        let j11 = 1.0 + g[1][1] * df[1];
        let det = j00 * j11 - j01 * j10;
        let step = [
            (j11 * r[0] - j01 * r[1]) / det,
            (j00 * r[1] - j10 * r[0]) / det,
        ];
        d[0] -= step[0];
        d[1] -= step[1];
        let scale = delta_free[0].abs().max(delta_free[1].abs()).max(1e-12);
        if step[0].abs().max(step[1].abs()) <= 1e-13 * scale {
            break;
        }
    }
    [hertz_force(c_h, d[0]), hertz_force(c_h, d[1])]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compression_inverts_the_force_law() {
        let c_h = 8.34e10;
        for f in [1.0e3, 49.5e3, 3.0e5] {
            let d = hertz_compression(c_h, f);
            assert!((hertz_force(c_h, d) / f - 1.0).abs() < 1e-12);
        }
        assert!(hertz_force(c_h, -1e-6) == 0.0);
    }

    #[test]
    fn pair_solution_satisfies_both_equations() {
        let c_h = 8.34e10;
        let g = [[2.0e-10, 1.0e-12], [1.0e-12, 3.0e-10]];
        let free = [1.2e-4, 9.0e-5];
        let f = solve_contact_pair(c_h, free, g);
        for i in 0..2 {
            let delta = free[i] - g[i][0] * f[0] - g[i][1] * f[1];
            assert!((hertz_force(c_h, delta) - f[i]).abs() < 1e-6 * f[i].max(1.0));
        }
    }

    #[test]
    fn separated_wheel_carries_no_force() {
        let f = solve_contact_pair(8.34e10, [-1e-5, 8e-5], [[2e-10, 0.0], [0.0, 2e-10]]);
        assert!(f[0] == 0.0, "exactly zero when separated");
        assert!(f[1] > 0.0);
    }
}
