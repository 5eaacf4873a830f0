//! Fitting the model to a measurement by re-simulation: the misfit's statistical model, the
//! flat parameters, and a bounded Levenberg–Marquardt solver with finite-difference Jacobians.
//!
//! **Misfit.** Sensor s reads `y_sk = a_s·g_sk(θ) + ε_sk`: `g` the simulated pad force, `a_s`
//! the sensor's systematic factor (model and measurement relative errors of the uncertainty
//! table together, `a = (1 − E_model)(1 + E_meas)`), `ε` independent noise with the variance of
//! the table's absolute sources (uniform of width w: `w²/12`). The factor gets a Gaussian prior
//! with the mean and variance of the table's relative sources, and is profiled out in closed
//! form. `χ² = Σ (a_s g_sk − y_sk)²/σ² + Σ (a_s − ā)²/σ_a²` is −2 log-likelihood up to a
//! constant, so the Bayesian information criterion is `BIC = χ² + k·ln N`.

use crate::identify::Identifier;
use crate::model::calibration::{IdentificationParams, UncertaintyGroup, UncertaintyKind};
use crate::model::{Calibration, Effect, Flat, Record, Simulator, WheelPosition};
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicUsize, Ordering};

/// The statistical model of the misfit, from the calibration's uncertainty table.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct NoiseModel {
    /// Standard deviation of the independent per-sample noise (kN).
    pub sigma_kn: f64,
    /// Prior mean of a sensor's systematic factor `a`.
    pub gain_mean: f64,
    /// Prior standard deviation of `a`.
    pub gain_sd: f64,
    /// Lag-1 correlation ρ of the noise, an AR(1) (0: independent; see [`super::noise`]).
    #[serde(default)]
    pub rho: f64,
}

impl NoiseModel {
    /// The sensor factor `a` minimising `Σ(a·g − y)²/σ² + (a − ā)²/σ_a²` over one sensor's
    /// samples, from `Σ g·y` and `Σ g²`.
    pub fn profiled_gain(&self, gy: f64, gg: f64) -> f64 {
        let (s2, sa2) = (self.sigma_kn.powi(2), self.gain_sd.powi(2));
        (gy / s2 + self.gain_mean / sa2) / (gg / s2 + 1.0 / sa2)
    }

    /// Moments of the uniform sources of the table.
    pub fn from_settings(id: &IdentificationParams) -> NoiseModel {
        let (mut noise_var, mut model_mean, mut meas_mean, mut rel_var) = (0.0, 0.0, 0.0, 0.0);
        for u in &id.uncertainty {
            match (u.kind, u.group) {
                (UncertaintyKind::AbsoluteKn, _) => noise_var += u.variance(),
                (UncertaintyKind::Relative, UncertaintyGroup::Model) => {
                    model_mean += u.mean();
                    rel_var += u.variance();
                }
                (UncertaintyKind::Relative, UncertaintyGroup::Measurement) => {
                    meas_mean += u.mean();
                    rel_var += u.variance();
                }
                // Bounds, not noise: a rough tread's departure is what the diagnosis looks for.
                (UncertaintyKind::GoodWheelRelative | UncertaintyKind::BoundKn, _) => {}
            }
        }
        NoiseModel {
            sigma_kn: noise_var.sqrt().max(1e-6),
            gain_mean: (1.0 - model_mean) * (1.0 + meas_mean),
            gain_sd: rel_var.sqrt().max(1e-6),
            rho: 0.0,
        }
    }

    /// `x` whitened for this noise, in units of σ ([`super::noise::whiten`]).
    pub fn whiten(&self, x: &[f64]) -> Vec<f64> {
        super::noise::whiten(x, self.sigma_kn, self.rho)
    }
}

/// One measured series on its bank window.
#[derive(Debug, Clone, PartialEq)]
pub struct Observed {
    /// Sensor name.
    pub sensor: String,
    /// Global index of the window's first sample.
    pub first_sample: usize,
    /// Measured force (kN), one per window sample.
    pub values_kn: Vec<f64>,
}

/// Flat parameters of a fit: `[L (mm), d (mm), c/(d/2), X_p (m)]`.
pub type FlatVector = [f64; 4];

/// The flat of a flat vector on `wheel` (None when the numbers make no flat).
pub fn make_flat(v: &FlatVector, wheel: WheelPosition) -> Option<Flat> {
    let [l, d, r, xp] = *v;
    Flat::from_mm(l, d, r * d / 2.0, xp)
        .ok()
        .map(|f| f.on_wheel(wheel))
}

/// One evaluation of the misfit.
#[derive(Debug, Clone, PartialEq)]
pub struct Evaluation {
    /// χ² (−2 log-likelihood up to a constant).
    pub chi2: f64,
    /// Weighted residual vector: per sample `a_s g − y` whitened ([`NoiseModel::whiten`]; for
    /// independent noise `(a_s g − y)/σ`), then per sensor `(a_s − ā)/σ_a`.
    pub weighted: Vec<f64>,
    /// Profiled factor per sensor.
    pub gains: Vec<f64>,
    /// Simulated force per sensor (kN), without the factor.
    pub predicted_kn: Vec<Vec<f64>>,
}

/// A fitting problem: a measurement, the calibration it is simulated with and the wheel
/// carrying the flat.
pub struct Problem<'a> {
    base: Calibration,
    observed: &'a [Observed],
    noise: NoiseModel,
    wheel: WheelPosition,
    simulations: AtomicUsize,
}

impl<'a> Problem<'a> {
    /// The same problem with noise model `noise` (the simulation count carried over).
    pub fn with_noise(&self, noise: NoiseModel) -> Problem<'a> {
        Problem {
            base: self.base.clone(),
            observed: self.observed,
            noise,
            wheel: self.wheel,
            simulations: AtomicUsize::new(self.simulations()),
        }
    }

    /// `base`: the bank's calibration (its own effects kept; candidate effects are added).
    pub fn new(
        base: Calibration,
        observed: &'a [Observed],
        noise: NoiseModel,
        wheel: WheelPosition,
    ) -> Problem<'a> {
        Problem {
            base,
            observed,
            noise,
            wheel,
            simulations: AtomicUsize::new(0),
        }
    }

    /// The noise model.
    pub fn noise(&self) -> NoiseModel {
        self.noise
    }

    /// The wheel carrying the flat.
    pub fn wheel(&self) -> WheelPosition {
        self.wheel
    }

    /// The measured series.
    pub fn observed(&self) -> &[Observed] {
        self.observed
    }

    /// Samples compared.
    pub fn samples(&self) -> usize {
        self.observed.iter().map(|o| o.values_kn.len()).sum()
    }

    /// Simulations run so far.
    pub fn simulations(&self) -> usize {
        self.simulations.load(Ordering::Relaxed)
    }

    /// Simulates `flat` with `effects` added to the calibration: the force per observed sensor
    /// on its window (kN); None when the parameters make no valid model.
    pub fn simulate(&self, flat: &FlatVector, effects: &[Effect]) -> Option<Vec<Vec<f64>>> {
        let mut doc = self.base.clone();
        doc.effects.extend_from_slice(effects);
        let cal = doc.check().ok()?;
        let flat = make_flat(flat, self.wheel)?;
        let sim = Simulator::new(&cal).ok()?;
        self.simulations.fetch_add(1, Ordering::Relaxed);
        let resp = sim.run(Some(&flat), Record::default()).ok()?;
        self.observed
            .iter()
            .map(|o| {
                let si = cal.sensor_index(&o.sensor)?;
                let series = &resp.pad_force_n[si];
                (0..o.values_kn.len())
                    .map(|k| {
                        let g = (o.first_sample + k).checked_sub(resp.first_sample)?;
                        series.get(g).map(|f| f / 1e3)
                    })
                    .collect::<Option<Vec<f64>>>()
            })
            .collect()
    }

    /// The misfit of simulated series `g`.
    pub fn misfit(&self, g: Vec<Vec<f64>>) -> Evaluation {
        let NoiseModel {
            gain_mean: m,
            gain_sd: sa,
            ..
        } = self.noise;
        let mut weighted = Vec::with_capacity(self.samples() + g.len());
        let mut gains = Vec::with_capacity(g.len());
        for (o, gs) in self.observed.iter().zip(&g) {
            // Whitened (unit-variance) prediction and measurement: the factor scales the
            // prediction, and whitening is linear, so it is profiled on the whitened series.
            let (gw, yw) = (self.noise.whiten(gs), self.noise.whiten(&o.values_kn));
            let (mut gy, mut gg) = (0.0, 0.0);
            for (&gk, &yk) in gw.iter().zip(&yw) {
                gy += gk * yk;
                gg += gk * gk;
            }
            let unit = NoiseModel {
                sigma_kn: 1.0,
                ..self.noise
            };
            let a = unit.profiled_gain(gy, gg);
            weighted.extend(gw.iter().zip(&yw).map(|(gk, yk)| a * gk - yk));
            gains.push(a);
        }
        weighted.extend(gains.iter().map(|a| (a - m) / sa));
        Evaluation {
            chi2: weighted.iter().map(|r| r * r).sum(),
            weighted,
            gains,
            predicted_kn: g,
        }
    }

    /// Simulates and scores.
    pub fn evaluate(&self, flat: &FlatVector, effects: &[Effect]) -> Option<Evaluation> {
        self.simulate(flat, effects).map(|g| self.misfit(g))
    }

    /// The χ² of [`Problem::evaluate`], infinite when the simulation fails (for ranking
    /// seeds and starts, where a failed one must never win).
    pub fn chi2(&self, flat: &FlatVector, effects: &[Effect]) -> f64 {
        self.evaluate(flat, effects)
            .map_or(f64::INFINITY, |e| e.chi2)
    }

    /// Samples of the raw prediction outside the Šídák thresholds at per-point probability
    /// `p` (the same rule as [`super::locate`], without a bank cell), and the RMS of the excess
    /// over all samples (kN).
    pub fn outside(&self, identifier: &Identifier, g: &[Vec<f64>], p: f64) -> (usize, f64) {
        let (mut n, mut s2, mut count) = (0usize, 0.0, 0usize);
        for (o, gs) in self.observed.iter().zip(g) {
            for (&gk, &y) in gs.iter().zip(&o.values_kn) {
                let (lo, hi) = identifier.thresholds(y, p);
                let r = gk - y;
                let excess = (r - hi).max(lo - r).max(0.0);
                if excess > 0.0 {
                    n += 1;
                }
                s2 += excess * excess;
                count += 1;
            }
        }
        (n, (s2 / count.max(1) as f64).sqrt())
    }
}

/// What a fitted parameter stands for, where the diagnosis reads one back (its label is for
/// people only).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Role {
    /// Read back only as part of the effect.
    #[default]
    Other,
    /// Where the effect is along the track (a rail dip's position, a second flat's impact
    /// position).
    Position,
    /// A second flat's depth (its L0 is told from it).
    SecondFlatDepth,
}

/// A fitted parameter's bounds and finite-difference step.
#[derive(Debug, Clone, PartialEq)]
pub struct Param {
    /// Name and unit.
    pub name: String,
    /// What it stands for.
    pub role: Role,
    /// Lower bound.
    pub lo: f64,
    /// Upper bound.
    pub hi: f64,
    /// Finite-difference step (also the scale of the damping).
    pub step: f64,
}

impl Param {
    /// A parameter.
    pub fn new(name: &str, lo: f64, hi: f64, step: f64) -> Param {
        Param {
            name: name.to_string(),
            role: Role::Other,
            lo,
            hi,
            step,
        }
    }

    /// The parameter standing for `role`.
    pub fn with_role(self, role: Role) -> Param {
        Param { role, ..self }
    }
}

/// What a Levenberg–Marquardt run found.
#[derive(Debug, Clone, PartialEq)]
pub struct Fitted {
    /// Parameters at the optimum.
    pub x: Vec<f64>,
    /// Standard deviations from `(JᵀJ)⁻¹` (NaN where singular or at a bound).
    pub sd: Vec<f64>,
    /// The evaluation at the optimum.
    pub eval: Evaluation,
    /// Iterations taken.
    pub iterations: usize,
}

/// Bounded Levenberg–Marquardt on `f` (an evaluation of the parameters, None when they make no
/// model) from `x0`, at most `max_iter` Jacobians. Forward differences, one simulation per
/// parameter, in parallel; steps are clipped to the bounds.
pub fn levenberg_marquardt(
    params: &[Param],
    x0: &[f64],
    f: &(dyn Fn(&[f64]) -> Option<Evaluation> + Sync),
    max_iter: usize,
) -> Option<Fitted> {
    let n = params.len();
    let clip = |x: &mut [f64]| {
        for (v, p) in x.iter_mut().zip(params) {
            *v = v.clamp(p.lo, p.hi);
        }
    };
    let mut x = x0.to_vec();
    clip(&mut x);
    let mut cur = f(&x)?;
    let mut lambda = 1e-2;
    let mut jac: Option<DMatrix<f64>> = None;
    let mut iterations = 0;
    for _ in 0..max_iter {
        iterations += 1;
        // Jacobian by forward differences (backward at the upper bound).
        let cols: Vec<Option<(Vec<f64>, f64)>> = (0..n)
            .into_par_iter()
            .map(|j| {
                let mut xp = x.clone();
                let h = if x[j] + params[j].step > params[j].hi {
                    -params[j].step
                } else {
                    params[j].step
                };
                xp[j] += h;
                f(&xp).map(|e| (e.weighted, h))
            })
            .collect();
        let m = cur.weighted.len();
        let mut j_mat = DMatrix::<f64>::zeros(m, n);
        for (j, c) in cols.into_iter().enumerate() {
            let Some((w, h)) = c else { continue };
            for i in 0..m {
                j_mat[(i, j)] = (w[i] - cur.weighted[i]) / h;
            }
        }
        let r = DVector::from_column_slice(&cur.weighted);
        let jtj = j_mat.transpose() * &j_mat;
        let jtr = j_mat.transpose() * &r;
        jac = Some(j_mat);
        let mut improved = false;
        for _ in 0..8 {
            let mut a = jtj.clone();
            for d in 0..n {
                a[(d, d)] += lambda * jtj[(d, d)].max(1e-9);
            }
            let Some(step) = a.cholesky().map(|c| c.solve(&(-&jtr))) else {
                lambda *= 10.0;
                continue;
            };
            let mut xn: Vec<f64> = x.iter().zip(step.iter()).map(|(a, b)| a + b).collect();
            clip(&mut xn);
            match f(&xn) {
                Some(e) if e.chi2 < cur.chi2 => {
                    let gain = cur.chi2 - e.chi2;
                    x = xn;
                    cur = e;
                    lambda = (lambda / 4.0).max(1e-7);
                    improved = true;
                    if gain < 1e-4 * cur.chi2.max(1.0) {
                        return Some(finish(params, x, cur, jac, iterations));
                    }
                    break;
                }
                _ => lambda *= 8.0,
            }
        }
        if !improved {
            break;
        }
    }
    Some(finish(params, x, cur, jac, iterations))
}

fn finish(
    params: &[Param],
    x: Vec<f64>,
    eval: Evaluation,
    jac: Option<DMatrix<f64>>,
    iterations: usize,
) -> Fitted {
    let n = params.len();
    let sd = jac
        .and_then(|j| (j.transpose() * j).try_inverse())
        .map(|c| (0..n).map(|i| c[(i, i)].max(0.0).sqrt()).collect())
        .unwrap_or_else(|| vec![f64::NAN; n]);
    Fitted {
        x,
        sd,
        eval,
        iterations,
    }
}

/// The flat's parameters for fitting, bounded by the population ranges (X_p with a margin).
pub fn flat_params(pop: &crate::model::calibration::PopulationParams) -> Vec<Param> {
    let span = |r: [f64; 2]| r[1] - r[0];
    vec![
        Param::new(
            "L (mm)",
            pop.length_mm[0],
            pop.length_mm[1],
            2e-3 * span(pop.length_mm),
        ),
        Param::new(
            "d (mm)",
            pop.depth_mm[0],
            pop.depth_mm[1],
            2e-3 * span(pop.depth_mm),
        ),
        Param::new("c/(d/2)", 0.0, 0.98, 2e-3),
        // The apparent impact position of a series shifted in time (a clock offset, a speed
        // deviation) may lie beyond the population: a margin of 0.25 m (18 ms at 50 km/h).
        Param::new(
            "X_p (m)",
            pop.impact_position_m[0] - XP_MARGIN_M,
            pop.impact_position_m[1] + XP_MARGIN_M,
            2e-4,
        ),
    ]
}

/// How far beyond the population's X_p range a fit may go (m).
pub const XP_MARGIN_M: f64 = 0.25;

/// The flat vector of stored parameters `[L, d, c, X_p]`.
pub fn flat_vector(l: f64, d: f64, c: f64, xp: f64) -> FlatVector {
    [l, d, if d > 0.0 { 2.0 * c / d } else { 0.0 }, xp]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn eval_of(r: Vec<f64>) -> Evaluation {
        Evaluation {
            chi2: r.iter().map(|x| x * x).sum(),
            weighted: r,
            gains: Vec::new(),
            predicted_kn: Vec::new(),
        }
    }

    #[test]
    fn levenberg_marquardt_recovers_an_exponential_and_stops_at_a_bound() {
        let t: Vec<f64> = (0..40).map(|k| k as f64 * 0.1).collect();
        let y: Vec<f64> = t.iter().map(|t| 3.0 * (-0.7 * t).exp()).collect();
        let f = |x: &[f64]| {
            Some(eval_of(
                t.iter()
                    .zip(&y)
                    .map(|(t, y)| x[0] * (-x[1] * t).exp() - y)
                    .collect(),
            ))
        };
        let params = [
            Param::new("a", 0.0, 10.0, 1e-6),
            Param::new("b", 0.0, 5.0, 1e-6),
        ];
        let r = levenberg_marquardt(&params, &[1.0, 2.0], &f, 100).unwrap();
        assert!((r.x[0] - 3.0).abs() < 1e-4, "{:?}", r.x);
        assert!((r.x[1] - 0.7).abs() < 1e-4, "{:?}", r.x);
        // The optimum a = 3 lies above an upper bound of 2: the fit ends on the bound.
        let bounded = [
            Param::new("a", 0.0, 2.0, 1e-6),
            Param::new("b", 0.0, 5.0, 1e-6),
        ];
        let r = levenberg_marquardt(&bounded, &[1.0, 2.0], &f, 100).unwrap();
        assert!((r.x[0] - 2.0).abs() < 1e-9, "{:?}", r.x);
    }
}
