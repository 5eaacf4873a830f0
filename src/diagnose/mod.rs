//! Diagnosis (issue #5): *locate* where simulation and measurement disagree, *name* the missing
//! effect ([`name`]), *add* it to the calibration and identify again on a local bank, and show
//! the gap before and after ([`diagnose`]).
//!
//! Locate: the best instance of an identification (the residual-minimisation optimum) is compared
//! with the measurement at every sample of every sensor. The thresholds are Šídák over all
//! those samples, `φ^(1/N)`, so that clean data leaves them anywhere with probability ≤ 1 − φ.
//! They are widened sample by sample by the instance's cell (κ × the largest difference to its
//! neighbours' predictions, as in falsification). Samples outside are gathered per sensor into time
//! windows (runs of samples outside, gaps of up to [`MERGE_SAMPLES`] bridged), each with the
//! track positions of the bogie centre and the wheels.

pub mod fit;
pub mod name;
pub mod suite;

use crate::audit::AuditError;
use crate::identify::{Identification, Identifier};
use serde::{Deserialize, Serialize};

/// Runs of samples outside the thresholds closer than this are one window.
pub const MERGE_SAMPLES: usize = 5;

/// A time window where the residual leaves the thresholds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GapWindow {
    /// Bank time span (s).
    pub time_s: [f64; 2],
    /// Bogie-centre position over the span (m along the rail).
    pub bogie_centre_m: [f64; 2],
    /// Leading and trailing wheel positions at the window's largest excess (m).
    pub wheels_m: [f64; 2],
    /// Samples outside in the window.
    pub samples_outside: usize,
    /// Largest excess beyond the thresholds (kN).
    pub max_outside_kn: f64,
}

/// One sensor's disagreement.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SensorGap {
    /// Sensor.
    pub sensor: String,
    /// Samples compared.
    pub samples: usize,
    /// Samples outside the thresholds.
    pub samples_outside: usize,
    /// Expected outside by chance, `(1 − p)·samples` (independent samples; systematic errors
    /// make exceedances cluster, but their total probability stays ≤ 1 − φ).
    pub expected_by_chance: f64,
    /// RMS of the residual (kN).
    pub rms_residual_kn: f64,
    /// RMS of the excess over the thresholds (0 inside), all samples (kN).
    pub gap_rms_kn: f64,
    /// Windows where it leaves the thresholds, largest excess first.
    pub windows: Vec<GapWindow>,
    /// Residual (prediction − measurement) per sample (kN), for the plot.
    pub residual_kn: Vec<f64>,
    /// Thresholds per sample, widened by the instance's cell (kN).
    pub thresholds_kn: Vec<[f64; 2]>,
}

/// Where the best instance and the measurement disagree.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Located {
    /// The instance compared (the residual-minimisation optimum).
    pub instance: u32,
    /// Per-sample probability of the thresholds, `φ^(1/N)` over all N samples.
    pub per_point_probability: f64,
    /// Per sensor of the measurement.
    pub sensors: Vec<SensorGap>,
    /// RMS residual over all samples (kN).
    pub rms_residual_kn: f64,
    /// RMS of the excess over the thresholds (0 inside) over all samples (kN): the gap.
    pub gap_rms_kn: f64,
    /// Samples outside over all sensors.
    pub samples_outside: usize,
    /// Expected by chance over all sensors.
    pub expected_by_chance: f64,
}

/// Locates the disagreement of identification `id` (made by `identifier`).
pub fn locate(identifier: &Identifier, id: &Identification) -> Result<Located, AuditError> {
    let bank = identifier.bank();
    let meta = bank.metadata();
    let cal = &meta.calibration;
    let best = id.residual_minimisation.instance;
    let stored = bank.read_instance(best as usize)?;
    // The instance stands for its cell: its thresholds widen by κ × the largest difference to
    // its neighbours' predictions, sample by sample, as in falsification.
    let resolution = identifier.resolution();
    let neighbours: Vec<crate::bank::StoredInstance> = match resolution {
        Some(r) => r
            .cells
            .neighbours(best as usize)
            .iter()
            .map(|&j| bank.read_instance(j as usize))
            .collect::<Result<_, _>>()?,
        None => Vec::new(),
    };
    let kappa = resolution.map_or(0.0, |r| r.kappa);
    // Šídák over every sample compared: clean data leaves the thresholds anywhere with
    // probability ≤ 1 − φ, whatever the correlation the systematic errors bring.
    let total: usize = id.series.iter().map(|s| s.values_kn.len()).sum();
    let p = identifier.settings().phi.powf(1.0 / total.max(1) as f64);
    let v = cal.run.speed_km_per_h / 3.6;
    let lead0 = cal.run.leading_wheel_start_m;
    let hb = cal.vehicle.half_wheelbase_m;
    let mut sensors = Vec::new();
    let (mut sum2, mut count, mut outside_all, mut expected_all) = (0.0, 0usize, 0usize, 0.0);
    let mut gap2 = 0.0;
    for ser in &id.series {
        let Some(axis) = meta.sensors.iter().position(|a| a.name == ser.sensor) else {
            continue;
        };
        let g = &stored.forces_kn[axis];
        let time = |k: usize| ser.t0_s + k as f64 / ser.sample_rate_hz;
        let mut residual = Vec::with_capacity(g.len());
        let mut thresholds = Vec::with_capacity(g.len());
        let mut excess = Vec::with_capacity(g.len());
        for (k, (&gk, &y)) in g.iter().zip(&ser.values_kn).enumerate() {
            let r = gk as f64 - y;
            let spread = neighbours
                .iter()
                .map(|n| (n.forces_kn[axis][k] - gk).abs() as f64)
                .fold(0.0, f64::max);
            let (lo, hi) = identifier.thresholds(y, p);
            let (lo, hi) = (lo - kappa * spread, hi + kappa * spread);
            residual.push(r);
            thresholds.push([lo, hi]);
            excess.push((r - hi).max(lo - r));
        }
        let outside: Vec<usize> = (0..excess.len()).filter(|&k| excess[k] > 0.0).collect();
        // Windows: runs of outside samples, gaps up to MERGE_SAMPLES bridged.
        let mut windows: Vec<GapWindow> = Vec::new();
        let mut start = 0;
        while start < outside.len() {
            let mut end = start;
            while end + 1 < outside.len() && outside[end + 1] - outside[end] <= MERGE_SAMPLES {
                end += 1;
            }
            let (k0, k1) = (outside[start], outside[end]);
            let kmax = outside[start..=end]
                .iter()
                .copied()
                .max_by(|&a, &b| excess[a].total_cmp(&excess[b]))
                .expect("a window has samples");
            let centre = |t: f64| lead0 - hb + v * t;
            windows.push(GapWindow {
                time_s: [time(k0), time(k1)],
                bogie_centre_m: [centre(time(k0)), centre(time(k1))],
                wheels_m: [centre(time(kmax)) + hb, centre(time(kmax)) - hb],
                samples_outside: end - start + 1,
                max_outside_kn: excess[kmax],
            });
            start = end + 1;
        }
        windows.sort_by(|a, b| b.max_outside_kn.total_cmp(&a.max_outside_kn));
        let s2: f64 = residual.iter().map(|r| r * r).sum();
        let e2: f64 = excess.iter().map(|e| e.max(0.0).powi(2)).sum();
        gap2 += e2;
        sum2 += s2;
        count += residual.len();
        outside_all += outside.len();
        let expected = (1.0 - p) * residual.len() as f64;
        expected_all += expected;
        sensors.push(SensorGap {
            sensor: ser.sensor.clone(),
            samples: residual.len(),
            samples_outside: outside.len(),
            expected_by_chance: expected,
            rms_residual_kn: (s2 / residual.len().max(1) as f64).sqrt(),
            gap_rms_kn: (e2 / residual.len().max(1) as f64).sqrt(),
            windows,
            residual_kn: residual,
            thresholds_kn: thresholds,
        });
    }
    Ok(Located {
        instance: best,
        per_point_probability: p,
        sensors,
        rms_residual_kn: (sum2 / count.max(1) as f64).sqrt(),
        gap_rms_kn: (gap2 / count.max(1) as f64).sqrt(),
        samples_outside: outside_all,
        expected_by_chance: expected_all,
    })
}

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
}

impl Default for Options {
    fn default() -> Options {
        Options {
            local_instances: 1000,
            local_bank_dir: None,
            max_order: 12,
            starts: 4,
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
            best_instance: id.residual_minimisation.instance,
            best_l0_mm: id.residual_minimisation.l0_mm,
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
    /// The calibration with the effect (TOML), as written next to the report.
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

/// Sleepers to try: those of the two sensors with the most samples outside, and their
/// neighbours.
fn candidate_sleepers(l: &Located, cal: &crate::model::CheckedCalibration) -> Vec<usize> {
    let mut by: Vec<&SensorGap> = l.sensors.iter().filter(|s| s.samples_outside > 0).collect();
    by.sort_by_key(|s| std::cmp::Reverse(s.samples_outside));
    let bays = cal.track.bays;
    let mut out = Vec::new();
    for s in by.iter().take(2) {
        if let Some(i) = cal.sensor_index(&s.sensor) {
            let k = cal.sensors.pad[i].sleeper;
            for kk in [k.saturating_sub(1), k, k + 1] {
                if (1..bays).contains(&kk) && !out.contains(&kk) {
                    out.push(kk);
                }
            }
        }
    }
    out.sort_unstable();
    out
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
    let xp = &flat_params[3];
    let mut grid: Vec<fit::FlatVector> = Vec::new();
    let mut x = xp.lo;
    while x <= xp.hi + 1e-9 {
        grid.push([starts[0].1[0], starts[0].1[1], starts[0].1[2], x]);
        x += 0.02;
    }
    let mut scored: Vec<(f64, fit::FlatVector)> = grid
        .par_iter()
        .map(|v| {
            let chi2 = problem.evaluate(v, &[]).map_or(f64::INFINITY, |e| e.chi2);
            (chi2, *v)
        })
        .collect();
    scored.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut all_starts: Vec<fit::FlatVector> = starts.iter().map(|s| s.1).collect();
    all_starts.extend(scored.iter().take(2).map(|s| s.1));
    let fits: Vec<fit::Fitted> = all_starts
        .par_iter()
        .filter_map(|v| {
            let eval = |x: &[f64]| problem.evaluate(&[x[0], x[1], x[2], x[3]], &[]);
            fit::levenberg_marquardt(&flat_params, v, &eval, 12)
        })
        .collect();
    let best = fits
        .into_iter()
        .min_by(|a, b| a.eval.chi2.total_cmp(&b.eval.chi2))
        .ok_or_else(|| DiagnoseError::Other("the flat-only fit failed at every start".into()))?;
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
    let ctx = name::Context {
        sleepers: candidate_sleepers(&out.before, &cal),
        sensors: obs.iter().map(|o| o.sensor.clone()).collect(),
        sensor_positions_m: obs
            .iter()
            .filter_map(|o| cal.sensor_index(&o.sensor))
            .map(|i| cal.sensor_position_m(i))
            .collect(),
        wheels: vec![
            crate::model::WheelPosition::Leading,
            crate::model::WheelPosition::Trailing,
        ],
        max_order: opts.max_order,
    };
    let families = name::families(&ctx);
    let naming = name::name(&problem, &judge, &families, &flat_params, flat0, &best.eval);
    lap("name", &mut timings);
    out.verdict = naming.verdict.clone();
    if let (Some(i), Some(dir)) = (naming.named, &opts.local_bank_dir) {
        let c = &naming.ranking[i];
        let effect = c.effect.clone().expect("a named candidate has an effect");
        let mut doc = cal.document().clone();
        doc.effects.push(effect);
        // The local bank: the fitted flat ± 1.5 cells of the original bank in each parameter
        // (a cell: the population span / instances^(1/4)), within the original ranges.
        let pop = &cal.population;
        let cell = (bank.instances().max(1) as f64).powf(-0.25) * 1.5;
        let around = |v: f64, r: [f64; 2]| {
            let (v, w) = (v.clamp(r[0], r[1]), cell * (r[1] - r[0]));
            [(v - w).max(r[0]), (v + w).min(r[1])]
        };
        let [l, d, cc, xp] = c.flat;
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
        let again = local.identify(m, sensors, crate::identify::Extras::NONE)?;
        let after = locate(&local, &again)?;
        let after_stage = Stage::of(&again, &after);
        lap("identify again", &mut timings);
        out.added = Some(Added {
            calibration_toml: with.document().to_toml_string(),
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
