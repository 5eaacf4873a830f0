//! Auditing model instances: re-simulate one with the calibration stored in the bank and
//! compare with its stored series sample by sample; with a measurement, show every comparison
//! point's residual against its thresholds and which points falsify it, ranked.
//!
//! Identical series are expected while code and calibration are unchanged: the bank is
//! written as f32 kN from the same simulator, so any difference, however small, is reported
//! as drift.

use crate::bank::{Bank, BankError, StoredInstance};
use crate::identify::{envelope, Identification, Identifier};
use crate::model::{
    CheckedCalibration, Flat, Record, SimError, Simulator, WheelPosition, Workspace,
};
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Errors of an audit.
#[derive(Debug, Error)]
pub enum AuditError {
    /// The bank could not be read.
    #[error(transparent)]
    Bank(#[from] BankError),
    /// The instance could not be simulated.
    #[error("instance {instance}: {source}")]
    Simulation {
        /// The instance.
        instance: u32,
        /// The cause.
        #[source]
        source: SimError,
    },
    /// The stored parameters do not make a flat.
    #[error("instance {instance}: stored parameters are not a valid flat: {message}")]
    Parameters {
        /// The instance.
        instance: u32,
        /// Why.
        message: String,
    },
    /// The bank's predictions could not be read as the identification compared them.
    #[error(transparent)]
    Identify(#[from] Box<crate::identify::IdentifyError>),
    /// No flat was detected: there is no best instance to locate a gap from.
    #[error("no flat was detected in the measurement: the flat-free model fits it, so there is no model gap to locate")]
    NoFlatDetected,
}

/// How one sensor's re-simulated series compares with the stored one.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SensorDiff {
    /// Sensor.
    pub sensor: String,
    /// Largest |re-simulated − stored| (kN).
    pub max_abs_kn: f64,
    /// Sample where it is largest.
    pub worst_sample: usize,
    /// RMS difference (kN).
    pub rms_kn: f64,
    /// Samples that differ at all.
    pub differing_samples: usize,
    /// Samples compared.
    pub samples: usize,
}

/// Re-simulated against stored, over all sensors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Resimulation {
    /// Instance number.
    pub instance: u32,
    /// Bit-for-bit identical.
    pub identical: bool,
    /// Largest |difference| over all sensors (kN).
    pub max_abs_kn: f64,
    /// RMS difference over all samples (kN).
    pub rms_kn: f64,
    /// Per sensor.
    pub sensors: Vec<SensorDiff>,
}

impl Resimulation {
    /// One line for people.
    pub fn verdict(&self) -> String {
        let samples: usize = self.sensors.iter().map(|s| s.samples).sum();
        if self.identical {
            format!(
                "identical to the stored series, bit for bit ({} sensors, {samples} samples)",
                self.sensors.len()
            )
        } else {
            let worst = self
                .sensors
                .iter()
                .max_by(|a, b| a.max_abs_kn.total_cmp(&b.max_abs_kn))
                .expect("a bank has sensors");
            let differing: usize = self.sensors.iter().map(|s| s.differing_samples).sum();
            format!(
                "DIFFERS from the stored series: max |Δ| {:.4} kN at {} sample {}, RMS {:.4} kN, {differing} of {samples} samples differ",
                self.max_abs_kn, worst.sensor, worst.worst_sample, self.rms_kn
            )
        }
    }
}

/// The re-simulator of a bank's instances (the simulator is assembled once).
pub struct Resimulator<'a> {
    bank: &'a Bank,
    cal: CheckedCalibration,
    sim: Simulator,
}

impl<'a> Resimulator<'a> {
    /// With the calibration stored in the bank, or `calibration` to audit against another
    /// (a changed track calibration shows up as drift).
    pub fn new(
        bank: &'a Bank,
        calibration: Option<CheckedCalibration>,
    ) -> Result<Resimulator<'a>, AuditError> {
        let cal = match calibration {
            Some(c) => c,
            None => bank
                .metadata()
                .calibration
                .clone()
                .check()
                .map_err(|source| BankError::DerivedCalibration {
                    context: "the bank's stored calibration is invalid".to_string(),
                    source,
                })?,
        };
        // A folded bank is re-simulated as it was simulated: its stored pads and instances.
        let cal = cal.stored();
        let sim = Simulator::new(&cal).map_err(|source| AuditError::Simulation {
            instance: 0,
            source,
        })?;
        Ok(Resimulator { bank, cal, sim })
    }

    /// A workspace for [`Resimulator::run`] (one per thread).
    pub fn workspace(&self) -> Workspace {
        self.sim.workspace()
    }

    /// Re-simulates a stored instance: its series (kN, as the bank stores them) per sensor.
    pub fn run(
        &self,
        stored: &StoredInstance,
        ws: &mut Workspace,
    ) -> Result<Vec<Vec<f32>>, AuditError> {
        // A folded bank's instance: its stored instance re-simulated at the X_p stored (bit
        // for bit what the generator ran), the windows then shifted as the bank presents them.
        let as_stored;
        let (stored, shift) = match self.bank.fold_split(stored.instance as usize) {
            Some((i, k)) => {
                as_stored = self.bank.read_stored_instance(i)?;
                (&as_stored, k)
            }
            None => (stored, 0),
        };
        let [l, d, c, xp, _, wheel, _] = stored.parameters;
        let wheel = WheelPosition::from_code(wheel as u8);
        let flat = Flat::from_mm(l, d, c, xp)
            .map_err(|e| AuditError::Parameters {
                instance: stored.instance,
                message: e.to_string(),
            })?
            .on_wheel(wheel);
        let resp = self
            .sim
            .run_with(Some(&flat), Record::default(), ws)
            .map_err(|source| AuditError::Simulation {
                instance: stored.instance,
                source,
            })?;
        // The bank's sensors by name, in the calibration simulated (they may differ when
        // auditing against another calibration).
        let names: Vec<&str> = self
            .cal
            .sensors
            .pad
            .iter()
            .map(|p| p.name.as_str())
            .collect();
        let series = self
            .bank
            .stored_axes()
            .iter()
            .map(|a| match names.iter().position(|n| *n == a.name) {
                Some(si) if a.first_sample >= resp.first_sample => {
                    let available = resp.pad_force_n[si].len() + resp.first_sample;
                    (a.first_sample..a.first_sample + a.samples)
                        .map(|g| {
                            if g < available {
                                (resp.pad_force_n[si][g - resp.first_sample] / 1e3) as f32
                            } else {
                                f32::NAN
                            }
                        })
                        .collect()
                }
                _ => vec![f32::NAN; a.samples],
            })
            .collect::<Vec<Vec<f32>>>();
        Ok(self.bank.presented_windows(&series, shift))
    }
}

/// Compares re-simulated with stored series.
pub fn compare(stored: &StoredInstance, resim: &[Vec<f32>], bank: &Bank) -> Resimulation {
    let mut sensors = Vec::new();
    let (mut sum2, mut count, mut max_all) = (0.0f64, 0usize, 0.0f64);
    let mut identical = true;
    for ((axis, s), r) in bank
        .metadata()
        .sensors
        .iter()
        .zip(&stored.forces_kn)
        .zip(resim)
    {
        let (mut max, mut worst, mut s2, mut differ) = (0.0f64, 0usize, 0.0f64, 0usize);
        for (k, (&a, &b)) in s.iter().zip(r).enumerate() {
            if a.to_bits() != b.to_bits() {
                differ += 1;
                identical = false;
            }
            let d = (b as f64 - a as f64).abs();
            // A missing sample (NaN) counts as infinitely far.
            let d = if d.is_nan() { f64::INFINITY } else { d };
            if d > max {
                max = d;
                worst = k;
            }
            s2 += if d.is_finite() { d * d } else { 0.0 };
        }
        sum2 += s2;
        count += s.len();
        max_all = max_all.max(max);
        sensors.push(SensorDiff {
            sensor: axis.name.clone(),
            max_abs_kn: max,
            worst_sample: worst,
            rms_kn: (s2 / s.len().max(1) as f64).sqrt(),
            differing_samples: differ,
            samples: s.len(),
        });
    }
    Resimulation {
        instance: stored.instance,
        identical,
        max_abs_kn: max_all,
        rms_kn: (sum2 / count.max(1) as f64).sqrt(),
        sensors,
    }
}

/// One comparison point, seen from one instance.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PointCheck {
    /// Order among the EIP (1 = first chosen), the envelope points after them.
    pub order: usize,
    /// Sensor.
    pub sensor: String,
    /// Sample within the sensor's window.
    pub sample: usize,
    /// Bank time (s).
    pub time_s: f64,
    /// Measured force (kN).
    pub measured_kn: f64,
    /// The instance's stored prediction (kN).
    pub predicted_kn: f64,
    /// Prediction − measurement (kN).
    pub residual_kn: f64,
    /// Thresholds on the residual (kN).
    pub threshold_kn: [f64; 2],
    /// The instance's own cell widening (kN; see `identify::cells`).
    pub widening_kn: f64,
    /// The bank mesh's discretisation allowance for the instance there (kN; its share of its
    /// step between adjacent samples, `identify::discretisation`).
    #[serde(default)]
    pub discretisation_kn: f64,
    /// How far the residual lies outside the widened thresholds (kN; ≤ 0: inside, by that
    /// margin).
    pub outside_by_kn: f64,
    /// For an envelope point, its window ("max ±2": the maximum over ±2 samples); the values
    /// above are then the window's extremes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub envelope: Option<String>,
}

/// An instance against a measurement.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MeasuredCheck {
    /// The measurement file.
    pub measurement: String,
    /// Kept (inside the widened thresholds at every point).
    pub kept: bool,
    /// Member of the identification's candidate model set (agrees with `kept`).
    pub in_cms: bool,
    /// Kept at every point and by one gain per sensor at every point read (`None`: no stage).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shared_gains_kept: Option<bool>,
    /// Every comparison point, in EIP order.
    pub points: Vec<PointCheck>,
    /// The points that falsify it, most outside first (indices into `points`).
    pub falsified_by: Vec<usize>,
    /// The identification's per-point probability.
    pub per_point_probability: f64,
}

/// One comparison point as falsification judges an instance there.
struct Judged<'a> {
    order: usize,
    sensor: &'a str,
    sample: usize,
    time_s: f64,
    predicted: f64,
    measured: f64,
    /// The measured force's thresholds.
    thresholds: (f64, f64),
    /// Every instance's prediction (for the widening).
    all: &'a [f32],
    /// The instance's discretisation allowance (kN).
    allowance: f64,
    /// The bank's flat-free force there as the identification compared it (kN), and the
    /// roughness it was judged with: the bounded sources' widening.
    flat_free: f64,
    roughness: &'a crate::identify::RoughnessUse,
}

impl Judged<'_> {
    /// The check of instance `i` at per-point probability `p`.
    fn check(&self, identifier: &Identifier, i: usize, p: f64) -> PointCheck {
        let residual = self.predicted - self.measured;
        let widening = identifier
            .resolution()
            .map_or(0.0, |r| r.kappa * r.cells.spread(self.all, i));
        // The band identification applies to this prediction (its own force's thresholds
        // where it exceeds the measurement and the measured force's band fails).
        let (t_lo, t_hi) = if residual >= self.thresholds.0 && residual <= self.thresholds.1 {
            self.thresholds
        } else if self.predicted.abs() > self.measured.abs() {
            identifier
                .point_curve(self.roughness, self.measured, self.flat_free, p)
                .at(self.predicted)
        } else {
            self.thresholds
        };
        let extra = widening + self.allowance;
        let (lo, hi) = (t_lo - extra, t_hi + extra);
        let outside = if residual > hi {
            residual - hi
        } else if residual < lo {
            lo - residual
        } else {
            -(residual - lo).min(hi - residual)
        };
        PointCheck {
            order: self.order,
            sensor: self.sensor.to_string(),
            sample: self.sample,
            time_s: self.time_s,
            measured_kn: self.measured,
            predicted_kn: self.predicted,
            residual_kn: residual,
            threshold_kn: [t_lo, t_hi],
            widening_kn: widening,
            discretisation_kn: self.allowance,
            outside_by_kn: outside,
            envelope: None,
        }
    }
}

/// Checks stored instance `stored` against the identification `id` made by `identifier`: at
/// every EIP, then at every envelope point (`identify::envelope`), as falsification judges it.
/// None when the pass was not sized (no flat detected): there are no comparison points.
pub fn check_against(
    identifier: &Identifier,
    id: &Identification,
    stored: &StoredInstance,
) -> Result<Option<MeasuredCheck>, AuditError> {
    let Some(sizing) = &id.sizing else {
        return Ok(None);
    };
    let bank = identifier.bank();
    let axes = &bank.metadata().sensors;
    let axis_of = |series: usize| {
        let name = &id.series[series].sensor;
        axes.iter()
            .position(|a| &a.name == name)
            .expect("identified sensors are the bank's")
    };
    let i = stored.instance as usize;
    let p = sizing.per_point_probability;
    // As the identification compared: its average, its roughness.
    let cmp = id.comparison;
    let rough = id
        .roughness
        .clone()
        .unwrap_or_else(|| crate::identify::RoughnessUse::none(0.0, 0.0));
    let own: Vec<Vec<f64>> = stored
        .forces_kn
        .iter()
        .map(|f| {
            let x: Vec<f64> = f.iter().map(|&v| f64::from(v)).collect();
            crate::model::average::centred_average(&x, cmp.weights())
        })
        .collect();
    // The instance's discretisation allowance (samples compared one by one): its share of its
    // own largest step over samples `a..=b` of an axis.
    let share = identifier
        .discretisation()
        .filter(|_| cmp == crate::identify::Comparison::Samples)
        .map_or(0.0, |d| d[i] as f64);
    let allowance = |axis: usize, a: usize, b: usize| {
        let f = &stored.forces_kn[axis];
        share
            * crate::identify::domain::falsify::largest_step(
                f[a..=b.min(f.len() - 1)].iter().copied(),
            ) as f64
    };
    let n = bank.instances();
    let read = |points: &[(usize, usize)]| -> Result<Vec<Vec<f32>>, AuditError> {
        let mut flat = vec![0.0f32; points.len() * n];
        identifier
            .read_compared(points, cmp, &mut flat)
            .map_err(|e| AuditError::Identify(Box::new(e)))?;
        Ok(flat.chunks(n.max(1)).map(<[f32]>::to_vec).collect())
    };
    let (eip, candidates) = (&sizing.eip, &sizing.candidates);
    let mut points = Vec::with_capacity(eip.len() + sizing.envelope.len());
    // The neighbours' predictions at the EIP give the instance's own widening.
    let cols: Vec<(usize, usize)> = eip
        .iter()
        .map(|&e| (axis_of(candidates[e].series), candidates[e].sample))
        .collect();
    let columns = read(&cols)?;
    for (order, (&e, (&(axis, k), col))) in eip.iter().zip(cols.iter().zip(&columns)).enumerate() {
        let c = &candidates[e];
        let judged = Judged {
            order: order + 1,
            sensor: &axes[axis].name,
            sample: k,
            time_s: c.time_s,
            predicted: own[axis][k],
            measured: c.measured_kn,
            thresholds: (c.threshold_low_kn, c.threshold_high_kn),
            all: col,
            allowance: allowance(axis, k.saturating_sub(1), k + 1),
            flat_free: identifier.flat_free_peak_kn(axis, k, k, cmp),
            roughness: &rough,
        };
        points.push(judged.check(identifier, i, p));
    }
    // Envelope points: the window's extreme of the stored series, and of every instance for
    // the widening.
    for (j, x) in sizing.envelope.iter().enumerate() {
        let axis = axis_of(x.series);
        let window = x.sample - x.half_width..=x.sample + x.half_width;
        let data = read(&window.clone().map(|k| (axis, k)).collect::<Vec<_>>())?;
        let refs: Vec<&[f32]> = data.iter().map(Vec::as_slice).collect();
        let max = x.kind == crate::identify::select::envelope::Extreme::Max;
        let all = envelope::feature(&refs, max);
        let own = envelope::extreme(window.map(|k| own[axis][k]), max);
        let ser = &id.series[x.series];
        let judged = Judged {
            order: eip.len() + j + 1,
            sensor: &axes[axis].name,
            sample: x.sample,
            time_s: ser.t0_s + x.sample as f64 / ser.sample_rate_hz,
            predicted: own,
            measured: x.measured_kn,
            thresholds: (x.threshold_low_kn, x.threshold_high_kn),
            all: &all,
            allowance: allowance(axis, x.sample - x.half_width, x.sample + x.half_width),
            flat_free: identifier.flat_free_peak_kn(
                axis,
                x.sample - x.half_width,
                x.sample + x.half_width,
                cmp,
            ),
            roughness: &rough,
        };
        let mut check = judged.check(identifier, i, p);
        check.envelope = Some(format!("{} ±{}", x.kind, x.half_width));
        points.push(check);
    }
    let mut falsified_by: Vec<usize> = (0..points.len())
        .filter(|&p| points[p].outside_by_kn > 0.0)
        .collect();
    falsified_by.sort_by(|&a, &b| {
        points[b]
            .outside_by_kn
            .total_cmp(&points[a].outside_by_kn)
            .then(a.cmp(&b))
    });
    // Kept at every point, then by one gain per sensor (docs/model.md, "Shared gains").
    let keeps = identifier.shared_keeps(id, sizing, i);
    let shared = falsified_by.is_empty() && keeps.map_err(|e| AuditError::Identify(Box::new(e)))?;
    Ok(Some(MeasuredCheck {
        measurement: id.measurement.clone(),
        kept: shared,
        shared_gains_kept: identifier.settings().shared_gains.then_some(shared),
        in_cms: sizing.cms.iter().any(|m| m.instance == stored.instance),
        points,
        falsified_by,
        per_point_probability: p,
    }))
}

/// The instances `bank audit --sample K` re-simulates: K spread evenly through the bank
/// (the middle of each of K equal blocks), so every shard and every part of the population
/// is visited.
pub fn sample_instances(n: usize, k: usize) -> Vec<usize> {
    let k = k.clamp(1, n.max(1));
    (0..k).map(|j| ((2 * j + 1) * n) / (2 * k)).collect()
}

/// A drift check of a whole bank (`bank audit`): K instances spread through it
/// ([`sample_instances`]), re-simulated in parallel (rayon, one workspace per thread) and
/// compared with their stored series.
pub struct BankAudit<'a> {
    bank: &'a Bank,
    resim: Resimulator<'a>,
    picks: Vec<usize>,
}

impl<'a> BankAudit<'a> {
    /// Plans the audit of `sample` instances of `bank`, re-simulated with the bank's stored
    /// calibration or with `calibration`.
    pub fn new(
        bank: &'a Bank,
        calibration: Option<CheckedCalibration>,
        sample: usize,
    ) -> Result<BankAudit<'a>, AuditError> {
        let resim = Resimulator::new(bank, calibration)?;
        let picks = sample_instances(bank.instances(), sample);
        Ok(BankAudit { bank, resim, picks })
    }

    /// The instances it re-simulates, in order.
    pub fn instances(&self) -> &[usize] {
        &self.picks
    }

    /// Re-simulates every planned instance; the results are in the order of
    /// [`BankAudit::instances`] whatever the number of threads.
    pub fn run(&self) -> Result<BankAuditReport, AuditError> {
        use rayon::prelude::*;
        let results = self
            .picks
            .par_iter()
            .map_init(
                || self.resim.workspace(),
                |ws, &i| -> Result<Resimulation, AuditError> {
                    let stored = self.bank.read_instance(i)?;
                    let r = self.resim.run(&stored, ws)?;
                    Ok(compare(&stored, &r, self.bank))
                },
            )
            .collect::<Result<_, _>>()?;
        Ok(BankAuditReport { results })
    }
}

/// What a bank audit found.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BankAuditReport {
    /// One comparison per re-simulated instance, in the order of [`BankAudit::instances`].
    pub results: Vec<Resimulation>,
}

impl BankAuditReport {
    /// The instances that differ from the bank.
    pub fn drifted(&self) -> Vec<&Resimulation> {
        self.results.iter().filter(|r| !r.identical).collect()
    }

    /// The largest |difference| over the drifted instances (kN; 0 without drift).
    pub fn worst_kn(&self) -> f64 {
        self.drifted()
            .iter()
            .map(|r| r.max_abs_kn)
            .fold(0.0f64, f64::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_are_spread_and_distinct() {
        assert_eq!(sample_instances(100, 4), vec![12, 37, 62, 87]);
        assert_eq!(sample_instances(3, 10), vec![0, 1, 2]);
        let s = sample_instances(50_000, 16);
        assert!(s.windows(2).all(|w| w[1] > w[0]));
        assert!(*s.last().unwrap() < 50_000);
    }
}
