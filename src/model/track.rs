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
pub use super::rail_element::RailSection;
pub(crate) use super::rail_element::TimoshenkoElement;

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
    /// Sleeper spacing (m): every bay's length.
    spacing_m: f64,
    /// Per bay, its rail element (the bay's length over its element count).
    bay_element: Vec<TimoshenkoElement>,
    /// Per bay, its element stiffness matrix.
    bay_k: Vec<[[f64; 4]; 4]>,
    /// Per bay, its element count.
    bay_elements: Vec<usize>,
    /// The element length when every bay has the same count.
    uniform_m: Option<f64>,
    /// The node at each bay's start (and, last, the rail's end): sleeper k sits on node
    /// `bay_node[k]`.
    bay_node: Vec<usize>,
    elements: usize,
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
}

impl TrackModel {
    /// Assembles the track of a calibration with `elements_per_bay` rail elements per bay.
    pub fn new(cal: &CheckedCalibration, elements_per_bay: usize, support: Support) -> TrackModel {
        TrackModel::with_bays(cal, &vec![elements_per_bay; cal.track.bays], support)
    }

    /// Assembles the track of a calibration with `bay_elements[b]` rail elements in bay `b`
    /// (a mesh refined where it is needed: the nodes stay on the sleepers).
    pub fn with_bays(
        cal: &CheckedCalibration,
        bay_elements: &[usize],
        support: Support,
    ) -> TrackModel {
        let t = &cal.track;
        assert_eq!(bay_elements.len(), t.bays, "one element count a bay");
        let section = RailSection::from_calibration(cal);
        let mut bay_node = vec![0usize];
        for &n in bay_elements {
            bay_node.push(bay_node.last().copied().unwrap_or(0) + n.max(1));
        }
        let elements = bay_node[t.bays];
        let bay_element: Vec<TimoshenkoElement> = bay_elements
            .iter()
            .map(|&n| TimoshenkoElement::new(t.sleeper_spacing_m / n.max(1) as f64, &section))
            .collect();
        let matrices: Vec<_> = bay_element.iter().map(|e| e.matrices(&section)).collect();
        // Which sleeper (bay boundary) a node is, if any.
        let mut boundary = vec![None; elements + 1];
        for (k, &node) in bay_node.iter().enumerate() {
            boundary[node] = Some(k);
        }

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
            let on_sleeper = boundary[node].is_some();
            if !(on_sleeper && support == Support::Rigid) {
                node_w[node] = Some(n);
                n += 1;
            }
            node_psi[node] = Some(n);
            n += 1;
            if let (Some(k), Support::Elastic) = (boundary[node], support) {
                sleeper_dof[k - 1] = Some(n);
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
            if let (Some(s), Some(w)) = (s, node_w[bay_node[k + 1]]) {
                hb = hb.max(s - w);
            }
        }

        let mut k = BandedSym::zeros(n, hb);
        let mut m = BandedSym::zeros(n, hb);
        let mut c = BandedSym::zeros(n, hb);
        for (bay, (ke, me)) in matrices.iter().enumerate() {
            for e in bay_node[bay]..bay_node[bay + 1] {
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
        }
        let mut pad_stiffness_at = vec![0.0; n];
        let mut voided = Vec::new();
        for (idx, s) in sleeper_dof.iter().enumerate() {
            let (Some(s), Some(w)) = (*s, node_w[bay_node[idx + 1]]) else {
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
            spacing_m: t.sleeper_spacing_m,
            bay_k: matrices.iter().map(|(ke, _)| *ke).collect(),
            bay_element,
            bay_elements: bay_elements.iter().map(|&n| n.max(1)).collect(),
            uniform_m: bay_elements
                .iter()
                .all(|&n| n == bay_elements[0])
                .then(|| t.sleeper_spacing_m / bay_elements[0].max(1) as f64),
            bay_node,
            elements,
            node_w,
            node_psi,
            sleeper_dof,
            voided,
            pad_stiffness_at,
            pad_damping: t.pad_damping_ns_per_m,
        }
    }

    /// Number of DOFs.
    pub fn dofs(&self) -> usize {
        self.k.n()
    }

    /// The rail element of the first bay (every bay's, on a uniform mesh).
    pub fn element(&self) -> &TimoshenkoElement {
        &self.bay_element[0]
    }

    /// Number of rail elements.
    pub fn elements(&self) -> usize {
        self.elements
    }

    /// Rail length (m).
    pub fn length_m(&self) -> f64 {
        self.bay_elements.len() as f64 * self.spacing_m
    }

    /// The element under position `x`, its bay, and the local coordinate ξ ∈ [0, 1] in it.
    #[inline]
    fn element_at(&self, x: f64) -> (usize, usize, f64) {
        if let Some(l) = self.uniform_m {
            // One element length everywhere: the element from x directly (as before meshes
            // could be refined: the same floating-point steps, the same banks).
            let e = ((x / l).floor().max(0.0) as usize).min(self.elements - 1);
            let b = (e / self.bay_elements[0]).min(self.bay_elements.len() - 1);
            return (e, b, ((x - e as f64 * l) / l).clamp(0.0, 1.0));
        }
        let bays = self.bay_elements.len();
        let b = ((x / self.spacing_m).floor().max(0.0) as usize).min(bays - 1);
        let n = self.bay_elements[b];
        let l = self.spacing_m / n as f64;
        let local = x - b as f64 * self.spacing_m;
        let j = ((local / l).floor().max(0.0) as usize).min(n - 1);
        (
            self.bay_node[b] + j,
            b,
            ((local - j as f64 * l) / l).clamp(0.0, 1.0),
        )
    }

    /// The element under position `x` and the deflection shape functions there, with the
    /// element's DOF indices (`usize::MAX` marks a constrained DOF, whose weight is zeroed).
    #[inline]
    pub fn locate(&self, x: f64) -> ([usize; 4], [f64; 4]) {
        let (e, b, xi) = self.element_at(x);
        let mut n = self.bay_element[b].n_w(xi);
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
        let (_, b, xi) = self.element_at(x);
        self.bay_element[b].interior_compliance(xi)
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
        let w = self.node_w[*self.bay_node.get(sleeper)?]?;
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
        let last = self.bay_k.len() - 1;
        let section_k = |e: usize, row: usize| -> f64 {
            let dofs = [
                self.node_w[e],
                self.node_psi[e],
                self.node_w[e + 1],
                self.node_psi[e + 1],
            ];
            let ke = &self.bay_k[if e == 0 { 0 } else { last }];
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
    fn a_refined_stretch_leaves_the_static_deflection_at_the_sleepers_as_it_was() {
        // The element's interdependent interpolation is exact for nodal loads, so the static
        // deflection at every node is the beam's whatever the mesh: refining bays 12–21 to 40
        // elements, against 4 everywhere, must leave every sleeper's deflection under 100 kN
        // on sleeper 17 unchanged but for round-off (1e-9 relative), and the mass the same.
        let cal = Calibration::default().check().unwrap();
        let bays = cal.track.bays;
        let mut mixed = vec![4; bays];
        mixed[12..22].iter_mut().for_each(|n| *n = 40);
        let deflections = |t: &TrackModel| -> Vec<f64> {
            let mut u = vec![0.0; t.dofs()];
            u[t.pad_dofs(17).unwrap().0] = 1e5;
            t.k.factor().unwrap().solve_in_place(&mut u);
            (1..bays).map(|k| u[t.pad_dofs(k).unwrap().0]).collect()
        };
        let uniform = TrackModel::new(&cal, 4, Support::Elastic);
        let refined = TrackModel::with_bays(&cal, &mixed, Support::Elastic);
        assert_eq!(refined.elements(), 4 * bays + 36 * 10);
        let (a, b) = (deflections(&uniform), deflections(&refined));
        let peak = a.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        for (k, (x, y)) in a.iter().zip(&b).enumerate() {
            assert!(
                (x - y).abs() <= 1e-9 * peak,
                "sleeper {}: {x} vs {y}",
                k + 1
            );
        }
        // Rigid translation of the rail (w = 1 at every free rail node): the same mass.
        let mass = |t: &TrackModel| {
            let mut one = vec![0.0; t.dofs()];
            t.node_w.iter().flatten().for_each(|&d| one[d] = 1.0);
            let mut y = vec![0.0; t.dofs()];
            t.m.mul_vec(&one, &mut y);
            one.iter().zip(&y).map(|(a, b)| a * b).sum::<f64>()
        };
        let (ma, mb) = (mass(&uniform), mass(&refined));
        assert!((ma - mb).abs() < 1e-9 * ma, "{ma} vs {mb}");
        // Contact lookup: a point in a refined bay lies in the bay's element of its position.
        let x = 17.3 * cal.track.sleeper_spacing_m;
        let (e, b, xi) = refined.element_at(x);
        assert_eq!(b, 17);
        let l = cal.track.sleeper_spacing_m / 40.0;
        let x_e = 17.0 * cal.track.sleeper_spacing_m + (e - refined.bay_node[17]) as f64 * l;
        assert!((x_e + xi * l - x).abs() < 1e-12, "{e} {xi}");
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
