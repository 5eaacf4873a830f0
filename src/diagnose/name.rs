//! Naming the missing effect: every effect of the library is fitted, with the flat, to the
//! measurement by re-simulation, and scored with the Bayesian information criterion.
//!
//! Stages (all simulations on the bank's calibration with the candidate effect added):
//! 1. *Seeds.* Each effect kind has families (one per discrete choice: a sleeper, a sensor, a
//!    wheel and polygon order) and seeds (starting values: a grid over wavelengths, phases,
//!    positions). Every seed is simulated with the flat held at the flat-only fit.
//! 2. *Effect fit.* Per kind, the two best seeds (of different families where the kind has
//!    several) are fitted by Levenberg–Marquardt over the effect's parameters, flat held.
//! 3. *Joint fit.* The best candidate of each of the [`JOINT`] best kinds by BIC, and the best
//!    kind's second place, are refitted with the flat parameters free as well.
//!
//! `BIC = χ² + k·ln N + 2·ln M`: k the continuous parameters fitted (4 for the flat plus the
//! effect's), N the samples compared, M the families of the kind (a uniform prior over the
//! discrete choices: the more places an effect may sit, the more it must explain).

use super::fit::{levenberg_marquardt, Evaluation, FlatVector, Param, Problem};
use crate::model::{Effect, WheelPosition};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Kinds whose best candidate is refitted with the flat free.
pub const JOINT: usize = 3;
/// BIC difference that counts as "clearly better" (Kass & Raftery's "very strong").
pub const CLEARLY_BETTER: f64 = 10.0;
/// Levenberg–Marquardt Jacobians per fit, flat held (stage 2).
const MAX_ITER: usize = 10;
/// Levenberg–Marquardt Jacobians per joint fit (stage 3).
const MAX_ITER_JOINT: usize = 30;
/// Goodness of fit: a fit is adequate when χ² is below its upper `1 − 10⁻³` quantile under the
/// noise model (`z` of the Wilson–Hilferty normal approximation of χ²).
pub const ADEQUATE_Z: f64 = 3.09;

/// The Wilson–Hilferty `z` of `chi2` with `dof` degrees of freedom (standard normal if the
/// fit leaves only noise).
pub fn chi2_z(chi2: f64, dof: f64) -> f64 {
    let v = dof.max(1.0);
    let a = 2.0 / (9.0 * v);
    ((chi2 / v).cbrt() - (1.0 - a)) / a.sqrt()
}

/// A fitted parameter.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Estimate {
    /// Name and unit.
    pub name: String,
    /// Value at the optimum.
    pub value: f64,
    /// Standard deviation from the curvature of χ² (NaN where it could not be had).
    pub sd: f64,
}

/// One effect fitted to the measurement.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Candidate {
    /// Effect kind (`voided_sleeper`, …), `none` for the flat alone.
    pub kind: String,
    /// Where it acts, for people.
    pub location: String,
    /// The effect at its fitted parameters (None for the flat alone).
    pub effect: Option<Effect>,
    /// The effect's fitted parameters as fitted (e.g. log factors), with standard deviations.
    pub parameters: Vec<Estimate>,
    /// Flat `[L (mm), d (mm), c (mm), X_p (m)]` of the fit.
    pub flat: [f64; 4],
    /// χ² at the optimum.
    pub chi2: f64,
    /// Continuous parameters fitted (flat and effect).
    pub k: usize,
    /// Families of the kind (M).
    pub families: usize,
    /// BIC.
    pub bic: f64,
    /// Whether the flat was refitted with the effect (stage 3) or held (stage 2).
    pub joint: bool,
    /// Goodness of fit: the Wilson–Hilferty `z` of χ² with N − k degrees of freedom.
    pub chi2_z: f64,
    /// `chi2_z ≤` [`ADEQUATE_Z`]: what the fit leaves is noise.
    pub adequate: bool,
    /// Samples of the fitted model's raw prediction outside the Šídák thresholds (for
    /// information: the thresholds bound the sensor factors, the fit estimates them).
    pub samples_outside: usize,
    /// RMS excess over the thresholds, all samples (kN).
    pub gap_rms_kn: f64,
    /// RMS of `a_s g − y` over all samples (kN): what the fit leaves after each sensor's
    /// systematic factor.
    pub fit_rms_kn: f64,
    /// Profiled sensor factors.
    pub gains: Vec<f64>,
}

/// The ranking and the verdict.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Naming {
    /// The criterion, in words.
    pub criterion: String,
    /// Samples compared (N).
    pub samples: usize,
    /// The flat alone, fitted.
    pub no_effect: Candidate,
    /// All effects fitted, best BIC first (one entry per kind and location).
    pub ranking: Vec<Candidate>,
    /// Index into `ranking` of the effect named, if one is.
    pub named: Option<usize>,
    /// BIC of the flat alone minus the best's.
    pub evidence_over_none: f64,
    /// BIC of the runner-up (another kind or location) minus the best's.
    pub evidence_over_runner_up: f64,
    /// The verdict in words.
    pub verdict: String,
    /// Simulations run.
    pub simulations: usize,
}

/// Makes the effect of a family from its fitted parameters.
type Build = Box<dyn Fn(&[f64]) -> Effect + Send + Sync>;

/// A family of an effect kind: one discrete choice, its continuous parameters and seeds.
pub struct Family {
    kind: &'static str,
    location: String,
    params: Vec<Param>,
    seeds: Vec<Vec<f64>>,
    build: Build,
}

/// Where to look: what the locate step and the calibration say.
#[derive(Debug, Clone, PartialEq)]
pub struct Context {
    /// Sleepers to try for the sleeper effects.
    pub sleepers: Vec<usize>,
    /// Sensors measured.
    pub sensors: Vec<String>,
    /// Sensor positions along the rail (m).
    pub sensor_positions_m: Vec<f64>,
    /// Wheels.
    pub wheels: Vec<WheelPosition>,
    /// Highest polygon order tried.
    pub max_order: u32,
}

/// What moves the flat's strikes in time: the effects that shift the series in time are fitted
/// with the *apparent* impact position (where the strike would be without them) held, so
/// that the flat-only fit's X_p stays right while the effect changes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Timing {
    /// Nominal speed (m/s).
    pub speed_m_per_s: f64,
    /// Start position of the wheel carrying the flat (m).
    pub wheel_start_m: f64,
    /// Start position of the leading wheel (m).
    pub lead_start_m: f64,
    /// The laser trigger (m).
    pub laser_m: f64,
}

impl Timing {
    /// The flat whose strikes, with effect `e`, come when those of `apparent` would without.
    /// Time offset τ: `X_p = X_app − v·τ`. Speed `v' = (1 + f)·v` with the trigger delay
    /// `δ = (x_laser − x_0)(1/v − 1/v')`: `X_p = x_w0 + v'·((X_app − x_w0)/v − δ)`.
    pub fn actual(&self, apparent: FlatVector, e: &Effect) -> FlatVector {
        let v = self.speed_m_per_s;
        let mut f = apparent;
        match e {
            Effect::TimeOffset { offset_ms } => f[3] -= v * offset_ms * 1e-3,
            Effect::SpeedDeviation { fraction } => {
                let v2 = v * (1.0 + fraction);
                let delay = (self.laser_m - self.lead_start_m) * (1.0 / v - 1.0 / v2);
                f[3] = self.wheel_start_m + v2 * ((apparent[3] - self.wheel_start_m) / v - delay);
            }
            _ => {}
        }
        f
    }
}

/// The library's effects as families to fit.
pub fn families(ctx: &Context) -> Vec<Family> {
    let mut out = Vec::new();
    let ln = f64::ln;
    for &k in &ctx.sleepers {
        out.push(Family {
            kind: "voided_sleeper",
            location: format!("sleeper {k}"),
            params: vec![Param::new("gap (mm)", 0.0, 5.0, 0.005)],
            seeds: vec![vec![0.2], vec![1.0]],
            build: Box::new(move |p| Effect::VoidedSleeper {
                sleeper: k,
                gap_mm: p[0],
            }),
        });
        out.push(Family {
            kind: "pad_stiffness",
            location: format!("sleeper {k}"),
            params: vec![Param::new("ln factor", ln(0.02), ln(50.0), 0.01)],
            seeds: vec![vec![ln(0.4)], vec![ln(2.5)]],
            build: Box::new(move |p| Effect::PadStiffness {
                sleeper: k,
                factor: p[0].exp(),
            }),
        });
        out.push(Family {
            kind: "ballast_stiffness",
            location: format!("sleeper {k}"),
            params: vec![Param::new("ln factor", ln(0.02), ln(50.0), 0.01)],
            seeds: vec![vec![ln(0.3)], vec![ln(3.0)]],
            build: Box::new(move |p| Effect::BallastStiffness {
                sleeper: k,
                factor: p[0].exp(),
            }),
        });
    }
    let lo = ctx
        .sensor_positions_m
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min);
    let hi = ctx
        .sensor_positions_m
        .iter()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max);
    let (x0, x1) = (lo - 1.4, hi + 1.4);
    let mut dip_seeds = Vec::new();
    let mut x = x0;
    while x <= x1 + 1e-9 {
        dip_seeds.push(vec![x, 0.5, 0.5]);
        x += 0.35;
    }
    out.push(Family {
        kind: "rail_dip",
        location: "rail".into(),
        params: vec![
            Param::new("position (m)", x0, x1, 0.005),
            Param::new("length (m)", 0.1, 3.0, 0.005),
            Param::new("depth (mm)", -3.0, 3.0, 0.005),
        ],
        seeds: dip_seeds,
        build: Box::new(|p| Effect::RailDip {
            position_m: p[0],
            length_m: p[1],
            depth_mm: p[2],
        }),
    });
    let quadrature = |a: f64| vec![[a, 0.0], [0.0, a], [-a, 0.0], [0.0, -a]];
    let mut irr_seeds = Vec::new();
    for lambda in [0.3, 0.5, 0.8, 1.2, 2.0, 3.0, 5.0] {
        for [s, c] in quadrature(0.2) {
            irr_seeds.push(vec![lambda, s, c]);
        }
    }
    out.push(Family {
        kind: "rail_irregularity",
        location: "whole rail".into(),
        params: vec![
            Param::new("wavelength (m)", 0.2, 6.0, 0.002),
            Param::new("A·cos φ (mm)", -3.0, 3.0, 0.005),
            Param::new("A·sin φ (mm)", -3.0, 3.0, 0.005),
        ],
        seeds: irr_seeds,
        build: Box::new(|p| Effect::RailIrregularity {
            wavelength_m: p[0],
            amplitude_mm: p[1].hypot(p[2]),
            phase_deg: p[2].atan2(p[1]).to_degrees(),
        }),
    });
    for &wheel in &ctx.wheels {
        for order in 1..=ctx.max_order {
            out.push(Family {
                kind: "wheel_out_of_round",
                location: format!("{} wheel, order {order}", wheel.name()),
                params: vec![
                    Param::new("A·cos φ (mm)", -3.0, 3.0, 0.005),
                    Param::new("A·sin φ (mm)", -3.0, 3.0, 0.005),
                ],
                seeds: vec![vec![0.1, 0.0], vec![0.0, 0.1]],
                build: Box::new(move |p| Effect::WheelOutOfRound {
                    wheel,
                    order,
                    amplitude_mm: p[0].hypot(p[1]),
                    phase_deg: p[1].atan2(p[0]).to_degrees(),
                }),
            });
        }
    }
    for name in &ctx.sensors {
        let sensor = name.clone();
        out.push(Family {
            kind: "sensor_gain",
            location: format!("sensor {name}"),
            params: vec![Param::new("ln factor", ln(0.2), ln(5.0), 0.005)],
            seeds: vec![vec![ln(0.7)], vec![ln(1.4)]],
            build: Box::new(move |p| Effect::SensorGain {
                sensor: sensor.clone(),
                factor: p[0].exp(),
            }),
        });
    }
    out.push(Family {
        kind: "time_offset",
        location: "recording clock".into(),
        params: vec![Param::new("offset (ms)", -30.0, 30.0, 0.05)],
        seeds: [-10.0, -4.0, -1.5, 1.5, 4.0, 10.0]
            .iter()
            .map(|&t| vec![t])
            .collect(),
        build: Box::new(|p| Effect::TimeOffset { offset_ms: p[0] }),
    });
    out.push(Family {
        kind: "speed_deviation",
        location: "train".into(),
        params: vec![Param::new("fraction", -0.3, 0.3, 5e-4)],
        seeds: [-0.08, -0.03, 0.03, 0.08]
            .iter()
            .map(|&t| vec![t])
            .collect(),
        build: Box::new(|p| Effect::SpeedDeviation { fraction: p[0] }),
    });
    let mut bounce_seeds = Vec::new();
    for f in [0.8, 1.2, 1.8, 2.5, 3.5, 5.0] {
        for [s, c] in quadrature(0.1) {
            bounce_seeds.push(vec![f, s, c]);
        }
    }
    out.push(Family {
        kind: "car_body_bounce",
        location: "car body".into(),
        params: vec![
            Param::new("frequency (Hz)", 0.3, 10.0, 0.002),
            Param::new("a·cos φ", -0.9, 0.9, 0.002),
            Param::new("a·sin φ", -0.9, 0.9, 0.002),
        ],
        seeds: bounce_seeds,
        build: Box::new(|p| Effect::CarBodyBounce {
            amplitude: p[1].hypot(p[2]).min(0.95),
            frequency_hz: p[0],
            phase_deg: p[2].atan2(p[1]).to_degrees(),
        }),
    });
    out
}

/// The location of an effect for people (finer than the family's for fitted positions).
fn location_of(family: &Family, e: &Effect) -> String {
    match e {
        Effect::RailDip {
            position_m,
            length_m,
            ..
        } => format!("x = {position_m:.2} m, {length_m:.2} m long"),
        Effect::RailIrregularity { wavelength_m, .. } => {
            format!("whole rail, wavelength {wavelength_m:.2} m")
        }
        Effect::CarBodyBounce { frequency_hz, .. } => format!("car body, {frequency_hz:.2} Hz"),
        _ => family.location.clone(),
    }
}

/// Whether two candidates are the same effect in the same place (a dip within a half bay).
fn same_place(a: &Candidate, b: &Candidate) -> bool {
    if a.kind != b.kind {
        return false;
    }
    match (&a.effect, &b.effect) {
        (
            Some(Effect::RailDip { position_m: x, .. }),
            Some(Effect::RailDip { position_m: y, .. }),
        ) => (x - y).abs() < 0.35,
        (
            Some(Effect::WheelOutOfRound { wheel: w1, .. }),
            Some(Effect::WheelOutOfRound { wheel: w2, .. }),
        ) => w1 == w2 && a.location == b.location,
        (Some(Effect::RailIrregularity { .. }), Some(Effect::RailIrregularity { .. }))
        | (Some(Effect::CarBodyBounce { .. }), Some(Effect::CarBodyBounce { .. }))
        | (Some(Effect::TimeOffset { .. }), Some(Effect::TimeOffset { .. }))
        | (Some(Effect::SpeedDeviation { .. }), Some(Effect::SpeedDeviation { .. })) => true,
        _ => a.location == b.location,
    }
}

/// What the naming needs of the identification besides the fitting problem.
pub struct Judge<'a> {
    /// Strike timing (see [`Timing`]).
    pub timing: Timing,
    /// Thresholds of the identification.
    pub identifier: &'a crate::identify::Identifier,
    /// Šídák per-sample probability over all samples.
    pub per_point_probability: f64,
}

#[derive(Clone)]
struct Fit {
    family: usize,
    x: Vec<f64>,
    sd: Vec<f64>,
    /// The flat as fitted (apparent impact position; [`Timing::actual`] gives the simulated).
    apparent: FlatVector,
    eval: Evaluation,
    joint: bool,
}

/// Fits every effect of `families` and names one if the evidence is clear. `flat0` is the
/// flat-only fit, `none` its evaluation.
pub fn name(
    problem: &Problem,
    judge: &Judge,
    families: &[Family],
    flat_params: &[Param],
    flat0: FlatVector,
    none: &Evaluation,
) -> Naming {
    let n = problem.samples();
    let ln_n = (n as f64).ln();
    let kinds: Vec<&str> = {
        let mut k: Vec<&str> = families.iter().map(|f| f.kind).collect();
        k.dedup();
        k
    };
    let per_kind = |kind: &str| families.iter().filter(|f| f.kind == kind).count();
    let bic = |chi2: f64, k: usize, kind: &str| {
        chi2 + k as f64 * ln_n + 2.0 * (per_kind(kind) as f64).ln()
    };
    // Stage 1: every seed, flat held.
    let seeds: Vec<(usize, usize)> = families
        .iter()
        .enumerate()
        .flat_map(|(f, fam)| (0..fam.seeds.len()).map(move |s| (f, s)))
        .collect();
    let seed_chi2: Vec<f64> = seeds
        .par_iter()
        .map(|&(f, s)| {
            let e = (families[f].build)(&families[f].seeds[s]);
            problem
                .evaluate(&judge.timing.actual(flat0, &e), &[e])
                .map_or(f64::INFINITY, |e| e.chi2)
        })
        .collect();
    // Stage 2: per kind, the two best seeds (of different families when it has several).
    let mut starts: Vec<(usize, usize)> = Vec::new();
    for kind in &kinds {
        let mut of_kind: Vec<usize> = (0..seeds.len())
            .filter(|&i| families[seeds[i].0].kind == *kind && seed_chi2[i].is_finite())
            .collect();
        of_kind.sort_by(|&a, &b| seed_chi2[a].total_cmp(&seed_chi2[b]));
        let several = per_kind(kind) > 1;
        let mut taken: Vec<(usize, usize)> = Vec::new();
        for i in of_kind {
            if taken.len() == 2 {
                break;
            }
            if several && taken.iter().any(|t| t.0 == seeds[i].0) {
                continue;
            }
            taken.push(seeds[i]);
        }
        starts.extend(taken);
    }
    let held: Vec<Fit> = starts
        .par_iter()
        .filter_map(|&(f, s)| {
            let fam = &families[f];
            // The impact position moves with every effect that shifts the series in time:
            // it is fitted here too; L, d and c are held.
            let mut params = vec![flat_params[3].clone()];
            params.extend(fam.params.iter().cloned());
            let mut x0 = vec![flat0[3]];
            x0.extend_from_slice(&fam.seeds[s]);
            let eval = |x: &[f64]| {
                let e = (fam.build)(&x[1..]);
                let flat = judge
                    .timing
                    .actual([flat0[0], flat0[1], flat0[2], x[0]], &e);
                problem.evaluate(&flat, &[e])
            };
            let r = levenberg_marquardt(&params, &x0, &eval, MAX_ITER)?;
            let apparent = [flat0[0], flat0[1], flat0[2], r.x[0]];
            Some(Fit {
                family: f,
                apparent,
                x: r.x[1..].to_vec(),
                sd: r.sd[1..].to_vec(),
                eval: r.eval,
                joint: false,
            })
        })
        .collect();
    // Stage 3: the best by BIC, refitted with the flat free.
    let mut order: Vec<usize> = (0..held.len()).collect();
    let score = |fit: &Fit| {
        let fam = &families[fit.family];
        let k = fam.params.len() + 4;
        bic(fit.eval.chi2, k, fam.kind)
    };
    order.sort_by(|&a, &b| score(&held[a]).total_cmp(&score(&held[b])));
    // The best of each of the JOINT best kinds, and the best kind's second place.
    let mut chosen: Vec<usize> = Vec::new();
    let mut kinds_taken: Vec<&str> = Vec::new();
    for &i in &order {
        let kind = families[held[i].family].kind;
        if kinds_taken.len() < JOINT && !kinds_taken.contains(&kind) {
            kinds_taken.push(kind);
            chosen.push(i);
        }
    }
    if let Some(&first) = chosen.first() {
        let f0 = &families[held[first].family];
        if let Some(&second) = order.iter().find(|&&i| {
            i != first
                && families[held[i].family].kind == f0.kind
                && families[held[i].family].location != f0.location
        }) {
            chosen.push(second);
        }
    }
    let joint: Vec<(usize, Option<Fit>)> = chosen
        .par_iter()
        .map(|&i| {
            let h = &held[i];
            let fam = &families[h.family];
            let mut params = flat_params.to_vec();
            params.extend(fam.params.iter().cloned());
            let mut x0 = h.apparent.to_vec();
            x0.extend_from_slice(&h.x);
            let eval = |x: &[f64]| {
                let e = (fam.build)(&x[4..]);
                let flat = judge.timing.actual([x[0], x[1], x[2], x[3]], &e);
                problem.evaluate(&flat, &[e])
            };
            let fit = levenberg_marquardt(&params, &x0, &eval, MAX_ITER_JOINT)
                .filter(|r| r.eval.chi2 <= h.eval.chi2)
                .map(|r| Fit {
                    family: h.family,
                    apparent: [r.x[0], r.x[1], r.x[2], r.x[3]],
                    x: r.x[4..].to_vec(),
                    sd: r.sd[4..].to_vec(),
                    eval: r.eval,
                    joint: true,
                });
            (i, fit)
        })
        .collect();
    let mut fits: Vec<Fit> = Vec::new();
    for &i in &order {
        match joint.iter().find(|(j, _)| *j == i) {
            Some((_, Some(_))) => {}
            _ => fits.push(held[i].clone()),
        }
    }
    fits.extend(joint.into_iter().filter_map(|(_, f)| f));
    let p = judge.per_point_probability;
    let to_candidate = |fit: &Fit| {
        let fam = &families[fit.family];
        let effect = (fam.build)(&fit.x);
        let (outside, gap) = problem.outside(judge.identifier, &fit.eval.predicted_kn, p);
        let k = fam.params.len() + 4;
        let z = chi2_z(fit.eval.chi2, (n - k) as f64);
        let flat = flat_mm(&judge.timing.actual(fit.apparent, &effect));
        Candidate {
            kind: fam.kind.to_string(),
            location: location_of(fam, &effect),
            effect: Some(effect),
            parameters: fam
                .params
                .iter()
                .zip(fit.x.iter().zip(&fit.sd))
                .map(|(p, (&v, &sd))| Estimate {
                    name: p.name.clone(),
                    value: v,
                    sd,
                })
                .collect(),
            flat,
            chi2: fit.eval.chi2,
            k,
            families: per_kind(fam.kind),
            bic: bic(fit.eval.chi2, k, fam.kind),
            chi2_z: z,
            adequate: z <= ADEQUATE_Z,
            joint: fit.joint,
            samples_outside: outside,
            gap_rms_kn: gap,
            fit_rms_kn: fit_rms(problem, &fit.eval),
            gains: fit.eval.gains.clone(),
        }
    };
    let mut ranking: Vec<Candidate> = fits.iter().map(to_candidate).collect();
    ranking.sort_by(|a, b| a.bic.total_cmp(&b.bic));
    // One entry per kind and place: the better fit of duplicates.
    let mut unique: Vec<Candidate> = Vec::new();
    for c in ranking {
        if !unique.iter().any(|u| same_place(u, &c)) {
            unique.push(c);
        }
    }
    let (outside0, gap0) = problem.outside(judge.identifier, &none.predicted_kn, p);
    let z0 = chi2_z(none.chi2, (n - 4) as f64);
    let no_effect = Candidate {
        kind: "none".into(),
        location: "—".into(),
        effect: None,
        parameters: Vec::new(),
        flat: flat_mm(&flat0),
        chi2: none.chi2,
        k: 4,
        families: 1,
        bic: none.chi2 + 4.0 * ln_n,
        chi2_z: z0,
        adequate: z0 <= ADEQUATE_Z,
        joint: true,
        samples_outside: outside0,
        gap_rms_kn: gap0,
        fit_rms_kn: fit_rms(problem, none),
        gains: none.gains.clone(),
    };
    let (named, over_none, over_runner, verdict) = decide(&unique, &no_effect);
    Naming {
        criterion: format!(
            "BIC = χ² + k·ln N + 2·ln M (N = {n} samples; σ = {:.3} kN noise, sensor factor prior {:.3} ± {:.3}); \
             an effect is named when its BIC is at least {CLEARLY_BETTER} below the flat alone's and the runner-up's \
             (another kind or place), and its fit leaves only noise (Wilson–Hilferty z of χ² ≤ {ADEQUATE_Z})",
            problem.noise().sigma_kn,
            problem.noise().gain_mean,
            problem.noise().gain_sd
        ),
        samples: n,
        no_effect,
        ranking: unique,
        named,
        evidence_over_none: over_none,
        evidence_over_runner_up: over_runner,
        verdict,
        simulations: problem.simulations(),
    }
}

/// The decision rule on a ranking (best BIC first).
fn decide(ranking: &[Candidate], none: &Candidate) -> (Option<usize>, f64, f64, String) {
    let Some(best) = ranking.first() else {
        return (
            None,
            0.0,
            0.0,
            "no effect could be fitted: no missing effect named".into(),
        );
    };
    let over_none = none.bic - best.bic;
    let over_runner = ranking
        .iter()
        .skip(1)
        .find(|c| !same_place(c, best))
        .map_or(f64::INFINITY, |c| c.bic - best.bic);
    let what = format!("{} at {}", best.kind, best.location);
    let named = over_none >= CLEARLY_BETTER && over_runner >= CLEARLY_BETTER && best.adequate;
    let verdict = if named {
        format!(
            "missing effect: {what} (ΔBIC {over_none:.0} over the flat alone, {over_runner:.0} over the runner-up; fit z = {:.1})",
            best.chi2_z
        )
    } else if over_none < CLEARLY_BETTER && none.adequate {
        format!(
            "no missing effect found: the flat alone, fitted between the bank's instances, leaves only noise (z = {:.1}) and no effect is clearly better (best: {what}, ΔBIC {over_none:.1})",
            none.chi2_z
        )
    } else if over_none < CLEARLY_BETTER {
        format!(
            "no effect in the library explains the disagreement better than the flat alone (best: {what}, ΔBIC {over_none:.1} < {CLEARLY_BETTER}; the flat alone leaves z = {:.1})",
            none.chi2_z
        )
    } else if !best.adequate {
        format!(
            "no effect in the library explains the disagreement: the best, {what}, reduces it (ΔBIC {over_none:.0}) but leaves more than noise (z = {:.1} > {ADEQUATE_Z})",
            best.chi2_z
        )
    } else {
        format!(
            "the disagreement is explained, but not uniquely: {what} and the runner-up are within ΔBIC {over_runner:.1} < {CLEARLY_BETTER}; no effect named"
        )
    };
    (named.then_some(0), over_none, over_runner, verdict)
}

/// `[L, d, c, X_p]` of a flat vector.
pub fn flat_mm(v: &FlatVector) -> [f64; 4] {
    [v[0], v[1], v[2] * v[1] / 2.0, v[3]]
}

fn fit_rms(problem: &Problem, e: &Evaluation) -> f64 {
    let s = problem.noise().sigma_kn;
    let n = problem.samples();
    let s2: f64 = e.weighted[..n].iter().map(|r| (r * s).powi(2)).sum();
    (s2 / n.max(1) as f64).sqrt()
}
