//! Identification from the bank (paper §2–3, docs/model.md §7–8): perceptually important points
//! of the measured series, joint-entropy selection, error-domain model falsification.
//!
//! [`Identifier::new`] opens what is reused across measurements (the memory-mapped bank, its
//! parameters, the Monte Carlo uncertainty samples); [`Identifier::identify`] is the per-
//! measurement path: align, PIP, read the candidate columns, entropy selection, falsify.

mod baselines;
pub(crate) mod buffer;
pub(crate) mod cells;
pub(crate) mod detect;
mod discretisation;
pub(crate) mod entropy;
pub mod envelope;
pub mod falsify;
pub(crate) mod family;
mod flat_free;
pub(crate) mod load;
pub(crate) mod measurement;
pub(crate) mod pip;
mod prepare;
pub(crate) mod ranges;
pub mod refine;
pub mod result;
pub(crate) mod severity;
pub(crate) mod sparse;
mod stages;
pub mod synth;
pub(crate) mod uncertainty;

pub use measurement::Measurement;
pub use result::Identification;
pub use severity::{FlatVerdict, Severity, SeverityRange};

use crate::bank::{Bank, BankError, Parameters};
use crate::model::calibration::IdentificationParams;
use crate::model::WheelPosition;

pub use detect::{Detection, DetectionLimit};
use falsify::{falsify, Resolution};
use prepare::Prepared;
use ranges::ranges_of;
use result::ParamRanges;
pub use result::WheelRanges;
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
        } = self.prepare(m, sensors)?;
        let axes: Vec<usize> = used.iter().map(|&(_, bi)| bi).collect();
        // The load the record shows, and the record put on the bank's load (load::at_bank_load).
        let load = self.load_of(&self.detect(&axes, &series));
        if let Some(l) = load.as_ref().filter(|_| !extras.as_recorded) {
            self.at_bank_load(&axes, &mut series, l);
        }
        let detection = self.detect(&axes, &series);
        laps.lap("detection");
        if !detection.flat_detected {
            return self.no_flat(m, (alignment, series), detection, load, &axes, laps.timings);
        }
        let parts = stages::Prepared {
            alignment,
            series,
            load,
            detection,
        };
        let z = stages::Sizing {
            m,
            extras,
            used: &used,
            cands: &cands,
        };
        let mut buffer = self.buffers.lock().unwrap_or_else(|e| e.into_inner());
        let read = self.read_predictions(&z, &parts.series, &mut buffer, &mut laps)?;
        let mut bin_buffer = self.bin_buffers.lock().unwrap_or_else(|e| e.into_inner());
        let selected = self.select_points(&read, &mut bin_buffer, &mut laps)?;
        let judged = self.judge(
            &z,
            &parts.series,
            &read,
            &selected,
            &axes,
            &parts.detection,
            &mut laps,
        )?;
        self.assemble(&z, &read, selected, judged, parts, laps)
    }
}
