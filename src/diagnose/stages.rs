//! The stages of [`super::diagnose`] after locating a disagreement, each one lap of
//! `timings_s`: the flat alone fitted between the bank's instances ([`fit_flat_alone`]); the
//! noise read from the record and the flat refitted under it ([`under_the_records_noise`]);
//! every effect of the library fitted with the flat, one or a pair named
//! ([`name_effects`]); the named effects added on a local bank and the measurement identified
//! again ([`add_and_identify_again`]).

use super::{
    best_bank_instances, fit, library, locate, name, noise, restart, select, Added, DiagnoseError,
    Diagnosis, Located, Naming, Options, Stage,
};
use crate::identify::Identifier;
use crate::model::{CheckedCalibration, Effect, EffectKind, WheelPosition};
use crate::stopwatch::Stopwatch;

/// A candidate that adds a second flat.
const SECOND_FLAT: name::CandidateKind = name::CandidateKind::Effect(EffectKind::SecondFlat);
use rayon::prelude::*;
use std::path::Path;

/// The flat alone, fitted to the record: the problem it was fitted in, its parameters' bounds,
/// the fit, the judge of thresholds and strike timing, the wheel, and the samples it leaves
/// outside the thresholds.
pub(super) struct FlatOnly<'a> {
    pub(super) problem: fit::Problem<'a>,
    pub(super) flat_params: Vec<fit::Param>,
    pub(super) best: fit::Fitted,
    pub(super) judge: name::Judge<'a>,
    pub(super) wheel: WheelPosition,
    pub(super) outside: usize,
}

impl FlatOnly<'_> {
    /// The fitted flat `[L, d, c (mm), X_p (m)]`.
    pub(super) fn flat(&self) -> fit::FlatVector {
        let x = &self.best.x;
        [x[0], x[1], x[2], x[3]]
    }
}

/// Stage 2: the flat alone, fitted between the bank's instances: Levenberg–Marquardt from the
/// best bank instances and from the best one with X_p on a 20 mm grid over the fit's X_p
/// bounds (a series shifted in time puts the apparent impact outside the bank), then the same
/// restart as every effect's joint fit gets ([`restart`]), so that an effect never wins over
/// the flat alone by a better search alone.
pub(super) fn fit_flat_alone<'a>(
    identifier: &'a Identifier,
    obs: &'a [fit::Observed],
    opts: &Options,
    cal: &CheckedCalibration,
    before: &Located,
) -> Result<FlatOnly<'a>, DiagnoseError> {
    let noise = fit::NoiseModel::from_settings(identifier.settings());
    let starts = best_bank_instances(identifier, noise, obs, opts.starts)?;
    let wheel = starts[0].2;
    let problem = fit::Problem::new(cal.document().clone(), obs, noise, wheel);
    let flat_params = fit::flat_params(&cal.population);
    let chi2_of = |v: &fit::FlatVector| problem.chi2(v, &[]);
    let fit_from = |v: &fit::FlatVector| {
        let eval = |x: &[f64]| problem.evaluate(&[x[0], x[1], x[2], x[3]], &[]);
        fit::levenberg_marquardt(&flat_params, v, &eval, 12)
    };
    let xp = &flat_params[3];
    let mut grid: Vec<fit::FlatVector> = Vec::new();
    let mut x = xp.lo;
    while x <= xp.hi + 1e-9 {
        grid.push([starts[0].1[0], starts[0].1[1], starts[0].1[2], x]);
        x += 0.02;
    }
    let mut scored: Vec<(f64, fit::FlatVector)> =
        grid.par_iter().map(|v| (chi2_of(v), *v)).collect();
    scored.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut all_starts: Vec<fit::FlatVector> = starts.iter().map(|s| s.1).collect();
    all_starts.extend(scored.iter().take(2).map(|s| s.1));
    let fits: Vec<fit::Fitted> = all_starts.par_iter().filter_map(fit_from).collect();
    let best = fits
        .into_iter()
        .min_by(|a, b| a.eval.chi2.total_cmp(&b.eval.chi2))
        .ok_or(DiagnoseError::FlatOnlyFit)?;
    let start = [best.x[0], best.x[1], best.x[2], best.x[3]];
    let best = restart::flat_restart(&flat_params, start, best.eval.chi2, &chi2_of)
        .and_then(|v| fit_from(&v))
        .filter(|r| r.eval.chi2 < best.eval.chi2)
        .unwrap_or(best);
    let lead = cal.run.leading_wheel_start_m;
    let judge = name::Judge {
        timing: name::Timing {
            speed_m_per_s: cal.speed_m_per_s(),
            wheel_start_m: lead - 2.0 * cal.vehicle.half_wheelbase_m * wheel.index() as f64,
            lead_start_m: lead,
            laser_m: cal.sensors.laser_trigger_m,
        },
        identifier,
        per_point_probability: before.per_point_probability,
    };
    let (outside, _) = problem.outside(
        identifier,
        &best.eval.predicted_kn,
        judge.per_point_probability,
    );
    Ok(FlatOnly {
        problem,
        flat_params,
        best,
        judge,
        wheel,
        outside,
    })
}

/// Stage 3: the noise from the record ([`estimate_noise`]; the table's when
/// `opts.noise_from_data` is off), and the flat alone refitted under it.
pub(super) fn under_the_records_noise<'a>(
    f: FlatOnly<'a>,
    opts: &Options,
    cal: &CheckedCalibration,
) -> (FlatOnly<'a>, noise::NoiseEstimate) {
    let (estimate, mut noise_model) = estimate_noise(&f.problem, &f.best, &f.judge.timing, cal);
    if !opts.noise_from_data {
        noise_model = f.problem.noise();
    }
    let problem = f.problem.with_noise(noise_model);
    let best = {
        let eval = |x: &[f64]| problem.evaluate(&[x[0], x[1], x[2], x[3]], &[]);
        fit::levenberg_marquardt(&f.flat_params, &f.best.x, &eval, 6).unwrap_or(f.best)
    };
    (FlatOnly { problem, best, ..f }, estimate)
}

/// Stage 4: every effect of the library fitted with the flat and ranked ([`name::name`]);
/// when the best single effect is clearly better than the flat alone but leaves more than
/// noise, forward selection to a pair ([`select::forward`]) from it and, when that names no
/// pair, from the best of the next kind too (the best single fit may be a stand-in for two).
/// Noise above the table is a finding of its own when no effect is named: the site should
/// hear which table entry to change, not that nothing explains the record. Sets the
/// diagnosis's verdict (and its noise finding).
pub(super) fn name_effects(
    f: &FlatOnly<'_>,
    opts: &Options,
    cal: &CheckedCalibration,
    estimate: &noise::NoiseEstimate,
    out: &mut Diagnosis,
) -> Naming {
    let (problem, judge) = (&f.problem, &f.judge);
    let flat0 = f.flat();
    let bays = cal.track.bays;
    let ctx = name::Context {
        sleepers: (1..bays).collect(),
        sensors: problem
            .observed()
            .iter()
            .map(|o| o.sensor.clone())
            .collect(),
        sensor_positions_m: problem
            .observed()
            .iter()
            .filter_map(|o| cal.sensor_index(&o.sensor))
            .map(|i| cal.sensor_position_m(i))
            .collect(),
        rail_m: [0.0, bays as f64 * cal.track.sleeper_spacing_m],
        wheels: vec![WheelPosition::Leading, WheelPosition::Trailing],
        max_order: opts.max_order,
        flat: (f.wheel, flat0[3]),
        circumference_m: std::f64::consts::TAU * cal.vehicle.wheel_radius_m,
        // A second flat is often smaller than the population's flats: from 10 mm and 0.05 mm.
        length_mm: [10.0, cal.population.length_mm[1]],
        depth_mm: [0.05, cal.population.depth_mm[1]],
    };
    let families = name::families(&ctx);
    let mut naming = name::name(
        problem,
        judge,
        &families,
        &f.flat_params,
        flat0,
        &f.best.eval,
    );
    out.verdict = naming.verdict.clone();
    let needs_more = naming.ranking.first().is_some_and(|c| !c.adequate);
    if naming.evidence_over_none >= name::CLEARLY_BETTER && needs_more {
        let mut firsts: Vec<&name::Candidate> = Vec::new();
        for c in &naming.ranking {
            if firsts.len() < 2 && !firsts.iter().any(|f| f.kind == c.kind) {
                firsts.push(c);
            }
        }
        let mut chosen: Option<select::SecondStep> = None;
        for (i, first) in firsts.into_iter().enumerate() {
            // (No single effect is named here: the best one leaves more than noise.)
            if i > 0 && chosen.as_ref().is_some_and(|s| s.named) {
                break;
            }
            let step = select::forward(
                problem,
                judge,
                &families,
                &f.flat_params,
                first,
                &naming.ranking,
            );
            let pair_bic =
                |s: &select::SecondStep| s.ranking.first().map_or(f64::INFINITY, |c| c.bic);
            let better = match &chosen {
                None => true,
                Some(c) => (step.named, -pair_bic(&step)) > (c.named, -pair_bic(c)),
            };
            if better {
                chosen = Some(step);
            }
        }
        if let Some(step) = chosen {
            out.verdict = if step.named {
                step.verdict.clone()
            } else {
                format!("{}; forward selection: {}", naming.verdict, step.verdict)
            };
            naming.second = Some(step);
        }
    }
    naming.simulations = problem.simulations();
    naming.second_flat_l0_mm = named_second_flat_l0(&naming, cal.vehicle.wheel_radius_m);
    if naming.named_effects().is_empty() {
        let table = &judge.identifier.settings().uncertainty;
        if let Some(found) = estimate
            .sigma_estimated_kn
            .and_then(|s| noise::NoiseAboveTable::of(s, estimate.rho, table))
        {
            out.verdict = format!(
                "{}; with it, the library's effects: {}",
                found.words(),
                out.verdict
            );
            out.noise_above_table = Some(found);
        }
    }
    naming
}

/// What identifying again needs: the original identifier and measurement, the bank's
/// calibration, the flat's wheel, and the observer of the local bank's generation.
pub(super) struct Again<'a> {
    pub(super) identifier: &'a Identifier,
    pub(super) m: &'a crate::identify::Measurement,
    pub(super) sensors: Option<&'a [String]>,
    pub(super) cal: &'a CheckedCalibration,
    pub(super) wheel: WheelPosition,
    pub(super) observer: &'a dyn crate::bank::GenerateObserver,
}

/// Stage 5: the named effects added to the calibration; a local bank around the fitted flat
/// (± 1.5 cells of the original bank in each parameter, a cell the population span /
/// instances^(1/4), within the original ranges; a few cells of X_p, not a revolution: not
/// folded) generated in `dir`; the measurement identified again on it and located.
pub(super) fn add_and_identify_again(
    a: &Again<'_>,
    named: &[Effect],
    flat: [f64; 4],
    opts: &Options,
    dir: &Path,
    clock: &mut Stopwatch,
) -> Result<Added, DiagnoseError> {
    let (cal, wheel) = (a.cal, a.wheel);
    let bank = a.identifier.bank();
    let mut doc = cal.unfolded();
    doc.effects.extend(named.iter().cloned());
    let pop = &cal.population;
    let cell = (bank.instances().max(1) as f64).powf(-0.25) * 1.5;
    let around = |v: f64, r: [f64; 2]| {
        let (v, w) = (v.clamp(r[0], r[1]), cell * (r[1] - r[0]));
        [(v - w).max(r[0]), (v + w).min(r[1])]
    };
    let [l, d, cc, xp] = flat;
    doc.population.length_mm = around(l, pop.length_mm);
    doc.population.depth_mm = around(d, pop.depth_mm);
    let mut cr = around(cc, pop.curvature_mm);
    cr[0] = cr[0].min(0.9 * doc.population.depth_mm[0] / 2.0);
    doc.population.curvature_mm = cr;
    doc.population.impact_position_m = around(xp, pop.impact_position_m);
    if doc.population.flat_wheels.is_some() {
        doc.population.flat_wheels = Some(vec![wheel]);
    }
    let local_ranges = [
        doc.population.length_mm,
        doc.population.depth_mm,
        doc.population.curvature_mm,
        doc.population.impact_position_m,
    ];
    let with = doc.check().map_err(|source| DiagnoseError::Calibration {
        what: "the calibration with the effect",
        source,
    })?;
    let gen = crate::bank::GenerateOptions {
        instances: opts.local_instances,
        seed: 0,
        shard_size: opts.local_instances.clamp(1, 5000),
        machine_shard: None,
        format: crate::bank::StorageFormat::default(),
        simulate_missing: true,
        // A study bank: what its passes need is computed when first needed.
        tables: false,
    };
    crate::bank::generate(&with, dir, &gen, a.observer)?;
    clock.lap("local bank");
    let local = Identifier::new(
        crate::bank::Bank::open(dir)?,
        a.identifier.settings().clone(),
    )?;
    let again = local.identify(a.m, a.sensors, crate::identify::Extras::AS_RECORDED)?;
    let sized = again
        .sizing
        .as_ref()
        .ok_or(crate::audit::AuditError::NoFlatDetected)?;
    let after = locate(&local, &again, sized)?;
    let after_stage = Stage::of(&again, sized, &after);
    clock.lap("identify again");
    // The bank's own calibration with the effect: what a regenerated bank is built from.
    let mut whole = cal.document().clone();
    whole.effects.extend(named.iter().cloned());
    Ok(Added {
        calibration_toml: whole.to_toml_string(),
        local_bank: dir.display().to_string(),
        local_ranges,
        after,
        after_stage,
        identification: again,
    })
}

/// The L0 range of a named second flat, single or in a pair.
fn named_second_flat_l0(naming: &Naming, wheel_radius_m: f64) -> Option<[f64; 2]> {
    let n = naming.samples;
    match (&naming.second, naming.named) {
        (Some(s), _) if s.named => {
            let pair = s.ranking.first()?;
            if pair.kind == SECOND_FLAT {
                library::second_flat_l0_mm(pair, false, wheel_radius_m, n)
            } else if s.first.kind == SECOND_FLAT {
                library::second_flat_l0_mm(pair, true, wheel_radius_m, n)
            } else {
                None
            }
        }
        (_, Some(i)) if naming.ranking[i].kind == SECOND_FLAT => {
            library::second_flat_l0_mm(&naming.ranking[i], false, wheel_radius_m, n)
        }
        _ => None,
    }
}

/// The noise of the record: σ and ρ estimated from the flat-free parts of the flat-only
/// fit's residual ([`noise`]), and the noise model the fits use from then on.
pub(super) fn estimate_noise(
    problem: &fit::Problem,
    best: &fit::Fitted,
    timing: &name::Timing,
    cal: &crate::model::CheckedCalibration,
) -> (noise::NoiseEstimate, fit::NoiseModel) {
    let table = problem.noise();
    let rate = cal.output.sample_rate_hz;
    let obs = problem.observed();
    let flat = [best.x[0], best.x[1], best.x[2], best.x[3]];
    let v = timing.speed_m_per_s;
    let t_end = obs
        .iter()
        .map(|o| (o.first_sample + o.values_kn.len()) as f64 / rate)
        .fold(0.0, f64::max);
    // The strikes as the integrator schedules them, widened by the noise estimate's margins.
    let strikes: Vec<(f64, f64)> = fit::make_flat(&flat, problem.wheel())
        .map(|f| {
            let schedule = crate::model::schedule::strike_zones(
                &f,
                timing.wheel_start_m,
                v,
                cal.vehicle.wheel_radius_m,
                t_end,
                &cal.integration,
            );
            schedule
                .strike_times_s
                .iter()
                .map(|t| {
                    (
                        t - noise::STRIKE_BEFORE_S,
                        t + f.length_m() / v + noise::STRIKE_AFTER_S,
                    )
                })
                .collect()
        })
        .unwrap_or_default();
    let residuals: Vec<Vec<f64>> = obs
        .iter()
        .zip(&best.eval.predicted_kn)
        .zip(&best.eval.gains)
        .map(|((o, g), a)| o.values_kn.iter().zip(g).map(|(y, g)| y - a * g).collect())
        .collect();
    let keep = noise::flat_free(
        &obs.iter().map(|o| o.first_sample).collect::<Vec<_>>(),
        &obs.iter().map(|o| o.values_kn.len()).collect::<Vec<_>>(),
        rate,
        &strikes,
    );
    let found = noise::estimate(&residuals, &keep);
    let (sigma_hat, rho, samples) = found.map_or((None, 0.0, 0), |(s, r, n)| (Some(s), r, n));
    let used = sigma_hat.map_or(table.sigma_kn, |s| s.max(table.sigma_kn));
    (
        noise::NoiseEstimate {
            sigma_table_kn: table.sigma_kn,
            sigma_estimated_kn: sigma_hat,
            rho,
            samples,
            sigma_used_kn: used,
        },
        fit::NoiseModel {
            sigma_kn: used,
            rho,
            ..table
        },
    )
}
