//! Detection's second test, on the record as taken: a strike that the comparison's average
//! spreads (docs/detection.md, "Rough wheels").

use serde::{Deserialize, Serialize};

/// The ratio beyond which a record's largest high-frequency value over its level is a strike,
/// not roughness or noise ([`SpikeTest`]; measured on good wheels: docs/detection.md).
pub(crate) const SPIKE_RATIO: f64 = 8.0;

/// Detection's second test, on the record as taken: a short, sharp strike (a flat below the
/// population) that the comparison's average spreads stands out of the record's own
/// high-frequency content, `x − B₅x`, however rough the treads: a flat is detected when at
/// some sensor the largest `|x − B₅x|` where a wheel is near exceeds [`SPIKE_RATIO`] times the
/// pass's level (the robust scale over the loaded samples, the median over the sensors, at
/// least what the table's noise alone gives).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpikeTest {
    /// Whether a strike stands out.
    pub flat_detected: bool,
    /// The pass's level it is measured against (kN).
    pub level_kn: f64,
    /// The ratio a strike must exceed.
    pub ratio_limit: f64,
    /// Per sensor: its name, largest `|x − B₅x|` (kN) and that over the level.
    pub sensors: Vec<(String, f64, f64)>,
}

impl SpikeTest {
    /// The test of sensors `names` with largest values `peaks_kn` against the level `level_kn`.
    pub fn of(names: &[String], peaks_kn: &[f64], level_kn: f64) -> SpikeTest {
        let sensors: Vec<(String, f64, f64)> = names
            .iter()
            .zip(peaks_kn)
            .map(|(n, &p)| (n.clone(), p, p / level_kn.max(1e-9)))
            .collect();
        SpikeTest {
            flat_detected: sensors.iter().any(|s| s.2 > SPIKE_RATIO),
            level_kn,
            ratio_limit: SPIKE_RATIO,
            sensors,
        }
    }
}
