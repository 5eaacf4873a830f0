//! Diagnosis: *locate* where simulation and measurement disagree, *name* the missing
//! effect ([`name`]), *add* it to the calibration and identify again on a local bank, and show
//! the gap before and after ([`diagnose`]).
//!
//! Locate ([`locate`]), fit the flat alone, estimate the noise from the record ([`noise`]),
//! name up to two effects ([`name`], [`select`]), and add them and identify again.

pub mod fit;
pub(crate) mod library;
pub(crate) mod locate;
pub mod name;
pub mod noise;
pub(crate) mod outcome;
pub(crate) mod restart;
pub(crate) mod select;
mod stages;
pub mod surface;

use crate::audit::AuditError;
use crate::identify::{Identification, Identifier, Sizing};
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
    /// noise (the first diagnosis, kept to measure against).
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
    /// The numbers of identification `id` (sized as `sizing`), located as `l`.
    fn of(id: &Identification, sizing: &Sizing, l: &Located) -> Stage {
        Stage {
            bank_id: id.bank_id.clone(),
            bank_instances: id.bank_instances,
            cms: sizing.cms.len(),
            l0_mm: sizing
                .falsifications
                .first()
                .and_then(|f| f.ranges.as_ref())
                .map(|r| r.l0_mm),
            best_instance: l.instance,
            best_l0_mm: sizing
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
    /// Where the departure from the good wheel lives, wheel or rail ([`surface`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub surface: Option<surface::SurfaceOrigin>,
    /// The ranking of the effects (None when there was nothing to explain).
    pub naming: Option<Naming>,
    /// The effect added, when one was named and a local bank asked for.
    pub added: Option<Added>,
    /// The verdict in words.
    pub verdict: String,
    /// Wall-clock of the stages (s).
    pub timings_s: Vec<(String, f64)>,
}

pub use name::{Candidate, CandidateKind, Naming};

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
    /// A calibration that does not check (the bank's, or the bank's with the effect added).
    #[error("{what}")]
    Calibration {
        /// Which calibration.
        what: &'static str,
        /// Why.
        #[source]
        source: crate::model::CalibrationError,
    },
    /// The flat-only fit found no finite misfit from any start.
    #[error("the flat-only fit failed at every start")]
    FlatOnlyFit,
    /// No instance of the bank gave a finite misfit against the record.
    #[error("no bank instance could be compared")]
    NothingComparable,
}

/// The measured series of identification `id` of `m` on the bank's windows, as recorded (the
/// diagnosis fits raw simulations to the record's own samples, its noise model per sample).
pub fn observed(
    identifier: &Identifier,
    id: &Identification,
    m: &crate::identify::Measurement,
) -> Result<Vec<fit::Observed>, DiagnoseError> {
    let meta = identifier.bank().metadata();
    Ok(identifier
        .series_as_recorded(m, id)?
        .iter()
        .filter_map(|s| {
            let axis = meta.sensors.iter().find(|a| a.name == s.sensor)?;
            Some(fit::Observed {
                sensor: s.sensor.clone(),
                first_sample: axis.first_sample,
                values_kn: s.values_kn.clone(),
            })
        })
        .collect())
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
        return Err(DiagnoseError::NothingComparable);
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

/// Diagnoses identification `id` of measurement `m` (made by `identifier`, with `sensors`),
/// stage by stage ([`stages`]): locate; when the model disagrees, fit the flat alone, estimate
/// the noise from the record, fit every effect with the flat and name one (or a pair) if the
/// evidence is clear; and (with `opts.local_bank_dir`) add it, regenerate a local bank and
/// identify again.
pub fn diagnose(
    identifier: &Identifier,
    m: &crate::identify::Measurement,
    sensors: Option<&[String]>,
    id: &Identification,
    opts: &Options,
    observer: &dyn crate::bank::GenerateObserver,
) -> Result<Diagnosis, DiagnoseError> {
    let mut clock = crate::stopwatch::Stopwatch::start_s();
    let sizing = id.sizing.as_ref().ok_or(AuditError::NoFlatDetected)?;
    let before = locate(identifier, id, sizing)?;
    let before_stage = Stage::of(id, sizing, &before);
    clock.lap("locate");
    let mut out = Diagnosis {
        measurement: id.measurement.clone(),
        before,
        before_stage,
        noise: None,
        noise_above_table: None,
        surface: surface::origin(identifier, m, id)?,
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
        out.timings_s = clock.laps;
        return Ok(out);
    }
    let cal = identifier
        .bank()
        .metadata()
        .calibration
        .clone()
        .check()
        .map_err(|source| DiagnoseError::Calibration {
            what: "the bank's calibration",
            source,
        })?;
    let obs = observed(identifier, id, m)?;
    let flat_only = stages::fit_flat_alone(identifier, &obs, opts, &cal, &out.before)?;
    clock.lap("flat-only fit");
    if flat_only.outside == 0 {
        let flat0 = flat_only.flat();
        out.verdict = format!(
            "no missing effect found: the flat alone, fitted between the bank's instances (L {:.1} mm, d {:.3} mm, X_p {:.4} m), agrees within the thresholds at every sample; the {} samples outside were the bank's resolution",
            flat0[0], flat0[1], flat0[3], out.before.samples_outside
        );
        out.timings_s = clock.laps;
        return Ok(out);
    }
    let (flat_only, estimate) = stages::under_the_records_noise(flat_only, opts, &cal);
    out.noise = Some(estimate);
    clock.lap("noise");
    let naming = stages::name_effects(&flat_only, opts, &cal, &estimate, &mut out);
    clock.lap("name");
    if let (Some(flat), Some(dir)) = (naming.named_flat(), &opts.local_bank_dir) {
        let named = naming.named_effects();
        let added = stages::add_and_identify_again(
            &stages::Again {
                identifier,
                m,
                sensors,
                cal: &cal,
                wheel: flat_only.wheel,
                observer,
            },
            &named,
            flat,
            opts,
            dir,
            &mut clock,
        )?;
        out.added = Some(added);
    }
    out.naming = Some(naming);
    out.timings_s = clock.laps;
    Ok(out)
}
