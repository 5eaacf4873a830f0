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
//!    kind's second place (or, for a kind of one family, its next two starts), are refitted
//!    with the flat parameters free as well — from the held fit's flat and from a restart
//!    found with the effect held ([`super::restart`]), the better kept.
//!
//! `BIC = χ² + k·ln N + 2·ln M`: k the continuous parameters fitted (4 for the flat plus the
//! effect's), N the samples compared, M the families of the kind (a uniform prior over the
//! discrete choices: the more places an effect may sit, the more it must explain).

use super::fit::{levenberg_marquardt, Evaluation, FlatVector, Param, Problem, Role};
pub use super::library::{families, Context, EffectChoice};
use super::library::{location_of, sleeper_of};
pub use super::outcome::{Candidate, CandidateKind, Estimate, Naming};
use super::restart::fit_with_restart;
use crate::model::{Effect, EffectKind};
use rayon::prelude::*;

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

/// Whether two candidates are the same effect in the same place: a sleeper effect within one
/// sleeper, a dip within a half bay, a second flat on the same wheel.
pub(crate) fn same_place(a: &Candidate, b: &Candidate) -> bool {
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
        (
            Some(Effect::SecondFlat { wheel: w1, .. }),
            Some(Effect::SecondFlat { wheel: w2, .. }),
        ) => w1 == w2,
        (Some(Effect::RailIrregularity { .. }), Some(Effect::RailIrregularity { .. }))
        | (Some(Effect::CarBodyBounce { .. }), Some(Effect::CarBodyBounce { .. }))
        | (Some(Effect::TimeOffset { .. }), Some(Effect::TimeOffset { .. }))
        | (Some(Effect::SpeedDeviation { .. }), Some(Effect::SpeedDeviation { .. })) => true,
        (Some(e1), Some(e2)) => match (sleeper_of(e1), sleeper_of(e2)) {
            (Some(k1), Some(k2)) => k1.abs_diff(k2) <= 1,
            _ => a.location == b.location,
        },
        _ => a.location == b.location,
    }
}

/// How well the place of `best` is known: the places of its kind whose fits come within
/// [`CLEARLY_BETTER`] of its BIC (`all`, every fit before duplicates were merged), and for a
/// fitted position its ± 2 standard deviations.
pub(crate) fn place_uncertainty(best: &Candidate, all: &[Candidate]) -> String {
    let near: Vec<&Candidate> = all
        .iter()
        .filter(|c| c.kind == best.kind && c.bic - best.bic < CLEARLY_BETTER)
        .collect();
    let position = |c: &Candidate| match &c.effect {
        Some(Effect::RailDip { position_m, .. }) => Some(*position_m),
        Some(Effect::SecondFlat {
            impact_position_m, ..
        }) => Some(*impact_position_m),
        _ => None,
    };
    let sd = |c: &Candidate, role: Role| {
        c.parameters
            .iter()
            .find(|p| p.role == role && !p.of_first)
            .map(|p| p.sd)
            .filter(|s| s.is_finite())
    };
    if let Some(k) = best.effect.as_ref().and_then(sleeper_of) {
        let ks: Vec<usize> = near
            .iter()
            .filter_map(|c| c.effect.as_ref().and_then(sleeper_of))
            .collect();
        let (lo, hi) = (
            ks.iter().copied().min().unwrap_or(k),
            ks.iter().copied().max().unwrap_or(k),
        );
        if lo == hi {
            format!("sleeper {k}; no other sleeper within ΔBIC {CLEARLY_BETTER}")
        } else {
            format!("sleeper {k}; sleepers {lo}–{hi} within ΔBIC {CLEARLY_BETTER}")
        }
    } else if let Some(x) = position(best) {
        let xs: Vec<f64> = near.iter().filter_map(|c| position(c)).collect();
        let (lo, hi) = xs.iter().fold((x, x), |(a, b), &v| (a.min(v), b.max(v)));
        let sd = sd(best, Role::Position);
        format!(
            "x = {x:.3} m{}; fits within ΔBIC {CLEARLY_BETTER} span {lo:.3}–{hi:.3} m",
            sd.map_or(String::new(), |s| format!(" ± {:.3} m (2 sd)", 2.0 * s))
        )
    } else {
        best.location.clone()
    }
}

/// The seeds (indices into `seeds`, best first) a kind's fits start from: two, of different
/// families when the kind has several; for families that spread (a dip, a second flat on
/// each wheel), each family's [`super::library::Spread`]: its `seeds` best at least `apart`
/// apart in parameter `param`.
/// Effect family `fam` fitted from `seed` over its parameters and X_p, the flat's L, d, c held
/// at `flat` and the effects `held` held too (none for a single effect). The impact position
/// moves with every effect that shifts the series in time, so it is fitted here too. The
/// result's `x` and `sd` are `[X_p, the effect's parameters…]`.
pub(crate) fn fit_held(
    problem: &Problem,
    judge: &Judge,
    flat_params: &[Param],
    fam: &EffectChoice,
    seed: &[f64],
    flat: FlatVector,
    held: &[Effect],
) -> Option<super::fit::Fitted> {
    let mut params = vec![flat_params[3].clone()];
    params.extend(fam.params.iter().cloned());
    let mut x0 = vec![flat[3]];
    x0.extend_from_slice(seed);
    let eval = |x: &[f64]| {
        let e = (fam.build)(&x[1..]);
        let apparent = [flat[0], flat[1], flat[2], x[0]];
        let actual = held
            .iter()
            .chain([&e])
            .fold(apparent, |f, effect| judge.timing.actual(f, effect));
        let mut effects = held.to_vec();
        effects.push(e);
        problem.evaluate(&actual, &effects)
    };
    levenberg_marquardt(&params, &x0, &eval, MAX_ITER)
}

/// The starts of kind `kind` among `seeds` (family, seed) scored `seed_chi2`: its finite
/// seeds best first, picked by [`pick_starts`].
pub(crate) fn kind_starts(
    families: &[EffectChoice],
    seeds: &[(usize, usize)],
    seed_chi2: &[f64],
    kind: EffectKind,
) -> Vec<(usize, usize)> {
    let mut of_kind: Vec<usize> = (0..seeds.len())
        .filter(|&i| families[seeds[i].0].kind == kind && seed_chi2[i].is_finite())
        .collect();
    of_kind.sort_by(|&a, &b| seed_chi2[a].total_cmp(&seed_chi2[b]));
    let several = families.iter().filter(|f| f.kind == kind).count() > 1;
    pick_starts(families, seeds, &of_kind, several)
}

fn pick_starts(
    families: &[EffectChoice],
    seeds: &[(usize, usize)],
    best_first: &[usize],
    several: bool,
) -> Vec<(usize, usize)> {
    let mut taken: Vec<(usize, usize)> = Vec::new();
    for &i in best_first {
        let (f, s) = seeds[i];
        let fam = &families[f];
        let clash = match fam.spread {
            // Spread seeds: up to `seeds` of this family, at least `apart` apart in `param`.
            Some(sp) => {
                let mine: Vec<&(usize, usize)> = taken.iter().filter(|t| t.0 == f).collect();
                let p = sp.param;
                mine.len() >= sp.seeds
                    || mine
                        .iter()
                        .any(|&&(_, ts)| (fam.seeds[ts][p] - fam.seeds[s][p]).abs() < sp.apart)
            }
            None => taken.len() >= 2 || (several && taken.iter().any(|t| t.0 == f)),
        };
        if !clash {
            taken.push((f, s));
        }
    }
    taken
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
    families: &[EffectChoice],
    flat_params: &[Param],
    flat0: FlatVector,
    none: &Evaluation,
) -> Naming {
    let n = problem.samples();
    let ln_n = (n as f64).ln();
    let kinds: Vec<EffectKind> = {
        let mut k: Vec<EffectKind> = families.iter().map(|f| f.kind).collect();
        k.dedup();
        k
    };
    let per_kind = |kind: EffectKind| families.iter().filter(|f| f.kind == kind).count();
    let bic = |chi2: f64, k: usize, kind: EffectKind| {
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
            problem.chi2(&judge.timing.actual(flat0, &e), &[e])
        })
        .collect();
    // Stage 2: per kind, the two best seeds (of different families when it has several).
    let starts: Vec<(usize, usize)> = kinds
        .iter()
        .flat_map(|&kind| kind_starts(families, &seeds, &seed_chi2, kind))
        .collect();
    let held: Vec<Fit> = starts
        .par_iter()
        .filter_map(|&(f, s)| {
            let fam = &families[f];
            let r = fit_held(problem, judge, flat_params, fam, &fam.seeds[s], flat0, &[])?;
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
    let mut kinds_taken: Vec<EffectKind> = Vec::new();
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
        // A kind of one family (a clock, a dip, a bounce) has no second place: its other
        // starts are refitted with the flat free too, since with the flat held the best start
        // may sit in a local minimum that another escapes.
        if per_kind(f0.kind) == 1 {
            let others: Vec<usize> = order
                .iter()
                .copied()
                .filter(|&i| i != first && held[i].family == held[first].family)
                .take(2)
                .collect();
            chosen.extend(others);
        }
    }
    let joint: Vec<(usize, Option<Fit>)> = chosen
        .par_iter()
        .map(|&i| {
            let h = &held[i];
            let fam = &families[h.family];
            let mut params = flat_params.to_vec();
            params.extend(fam.params.iter().cloned());
            let eval = |x: &[f64]| {
                let e = (fam.build)(&x[4..]);
                let flat = judge.timing.actual([x[0], x[1], x[2], x[3]], &e);
                problem.evaluate(&flat, &[e])
            };
            let from = |start: FlatVector| {
                let mut x0 = start.to_vec();
                x0.extend_from_slice(&h.x);
                levenberg_marquardt(&params, &x0, &eval, MAX_ITER_JOINT)
            };
            // From the held fit's flat, and from the grid's best flat with the effect held
            // when that fits better ([`super::restart`]).
            let e = (fam.build)(&h.x);
            let chi2_of = |v: &FlatVector| {
                problem.chi2(&judge.timing.actual(*v, &e), std::slice::from_ref(&e))
            };
            let fit = fit_with_restart(flat_params, h.apparent, h.eval.chi2, &chi2_of, from)
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
            kind: CandidateKind::Effect(fam.kind),
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
                    role: p.role,
                    of_first: false,
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
            family: fit.family,
            apparent: fit.apparent,
        }
    };
    let mut ranking: Vec<Candidate> = fits.iter().map(to_candidate).collect();
    ranking.sort_by(|a, b| a.bic.total_cmp(&b.bic));
    // One entry per kind and place: the better fit of duplicates.
    let mut unique: Vec<Candidate> = Vec::new();
    for c in ranking.iter().cloned() {
        if !unique.iter().any(|u| same_place(u, &c)) {
            unique.push(c);
        }
    }
    let (outside0, gap0) = problem.outside(judge.identifier, &none.predicted_kn, p);
    let z0 = chi2_z(none.chi2, (n - 4) as f64);
    let no_effect = Candidate {
        kind: CandidateKind::None,
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
        family: usize::MAX,
        apparent: flat0,
    };
    let (named, over_none, over_runner, verdict) = decide(&unique, &no_effect);
    let place = unique.first().map(|b| place_uncertainty(b, &ranking));
    Naming {
        criterion: format!(
            "BIC = χ² + k·ln N + 2·ln M (N = {n} samples; noise σ = {:.3} kN, AR(1) ρ = {:.2}, sensor factor prior {:.3} ± {:.3}); \
             an effect is named when its BIC is at least {CLEARLY_BETTER} below the flat alone's and the runner-up's \
             (another kind or place), and its fit leaves only noise (Wilson–Hilferty z of χ² ≤ {ADEQUATE_Z})",
            problem.noise().sigma_kn,
            problem.noise().rho,
            problem.noise().gain_mean,
            problem.noise().gain_sd
        ),
        samples: n,
        no_effect,
        ranking: unique,
        named,
        place,
        evidence_over_none: over_none,
        evidence_over_runner_up: over_runner,
        verdict,
        simulations: problem.simulations(),
        second: None,
        second_flat_l0_mm: None,
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

/// RMS of `a_s g − y` over all samples (kN).
pub(crate) fn fit_rms(problem: &Problem, e: &Evaluation) -> f64 {
    let mut s2 = 0.0;
    for ((o, g), a) in problem.observed().iter().zip(&e.predicted_kn).zip(&e.gains) {
        s2 += g
            .iter()
            .zip(&o.values_kn)
            .map(|(g, y)| (a * g - y).powi(2))
            .sum::<f64>();
    }
    (s2 / problem.samples().max(1) as f64).sqrt()
}
