//! Identification from the bank (paper §2–3, docs/model.md §7–8): perceptually important points
//! of the measured series, joint-entropy selection, error-domain model falsification.
//!
//! [`Identifier::new`] opens what is reused across measurements (the memory-mapped bank, its
//! parameters, the Monte Carlo uncertainty samples); [`Identifier::identify`] is the per-
//! measurement path: align, PIP, read the candidate columns, entropy selection, falsify.

// The stages, each folder using only those above it here: the pass as the bank sees it; the
// error domain (the uncertainty table, the thresholds, the cells and the falsification rule);
// detection; where to compare; what the answer says.
pub(crate) mod answer;
pub(crate) mod detect;
pub(crate) mod domain;
mod identifier;
pub(crate) mod input;
pub mod refine;
pub(crate) mod select;
mod stages;
pub mod synth;

// The public modules of the stages, under the paths they had before the stage folders.
pub use answer::json;
pub use answer::result;
pub use detect::out_of_round;
pub use detect::roughness;
pub use domain::falsify;
pub use input::compare;
pub use select::envelope;

pub use answer::identification::Identification;
pub use answer::severity::{FlatVerdict, Severity, SeverityRange};
pub use answer::sizing::Sizing;
pub use identifier::Identifier;
pub use input::measurement::Measurement;

use crate::bank::BankError;
use crate::model::WheelPosition;
use crate::stopwatch::Stopwatch;

pub use compare::Comparison;
pub use detect::spike::SpikeTest;
pub use detect::{Detection, DetectionLimit};
use input::prepare::Prepared;
pub use result::WheelRanges;
pub use roughness::RoughnessUse;
use std::path::PathBuf;
use thiserror::Error;

pub use answer::ranges::wheels_of;
pub use detect::family::Members;
pub use domain::cells::{unit_points, Cells};
pub use domain::uncertainty::{CombinedUncertainty, ThresholdCurve};

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
    /// A refinement setting outside its range, named with its value.
    #[error("refine {setting} = {value}: must be {range}")]
    Setting {
        /// The setting, in words ("simulations", "kappa", …).
        setting: &'static str,
        /// Its value as given.
        value: String,
        /// The range it must lie in.
        range: &'static str,
    },
    /// A pass without its speed, against a family (its speed picks the member).
    #[error("{}: the pass's speed is needed to pick a bank", path.display())]
    NoSpeed {
        /// The measurement.
        path: PathBuf,
    },
    /// No member of a family over loads at the pass's speed holds the load the record shows.
    #[error("{refusal} (the record's load: {:.1}–{:.1} kN a wheel, {:.0} %; car body ≈ {car_body_mass_kg:.0} kg)", interval_kn[0], interval_kn[1], probability * 100.0)]
    Load {
        /// Why no member holds it (in the message, so not a source: its words once).
        refusal: crate::bank::family::SpeedError,
        /// The load interval the record shows (kN a wheel).
        interval_kn: [f64; 2],
        /// The interval's probability.
        probability: f64,
        /// The car-body mass that load means (kg).
        car_body_mass_kg: f64,
    },
    /// The bank's roughness table has no row for the wheels the settings state.
    #[error("the bank's roughness table has no row for {wheels} wheels")]
    NoRoughnessRow {
        /// The wheels stated, in words.
        wheels: &'static str,
    },
    /// A bank's stored calibration that no longer checks or builds a model (a bank from
    /// another version), for a refinement that simulates with it.
    #[error("bank {bank_id}: its stored calibration: {reason}")]
    StoredCalibration {
        /// The bank.
        bank_id: String,
        /// Why, as the calibration check or the model says it (either error's words).
        reason: String,
    },
    /// A refinement's simulation of a flat failed.
    #[error("refinement: simulating a flat failed: {0}")]
    Simulation(crate::model::SimError),
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

impl Identifier {
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
        let mut laps = Stopwatch::start_ms();
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
        // The load the record shows, and the record put on the bank's load (input::load::at_bank_load).
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
                laps.laps,
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
        let z = stages::SizingInput {
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
