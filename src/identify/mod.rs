//! Identification from the bank (paper §2–3, docs/model.md §7–8): perceptually important points
//! of the measured series, joint-entropy selection, error-domain model falsification.
//!
//! [`Identifier::new`] opens what is reused across measurements (the memory-mapped bank, its
//! parameters, the Monte Carlo uncertainty samples); [`Identifier::identify`] is the per-
//! measurement path: align, PIP, read the candidate columns, entropy selection, falsify.

mod baselines;
pub(crate) mod buffer;
pub(crate) mod cells;
pub mod compare;
pub(crate) mod detect;
mod discretisation;
pub(crate) mod entropy;
pub mod envelope;
pub mod falsify;
pub(crate) mod family;
mod flat_free;
pub(crate) mod harmonic;
pub(crate) mod load;
pub(crate) mod measurement;
pub mod out_of_round;
pub(crate) mod pip;
mod prepare;
pub(crate) mod ranges;
pub mod refine;
pub mod result;
pub mod roughness;
pub(crate) mod severity;
pub(crate) mod sparse;
pub(crate) mod spike;
mod stages;
pub mod synth;
pub(crate) mod table_bounds;
pub(crate) mod uncertainty;

pub use measurement::Measurement;
pub use result::Identification;
pub use severity::{FlatVerdict, Severity, SeverityRange};

use crate::bank::{Bank, BankError, Parameters};
use crate::model::calibration::IdentificationParams;
use crate::model::WheelPosition;

pub use compare::Comparison;
pub use detect::{Detection, DetectionLimit};
use falsify::{falsify, Resolution};
use prepare::Prepared;
use ranges::ranges_of;
use result::ParamRanges;
pub use result::WheelRanges;
pub use roughness::RoughnessUse;
pub use spike::SpikeTest;
pub(crate) use stages::Laps;
use std::path::PathBuf;
use std::sync::Mutex;
use thiserror::Error;

pub use cells::{unit_points, Cells};
pub use family::Members;
pub use ranges::wheels_of;
pub use uncertainty::{CombinedUncertainty, ThresholdCurve};

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
    /// The bank's departures tables (samples, averaged), loaded when a pass first needs one.
    departures: [Mutex<Option<std::sync::Arc<crate::bank::departures::Departures>>>; 2],
    /// The bank's flat-free predictions through the average, per axis ([`compare`]).
    flat_free_averaged: Vec<Vec<f32>>,
    /// The table's level factor per number of sensors ([`load::level_factor`]), drawn once.
    load_levels: Mutex<std::collections::HashMap<usize, (f64, [f64; 2])>>,
    /// The bank's roughness table, loaded when a pass first needs it ([`roughness`]).
    roughness: Mutex<Option<std::sync::Arc<crate::bank::roughness::RoughnessTable>>>,
    /// The high-frequency level the settings' noise alone gives ([`roughness::noise_hf_kn`]),
    /// drawn when a pass first needs it.
    noise_hf: std::sync::OnceLock<f64>,
    /// The bank's out-of-round basis, simulated when a pass first needs it ([`out_of_round`]).
    out_of_round: Mutex<Option<std::sync::Arc<crate::bank::out_of_round::OutOfRoundBasis>>>,
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
        let flat_free_averaged = compare::averaged_templates(&bank.metadata().flat_free_kn);
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
            departures: [Mutex::new(None), Mutex::new(None)],
            flat_free_averaged,
            load_levels: Mutex::new(std::collections::HashMap::new()),
            roughness: Mutex::new(None),
            noise_hf: std::sync::OnceLock::new(),
            out_of_round: Mutex::new(None),
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

    /// The table's hard bounds a good wheel's record stays within ([`detect::TableBounds`];
    /// a pass adds its roughness, [`RoughnessUse::bounds`]).
    pub fn table_bounds(&self) -> detect::TableBounds {
        self.bounds
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

    /// The bank's flat-free prediction of bank axis `axis` at its samples `from..=to` as
    /// comparison `c` sees it (kN), the largest magnitude: what the bounded sources (a rough
    /// tread or rail) scale with at a comparison point or window.
    pub fn flat_free_peak_kn(&self, axis: usize, from: usize, to: usize, c: Comparison) -> f64 {
        let t = self.flat_free(axis, c);
        let last = t.len().saturating_sub(1);
        t[from.min(last)..=to.min(last)]
            .iter()
            .fold(0.0f64, |m, &g| m.max(f64::from(g).abs()))
    }

    /// The threshold curve of a point measured at `y_kn` whose flat-free prediction is
    /// `flat_free_kn`, in a pass judged with `roughness`: the table's curve widened by its
    /// bounded sources and by the roughness' bound there.
    pub fn point_curve(
        &self,
        roughness: &RoughnessUse,
        y_kn: f64,
        flat_free_kn: f64,
        p: f64,
    ) -> ThresholdCurve {
        let (a, b) = self.uncertainty.good_wheel_widening(flat_free_kn);
        let w = roughness.widening_kn(flat_free_kn);
        self.uncertainty.curve(y_kn, p).widened((a - w, b + w))
    }

    /// The thresholds of a point measured at `y_kn` whose flat-free prediction is
    /// `flat_free_kn`, in a pass judged with `roughness` (as [`Identifier::point_curve`]).
    pub fn point_thresholds(
        &self,
        roughness: &RoughnessUse,
        y_kn: f64,
        flat_free_kn: f64,
        p: f64,
    ) -> (f64, f64) {
        let (lo, hi) = self.uncertainty.thresholds_at(y_kn, flat_free_kn, p);
        let w = roughness.widening_kn(flat_free_kn);
        (lo - w, hi + w)
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

    /// Identifies the flat behind one measurement, stage by stage ([`stages`]): the
    /// measurement prepared (sensors, alignment, series on the bank's windows, PIPs); its load
    /// read and the record put on the bank's load; detection ([`detect`]) — when no flat is
    /// detected, that answer with the pass's detection limit and no sizing; else the bank's
    /// predictions read, the comparison points selected by joint entropy, the envelope points,
    /// falsification and the departure rule, and the result assembled. `sensors` restricts
    /// the sensors used.
    pub fn identify(
        &self,
        m: &Measurement,
        sensors: Option<&[String]>,
        extras: Extras,
    ) -> Result<Identification, IdentifyError> {
        let mut laps = Laps::start();
        let Prepared {
            used,
            alignment,
            mut series,
            cands,
            hf_kn,
            hf_peaks,
        } = self.prepare(m, sensors)?;
        let axes: Vec<usize> = used.iter().map(|&(_, bi)| bi).collect();
        // The roughness the pass is judged with, the bounds it gives, and how it is compared.
        let roughness = self.roughness_use(hf_kn)?;
        let bounds = roughness.bounds(self.bounds);
        let comparison = roughness.comparison();
        // The load the record shows, and the record put on the bank's load (load::at_bank_load).
        let load = self.load_of(&self.detect(&axes, &series, self.bounds, Comparison::Samples));
        if let Some(l) = load.as_ref().filter(|_| !extras.as_recorded) {
            self.at_bank_load(&axes, &mut series, l);
        }
        // Detection compares through the average, with the strike test on the record as taken;
        // wheels stated round, sample by sample as every pass did before roughness was
        // allowed for.
        let averaged = Comparison::Binomial5.series(&series);
        let detected_by = self.detection_comparison();
        let stated_round = detected_by == Comparison::Samples;
        let detection = if stated_round {
            self.detect(&axes, &series, bounds, Comparison::Samples)
        } else {
            let mut d = self.detect(&axes, &averaged, bounds, Comparison::Binomial5);
            let names: Vec<String> = series.iter().map(|s| s.sensor.clone()).collect();
            let level = hf_kn.max(roughness.noise_hf_kn);
            let spike = SpikeTest::of(&names, &hf_peaks, level);
            d.flat_detected |= spike.flat_detected;
            d.spike = Some(spike);
            d
        };
        laps.lap("detection");
        // A departure with no sharp strike may be an out-of-round wheel: named, not sized.
        let mut detection = detection;
        let strike = detection.spike.as_ref().is_some_and(|t| t.flat_detected);
        if detection.flat_detected && !strike {
            let compared = if stated_round { &series } else { &averaged };
            if let Some((fit, mut d)) =
                self.explain_out_of_round(&axes, compared, &detection, bounds, detected_by)?
            {
                d.spike = detection.spike.take();
                d.out_of_round = Some(fit);
                detection = d;
            }
            laps.lap("out of round");
        }
        if !detection.flat_detected {
            return self.no_flat(
                m,
                (alignment, series),
                (detection, roughness),
                load,
                &axes,
                laps.timings,
            );
        }
        // Sizing compares as the roughness says: the departure rule with that comparison's test.
        let (series, cands, rule) = match comparison {
            Comparison::Binomial5 => {
                let cands = self.candidates(&averaged);
                (averaged, cands, detection.clone())
            }
            Comparison::Samples if stated_round => {
                let rule = detection.clone();
                (series, cands, rule)
            }
            Comparison::Samples => {
                let rule = self.detect(&axes, &series, bounds, Comparison::Samples);
                (series, cands, rule)
            }
        };
        let parts = stages::Prepared {
            alignment,
            series,
            load,
            detection,
            rule,
        };
        let z = stages::Sizing {
            m,
            extras,
            used: &used,
            cands: &cands,
            roughness: &roughness,
            comparison,
        };
        let mut buffer = self.buffers.lock().unwrap_or_else(|e| e.into_inner());
        let read = self.read_predictions(&z, &parts.series, &mut buffer, &mut laps)?;
        let mut bin_buffer = self.bin_buffers.lock().unwrap_or_else(|e| e.into_inner());
        let selected = self.select_points(&z, &read, &mut bin_buffer, &mut laps)?;
        let judged = self.judge(
            &z,
            &parts.series,
            &read,
            &selected,
            &axes,
            &parts.rule,
            &mut laps,
        )?;
        self.assemble(&z, &read, selected, judged, parts, laps)
    }
}
