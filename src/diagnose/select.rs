//! Two effects at once: forward selection by BIC. When the best single effect is
//! clearly better than the flat alone but leaves more than noise, every other family is fitted
//! *with it held* (seeds, then Levenberg–Marquardt over the new effect and X_p), the best
//! [`PAIRS`] pairs are refitted with the flat and both effects free (from the held fit's flat
//! and from a restart, [`super::restart`]), and the best pair is named
//! when each effect is supported on its own: its BIC at least [`CLEARLY_BETTER`] below the
//! first effect alone's *and* below the second's alone, and what it leaves is noise.
//!
//! BIC of a pair: `χ² + k·ln N + 2·ln M₁ + 2·ln M₂` (k: the flat's 4 and both effects'
//! parameters; M the families of each kind, as for one effect).

use super::fit::{levenberg_marquardt, Evaluation, FlatVector, Param, Problem};
use super::library::{location_of, EffectChoice};
use super::name::{
    chi2_z, fit_held, fit_rms, flat_mm, kind_starts, same_place, Candidate, CandidateKind,
    Estimate, Judge, ADEQUATE_Z, CLEARLY_BETTER,
};
pub(crate) use super::outcome::SecondStep;
use super::restart::fit_with_restart;
use crate::model::{Effect, EffectKind};
use rayon::prelude::*;

/// Kinds (by their best seed's χ²) whose starts are fitted as the second effect.
pub(crate) const SECOND_KINDS: usize = 4;
/// Pairs refitted with the flat and both effects free.
pub(crate) const PAIRS: usize = 2;
/// Levenberg–Marquardt Jacobians, second effect fitted with the first held.
const MAX_ITER: usize = 10;
/// Jacobians of a joint fit.
const MAX_ITER_JOINT: usize = 20;

/// The flat that, with both effects, strikes when `apparent` would without them.
fn actual2(judge: &Judge, apparent: FlatVector, e1: &Effect, e2: &Effect) -> FlatVector {
    judge.timing.actual(judge.timing.actual(apparent, e1), e2)
}

/// Forward selection from `first` (a candidate of [`super::name::name`]'s ranking); `singles`
/// is that ranking (for the second effect's own BIC).
pub(crate) fn forward(
    problem: &Problem,
    judge: &Judge,
    families: &[EffectChoice],
    flat_params: &[Param],
    first: &Candidate,
    singles: &[Candidate],
) -> SecondStep {
    let n = problem.samples();
    let ln_n = (n as f64).ln();
    let per_kind = |kind: EffectKind| families.iter().filter(|f| f.kind == kind).count();
    let f1 = &families[first.family];
    let x1: Vec<f64> = first.parameters.iter().map(|p| p.value).collect();
    let e1 = (f1.build)(&x1);
    let apparent = first.apparent;
    let penalty = |f: &EffectChoice| 2.0 * (per_kind(f.kind) as f64).ln();
    // Seeds of every other family, the first effect and the flat held.
    let seeds: Vec<(usize, usize)> = families
        .iter()
        .enumerate()
        .filter(|(f, fam)| *f != first.family && !(fam.kind == f1.kind && fam.spread.is_some()))
        .flat_map(|(f, fam)| (0..fam.seeds.len()).map(move |s| (f, s)))
        .collect();
    let seed_chi2: Vec<f64> = seeds
        .par_iter()
        .map(|&(f, s)| {
            let e2 = (families[f].build)(&families[f].seeds[s]);
            let flat = actual2(judge, apparent, &e1, &e2);
            problem.chi2(&flat, &[e1.clone(), e2])
        })
        .collect();
    // The SECOND_KINDS kinds whose best seed fits best, their starts.
    let mut kinds: Vec<(EffectKind, f64)> = Vec::new();
    for (i, &(f, _)) in seeds.iter().enumerate() {
        let kind = families[f].kind;
        match kinds.iter_mut().find(|k| k.0 == kind) {
            Some(k) => k.1 = k.1.min(seed_chi2[i]),
            None => kinds.push((kind, seed_chi2[i])),
        }
    }
    kinds.sort_by(|a, b| a.1.total_cmp(&b.1));
    let starts: Vec<(usize, usize)> = kinds
        .iter()
        .take(SECOND_KINDS)
        .flat_map(|&(kind, _)| kind_starts(families, &seeds, &seed_chi2, kind))
        .collect();
    // The second effect and X_p fitted, the first held.
    let held: Vec<(usize, Vec<f64>, f64, Evaluation)> = starts
        .par_iter()
        .filter_map(|&(f, s)| {
            let fam = &families[f];
            let held = std::slice::from_ref(&e1);
            let r = fit_held(
                problem,
                judge,
                flat_params,
                fam,
                &fam.seeds[s],
                apparent,
                held,
            )?;
            Some((f, r.x[1..].to_vec(), r.x[0], r.eval))
        })
        .collect();
    let k_pair = |f2: &EffectChoice| 4 + f1.params.len() + f2.params.len();
    let bic_pair =
        |chi2: f64, f2: &EffectChoice| chi2 + k_pair(f2) as f64 * ln_n + penalty(f1) + penalty(f2);
    let mut order: Vec<usize> = (0..held.len()).collect();
    order.sort_by(|&a, &b| {
        let (fa, fb) = (&families[held[a].0], &families[held[b].0]);
        bic_pair(held[a].3.chi2, fa).total_cmp(&bic_pair(held[b].3.chi2, fb))
    });
    // The best PAIRS pairs, flat and both effects free.
    let k1 = f1.params.len();
    let joint: Vec<Candidate> = order
        .iter()
        .take(PAIRS)
        .map(|&i| {
            let (f, x2, xp, held_eval) = &held[i];
            let fam = &families[*f];
            let mut params = flat_params.to_vec();
            params.extend(f1.params.iter().cloned());
            params.extend(fam.params.iter().cloned());
            let start = [apparent[0], apparent[1], apparent[2], *xp];
            let mut x0 = start.to_vec();
            x0.extend_from_slice(&x1);
            x0.extend_from_slice(x2);
            let eval = |x: &[f64]| {
                let (a, b) = ((f1.build)(&x[4..4 + k1]), (fam.build)(&x[4 + k1..]));
                let flat = actual2(judge, [x[0], x[1], x[2], x[3]], &a, &b);
                problem.evaluate(&flat, &[a, b])
            };
            // From the held fit's flat, and from the grid's best flat with both effects held
            // when that fits better ([`super::restart`]).
            let held = [e1.clone(), (fam.build)(x2)];
            let chi2_of =
                |v: &FlatVector| problem.chi2(&actual2(judge, *v, &held[0], &held[1]), &held);
            let from = |v: FlatVector| {
                let mut x = x0.clone();
                x[..4].copy_from_slice(&v);
                levenberg_marquardt(&params, &x, &eval, MAX_ITER_JOINT)
            };
            let r = fit_with_restart(flat_params, start, held_eval.chi2, &chi2_of, from)
                .filter(|r| r.eval.chi2 <= held_eval.chi2)
                .map(|r| (r.x, r.sd, r.eval))
                .unwrap_or_else(|| (x0.clone(), vec![f64::NAN; x0.len()], held_eval.clone()));
            let (x, sd, ev) = r;
            let (a, b) = ((f1.build)(&x[4..4 + k1]), (fam.build)(&x[4 + k1..]));
            let flat_apparent = [x[0], x[1], x[2], x[3]];
            let k = k_pair(fam);
            let z = chi2_z(ev.chi2, (n - k) as f64);
            let (outside, gap) = problem.outside(
                judge.identifier,
                &ev.predicted_kn,
                judge.per_point_probability,
            );
            let estimates = |params: &[Param], x: &[f64], sd: &[f64], of_first: bool| {
                params
                    .iter()
                    .zip(x.iter().zip(sd))
                    .map(|(p, (&v, &s))| Estimate {
                        name: format!("{}{}", if of_first { "first: " } else { "" }, p.name),
                        value: v,
                        sd: s,
                        role: p.role,
                        of_first,
                    })
                    .collect::<Vec<_>>()
            };
            // The second effect's parameters, then the first's at the joint fit ("first: …").
            let mut parameters = estimates(&fam.params, &x[4 + k1..], &sd[4 + k1..], false);
            parameters.extend(estimates(&f1.params, &x[4..4 + k1], &sd[4..4 + k1], true));
            Candidate {
                kind: CandidateKind::Effect(fam.kind),
                location: location_of(fam, &b),
                flat: flat_mm(&actual2(judge, flat_apparent, &a, &b)),
                effect: Some(b),
                parameters,
                chi2: ev.chi2,
                k,
                families: per_kind(fam.kind),
                bic: bic_pair(ev.chi2, fam),
                joint: true,
                chi2_z: z,
                adequate: z <= ADEQUATE_Z,
                samples_outside: outside,
                gap_rms_kn: gap,
                fit_rms_kn: fit_rms(problem, &ev),
                gains: ev.gains.clone(),
                family: *f,
                apparent: flat_apparent,
            }
        })
        .collect();
    let mut ranking = joint;
    ranking.sort_by(|a, b| a.bic.total_cmp(&b.bic));
    let Some(best) = ranking.first() else {
        return SecondStep {
            first: first.clone(),
            ranking,
            effects: vec![e1],
            evidence_over_first: 0.0,
            evidence_over_second: 0.0,
            named: false,
            verdict: "no second effect could be fitted".into(),
        };
    };
    let first_x: Vec<f64> = best
        .parameters
        .iter()
        .filter(|p| p.of_first)
        .map(|p| p.value)
        .collect();
    let effects = vec![
        (f1.build)(&first_x),
        best.effect.clone().expect("a pair has its second effect"),
    ];
    let over_first = first.bic - best.bic;
    // The second effect alone: the best single fit of its kind and place when the single
    // stage made one, else refitted here with the flat from the pair's values.
    let fitted_alone = singles
        .iter()
        .filter(|c| same_place(c, best))
        .map(|c| c.bic)
        .fold(f64::INFINITY, f64::min);
    let second_alone = if fitted_alone.is_finite() {
        fitted_alone
    } else {
        let fam = &families[best.family];
        let k2 = fam.params.len();
        let mut params = flat_params.to_vec();
        params.extend(fam.params.iter().cloned());
        let mut x0 = best.apparent.to_vec();
        x0.extend(best.parameters.iter().take(k2).map(|p| p.value));
        let eval = |x: &[f64]| {
            let e2 = (fam.build)(&x[4..]);
            let flat = judge.timing.actual([x[0], x[1], x[2], x[3]], &e2);
            problem.evaluate(&flat, &[e2])
        };
        levenberg_marquardt(&params, &x0, &eval, MAX_ITER).map_or(f64::INFINITY, |r| {
            r.eval.chi2 + (4 + k2) as f64 * ln_n + penalty(fam)
        })
    };
    let over_second = second_alone - best.bic;
    let named = over_first >= CLEARLY_BETTER && over_second >= CLEARLY_BETTER && best.adequate;
    let what = format!(
        "{} at {} and {} at {}",
        first.kind, first.location, best.kind, best.location
    );
    let verdict = if named {
        format!(
            "missing effects: {what} (ΔBIC {over_first:.0} over the first alone, {over_second:.0} over the second alone; fit z = {:.1})",
            best.chi2_z
        )
    } else if over_first < CLEARLY_BETTER || over_second < CLEARLY_BETTER {
        format!(
            "a second effect is not supported on its own: best pair {what} (ΔBIC {over_first:.1} over the first alone, {over_second:.1} over the second alone; {CLEARLY_BETTER} needed)"
        )
    } else {
        format!(
            "no pair of library effects explains the disagreement: the best, {what}, leaves more than noise (z = {:.1} > {ADEQUATE_Z})",
            best.chi2_z
        )
    };
    SecondStep {
        first: first.clone(),
        ranking,
        effects,
        evidence_over_first: over_first,
        evidence_over_second: over_second,
        named,
        verdict,
    }
}
