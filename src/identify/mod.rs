//! Identification from the bank (paper §2–3, docs/model.md §7–8): perceptually important points
//! of the measured series, joint-entropy selection, error-domain model falsification.
//!
//! [`Identifier::new`] opens what is reused across measurements (the memory-mapped bank, its
//! parameters, the Monte Carlo uncertainty samples); [`Identifier::identify`] is the per-
//! measurement path: align, PIP, read the candidate columns, entropy selection, falsify.

mod baselines;
pub mod buffer;
pub mod cells;
pub mod detect;
mod discretisation;
pub mod entropy;
pub mod envelope;
pub mod falsify;
pub mod family;
mod flat_free;
pub mod load;
pub mod measurement;
pub mod pip;
mod prepare;
pub mod ranges;
pub mod refine;
pub mod result;
pub mod severity;
pub mod sparse;
pub mod synth;
pub mod uncertainty;

pub use measurement::Measurement;
pub use result::Identification;
pub use severity::{FlatVerdict, Severity, SeverityRange};

use crate::bank::{Bank, BankError, Parameters};
use crate::model::calibration::IdentificationParams;
use crate::model::WheelPosition;
use cells::Cells;
pub use detect::{Detection, DetectionLimit};
use entropy::{bin_into, binned_columns, greedy_joint_entropy};
use falsify::{falsify, residual_minimisation, Point, Resolution};
use prepare::Prepared;
use ranges::{instance, population_ranges, ranges_of};
pub use result::WheelRanges;
use result::{CandidatePoint, EntropyCurve, Falsification, InstanceParams, Method, ParamRanges};
use severity::{below_population_words, summarise};
use std::path::PathBuf;
use std::sync::Mutex;
use std::time::Instant;
use thiserror::Error;
use uncertainty::CombinedUncertainty;
pub use uncertainty::ThresholdCurve;

/// Errors of identification.
#[derive(Debug, Error)]
pub enum IdentifyError {
    /// A measurement file is malformed.
    #[error("{path}, line {line}: {message}")]
    Measurement {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// What is wrong, with the value.
        message: String,
    },
    /// The measurement does not cover a sensor's bank window after alignment.
    #[error("{path}: sensor `{sensor}` needs samples from {:.4} s to {:.4} s (file clock); the record spans {:.4} s to {:.4} s", needed[0], needed[1], recorded[0], recorded[1])]
    TooShort {
        /// The file.
        path: PathBuf,
        /// The sensor.
        sensor: String,
        /// Needed span (file clock).
        needed: [f64; 2],
        /// Recorded span.
        recorded: [f64; 2],
    },
    /// A sensor is not in the bank, or none is usable.
    #[error("{path}: {message}")]
    Sensors {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The bank could not be read.
    #[error(transparent)]
    Bank(#[from] BankError),
    /// No member of a bank family covers the pass's speed.
    #[error(transparent)]
    Speed(#[from] crate::bank::family::SpeedError),
    /// The working memory of an identification could not be mapped.
    #[error("cannot map {mb} MB for {what}")]
    Memory {
        /// What it was for.
        what: &'static str,
        /// Its size (MB).
        mb: usize,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// A setting or request outside its range, or a bank that cannot serve it, named with
    /// its value.
    #[error("{0}")]
    Invalid(String),
}

/// Which optional parts of the analysis to run besides the method itself.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Extras {
    /// Residual minimisation, random subsets and equidistant points (paper §4.4–4.6).
    pub baselines: bool,
    /// Joint entropy curves per sensor set (paper Fig. 16).
    pub curves: bool,
    /// The record as recorded: its load read and reported, but not put on the bank's load
    /// (diagnosis, which asks whether the model explains the record itself).
    pub as_recorded: bool,
}

impl Extras {
    /// The method alone: no baselines, no entropy curves.
    pub const NONE: Extras = Extras {
        baselines: false,
        curves: false,
        as_recorded: false,
    };
    /// The method alone on the record as recorded ([`Extras::as_recorded`]).
    pub const AS_RECORDED: Extras = Extras {
        baselines: false,
        curves: false,
        as_recorded: true,
    };
}

/// What is kept open between measurements.
pub struct Identifier {
    bank: Bank,
    params: Parameters,
    /// Each instance's neighbours and cell (the bank's resolution).
    cells: Cells,
    settings: IdentificationParams,
    uncertainty: CombinedUncertainty,
    /// The table's hard bounds the detection step and the departure rule judge with.
    bounds: detect::TableBounds,
    /// Each instance's discretisation share (empty: none; [`Identifier::discretisation`]).
    discretisation: Vec<f32>,
    buffers: Mutex<buffer::HugeBuffer>,
    bin_buffers: Mutex<buffer::HugeBuffer>,
    /// The bank's departures table, loaded when a pass first needs its detection limit.
    departures: Mutex<Option<std::sync::Arc<crate::bank::departures::Departures>>>,
    /// The table's level factor per number of sensors ([`load::level_factor`]), drawn once.
    load_levels: Mutex<std::collections::HashMap<usize, (f64, [f64; 2])>>,
}

impl Identifier {
    /// Opens the reusable state for a bank, with identification settings (the bank's stored
    /// calibration's, or the user's).
    pub fn new(bank: Bank, settings: IdentificationParams) -> Result<Identifier, IdentifyError> {
        // The stored graph when it was searched in today's metric; else (a bank written
        // before the metric was stretched) searched now, 0.3 s for 50,000 instances.
        let population = &bank.metadata().calibration.population;
        let stored = bank
            .neighbour_weights()
            .is_some_and(|w| crate::bank::neighbours::in_metric_of(w, population));
        let params = bank.read_parameters()?;
        let cells = Cells::new(&params, population, bank.neighbours().filter(|_| stored));
        Ok(Identifier::from_parts(bank, settings, params, cells))
    }

    /// [`Identifier::new`] with the cells' neighbour graph given (`None`: searched now).
    pub fn with_neighbours(
        bank: Bank,
        settings: IdentificationParams,
        graph: Option<Vec<u32>>,
    ) -> Result<Identifier, IdentifyError> {
        let params = bank.read_parameters()?;
        let population = &bank.metadata().calibration.population;
        let cells = Cells::new(&params, population, graph.as_deref());
        Ok(Identifier::from_parts(bank, settings, params, cells))
    }

    /// The identifier of an opened bank, its parameters and cells (the buffers empty until the
    /// first measurement).
    fn from_parts(
        bank: Bank,
        settings: IdentificationParams,
        params: Parameters,
        cells: Cells,
    ) -> Identifier {
        let uncertainty = CombinedUncertainty::new(&settings);
        let bounds = detect::TableBounds::of(&settings);
        let discretisation = discretisation::shares(&settings, &params, &bank);
        Identifier {
            bank,
            params,
            cells,
            settings,
            uncertainty,
            bounds,
            discretisation,
            buffers: Mutex::new(buffer::HugeBuffer::default()),
            bin_buffers: Mutex::new(buffer::HugeBuffer::default()),
            departures: Mutex::new(None),
            load_levels: Mutex::new(std::collections::HashMap::new()),
        }
    }

    /// The bank.
    pub fn bank(&self) -> &Bank {
        &self.bank
    }

    /// The bank's parameters (one row per instance).
    pub fn params(&self) -> &Parameters {
        &self.params
    }

    /// The settings in use.
    pub fn settings(&self) -> &IdentificationParams {
        &self.settings
    }

    /// Thresholds `[low, high]` on `prediction − measurement` (kN) where the measured force is
    /// `y_kn`, holding probability `p` (the combined uncertainty of the settings).
    pub fn thresholds(&self, y_kn: f64, p: f64) -> (f64, f64) {
        self.uncertainty.thresholds(y_kn, p)
    }

    /// The thresholds `[low, high]` on `g − y` that falsification applies to a prediction
    /// `g_kn` at a point measured at `y_kn`, with per-point probability `p`: the measured
    /// force's, or the prediction's own where it is larger ([`ThresholdCurve`]).
    pub fn band(&self, y_kn: f64, g_kn: f64, p: f64) -> (f64, f64) {
        if g_kn.abs() > y_kn.abs() {
            self.threshold_curve(y_kn, p).at(g_kn)
        } else {
            self.uncertainty.thresholds(y_kn, p)
        }
    }

    /// The thresholds of a point measured at `y_kn` as a function of the prediction's force
    /// ([`ThresholdCurve`]), at per-point probability `p`.
    pub fn threshold_curve(&self, y_kn: f64, p: f64) -> ThresholdCurve {
        self.uncertainty.curve(y_kn, p)
    }

    /// The bank's resolution as falsification uses it (`None` when switched off).
    pub fn resolution(&self) -> Option<Resolution<'_>> {
        (self.settings.bank_resolution > 0.0).then_some(Resolution {
            cells: &self.cells,
            kappa: self.settings.bank_resolution,
        })
    }

    /// The typical widening at a point: κ × the median neighbour spread (0 when off).
    fn typical_widening(&self, predictions: &[f32]) -> f64 {
        match self.resolution() {
            Some(r) => r.kappa * r.cells.typical_spread(predictions, 1024),
            None => 0.0,
        }
    }

    /// The parameter ranges a set of instances stands for.
    fn ranges(&self, members: impl Iterator<Item = usize> + Clone) -> Option<ParamRanges> {
        let cal = &self.bank.metadata().calibration;
        ranges_of(
            &self.params,
            self.resolution().map(|r| r.cells),
            &cal.population,
            (
                cal.vehicle.wheel_radius_m,
                cal.vehicle.static_wheel_load_n() / 1e3,
            ),
            members,
        )
    }

    /// Identifies the flat behind one measurement: detection first ([`detect`]); when no flat
    /// is detected, that answer with the pass's detection limit and no sizing; else the flat's
    /// size by falsification. `sensors` restricts the sensors used.
    pub fn identify(
        &self,
        m: &Measurement,
        sensors: Option<&[String]>,
        extras: Extras,
    ) -> Result<Identification, IdentifyError> {
        let mut timings = Vec::new();
        let mut clock = Instant::now();
        let mut lap = |name: &str, timings: &mut Vec<(String, f64)>| {
            timings.push((name.to_string(), clock.elapsed().as_secs_f64() * 1e3));
            clock = Instant::now();
        };
        let Prepared {
            used,
            alignment,
            mut series,
            cands,
        } = self.prepare(m, sensors)?;
        let axes: Vec<usize> = used.iter().map(|&(_, bi)| bi).collect();
        // The load the record shows, and the record put on the bank's load (load::at_bank_load).
        let load = self.load_of(&self.detect(&axes, &series));
        if let Some(l) = load.as_ref().filter(|_| !extras.as_recorded) {
            self.at_bank_load(&axes, &mut series, l);
        }
        let detection = self.detect(&axes, &series);
        lap("detection", &mut timings);
        if !detection.flat_detected {
            return self.no_flat(m, (alignment, series), detection, load, &axes, timings);
        }
        let meta = self.bank.metadata();
        let cal = &meta.calibration;
        let s = &self.settings;
        // Envelope windows at the impact spikes (identify::envelope): they depend on the
        // measurement only, so their columns are read with the candidates'.
        let hw = s.envelope_half_width_samples;
        let template: Vec<&[f32]> = used
            .iter()
            .map(|&(_, bi)| meta.flat_free_kn[bi].as_slice())
            .collect();
        let centres = envelope::windows(&series, &template, s.envelope_windows_per_sensor, hw);
        lap("align and pip", &mut timings);
        // Bank predictions at the candidates, then the envelope windows' (the hot read).
        let cols: Vec<usize> = cands
            .iter()
            .map(|&(si, k, _)| self.bank.sample_index(used[si].1, k))
            .chain(
                centres
                    .iter()
                    .flat_map(|&(si, k)| (k - hw..=k + hw).map(move |j| (si, j)))
                    .map(|(si, j)| self.bank.sample_index(used[si].1, j)),
            )
            .collect();
        let n = self.bank.instances();
        let mut buffer = self.buffers.lock().unwrap_or_else(|e| e.into_inner());
        let flat = buffer
            .values(cols.len() * n)
            .map_err(|source| IdentifyError::Memory {
                what: "the bank's predictions",
                mb: (cols.len() * n * 4) >> 20,
                source,
            })?;
        self.bank.read_columns_flat(&cols, flat)?;
        let (flat, env_flat) = flat.split_at(cands.len() * n);
        let predictions: Vec<&[f32]> = flat.chunks(n.max(1)).collect();
        let env_columns: Vec<&[f32]> = env_flat.chunks(n.max(1)).collect();
        lap("read columns", &mut timings);

        let measured: Vec<f64> = cands
            .iter()
            .map(|&(si, k, _)| series[si].values_kn[k])
            .collect();
        let alpha = s.alpha_fraction * (n as f64).log2();
        let all: Vec<usize> = (0..cands.len()).collect();
        // Entropy bins at the Šídák width for m points; m comes from the selection itself, so
        // select with m = 1, then again with the m found (the widths, and so the choice, change).
        // Bin width: the thresholds widened by the bank's typical resolution at the point, so
        // points the bank cannot resolve (moving impact edges) are not taken as informative.
        let widening: Vec<f64> = {
            use rayon::prelude::*;
            predictions
                .par_iter()
                .map(|g| self.typical_widening(g))
                .collect()
        };
        let bounds = |i: usize, p: f64| {
            let (lo, hi) = self.uncertainty.thresholds(measured[i], p);
            (lo - widening[i], hi + widening[i])
        };
        let mut bin_buffer = self.bin_buffers.lock().unwrap_or_else(|e| e.into_inner());
        let bins: &mut [u16] =
            bin_buffer
                .values(measured.len() * n)
                .map_err(|source| IdentifyError::Memory {
                    what: "the predictions' bins",
                    mb: (measured.len() * n * 2) >> 20,
                    source,
                })?;
        // Bins every candidate's predictions at the widths for p into `bins` (one column a
        // candidate); returns each column's number of bins, entropy and instances outside its
        // most populated bin.
        let bin_all = |p: f64, bins: &mut [u16]| -> Vec<entropy::Histogram> {
            use rayon::prelude::*;
            bins.par_chunks_mut(n.max(1))
                .enumerate()
                .map(|(i, b)| {
                    let (lo, hi) = bounds(i, p);
                    bin_into(predictions[i], hi - lo, b)
                })
                .collect()
        };
        lap("resolution", &mut timings);
        let hists = bin_all(s.phi, bins);
        let binned = binned_columns(bins, n, hists);
        lap("binning 1", &mut timings);
        let first = greedy_joint_entropy(&binned, &all, alpha, cands.len());
        let m1 = first.order.len().max(1);
        let p = s.phi.powf(1.0 / m1 as f64);
        lap("greedy 1", &mut timings);
        let hists = bin_all(p, bins);
        let binned = binned_columns(bins, n, hists);
        lap("binning 2", &mut timings);
        let selection = greedy_joint_entropy(&binned, &all, alpha, m1);
        let m_final = selection.order.len().max(1);
        lap("greedy 2", &mut timings);

        // Envelope points; Šídák over every point.
        let p_final = s.phi.powf(1.0 / (m_final + 2 * centres.len()) as f64);
        let (env_reported, env_features, env_curves) = envelope::points(
            &series,
            &centres,
            hw,
            &self.uncertainty,
            p_final,
            &env_columns,
        );
        lap("envelope", &mut timings);

        let thresholds: Vec<(f64, f64)> = (0..measured.len())
            .map(|i| self.uncertainty.thresholds(measured[i], p_final))
            .collect();
        // The thresholds at a prediction's own force where it exceeds the measurement: for the
        // EIP, and for every candidate when the baselines draw from them.
        let curves: Vec<Option<ThresholdCurve>> = (0..measured.len())
            .map(|i| {
                (extras.baselines || selection.order.contains(&i))
                    .then(|| self.uncertainty.curve(measured[i], p_final))
            })
            .collect();
        let point = |i: usize| Point {
            predictions: predictions[i],
            measured_kn: measured[i],
            low_kn: thresholds[i].0,
            high_kn: thresholds[i].1,
            curve: curves[i].as_ref(),
            discretisation: None,
        };
        // The discretisation allowance's steps (identify::discretisation).
        let shares = self.discretisation();
        let (eip_steps, env_steps) = match shares {
            Some(_) => self.allowance_steps(
                &used,
                &series,
                &cands,
                &selection.order,
                &predictions,
                &env_columns,
                hw,
            )?,
            None => (Vec::new(), Vec::new()),
        };
        let eip_points: Vec<Point> = selection
            .order
            .iter()
            .enumerate()
            .map(|(j, &i)| Point {
                discretisation: falsify::Discretisation::of(shares, &eip_steps, j),
                ..point(i)
            })
            .collect();
        let mut method_points = eip_points.clone();
        method_points.extend(
            envelope::as_points(&env_reported, &env_features, &env_curves)
                .into_iter()
                .enumerate()
                .map(|(j, p)| Point {
                    discretisation: falsify::Discretisation::of(shares, &env_steps, j / 2),
                    ..p
                }),
        );
        let cms_idx = falsify(&method_points, self.resolution());
        lap("falsify", &mut timings);
        let (cms_idx, below_population) = self.departure_rule(cms_idx, &axes, &detection)?;
        lap("departures", &mut timings);

        let candidates: Vec<CandidatePoint> = cands
            .iter()
            .enumerate()
            .map(|(i, &(si, k, order))| CandidatePoint {
                series: si,
                sample: k,
                time_s: series[si].t0_s + k as f64 / series[si].sample_rate_hz,
                measured_kn: measured[i],
                pip_order: order,
                entropy_bits: binned[i].entropy_bits,
                threshold_low_kn: thresholds[i].0,
                threshold_high_kn: thresholds[i].1,
                resolution_kn: widening[i],
            })
            .collect();
        let cms: Vec<InstanceParams> = cms_idx
            .iter()
            .map(|&k| instance(&self.params, k as usize))
            .collect();
        let cms_ranges = self.ranges(cms_idx.iter().map(|&k| k as usize));
        let wheel_ranges: Vec<WheelRanges> = [WheelPosition::Leading, WheelPosition::Trailing]
            .into_iter()
            .filter_map(|wheel| {
                let members: Vec<usize> = cms_idx
                    .iter()
                    .map(|&k| k as usize)
                    .filter(|&k| WheelPosition::from_code(self.params.flat_wheel[k]) == wheel)
                    .collect();
                Some(WheelRanges {
                    wheel,
                    cms_count: members.len(),
                    ranges: self.ranges(members.into_iter())?,
                })
            })
            .collect();
        let mut falsifications = vec![Falsification {
            method: Method::Eip {
                envelope: !env_reported.is_empty(),
                departures: s.falsify_at_departures,
            },
            points: method_points.len(),
            cms_count: cms.len(),
            ranges: cms_ranges.clone(),
        }];

        let rm = residual_minimisation(&eip_points);
        let mut random_subsets = None;
        if extras.baselines {
            let all_points: Vec<Point> = (0..cands.len()).map(point).collect();
            let (subsets, random) = self.random_subsets(&all_points, m_final);
            random_subsets = Some(subsets);
            falsifications.push(random);
            falsifications.push(self.equidistant(&series, &used, m_final, p_final)?);
            lap("baselines", &mut timings);
        }

        let mut entropy_curves = Vec::new();
        if extras.curves {
            let mut sets: Vec<(String, Vec<usize>)> = series
                .iter()
                .enumerate()
                .map(|(si, ser)| {
                    (
                        ser.sensor.clone(),
                        (0..cands.len()).filter(|&i| cands[i].0 == si).collect(),
                    )
                })
                .collect();
            if series.len() > 1 {
                let label = series
                    .iter()
                    .map(|s| s.sensor.as_str())
                    .collect::<Vec<_>>()
                    .join("+");
                sets.push((label, all.clone()));
            }
            for (label, allowed) in sets {
                let sel = greedy_joint_entropy(&binned, &allowed, 0.0, allowed.len());
                entropy_curves.push(EntropyCurve {
                    label,
                    joint_entropy_bits: sel.joint_bits,
                });
            }
            lap("entropy curves", &mut timings);
        }

        let population = population_ranges(cal);
        let refuted = cms.is_empty() && !below_population;
        let (summary, hint) = if below_population {
            below_population_words(&population, s)
        } else {
            summarise(&cms_ranges, cms.len(), n, method_points.len(), s)
        };
        let severity = SeverityRange::of_answer(
            true,
            cms_ranges.as_ref(),
            below_population.then_some(population.l0_mm[0]),
            s,
        );
        Ok(Identification {
            measurement: m.path.display().to_string(),
            speed: self.speed_use(m),
            load,
            bank_id: meta.bank_id.clone(),
            bank_instances: n,
            population,
            alignment,
            series,
            pip_distance: s.pip_distance,
            pips_per_series: s.pips_per_series,
            candidates,
            eip: selection.order,
            eip_joint_entropy_bits: selection.joint_bits,
            envelope: env_reported,
            alpha_bits: alpha,
            entropy_curves,
            phi: s.phi,
            per_point_probability: p_final,
            cms,
            falsifications,
            wheel_ranges,
            residual_minimisation: Some(instance(&self.params, rm)),
            random_subsets,
            model_class_refuted: refuted,
            below_population,
            detection: Some(detection),
            summary,
            maintenance_hint: hint,
            severity: Some(severity),
            timings_ms: timings,
            refinement: None,
        })
    }
}
