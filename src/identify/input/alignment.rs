//! How a pass was put on the bank's time axis ([`Alignment`]) and at which speed it was
//! compared ([`SpeedUse`]): what the input stage tells the answer (re-exported by
//! [`crate::identify::answer::result`]).

use serde::{Deserialize, Serialize};
use std::fmt;

/// How the measurement was put on the bank's time axis. Written as `laser trigger` or
/// `cross-correlation`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum AlignmentMethod {
    /// The laser trigger's time stamp.
    #[serde(rename = "laser trigger")]
    LaserTrigger,
    /// Cross-correlation with the bank's flat-free response.
    #[serde(rename = "cross-correlation")]
    CrossCorrelation,
}

impl fmt::Display for AlignmentMethod {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.pad(match self {
            AlignmentMethod::LaserTrigger => "laser trigger",
            AlignmentMethod::CrossCorrelation => "cross-correlation",
        })
    }
}

/// How the measurement was put on the bank's time axis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Alignment {
    /// The laser trigger or cross-correlation.
    pub method: AlignmentMethod,
    /// Bank time = measurement time + `shift_s`.
    pub shift_s: f64,
    /// For cross-correlation: the normalised correlation at the chosen shift (1 = perfect).
    pub correlation: Option<f64>,
}

/// The speed a pass was identified at.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct SpeedUse {
    /// The pass's speed (km/h), from its speed line or `--speed` (`None`: not stated; the
    /// library then compares it as if at the bank's speed).
    pub pass_km_per_h: Option<f64>,
    /// The speed of the bank (the family member) it was compared with (km/h); a pass at
    /// another speed was put on the bank's time axis (times × pass / bank).
    pub bank_km_per_h: f64,
}
