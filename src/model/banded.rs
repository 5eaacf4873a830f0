//! Symmetric banded matrices and their LDLᵀ factorisation.
//!
//! The track matrices are banded (half-bandwidth 4 with nodes ordered along the rail and
//! each sleeper's DOF next to its rail node), and the time stepper solves with the same
//! effective matrix every step. Neither nalgebra nor faer stores band matrices: their
//! sparse Cholesky solvers go through index arrays and general supernodal structure, which
//! for a ~300-row band is several times slower per solve than this contiguous band kernel
//! (see `benches/simulate.rs`, `band_solve` vs `sparse_solve`). The kernel is checked
//! against nalgebra's dense Cholesky in the tests below.

/// A symmetric matrix stored by its lower band: `lower[i*(hb+1) + d] = A[i][i-d]`.
#[derive(Debug, Clone, PartialEq)]
pub struct BandedSym {
    n: usize,
    hb: usize,
    lower: Vec<f64>,
}

/// Errors of the band kernel.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BandError {
    /// A pivot was not positive: the matrix is not positive definite.
    #[error("matrix not positive definite: pivot {pivot:e} at row {row}")]
    NotPositiveDefinite {
        /// Row of the failing pivot.
        row: usize,
        /// Its value.
        pivot: f64,
    },
}

impl BandedSym {
    /// An `n × n` zero matrix with half-bandwidth `hb`.
    pub fn zeros(n: usize, hb: usize) -> BandedSym {
        BandedSym {
            n,
            hb,
            lower: vec![0.0; n * (hb + 1)],
        }
    }

    /// Order of the matrix.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Half-bandwidth.
    pub fn half_bandwidth(&self) -> usize {
        self.hb
    }

    /// Adds `v` to `A[i][j]` (and, by symmetry, `A[j][i]`).
    ///
    /// Panics if `(i, j)` is outside the band: that is an assembly bug.
    pub fn add(&mut self, i: usize, j: usize, v: f64) {
        let (r, c) = if i >= j { (i, j) } else { (j, i) };
        let d = r - c;
        assert!(
            d <= self.hb,
            "entry ({i},{j}) outside half-bandwidth {}",
            self.hb
        );
        self.lower[r * (self.hb + 1) + d] += v;
    }

    /// `A[i][j]`.
    pub fn get(&self, i: usize, j: usize) -> f64 {
        let (r, c) = if i >= j { (i, j) } else { (j, i) };
        let d = r - c;
        if d > self.hb {
            0.0
        } else {
            self.lower[r * (self.hb + 1) + d]
        }
    }

    /// `self + s·other` (same shape).
    pub fn add_scaled(&self, s: f64, other: &BandedSym) -> BandedSym {
        assert_eq!((self.n, self.hb), (other.n, other.hb));
        let lower = self
            .lower
            .iter()
            .zip(&other.lower)
            .map(|(a, b)| a + s * b)
            .collect();
        BandedSym {
            n: self.n,
            hb: self.hb,
            lower,
        }
    }

    /// `y = A·x`.
    pub fn mul_vec(&self, x: &[f64], y: &mut [f64]) {
        let hb = self.hb;
        for i in 0..self.n {
            let row = &self.lower[i * (hb + 1)..(i + 1) * (hb + 1)];
            let mut acc = row[0] * x[i];
            let dmax = hb.min(i);
            for d in 1..=dmax {
                acc += row[d] * x[i - d];
            }
            y[i] = acc;
        }
        for i in 0..self.n {
            let row = &self.lower[i * (hb + 1)..(i + 1) * (hb + 1)];
            let xi = x[i];
            let dmax = hb.min(i);
            for d in 1..=dmax {
                y[i - d] += row[d] * xi;
            }
        }
    }

    /// Dense copy (tests and one-off set-up only).
    pub fn to_dense(&self) -> nalgebra::DMatrix<f64> {
        nalgebra::DMatrix::from_fn(self.n, self.n, |i, j| self.get(i, j))
    }

    /// LDLᵀ factorisation (no pivoting; the matrix must be symmetric positive definite).
    pub fn factor(&self) -> Result<BandedLdl, BandError> {
        let (n, hb) = (self.n, self.hb);
        let w = hb + 1;
        let mut l = self.lower.clone(); // becomes L (unit diagonal implied) with D on the diagonal
        for i in 0..n {
            let j0 = i.saturating_sub(hb);
            for j in j0..i {
                // L[i][j] = (A[i][j] - Σ_k L[i][k] D[k] L[j][k]) / D[j],  k in max(i,j)-hb..j
                let k0 = j0.max(j.saturating_sub(hb));
                let mut s = l[i * w + (i - j)];
                for k in k0..j {
                    s -= l[i * w + (i - k)] * l[k * w] * l[j * w + (j - k)];
                }
                l[i * w + (i - j)] = s / l[j * w];
            }
            let mut d = l[i * w];
            for k in j0..i {
                let lik = l[i * w + (i - k)];
                d -= lik * lik * l[k * w];
            }
            if d.is_nan() || d <= 0.0 {
                return Err(BandError::NotPositiveDefinite { row: i, pivot: d });
            }
            l[i * w] = d;
        }
        Ok(BandedLdl::from_factors(n, hb, l))
    }
}

/// The LDLᵀ factors of a [`BandedSym`], stored for the solve: `lower[i*(hb+1)+d] = L[i][i-d]`
/// (row-wise, for forward substitution), `upper[i*(hb+1)+d] = L[i+d][i]` (the same numbers
/// column-wise, for backward substitution) and `1/D`.
#[derive(Debug, Clone)]
pub struct BandedLdl {
    n: usize,
    hb: usize,
    lower: Vec<f64>,
    upper: Vec<f64>,
    inv_d: Vec<f64>,
}

impl BandedLdl {
    fn from_factors(n: usize, hb: usize, l: Vec<f64>) -> BandedLdl {
        let w = hb + 1;
        let mut upper = vec![0.0; n * w];
        let mut inv_d = vec![0.0; n];
        for i in 0..n {
            inv_d[i] = 1.0 / l[i * w];
            for d in 1..w {
                if i + d < n {
                    upper[i * w + d] = l[(i + d) * w + d];
                }
            }
        }
        let mut lower = l;
        for i in 0..n {
            lower[i * w] = 0.0;
        }
        BandedLdl {
            n,
            hb,
            lower,
            upper,
            inv_d,
        }
    }

    /// Solves `A·x = b` in place (`x` holds `b` on entry).
    pub fn solve_in_place(&self, x: &mut [f64]) {
        assert_eq!(x.len(), self.n, "right-hand side of the wrong length");
        if self.hb == 4 {
            self.solve_hb4(x);
        } else {
            self.solve_general(x);
        }
    }

    /// The track's band (half-bandwidth 4): the last four unknowns live in registers, so each
    /// substitution is one pass without bounds checks or scattered stores. The terms are
    /// summed farthest first so that only the last product waits for the previous unknown
    /// (the substitution is latency-bound).
    fn solve_hb4(&self, x: &mut [f64]) {
        let (mut x1, mut x2, mut x3, mut x4) = (0.0, 0.0, 0.0, 0.0);
        for (xi, row) in x.iter_mut().zip(self.lower.chunks_exact(5)) {
            let far = *xi - row[4] * x4 - row[3] * x3 - row[2] * x2;
            let s = far - row[1] * x1;
            *xi = s;
            (x4, x3, x2, x1) = (x3, x2, x1, s);
        }
        let (mut x1, mut x2, mut x3, mut x4) = (0.0, 0.0, 0.0, 0.0);
        for ((xi, col), inv_d) in x
            .iter_mut()
            .zip(self.upper.chunks_exact(5))
            .zip(&self.inv_d)
            .rev()
        {
            let far = *xi * inv_d - col[4] * x4 - col[3] * x3 - col[2] * x2;
            let s = far - col[1] * x1;
            *xi = s;
            (x4, x3, x2, x1) = (x3, x2, x1, s);
        }
    }

    fn solve_general(&self, x: &mut [f64]) {
        let (n, hb) = (self.n, self.hb);
        let w = hb + 1;
        for i in 0..n {
            let row = &self.lower[i * w..(i + 1) * w];
            let mut s = x[i];
            for d in 1..=hb.min(i) {
                s -= row[d] * x[i - d];
            }
            x[i] = s;
        }
        for i in (0..n).rev() {
            let col = &self.upper[i * w..(i + 1) * w];
            let mut s = x[i] * self.inv_d[i];
            for d in 1..w {
                if i + d < n {
                    s -= col[d] * x[i + d];
                }
            }
            x[i] = s;
        }
    }

    /// Order of the factored matrix.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Half-bandwidth.
    pub fn half_bandwidth(&self) -> usize {
        self.hb
    }

    /// Row `i` of `L` by distance: `[0, L[i][i−1], …, L[i][i−hb]]` (forward substitution).
    #[inline(always)]
    pub fn lower_row(&self, i: usize) -> &[f64] {
        let w = self.hb + 1;
        &self.lower[i * w..(i + 1) * w]
    }

    /// Column `i` of `L` by distance: `[0, L[i+1][i], …, L[i+hb][i]]` (backward substitution).
    #[inline(always)]
    pub fn upper_col(&self, i: usize) -> &[f64] {
        let w = self.hb + 1;
        &self.upper[i * w..(i + 1) * w]
    }

    /// `1/D[i]`.
    #[inline(always)]
    pub fn inv_pivot(&self, i: usize) -> f64 {
        self.inv_d[i]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spd_band(n: usize, hb: usize) -> BandedSym {
        let mut a = BandedSym::zeros(n, hb);
        for i in 0..n {
            a.add(i, i, 10.0 + (i % 7) as f64);
            for d in 1..=hb.min(i) {
                a.add(i, i - d, 1.0 / (1.0 + d as f64 + (i % 3) as f64));
            }
        }
        a
    }

    #[test]
    fn solve_matches_dense_cholesky() {
        let a = spd_band(57, 4);
        let b: Vec<f64> = (0..57).map(|i| (i as f64 * 0.37).sin()).collect();
        let mut x = b.clone();
        a.factor().unwrap().solve_in_place(&mut x);
        let dense = a
            .to_dense()
            .cholesky()
            .unwrap()
            .solve(&nalgebra::DVector::from_vec(b));
        for (xi, di) in x.iter().zip(dense.iter()) {
            assert!((xi - di).abs() < 1e-13, "{xi} vs {di}");
        }
    }

    #[test]
    fn general_and_specialised_solves_agree() {
        for hb in [2, 3, 4, 5] {
            let a = spd_band(41, hb);
            let b: Vec<f64> = (0..41).map(|i| (i as f64 * 0.91).cos()).collect();
            let mut x = b.clone();
            a.factor().unwrap().solve_in_place(&mut x);
            let dense = a
                .to_dense()
                .cholesky()
                .unwrap()
                .solve(&nalgebra::DVector::from_vec(b));
            for (xi, di) in x.iter().zip(dense.iter()) {
                assert!((xi - di).abs() < 1e-13, "hb {hb}: {xi} vs {di}");
            }
        }
    }

    #[test]
    fn mul_vec_matches_dense() {
        let a = spd_band(23, 3);
        let x: Vec<f64> = (0..23).map(|i| i as f64 - 5.0).collect();
        let mut y = vec![0.0; 23];
        a.mul_vec(&x, &mut y);
        let yd = a.to_dense() * nalgebra::DVector::from_vec(x);
        for (p, q) in y.iter().zip(yd.iter()) {
            assert!((p - q).abs() < 1e-12);
        }
    }

    #[test]
    fn indefinite_matrix_is_reported() {
        let mut a = BandedSym::zeros(3, 1);
        a.add(0, 0, 1.0);
        a.add(1, 1, -1.0);
        a.add(2, 2, 1.0);
        assert!(matches!(
            a.factor(),
            Err(BandError::NotPositiveDefinite { row: 1, .. })
        ));
    }
}
