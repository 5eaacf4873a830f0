//! What a receiver is sent: one JSON object an alarm, versioned by `schema` (docs/alarms.md,
//! "The body"). Fields are added within a version, never renamed or removed; a receiver
//! ignores fields it does not know.

use super::Rule;
use crate::identify::SeverityRange;
use serde::{Deserialize, Serialize};

/// The body's schema version.
pub const BODY_SCHEMA: u32 = 1;

/// One alarm as sent.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AlarmBody {
    /// [`BODY_SCHEMA`].
    pub schema: u32,
    /// The alarm's key, also sent as the `Idempotency-Key` header: the same alarm delivered
    /// twice (at least once) has the same key.
    pub key: String,
    /// The rule that raised it.
    pub rule: Rule,
    /// When it was raised (RFC 3339, UTC).
    pub raised_at: String,
    /// The site's name, when the configuration gives one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub site: Option<String>,
    /// The alarm in words.
    pub words: String,
    /// The wheel (`<bogie_id>/leading` or `…/trailing`), when the pass named its bogie.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wheel_id: Option<String>,
    /// `leading` or `trailing`, for an alarm of a pass.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wheel: Option<String>,
    /// The pass that raised it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pass: Option<PassRef>,
    /// The classes the pass's answer spans (`highest`: the one acted on).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub severity: Option<SeverityRange>,
    /// [`Rule::ClassRose`]: the wheel's classes at its previous pass.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub previous_severity: Option<SeverityRange>,
    /// The pass's L0 range (mm), when it sized a flat on this wheel.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub l0_mm: Option<[f64; 2]>,
    /// [`Rule::FlatGrew`]: the joint L0 range of the newest passes (mm).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub joint_l0_mm: Option<[f64; 2]>,
    /// [`Rule::Refusals`]: how many, within how long.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refusals: Option<RefusalCount>,
    /// [`Rule::CalibrationDrift`]: the check and what drifted.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drift: Option<Drift>,
}

/// The pass an alarm is about.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PassRef {
    /// Its row id (`serve`'s `/pass/<id>`).
    pub id: i64,
    /// Its key (SHA-256 of its record).
    pub key: String,
    /// When it was identified (RFC 3339, UTC).
    pub time: String,
    /// The measurement file.
    pub measurement: String,
    /// The bank it was compared with.
    pub bank_id: String,
    /// Its speed (km/h), when stated.
    pub speed_km_per_h: Option<f64>,
    /// Its verdict in words.
    pub summary: String,
}

/// The refusals that raised an alarm.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RefusalCount {
    /// Refused passes within the window.
    pub count: usize,
    /// The window (hours).
    pub hours: f64,
    /// The newest refused measurement.
    pub newest_measurement: String,
    /// Why it was refused.
    pub newest_reason: String,
}

/// A nightly check that found drift.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Drift {
    /// The check's report file (in the bank folder).
    pub check_file: String,
    /// What drifted.
    pub drifted: Vec<DriftLine>,
}

/// One value that drifted.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DriftLine {
    /// What (`pad stiffness`, a sensor's gain, …).
    pub what: String,
    /// The calibration's value.
    pub was: f64,
    /// The site's now: the estimate, then its interval (low, high).
    pub now: [f64; 3],
}
