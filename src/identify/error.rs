//! [`IdentifyError`]: why an identification failed, naming what failed.

use crate::bank::BankError;
use std::path::PathBuf;
use thiserror::Error;

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
