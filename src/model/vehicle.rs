//! Pitch-plane half bogie (docs/model.md §3, paper §4.2): bogie bounce `z_b`, bogie pitch `φ`,
//! leading wheel `z_w1`, trailing wheel `z_w2` (all positive downwards), primary
//! suspension `K_1, C_1` per wheel, and the quarter car body as the constant load `M_c·g`.

use super::calibration::CheckedCalibration;

/// DOF index of the bogie bounce.
pub(crate) const BOUNCE: usize = 0;
/// DOF index of wheel `i` (0 = leading, 1 = trailing).
pub(crate) const fn wheel(i: usize) -> usize {
    2 + i
}

/// The vehicle's linear matrices and constant load.
#[derive(Debug, Clone, PartialEq)]
pub struct VehicleModel {
    /// Diagonal mass matrix `diag(M_b, J_b, M_w, M_w)`.
    pub mass: [f64; 4],
    /// Stiffness `K_1·Σ b_i b_iᵀ` with `Δ_i = b_i·q = z_wi − z_b − e_i·φ`, `e = (+l_b, −l_b)`.
    pub k: [[f64; 4]; 4],
    /// Damping `C_1·Σ b_i b_iᵀ`.
    pub c: [[f64; 4]; 4],
    /// Gravity and car-body load `[(M_b + M_c)·g, 0, M_w·g, M_w·g]`.
    pub load: [f64; 4],
    /// Static suspension deflection `Δ = −(M_b + M_c)·g / (2·K_1)`.
    static_deflection: f64,
    half_wheelbase: f64,
}

impl VehicleModel {
    /// The half bogie of a calibration.
    pub fn new(cal: &CheckedCalibration) -> VehicleModel {
        let v = &cal.vehicle;
        let e = [v.half_wheelbase_m, -v.half_wheelbase_m];
        let mut k = [[0.0; 4]; 4];
        let mut c = [[0.0; 4]; 4];
        for (i, ei) in e.iter().enumerate() {
            let mut b = [-1.0, -ei, 0.0, 0.0];
            b[wheel(i)] = 1.0;
            for r in 0..4 {
                for s in 0..4 {
                    k[r][s] += v.primary_stiffness_n_per_m * b[r] * b[s];
                    c[r][s] += v.primary_damping_ns_per_m * b[r] * b[s];
                }
            }
        }
        let g = v.gravity_m_per_s2;
        VehicleModel {
            mass: [
                v.bogie_mass_kg,
                v.bogie_pitch_inertia_kg_m2,
                v.wheel_mass_kg,
                v.wheel_mass_kg,
            ],
            k,
            c,
            load: [
                (v.bogie_mass_kg + v.car_body_mass_kg) * g,
                0.0,
                v.wheel_mass_kg * g,
                v.wheel_mass_kg * g,
            ],
            static_deflection: -(v.bogie_mass_kg + v.car_body_mass_kg) * g
                / (2.0 * v.primary_stiffness_n_per_m),
            half_wheelbase: v.half_wheelbase_m,
        }
    }

    /// Static configuration given the two wheel displacements: both springs carry the same
    /// load, so `z_b = (z_w1 + z_w2)/2 − Δ` and `φ = (z_w1 − z_w2)/(2·l_b)`.
    pub fn static_state(&self, wheels: [f64; 2]) -> [f64; 4] {
        [
            0.5 * (wheels[0] + wheels[1]) - self.static_deflection,
            (wheels[0] - wheels[1]) / (2.0 * self.half_wheelbase),
            wheels[0],
            wheels[1],
        ]
    }

    /// Newmark effective matrix `M + γ·dt·C + β·dt²·K` (β = 1/4, γ = 1/2), inverted.
    pub fn effective_inverse(&self, dt: f64) -> [[f64; 4]; 4] {
        let m = nalgebra::Matrix4::from_fn(|r, s| {
            let mass = if r == s { self.mass[r] } else { 0.0 };
            mass + 0.5 * dt * self.c[r][s] + 0.25 * dt * dt * self.k[r][s]
        });
        let inv = m
            .try_inverse()
            .expect("vehicle effective matrix is positive definite");
        std::array::from_fn(|r| std::array::from_fn(|s| inv[(r, s)]))
    }
}

/// `y = A·x` for a 4×4 matrix.
#[inline]
pub(crate) fn mul4(a: &[[f64; 4]; 4], x: &[f64; 4]) -> [f64; 4] {
    std::array::from_fn(|r| a[r][0] * x[0] + a[r][1] * x[1] + a[r][2] * x[2] + a[r][3] * x[3])
}
