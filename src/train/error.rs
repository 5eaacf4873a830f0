//! Why a train could not be identified: each variant names what failed.

use crate::identify::IdentifyError;
use std::path::PathBuf;

/// Why a whole train's identification or refinement stopped.
#[derive(Debug, thiserror::Error)]
pub enum TrainError {
    /// The bank's population does not hold a flat on either wheel anywhere on a revolution.
    #[error(
        "bank {} does not cover a train: its population has the flat on the {wheels} wheel{} and X_p over {span_m:.2} m of the {revolution_m:.2} m wheel revolution. A flat can be on either wheel and strike anywhere along a revolution: build a bank of the site profile, the default (`wheelflat bank generate --out train-bank`; or `wheelflat calibration --out site.toml` to start a calibration from)",
        dir.display(),
        if wheels.contains(" and ") { "s" } else { "" }
    )]
    NotCovering {
        /// The bank's directory.
        dir: PathBuf,
        /// The wheels its population puts the flat on, in words ("leading and trailing").
        wheels: String,
        /// The span of X_p it draws (m).
        span_m: f64,
        /// The wheel's revolution (m).
        revolution_m: f64,
    },
    /// Not one bank (or family member) per bogie.
    #[error("{bogies} bogies and {banks} banks for them")]
    BanksPerBogie {
        /// Bogies found in the trigger file.
        bogies: usize,
        /// Banks given.
        banks: usize,
    },
    /// A bogie's identification or a wheel's refinement refused.
    #[error(transparent)]
    Identify(#[from] IdentifyError),
}
