//! The track: a Timoshenko–Rayleigh rail on discrete Kelvin pads, sleeper masses and
//! Kelvin ballast (docs/model.md §2, paper §4.2, Fig. 9), assembled as banded matrices.
//!
//! Degrees of freedom, in band order along the rail: for every interior rail node its
//! deflection `w` and cross-section rotation `ψ`, followed by the sleeper's vertical
//! displacement `z_s` where the node sits on a sleeper. Both rail ends are clamped
//! (`w = ψ = 0`) and carry no DOFs. Displacements are positive downwards.

use super::banded::BandedSym;
use super::calibration::CheckedCalibration;
use super::effect;

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

/// How the rail is held at the sleepers (a test switch; the product always uses `Elastic`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Support {
    /// Pads, sleeper masses and ballast as calibrated.
    Elastic,
    /// Rigid supports: the rail deflection is zero at every sleeper and at both ends, which
    /// are pinned instead of clamped (rotation free), for the pinned–pinned frequency check.
    Rigid,
}

/// The assembled track model.
#[derive(Debug, Clone)]
pub struct TrackModel {
    /// Stiffness matrix.
    pub k: BandedSym,
    /// Mass matrix.
    pub m: BandedSym,
    /// Damping matrix (pads and ballast).
    pub c: BandedSym,
    element: TimoshenkoElement,
    elements: usize,
    elements_per_bay: usize,
    /// DOF index of `w` at each node (`None` at constrained nodes); `ψ` follows it unless
    /// the node is constrained in rotation too (clamped ends).
    node_w: Vec<Option<usize>>,
    node_psi: Vec<Option<usize>>,
    /// For sleeper k (1-based, index k−1): its own DOF (elastic supports only).
    sleeper_dof: Vec<Option<usize>>,
    /// Voided sleepers: (sleeper DOF, gap (m), ballast stiffness, ballast damping). Their
    /// ballast is left out of `k` and `c` and acts as a unilateral support (see
    /// [`TrackModel::voided_ballast_force`]).
    pub voided: Vec<(usize, f64, f64, f64)>,
    /// Pad stiffness by rail DOF (non-zero at the rail DOFs over sleepers).
    pad_stiffness_at: Vec<f64>,
    pad_damping: f64,
    element_k: [[f64; 4]; 4],
}

impl TrackModel {
    /// Assembles the track of a calibration with `elements_per_bay` rail elements per bay.
    pub fn new(cal: &CheckedCalibration, elements_per_bay: usize, support: Support) -> TrackModel {
        let t = &cal.track;
        let section = RailSection::from_calibration(cal);
        let elements = t.bays * elements_per_bay;
        let element =
            TimoshenkoElement::new(t.sleeper_spacing_m / elements_per_bay as f64, &section);

        // Number the DOFs in band order.
        let mut node_w = vec![None; elements + 1];
        let mut node_psi = vec![None; elements + 1];
        let mut sleeper_dof = vec![None; t.bays - 1];
        let mut n = 0;
        let rotating_nodes = if support == Support::Rigid {
            0..elements + 1
        } else {
            1..elements
        };
        for node in rotating_nodes {
            let on_sleeper = node % elements_per_bay == 0;
            if !(on_sleeper && support == Support::Rigid) {
                node_w[node] = Some(n);
                n += 1;
            }
            node_psi[node] = Some(n);
            n += 1;
            if on_sleeper && support == Support::Elastic {
                sleeper_dof[node / elements_per_bay - 1] = Some(n);
                n += 1;
            }
        }
        // Half-bandwidth: element couplings span at most the DOFs of two adjacent nodes plus a sleeper.
        let mut hb = 1;
        for e in 0..elements {
            let dofs = [node_w[e], node_psi[e], node_w[e + 1], node_psi[e + 1]];
            let present: Vec<usize> = dofs.iter().flatten().copied().collect();
            if let (Some(lo), Some(hi)) = (present.iter().min(), present.iter().max()) {
                hb = hb.max(hi - lo);
            }
        }
        for (k, s) in sleeper_dof.iter().enumerate() {
            if let (Some(s), Some(w)) = (s, node_w[(k + 1) * elements_per_bay]) {
                hb = hb.max(s - w);
            }
        }

        let (ke, me) = element.matrices(&section);
        let mut k = BandedSym::zeros(n, hb);
        let mut m = BandedSym::zeros(n, hb);
        let mut c = BandedSym::zeros(n, hb);
        for e in 0..elements {
            let dofs = [node_w[e], node_psi[e], node_w[e + 1], node_psi[e + 1]];
            for a in 0..4 {
                for b in 0..=a {
                    if let (Some(i), Some(j)) = (dofs[a], dofs[b]) {
                        k.add(i, j, ke[a][b]);
                        m.add(i, j, me[a][b]);
                    }
                }
            }
        }
        let mut pad_stiffness_at = vec![0.0; n];
        let mut voided = Vec::new();
        for (idx, s) in sleeper_dof.iter().enumerate() {
            let (Some(s), Some(w)) = (*s, node_w[(idx + 1) * elements_per_bay]) else {
                continue;
            };
            // Effects that change one sleeper's pad or ballast stiffness, or void it.
            let kp = t.pad_stiffness_n_per_m * effect::pad_stiffness_factor(&cal.effects, idx + 1);
            let kb = t.ballast_stiffness_n_per_m
                * effect::ballast_stiffness_factor(&cal.effects, idx + 1);
            pad_stiffness_at[w] = kp;
            let gap = effect::void_gap_m(&cal.effects, idx + 1);
            // Pad (Kelvin) between rail and sleeper, ballast (Kelvin) between sleeper and
            // ground; a voided sleeper's ballast is unilateral and stays out of the matrices.
            let (kb_lin, cb_lin) = match gap {
                Some(g) => {
                    voided.push((s, g, kb, t.ballast_damping_ns_per_m));
                    (0.0, 0.0)
                }
                None => (kb, t.ballast_damping_ns_per_m),
            };
            k.add(w, w, kp);
            k.add(s, s, kp + kb_lin);
            k.add(s, w, -kp);
            c.add(w, w, t.pad_damping_ns_per_m);
            c.add(s, s, t.pad_damping_ns_per_m + cb_lin);
            c.add(s, w, -t.pad_damping_ns_per_m);
            m.add(s, s, t.sleeper_mass_kg);
        }
        TrackModel {
            k,
            m,
            c,
            element,
            elements,
            elements_per_bay,
            node_w,
            node_psi,
            sleeper_dof,
            voided,
            pad_stiffness_at,
            pad_damping: t.pad_damping_ns_per_m,
            element_k: ke,
        }
    }

    /// Number of DOFs.
    pub fn dofs(&self) -> usize {
        self.k.n()
    }

    /// The rail element used.
    pub fn element(&self) -> &TimoshenkoElement {
        &self.element
    }

    /// Number of rail elements.
    pub fn elements(&self) -> usize {
        self.elements
    }

    /// Rail length (m).
    pub fn length_m(&self) -> f64 {
        self.elements as f64 * self.element.length_m
    }

    /// The element under position `x` and the local coordinate ξ ∈ [0, 1] in it.
    #[inline]
    fn element_at(&self, x: f64) -> (usize, f64) {
        let l = self.element.length_m;
        let e = ((x / l).floor().max(0.0) as usize).min(self.elements - 1);
        (e, ((x - e as f64 * l) / l).clamp(0.0, 1.0))
    }

    /// The element under position `x` and the deflection shape functions there, with the
    /// element's DOF indices (`usize::MAX` marks a constrained DOF, whose weight is zeroed).
    #[inline]
    pub fn locate(&self, x: f64) -> ([usize; 4], [f64; 4]) {
        let (e, xi) = self.element_at(x);
        let mut n = self.element.n_w(xi);
        let dofs = [
            self.node_w[e],
            self.node_psi[e],
            self.node_w[e + 1],
            self.node_psi[e + 1],
        ];
        let mut idx = [usize::MAX; 4];
        for a in 0..4 {
            match dofs[a] {
                Some(d) => idx[a] = d,
                None => n[a] = 0.0,
            }
        }
        (idx, n)
    }

    /// Compliance of the element interior at `x` (see [`TimoshenkoElement::interior_compliance`]).
    #[inline]
    pub fn interior_compliance_at(&self, x: f64) -> f64 {
        self.element.interior_compliance(self.element_at(x).1)
    }

    /// Rail deflection at `x` interpolated with the element shape functions.
    #[inline]
    pub fn deflection_at(&self, u: &[f64], x: f64) -> f64 {
        let (idx, n) = self.locate(x);
        (0..4)
            .filter(|&a| idx[a] != usize::MAX)
            .map(|a| n[a] * u[idx[a]])
            .sum()
    }

    /// `(rail w DOF, sleeper DOF)` of sleeper `k` (1-based), elastic supports only.
    pub fn pad_dofs(&self, sleeper: usize) -> Option<(usize, usize)> {
        let w = self.node_w[sleeper * self.elements_per_bay]?;
        let s = self
            .sleeper_dof
            .get(sleeper.checked_sub(1)?)
            .copied()
            .flatten()?;
        Some((w, s))
    }

    /// The upward force of a voided sleeper's ballast on the sleeper (N, ≥ 0) at sleeper
    /// displacement `z` and velocity `zd` (downwards positive): `K_b·(z − g) + C_b·ż` once the
    /// gap is closed (never pulling), else 0.
    #[inline]
    pub fn voided_ballast_force(kb: f64, cb: f64, gap: f64, z: f64, zd: f64) -> f64 {
        if z > gap {
            (kb * (z - gap) + cb * zd).max(0.0)
        } else {
            0.0
        }
    }

    /// Rail-pad force at sleeper `k`, docs/model.md §6:
    /// `F_pad = K_p·(w_rail − z_s) + C_p·(ẇ_rail − ż_s)`, compression positive.
    #[inline]
    pub fn pad_force(&self, dofs: (usize, usize), u: &[f64], v: &[f64]) -> f64 {
        let (w, s) = dofs;
        self.pad_force_from(w, u[w] - u[s], v[w] - v[s])
    }

    /// Rail-pad force over rail DOF `w` from the pad's compression `u_w − z_s` and its rate.
    #[inline]
    pub fn pad_force_from(&self, w: usize, compression_m: f64, rate_m_per_s: f64) -> f64 {
        self.pad_stiffness_at[w] * compression_m + self.pad_damping * rate_m_per_s
    }

    /// Load carried by the clamped ends `[left, right]` (N, in the same sense as a pad force:
    /// positive when the end holds the rail up) for a static displacement field `u`.
    /// The support must apply `−(K_e·u_e)` on the clamped node's deflection row.
    pub fn end_reactions(&self, u: &[f64]) -> [f64; 2] {
        let section_k = |e: usize, row: usize| -> f64 {
            let dofs = [
                self.node_w[e],
                self.node_psi[e],
                self.node_w[e + 1],
                self.node_psi[e + 1],
            ];
            let ke = &self.element_k;
            -(0..4)
                .filter_map(|b| dofs[b].map(|d| ke[row][b] * u[d]))
                .sum::<f64>()
        };
        [section_k(0, 0), section_k(self.elements - 1, 2)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Calibration;

    #[test]
    fn quadrature_stiffness_equals_the_closed_form_timoshenko_element() {
        let cal = Calibration::default().check().unwrap();
        let s = RailSection::from_calibration(&cal);
        for l in [0.0875, 0.175, 0.35, 0.7] {
            let e = TimoshenkoElement::new(l, &s);
            let (k, _) = e.matrices(&s);
            let exact = e.segment_stiffness(l);
            for a in 0..4 {
                for b in 0..4 {
                    let scale = exact[a][a].abs().max(exact[b][b].abs());
                    assert!(
                        (k[a][b] - exact[a][b]).abs() < 1e-10 * scale,
                        "l {l} ({a},{b})"
                    );
                }
            }
        }
    }

    #[test]
    fn mass_matrix_carries_the_element_mass() {
        // Rigid translation w = 1: uᵀ·M·u = ρA·l (rotary inertia does not act, ψ = 0).
        let cal = Calibration::default().check().unwrap();
        let s = RailSection::from_calibration(&cal);
        let e = TimoshenkoElement::new(0.175, &s);
        let (_, m) = e.matrices(&s);
        let u = [1.0, 0.0, 1.0, 0.0];
        let mass: f64 = (0..4)
            .flat_map(|a| (0..4).map(move |b| (a, b)))
            .map(|(a, b)| u[a] * m[a][b] * u[b])
            .sum();
        assert!((mass / (s.rho_a * 0.175) - 1.0).abs() < 1e-12, "{mass}");
    }

    #[test]
    fn interior_compliance_vanishes_at_nodes_and_peaks_mid_element() {
        let cal = Calibration::default().check().unwrap();
        let s = RailSection::from_calibration(&cal);
        let e = TimoshenkoElement::new(0.175, &s);
        assert!(e.interior_compliance(0.0) == 0.0 && e.interior_compliance(1.0) == 0.0);
        let mid = e.interior_compliance(0.5);
        // Clamped–clamped beam, central load: l³/(192·EI) + l/(4·κGA).
        let exact = 0.175f64.powi(3) / (192.0 * s.ei) + 0.175 / (4.0 * s.kga);
        assert!((mid / exact - 1.0).abs() < 1e-9, "{mid} vs {exact}");
        assert!((e.interior_compliance(0.3) - e.interior_compliance(0.7)).abs() < 1e-12 * mid);
    }
}
