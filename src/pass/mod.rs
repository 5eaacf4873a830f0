//! The work one pass needs, shared by every command that identifies (`identify`, `train`,
//! `watch`, and the results database behind them): reading the input files within their
//! bounds ([`input`]), opening the bank or family and picking the member a pass is compared
//! with, identifying one measurement and refining it ([`single`]), identifying a whole train
//! pass and writing its table ([`train`]), and storing a pass in the results database
//! ([`store`]). The command line words what these return; nothing here prints.

pub mod input;
pub mod single;
pub mod store;
pub mod train;

use crate::history::DbError;
use crate::identify::IdentifyError;
use crate::model::CalibrationError;
use crate::report::identify::ReportError;
use std::path::PathBuf;

/// Why a pass could not be done; each variant keeps its cause ([`std::error::Error::source`])
/// and names the file it concerns.
#[derive(Debug, thiserror::Error)]
pub enum PassError {
    /// A file could not be read within its bounds.
    #[error(transparent)]
    Input(#[from] input::InputError),
    /// A calibration file that does not parse or check.
    #[error("in calibration file {}", path.display())]
    Calibration {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: Box<CalibrationError>,
    },
    /// The built-in calibration does not check (a defect of this build).
    #[error("the built-in calibration")]
    Defaults(#[source] Box<CalibrationError>),
    /// A bank's stored calibration that no longer checks (a bank from another version).
    #[error("the bank's stored calibration")]
    StoredCalibration(#[source] Box<CalibrationError>),
    /// The bank or family could not be opened.
    #[error("cannot open bank {}", path.display())]
    OpenBank {
        /// Its directory.
        path: PathBuf,
        /// Why.
        #[source]
        source: Box<IdentifyError>,
    },
    /// No member of the family can take this pass (its speed or load is outside them all).
    #[error("measurement {}", path.display())]
    NoMember {
        /// The measurement.
        path: PathBuf,
        /// Why.
        #[source]
        source: Box<IdentifyError>,
    },
    /// No member of the family can take one bogie of a train pass.
    #[error("{}: bogie {bogie} (lines {} and {})", triggers.display(), 2 * bogie, 2 * bogie + 1)]
    NoMemberForBogie {
        /// The trigger file.
        triggers: PathBuf,
        /// The bogie (1-based).
        bogie: usize,
        /// Why.
        #[source]
        source: Box<IdentifyError>,
    },
    /// Identification or refinement refused the pass.
    #[error(transparent)]
    Identify(Box<IdentifyError>),
    /// A train's checks, its identification or its refinement refused the pass.
    #[error(transparent)]
    Train(Box<crate::train::TrainError>),
    /// The results database refused a pass.
    #[error("cannot store {what}")]
    Store {
        /// The pass, in words.
        what: String,
        /// Why.
        #[source]
        source: Box<DbError>,
    },
    /// The results database could not be opened.
    #[error("cannot open the results database")]
    OpenDb(#[source] Box<DbError>),
    /// A pass's file could not be read to key it.
    #[error("cannot read {}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// A result could not be written.
    #[error("cannot write {}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// An output folder could not be made.
    #[error("cannot create output folder {}", path.display())]
    CreateFolder {
        /// The folder.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// An identification's result could not be written.
    #[error("cannot write the result in {}", dir.display())]
    Report {
        /// The folder.
        dir: PathBuf,
        /// Why.
        #[source]
        source: Box<ReportError>,
    },
}

impl From<crate::train::TrainError> for PassError {
    fn from(e: crate::train::TrainError) -> PassError {
        PassError::Train(Box::new(e))
    }
}

impl From<IdentifyError> for PassError {
    fn from(e: IdentifyError) -> PassError {
        PassError::Identify(Box::new(e))
    }
}
