//! The rail's section and its finite element: a Timoshenko beam element with interdependent
//! interpolation, its matrices by quadrature and its closed forms (docs/model.md §2).

use super::calibration::CheckedCalibration;

/// 4-point Gauss–Legendre rule on [0, 1]; exact for the degree-6 products below.
const GAUSS4: [(f64, f64); 4] = [
    (0.069_431_844_202_973_71, 0.173_927_422_568_726_93),
    (0.330_009_478_207_571_87, 0.326_072_577_431_273_07),
    (0.669_990_521_792_428_1, 0.326_072_577_431_273_07),
    (0.930_568_155_797_026_3, 0.173_927_422_568_726_93),
];

/// Cross-section and material of the rail.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RailSection {
    /// Bending stiffness EI (N·m²).
    pub ei: f64,
    /// Shear stiffness κGA (N).
    pub kga: f64,
    /// Mass per length ρA (kg/m).
    pub rho_a: f64,
    /// Rotary inertia per length ρI (kg·m).
    pub rho_i: f64,
}

impl RailSection {
    /// The section of a calibration's rail.
    pub fn from_calibration(cal: &CheckedCalibration) -> RailSection {
        let t = &cal.track;
        RailSection {
            ei: t.youngs_modulus_pa * t.rail_second_moment_m4,
            kga: t.shear_coefficient * t.shear_modulus_pa * t.rail_area_m2,
            rho_a: t.rail_density_kg_per_m3 * t.rail_area_m2,
            rho_i: t.rail_density_kg_per_m3 * t.rail_second_moment_m4,
        }
    }
}

/// Shape functions of the Timoshenko element with interdependent interpolation
/// (Friedman & Kosmatka 1993), `Φ = 12EI/(κGA·l²)`, `ξ = x/l`, nodal DOFs `(w1, ψ1, w2, ψ2)`:
///
/// `N_w = 1/(1+Φ)·[2ξ³−3ξ²−Φξ+1+Φ, l(ξ³−(2+Φ/2)ξ²+(1+Φ/2)ξ), −2ξ³+3ξ²+Φξ, l(ξ³−(1−Φ/2)ξ²−(Φ/2)ξ)]`
///
/// They reduce to the cubic Hermite functions when Φ → 0 (Euler–Bernoulli).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimoshenkoElement {
    /// Element length (m).
    pub length_m: f64,
    /// Shear parameter Φ.
    pub phi: f64,
    ei: f64,
    kga: f64,
}

impl TimoshenkoElement {
    /// An element of length `l` with section `s`.
    pub fn new(length_m: f64, s: &RailSection) -> TimoshenkoElement {
        TimoshenkoElement {
            length_m,
            phi: 12.0 * s.ei / (s.kga * length_m * length_m),
            ei: s.ei,
            kga: s.kga,
        }
    }

    /// Closed-form stiffness of a Timoshenko beam segment of length `a` (exact for end loads):
    /// `EI/((1+Φ_a)·a³)·[[12, 6a, −12, 6a], [6a, (4+Φ_a)a², −6a, (2−Φ_a)a²], …]`,
    /// `Φ_a = 12EI/(κGA·a²)`.
    pub fn segment_stiffness(&self, a: f64) -> [[f64; 4]; 4] {
        let p = 12.0 * self.ei / (self.kga * a * a);
        let s = self.ei / ((1.0 + p) * a * a * a);
        let (a2, q, r) = (a * a, 4.0 + p, 2.0 - p);
        [
            [12.0 * s, 6.0 * a * s, -12.0 * s, 6.0 * a * s],
            [6.0 * a * s, q * a2 * s, -6.0 * a * s, r * a2 * s],
            [-12.0 * s, -6.0 * a * s, 12.0 * s, -6.0 * a * s],
            [6.0 * a * s, r * a2 * s, -6.0 * a * s, q * a2 * s],
        ]
    }

    /// Deflection at `ξ` under a unit point load at `ξ` with both element ends clamped: the
    /// part of the exact static deflection under a load inside the element that the nodal
    /// interpolation cannot represent (the element's "bubble"). Added in series with the Hertz
    /// spring it makes the rail deflection under a wheel exact for static loads anywhere in an
    /// element, which removes the spurious force ripple at the element-crossing frequency
    /// `v / l_e` (docs/model.md §9). Computed by splitting the element at the load into two exact
    /// segments and condensing the free node: `G = (S⁻¹)₀₀` with
    /// `S = K_a[(w2,ψ2),(w2,ψ2)] + K_b[(w1,ψ1),(w1,ψ1)]`.
    #[inline]
    pub fn interior_compliance(&self, xi: f64) -> f64 {
        let l = self.length_m;
        let (a, b) = (xi * l, (1.0 - xi) * l);
        if a <= 1e-9 * l || b <= 1e-9 * l {
            return 0.0;
        }
        let ka = self.segment_stiffness(a);
        let kb = self.segment_stiffness(b);
        let s00 = ka[2][2] + kb[0][0];
        let s01 = ka[2][3] + kb[0][1];
        let s11 = ka[3][3] + kb[1][1];
        s11 / (s00 * s11 - s01 * s01)
    }

    /// Deflection shape functions `N_w(ξ)`.
    #[inline]
    pub fn n_w(&self, xi: f64) -> [f64; 4] {
        let (p, l) = (self.phi, self.length_m);
        let (x2, x3) = (xi * xi, xi * xi * xi);
        let f = 1.0 / (1.0 + p);
        [
            f * (2.0 * x3 - 3.0 * x2 - p * xi + 1.0 + p),
            f * l * (x3 - (2.0 + p / 2.0) * x2 + (1.0 + p / 2.0) * xi),
            f * (-2.0 * x3 + 3.0 * x2 + p * xi),
            f * l * (x3 - (1.0 - p / 2.0) * x2 - (p / 2.0) * xi),
        ]
    }

    /// `dN_w/dx`.
    fn dn_w(&self, xi: f64) -> [f64; 4] {
        let (p, l) = (self.phi, self.length_m);
        let x2 = xi * xi;
        let f = 1.0 / (1.0 + p);
        [
            f * (6.0 * x2 - 6.0 * xi - p) / l,
            f * (3.0 * x2 - (4.0 + p) * xi + 1.0 + p / 2.0),
            f * (-6.0 * x2 + 6.0 * xi + p) / l,
            f * (3.0 * x2 - (2.0 - p) * xi - p / 2.0),
        ]
    }

    /// Rotation shape functions `N_ψ(ξ)`.
    fn n_psi(&self, xi: f64) -> [f64; 4] {
        let (p, l) = (self.phi, self.length_m);
        let x2 = xi * xi;
        let f = 1.0 / (1.0 + p);
        [
            f * 6.0 * (x2 - xi) / l,
            f * (3.0 * x2 - (4.0 + p) * xi + 1.0 + p),
            -f * 6.0 * (x2 - xi) / l,
            f * (3.0 * x2 - (2.0 - p) * xi),
        ]
    }

    /// `dN_ψ/dx`.
    fn dn_psi(&self, xi: f64) -> [f64; 4] {
        let (p, l) = (self.phi, self.length_m);
        let f = 1.0 / (1.0 + p);
        [
            f * 6.0 * (2.0 * xi - 1.0) / (l * l),
            f * (6.0 * xi - (4.0 + p)) / l,
            -f * 6.0 * (2.0 * xi - 1.0) / (l * l),
            f * (6.0 * xi - (2.0 - p)) / l,
        ]
    }

    /// Element stiffness `K = ∫ EI·N_ψ'ᵀN_ψ' + κGA·(N_w' − N_ψ)ᵀ(N_w' − N_ψ) dx` and
    /// consistent mass `M = ∫ ρA·N_wᵀN_w + ρI·N_ψᵀN_ψ dx` (Timoshenko–Rayleigh),
    /// integrated exactly by Gauss quadrature.
    pub fn matrices(&self, s: &RailSection) -> ([[f64; 4]; 4], [[f64; 4]; 4]) {
        let mut k = [[0.0; 4]; 4];
        let mut m = [[0.0; 4]; 4];
        let l = self.length_m;
        for &(xi, wt) in &GAUSS4 {
            let (nw, dnw, npsi, dnpsi) =
                (self.n_w(xi), self.dn_w(xi), self.n_psi(xi), self.dn_psi(xi));
            let gamma: [f64; 4] = std::array::from_fn(|a| dnw[a] - npsi[a]);
            for a in 0..4 {
                for b in 0..4 {
                    k[a][b] += wt * l * (s.ei * dnpsi[a] * dnpsi[b] + s.kga * gamma[a] * gamma[b]);
                    m[a][b] += wt * l * (s.rho_a * nw[a] * nw[b] + s.rho_i * npsi[a] * npsi[b]);
                }
            }
        }
        (k, m)
    }
}
