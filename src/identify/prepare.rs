//! The per-measurement preparation of an identification: the sensors used, the alignment to
//! the bank's time axis, the measured series on the bank's windows, and their perceptually
//! important points.

use crate::bank::schema::SensorAxis;
use crate::identify::error::IdentifyError;
use crate::identify::identifier::Identifier;
use crate::identify::input::alignment::{Alignment, AlignmentMethod};
use crate::identify::input::measurement::MeasuredSeries;
use crate::identify::input::measurement::Measurement;
use crate::identify::input::pip::perceptually_important_points;
use crate::identify::input::pip::Candidate;

/// A measurement made ready for comparison with the bank.
pub(in crate::identify) struct Prepared {
    /// (measurement sensor index, bank axis index) of the sensors used.
    pub(in crate::identify) used: Vec<(usize, usize)>,
    pub(in crate::identify) alignment: Alignment,
    pub(in crate::identify) series: Vec<MeasuredSeries>,
    /// Candidate points: (series, sample, PIP order).
    pub(in crate::identify) cands: Vec<Candidate>,
    /// The record's high-frequency level (kN; [`crate::identify::detect::roughness`]): the median over the
    /// sensors used of the robust scale of `x − B₅x` over their loaded samples.
    pub(in crate::identify) hf_kn: f64,
    /// Per sensor used, the record's largest high-frequency value where a wheel is near (kN;
    /// [`crate::bank::roughness::hf_peak`]): detection's strike test.
    pub(in crate::identify) hf_peaks: Vec<f64>,
}

impl Identifier {
    /// The per-measurement preparation of [`Identifier::identify`]: sensors, alignment, the
    /// series on the bank's windows, and their PIPs.
    pub(in crate::identify) fn prepare(
        &self,
        m: &Measurement,
        sensors: Option<&[String]>,
    ) -> Result<Prepared, IdentifyError> {
        let meta = self.bank.metadata();
        let cal = &meta.calibration;
        // A pass at another speed than the bank's is put on the bank's time axis first.
        let m = &*m.at_bank_speed(cal.run.speed_km_per_h)?;

        // Sensors: those in the file (and asked for), each must be in the bank.
        let mut used: Vec<(usize, usize)> = Vec::new(); // (measurement index, bank axis index)
        for (mi, name) in m.sensors.iter().enumerate() {
            if sensors.is_some_and(|list| !list.iter().any(|x| x == name)) {
                continue;
            }
            let bi = meta
                .sensors
                .iter()
                .position(|a| &a.name == name)
                .ok_or_else(|| IdentifyError::Sensors {
                    path: m.path.clone(),
                    message: format!(
                        "sensor `{name}` is not in the bank (bank sensors: {})",
                        meta.sensors
                            .iter()
                            .map(|a| a.name.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                })?;
            used.push((mi, bi));
        }
        if let Some(list) = sensors {
            for name in list {
                if !m.sensors.contains(name) {
                    return Err(IdentifyError::Sensors {
                        path: m.path.clone(),
                        message: format!(
                            "sensor `{name}` was asked for but the file has no `{name}_kn` column"
                        ),
                    });
                }
            }
        }
        if used.is_empty() {
            return Err(IdentifyError::Sensors {
                path: m.path.clone(),
                message: "no usable sensor".into(),
            });
        }
        // Alignment.
        let speed = cal.run.speed_km_per_h / 3.6;
        let alignment = match m.laser_trigger_s {
            Some(t) => {
                let t_bank = (cal.sensors.laser_trigger_m - cal.run.leading_wheel_start_m) / speed;
                Alignment {
                    method: AlignmentMethod::LaserTrigger,
                    shift_s: t_bank - t,
                    correlation: None,
                }
            }
            None => {
                let pairs: Vec<(usize, &crate::bank::schema::SensorAxis, &[f32])> = used
                    .iter()
                    .map(|&(mi, bi)| (mi, &meta.sensors[bi], meta.flat_free_kn[bi].as_slice()))
                    .collect();
                let (shift_s, c) =
                    cross_correlate(m, &pairs).ok_or_else(|| IdentifyError::TooShort {
                        path: m.path.clone(),
                        sensor: m.sensors[used[0].0].clone(),
                        needed: [meta.sensors[used[0].1].t0_s, meta.sensors[used[0].1].t0_s],
                        recorded: [m.t0_s, m.t0_s + (m.len() - 1) as f64 * m.dt_s],
                    })?;
                Alignment {
                    method: AlignmentMethod::CrossCorrelation,
                    shift_s,
                    correlation: Some(c),
                }
            }
        };
        let mut series = Vec::with_capacity(used.len());
        let mut peaks = Vec::with_capacity(used.len());
        let mut hf = Vec::with_capacity(used.len());
        for &(mi, bi) in &used {
            let axis = &meta.sensors[bi];
            let values_kn = m.on_window(mi, axis, alignment.shift_s)?;
            let template: Vec<f64> = meta.flat_free_kn[bi]
                .iter()
                .map(|&g| f64::from(g))
                .collect();
            hf.push(crate::bank::roughness::hf_level(&values_kn, &template));
            peaks.push(crate::bank::roughness::hf_peak(&values_kn, &template));
            series.push(MeasuredSeries {
                sensor: axis.name.clone(),
                t0_s: axis.t0_s,
                sample_rate_hz: axis.sample_rate_hz,
                values_kn,
            });
        }
        hf.sort_by(f64::total_cmp);
        let hf_kn = hf[hf.len() / 2];

        let cands = self.candidates(&series);
        Ok(Prepared {
            used,
            alignment,
            series,
            cands,
            hf_kn,
            hf_peaks: peaks,
        })
    }

    /// The candidate points of `series`: each one's PIPs.
    pub(in crate::identify) fn candidates(&self, series: &[MeasuredSeries]) -> Vec<Candidate> {
        let s = &self.settings;
        let mut cands = Vec::new();
        for (si, ser) in series.iter().enumerate() {
            for (order, k) in
                perceptually_important_points(&ser.values_kn, s.pips_per_series, s.pip_distance)
                    .into_iter()
                    .enumerate()
            {
                cands.push(Candidate {
                    series: si,
                    sample: k,
                    order,
                });
            }
        }
        cands
    }

    /// The measured series of identification `id` of `m` as recorded: the same sensors on the
    /// bank's windows at the same alignment, without the comparison's average (and not put on
    /// the bank's load) — what a noise estimate reads.
    pub fn series_as_recorded(
        &self,
        m: &Measurement,
        id: &crate::identify::answer::identification::Identification,
    ) -> Result<Vec<MeasuredSeries>, IdentifyError> {
        let meta = self.bank.metadata();
        let raw = m.at_bank_speed(meta.calibration.run.speed_km_per_h)?;
        id.series
            .iter()
            .map(|s| {
                let axis = meta.sensors.iter().find(|a| a.name == s.sensor);
                let mi = raw.sensors.iter().position(|n| *n == s.sensor);
                let (Some(axis), Some(mi)) = (axis, mi) else {
                    return Err(IdentifyError::Sensors {
                        path: m.path.clone(),
                        message: format!(
                            "sensor `{}` of the identification is not in the record",
                            s.sensor
                        ),
                    });
                };
                Ok(MeasuredSeries {
                    values_kn: raw.on_window(mi, axis, id.alignment.shift_s)?,
                    ..s.clone()
                })
            })
            .collect()
    }
}

/// Best shift (bank time = file time + shift) by normalised cross-correlation of the measured
/// series with the bank's flat-free prediction, over whole-sample shifts that keep every window
/// inside the record. `pairs` are (measurement sensor index, bank axis, flat-free template).
fn cross_correlate(m: &Measurement, pairs: &[(usize, &SensorAxis, &[f32])]) -> Option<(f64, f64)> {
    let rate = 1.0 / m.dt_s;
    // File sample k sits at bank time t0 + k·dt + shift; choose shifts that put file samples
    // exactly on bank samples: shift = (g − k0)·dt − t0 for integer g − k0.
    let n = m.len() as i64;
    let mut best: Option<(f64, f64)> = None;
    let lo = pairs.iter().map(|(_, a, _)| a.first_sample as i64).min()?;
    let hi = pairs
        .iter()
        .map(|(_, a, _)| (a.first_sample + a.samples) as i64)
        .max()?;
    // offset o: bank sample G corresponds to file sample G − o.
    for o in (hi - n)..=lo {
        let mut num = 0.0;
        let mut yy = 0.0;
        let mut gg = 0.0;
        for (s, axis, template) in pairs {
            let y = &m.values_kn[*s];
            for (k, &g) in template.iter().enumerate() {
                let idx = axis.first_sample as i64 + k as i64 - o;
                let v = y[idx as usize];
                num += v * g as f64;
                yy += v * v;
                gg += g as f64 * g as f64;
            }
        }
        let c = num / (yy * gg).sqrt().max(1e-300);
        if best.is_none_or(|(_, b)| c > b) {
            let shift = o as f64 / rate - m.t0_s;
            best = Some((shift, c));
        }
    }
    best
}
