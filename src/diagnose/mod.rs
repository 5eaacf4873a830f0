//! Diagnosis (issue #5): *locate* where simulation and measurement disagree, *name* the missing
//! effect ([`name`]), *add* it to the calibration and identify again on a local bank, and show
//! the gap before and after ([`diagnose`]).
//!
//! Locate ([`locate`]), fit the flat alone, estimate the noise from the record ([`noise`]),
//! name up to two effects ([`name`], [`select`]), and add them and identify again.

pub mod fit;
pub mod library;
pub mod locate;
pub mod name;
pub mod noise;
pub mod restart;
pub mod select;

use crate::audit::AuditError;
use crate::identify::{Identification, Identifier};
use serde::{Deserialize, Serialize};

pub use locate::{locate, GapWindow, Located, SensorGap, MERGE_SAMPLES};

/// Options of a diagnosis.
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
    /// Instances of the local bank regenerated with the named effect.
    pub local_instances: usize,
    /// Where to write the local bank (None: no bank is regenerated, naming only).
    pub local_bank_dir: Option<std::path::PathBuf>,
    /// Highest polygon order tried for out-of-round wheels.
    pub max_order: u32,
    /// Bank instances (best by χ² over the whole series) the flat-only fit starts from.
    pub starts: usize,
    /// Estimate the noise from the record ([`noise`]); false keeps the table's independent
    /// noise (the diagnosis before issue 15, kept to measure against).
    pub noise_from_data: bool,
}

impl Default for Options {
    fn default() -> Options {
        Options {
            local_instances: 1000,
            local_bank_dir: None,
            max_order: 12,
            starts: 4,
            noise_from_data: true,
        }
    }
}

/// One identification's agreement with the measurement, in numbers.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Stage {
    /// Bank identity.
    pub bank_id: String,
    /// Instances in the bank.
    pub bank_instances: usize,
    /// Candidate model set size.
    pub cms: usize,
    /// L0 range of the CMS (mm), None when empty.
    pub l0_mm: Option<[f64; 2]>,
    /// The best instance (residual minimisation).
    pub best_instance: u32,
    /// Its L0 (mm).
    pub best_l0_mm: f64,
    /// RMS residual of the best instance over all samples (kN).
    pub rms_residual_kn: f64,
    /// Samples outside the thresholds.
    pub samples_outside: usize,
    /// Samples compared.
    pub samples: usize,
    /// RMS excess over the thresholds (kN).
    pub gap_rms_kn: f64,
}

impl Stage {
    fn of(id: &Identification, l: &Located) -> Stage {
        Stage {
            bank_id: id.bank_id.clone(),
            bank_instances: id.bank_instances,
            cms: id.cms.len(),
            l0_mm: id
                .falsifications
                .first()
                .and_then(|f| f.ranges.as_ref())
                .map(|r| r.l0_mm),
            best_instance: id.residual_minimisation.as_ref().map_or(0, |r| r.instance),
            best_l0_mm: id
                .residual_minimisation
                .as_ref()
                .map_or(f64::NAN, |r| r.l0_mm),
            rms_residual_kn: l.rms_residual_kn,
            samples_outside: l.samples_outside,
            samples: l.sensors.iter().map(|s| s.samples).sum(),
            gap_rms_kn: l.gap_rms_kn,
        }
    }
}

/// The effect added and what identification says with it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Added {
    /// The bank's calibration with the effect (TOML; its whole population), as written next to
    /// the report.
    pub calibration_toml: String,
    /// The local bank: where, and over which flat ranges.
    pub local_bank: String,
    /// Its population ranges `[L, d, c, X_p]`, each `[min, max]`.
    pub local_ranges: [[f64; 2]; 4],
    /// Where the gap is after.
    pub after: Located,
    /// The numbers after.
    pub after_stage: Stage,
    /// The identification after.
    pub identification: Identification,
}

/// A whole diagnosis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Diagnosis {
    /// The measurement file.
    pub measurement: String,
    /// Where the gap is before.
    pub before: Located,
    /// The numbers before.
    pub before_stage: Stage,
    /// The noise estimated from the record (None when there was nothing to explain).
    #[serde(default)]
    pub noise: Option<noise::NoiseEstimate>,
    /// The record's noise when it is above the uncertainty table and no effect is named: the
    /// finding, with the table entry to change.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise_above_table: Option<noise::NoiseAboveTable>,
    /// The ranking of the effects (None when there was nothing to explain).
    pub naming: Option<Naming>,
    /// The effect added, when one was named and a local bank asked for.
    pub added: Option<Added>,
    /// The verdict in words.
    pub verdict: String,
    /// Wall-clock of the stages (s).
    pub timings_s: Vec<(String, f64)>,
}

pub use name::{Candidate, Naming};

/// Errors of a diagnosis.
#[derive(Debug, thiserror::Error)]
pub enum DiagnoseError {
    /// Reading the bank or simulating.
    #[error(transparent)]
    Audit(#[from] AuditError),
    /// Reading or writing a bank.
    #[error(transparent)]
    Bank(#[from] crate::bank::BankError),
    /// Identifying again.
    #[error(transparent)]
    Identify(#[from] crate::identify::IdentifyError),
    /// Something else.
    #[error("{0}")]
    Other(String),
}

/// The measured series on the bank's windows.
pub fn observed(identifier: &Identifier, id: &Identification) -> Vec<fit::Observed> {
    let meta = identifier.bank().metadata();
    id.series
        .iter()
        .filter_map(|s| {
            let axis = meta.sensors.iter().find(|a| a.name == s.sensor)?;
            Some(fit::Observed {
                sensor: s.sensor.clone(),
                first_sample: axis.first_sample,
                values_kn: s.values_kn.clone(),
            })
        })
        .collect()
}

/// The `k` bank instances that fit the whole series best (χ² with the sensor factors profiled,
/// every 4th sample at most 256 per sensor), all on the best one's wheel: `(instance, flat
/// vector, wheel)`.
pub fn best_bank_instances(
    identifier: &Identifier,
    noise: fit::NoiseModel,
    observed: &[fit::Observed],
    k: usize,
) -> Result<Vec<(u32, fit::FlatVector, crate::model::WheelPosition)>, DiagnoseError> {
    let bank = identifier.bank();
    let meta = bank.metadata();
    let mut cols = Vec::new();
    // Per observed series: (index into `cols`, sample).
    let mut picks: Vec<Vec<(usize, usize)>> = vec![Vec::new(); observed.len()];
    for (o, series_picks) in observed.iter().zip(&mut picks) {
        let Some(s) = meta.sensors.iter().position(|a| a.name == o.sensor) else {
            continue;
        };
        let n = o.values_kn.len();
        let stride = (n / 256).max(4).min(n.max(1));
        for kk in (0..n).step_by(stride) {
            series_picks.push((cols.len(), kk));
            cols.push(bank.sample_index(s, kk));
        }
    }
    let data = bank.read_columns(&cols)?;
    let params = bank.read_parameters()?;
    let n_inst = bank.instances();
    use rayon::prelude::*;
    let chi2: Vec<f64> = (0..n_inst)
        .into_par_iter()
        .map(|i| {
            let mut total = 0.0;
            for (ob, series_picks) in observed.iter().zip(&picks) {
                let (mut gy, mut gg, mut yy) = (0.0, 0.0, 0.0);
                for &(c, kk) in series_picks {
                    let g = f64::from(data[c][i]);
                    let y = ob.values_kn[kk];
                    gy += g * y;
                    gg += g * g;
                    yy += y * y;
                }
                let a = noise.profiled_gain(gy, gg);
                total += (a * a * gg - 2.0 * a * gy + yy) / noise.sigma_kn.powi(2)
                    + ((a - noise.gain_mean) / noise.gain_sd).powi(2);
            }
            total
        })
        .collect();
    let mut order: Vec<usize> = (0..n_inst).filter(|&i| chi2[i].is_finite()).collect();
    order.sort_by(|&a, &b| chi2[a].total_cmp(&chi2[b]));
    let Some(&first) = order.first() else {
        return Err(DiagnoseError::Other(
            "no bank instance could be compared".into(),
        ));
    };
    let wheel = crate::model::WheelPosition::from_code(params.flat_wheel[first]);
    Ok(order
        .into_iter()
        .filter(|&i| params.flat_wheel[i] == params.flat_wheel[first])
        .take(k)
        .map(|i| {
            (
                params.instance[i],
                fit::flat_vector(
                    params.length_mm[i],
                    params.depth_mm[i],
                    params.curvature_mm[i],
                    params.impact_position_m[i],
                ),
                wheel,
            )
        })
        .collect())
}

/// The L0 range of a named second flat, single or in a pair.
fn named_second_flat_l0(naming: &Naming, wheel_radius_m: f64) -> Option<[f64; 2]> {
    let n = naming.samples;
    match (&naming.second, naming.named) {
        (Some(s), _) if s.named => {
            let pair = s.ranking.first()?;
            if pair.kind == "second_flat" {
                library::second_flat_l0_mm(pair, false, wheel_radius_m, n)
            } else if s.first.kind == "second_flat" {
                library::second_flat_l0_mm(pair, true, wheel_radius_m, n)
            } else {
                None
            }
        }
        (_, Some(i)) if naming.ranking[i].kind == "second_flat" => {
            library::second_flat_l0_mm(&naming.ranking[i], false, wheel_radius_m, n)
        }
        _ => None,
    }
}

/// A pass on the bank's time axis for diagnosis, and a note when its speed line was set
/// aside: within [`crate::bank::family::SPEED_TOLERANCE`] of the bank's speed the pass is resampled
/// ([`crate::identify::Measurement::at_bank_speed`]); farther, where identification refuses,
/// diagnosis takes the record as it is, on the bank's time axis, and lets the data speak:
/// a speed deviation, if named, is the speed the record shows.
pub fn on_bank_speed(
    m: &crate::identify::Measurement,
    bank_km_per_h: f64,
) -> Result<(crate::identify::Measurement, Option<String>), DiagnoseError> {
    match (m.at_bank_speed(bank_km_per_h), m.speed_km_per_h) {
        (Ok(on), _) => Ok((on.into_owned(), None)),
        (Err(_), Some(line)) => {
            let mut as_recorded = m.clone();
            as_recorded.speed_km_per_h = None;
            Ok((
                as_recorded,
                Some(format!(
                    "the speed line says {line} km/h, {:+.1} % from the bank's {bank_km_per_h} km/h, beyond the {:.0} % a bank covers: diagnosed as recorded on the bank's time axis; a speed deviation, if named, is the record's own speed",
                    (line / bank_km_per_h - 1.0) * 100.0,
                    crate::bank::family::SPEED_TOLERANCE * 100.0
                )),
            ))
        }
        (Err(e), None) => Err(e.into()),
    }
}

/// The noise of the record: σ and ρ estimated from the flat-free parts of the flat-only
/// fit's residual ([`noise`]), and the noise model the fits use from then on.
fn estimate_noise(
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

/// Diagnoses identification `id` of measurement `m` (made by `identifier`, with `sensors`):
/// locate, and when the model disagrees, fit the flat alone and with every effect, name one if
/// the evidence is clear, and (with `opts.local_bank_dir`) add it, regenerate a local bank and
/// identify again.
pub fn diagnose(
    identifier: &Identifier,
    m: &crate::identify::Measurement,
    sensors: Option<&[String]>,
    id: &Identification,
    opts: &Options,
    observer: &dyn crate::bank::GenerateObserver,
) -> Result<Diagnosis, DiagnoseError> {
    let mut timings = Vec::new();
    let mut clock = std::time::Instant::now();
    let mut lap = |name: &str, timings: &mut Vec<(String, f64)>| {
        timings.push((name.to_string(), clock.elapsed().as_secs_f64()));
        clock = std::time::Instant::now();
    };
    let before = locate(identifier, id)?;
    let before_stage = Stage::of(id, &before);
    lap("locate", &mut timings);
    let mut out = Diagnosis {
        measurement: id.measurement.clone(),
        before,
        before_stage,
        noise: None,
        noise_above_table: None,
        naming: None,
        added: None,
        verdict: String::new(),
        timings_s: Vec::new(),
    };
    if out.before.samples_outside == 0 {
        out.verdict = format!(
            "no missing effect found: the best instance ({}) agrees with the measurement within the thresholds at all {} samples",
            out.before.instance, out.before_stage.samples
        );
        out.timings_s = timings;
        return Ok(out);
    }
    let bank = identifier.bank();
    let cal = bank
        .metadata()
        .calibration
        .clone()
        .check()
        .map_err(|e| DiagnoseError::Other(format!("the bank's calibration: {e}")))?;
    let noise = fit::NoiseModel::from_settings(identifier.settings());
    let obs = observed(identifier, id);
    let starts = best_bank_instances(identifier, noise, &obs, opts.starts)?;
    let wheel = starts[0].2;
    let problem = fit::Problem::new(cal.document().clone(), &obs, noise, wheel);
    let flat_params = fit::flat_params(&cal.population);
    use rayon::prelude::*;
    // Starts: the best bank instances, and the best one with X_p on a 20 mm grid over the
    // fit's X_p bounds (a series shifted in time puts the apparent impact outside the bank).
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
        .ok_or_else(|| DiagnoseError::Other("the flat-only fit failed at every start".into()))?;
    // The same restart as every effect's joint fit gets ([`restart`]), so that an effect
    // never wins over the flat alone by a better search alone.
    let start = [best.x[0], best.x[1], best.x[2], best.x[3]];
    let best = restart::flat_restart(&flat_params, start, best.eval.chi2, &chi2_of)
        .and_then(|v| fit_from(&v))
        .filter(|r| r.eval.chi2 < best.eval.chi2)
        .unwrap_or(best);
    let flat0 = [best.x[0], best.x[1], best.x[2], best.x[3]];
    lap("flat-only fit", &mut timings);
    let lead = cal.run.leading_wheel_start_m;
    let judge = name::Judge {
        timing: name::Timing {
            speed_m_per_s: cal.speed_m_per_s(),
            wheel_start_m: lead - 2.0 * cal.vehicle.half_wheelbase_m * wheel.index() as f64,
            lead_start_m: lead,
            laser_m: cal.sensors.laser_trigger_m,
        },
        identifier,
        per_point_probability: out.before.per_point_probability,
    };
    let (outside0, _) = problem.outside(
        identifier,
        &best.eval.predicted_kn,
        judge.per_point_probability,
    );
    if outside0 == 0 {
        out.verdict = format!(
            "no missing effect found: the flat alone, fitted between the bank's instances (L {:.1} mm, d {:.3} mm, X_p {:.4} m), agrees within the thresholds at every sample; the {} samples outside were the bank's resolution",
            flat0[0], flat0[1], flat0[3], out.before.samples_outside
        );
        out.timings_s = timings;
        return Ok(out);
    }
    // The noise from the record; the flat alone refitted under it.
    let (estimate, mut noise_model) = estimate_noise(&problem, &best, &judge.timing, &cal);
    if !opts.noise_from_data {
        noise_model = problem.noise();
    }
    out.noise = Some(estimate);
    let problem = problem.with_noise(noise_model);
    let best = {
        let eval = |x: &[f64]| problem.evaluate(&[x[0], x[1], x[2], x[3]], &[]);
        fit::levenberg_marquardt(&flat_params, &best.x, &eval, 6).unwrap_or(best)
    };
    let flat0 = [best.x[0], best.x[1], best.x[2], best.x[3]];
    lap("noise", &mut timings);
    let bays = cal.track.bays;
    let ctx = name::Context {
        sleepers: (1..bays).collect(),
        sensors: obs.iter().map(|o| o.sensor.clone()).collect(),
        sensor_positions_m: obs
            .iter()
            .filter_map(|o| cal.sensor_index(&o.sensor))
            .map(|i| cal.sensor_position_m(i))
            .collect(),
        rail_m: [0.0, bays as f64 * cal.track.sleeper_spacing_m],
        wheels: vec![
            crate::model::WheelPosition::Leading,
            crate::model::WheelPosition::Trailing,
        ],
        max_order: opts.max_order,
        flat: (wheel, flat0[3]),
        circumference_m: std::f64::consts::TAU * cal.vehicle.wheel_radius_m,
        // A second flat is often smaller than the population's flats: from 10 mm and 0.05 mm.
        length_mm: [10.0, cal.population.length_mm[1]],
        depth_mm: [0.05, cal.population.depth_mm[1]],
    };
    let families = name::families(&ctx);
    let mut naming = name::name(&problem, &judge, &families, &flat_params, flat0, &best.eval);
    out.verdict = naming.verdict.clone();
    // Two effects: forward selection from the best single one when it is clearly better than
    // the flat alone but leaves more than noise (a fit that leaves only noise needs nothing
    // more); when that gives no pair, from the best of the next kind too (the best single
    // fit may be a stand-in for two).
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
                &problem,
                &judge,
                &families,
                &flat_params,
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
    // Noise above the table is a finding of its own when no effect is named: the site should
    // hear which table entry to change, not that nothing explains the record.
    let named = naming.named_effects();
    if named.is_empty() {
        let table = &identifier.settings().uncertainty;
        if let Some(f) = estimate
            .sigma_estimated_kn
            .and_then(|s| noise::NoiseAboveTable::of(s, estimate.rho, table))
        {
            out.verdict = format!(
                "{}; with it, the library's effects: {}",
                f.words(),
                out.verdict
            );
            out.noise_above_table = Some(f);
        }
    }
    lap("name", &mut timings);
    if let (Some(flat), Some(dir)) = (naming.named_flat(), &opts.local_bank_dir) {
        let mut doc = cal.unfolded(); // a few cells of X_p, not a revolution: not folded
        doc.effects.extend(named.iter().cloned());
        // The local bank: the fitted flat ± 1.5 cells of the original bank in each parameter
        // (a cell: the population span / instances^(1/4)), within the original ranges.
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
        let with = doc
            .check()
            .map_err(|e| DiagnoseError::Other(format!("the calibration with the effect: {e}")))?;
        let gen = crate::bank::GenerateOptions {
            instances: opts.local_instances,
            seed: 0,
            shard_size: opts.local_instances.clamp(1, 5000),
            machine_shard: None,
            format: crate::bank::StorageFormat::default(),
            simulate_missing: true,
        };
        crate::bank::generate(&with, dir, &gen, observer)?;
        lap("local bank", &mut timings);
        let local = Identifier::new(crate::bank::Bank::open(dir)?, identifier.settings().clone())?;
        let again = local.identify(m, sensors, crate::identify::Extras::AS_RECORDED)?;
        let after = locate(&local, &again)?;
        let after_stage = Stage::of(&again, &after);
        lap("identify again", &mut timings);
        // The bank's own calibration with the effect: what a regenerated bank is built from.
        let mut whole = cal.document().clone();
        whole.effects.extend(named.iter().cloned());
        out.added = Some(Added {
            calibration_toml: whole.to_toml_string(),
            local_bank: dir.display().to_string(),
            local_ranges,
            after,
            after_stage,
            identification: again,
        });
    }
    out.naming = Some(naming);
    out.timings_s = timings;
    Ok(out)
}
