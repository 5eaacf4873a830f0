//! A stored wheel pass as read from the database, every value checked before it is trusted.

use crate::history::record::{boxes_from_bytes, Claim, Space, WheelPass};
use crate::identify::{Severity, SeverityRange};
use crate::model::WheelPosition;

/// A stored pass of one wheel, as `history` reads it.
#[derive(Debug, Clone, PartialEq)]
pub struct StoredPass {
    /// Row id of the pass.
    pub pass_id: i64,
    /// When it was identified (RFC 3339, UTC).
    pub time: String,
    /// The same in Unix seconds.
    pub time_s: f64,
    /// The measurement file.
    pub measurement: String,
    /// The pass's speed (km/h).
    pub speed_km_per_h: Option<f64>,
    /// The bank's speed (km/h).
    pub bank_speed_km_per_h: f64,
    /// The bank it was compared with.
    pub bank_id: String,
    /// What it says of the wheel.
    pub wheel: WheelPass,
}

/// A row as read, checked by [`RawRow::parse`].
pub(crate) struct RawRow {
    pub(crate) pass_id: i64,
    pub(crate) time: String,
    pub(crate) time_s: f64,
    pub(crate) measurement: String,
    pub(crate) speed: Option<f64>,
    pub(crate) bank_speed: f64,
    pub(crate) bank_id: String,
    pub(crate) wheel: String,
    pub(crate) claim: String,
    pub(crate) l0: (Option<f64>, Option<f64>),
    pub(crate) severity: (Option<String>, Option<String>),
    pub(crate) limit: Option<f64>,
    pub(crate) space: String,
    pub(crate) cells: i64,
    pub(crate) boxes: Vec<u8>,
    pub(crate) dynamic_ratio: (Option<f64>, Option<f64>),
}

impl RawRow {
    /// The stored pass, every value checked before it is trusted.
    // Err(String): what is wrong; the caller names the file and the pass (`DbError::Corrupt`).
    pub(crate) fn parse(self) -> Result<StoredPass, String> {
        let wheel = match self.wheel.as_str() {
            "leading" => WheelPosition::Leading,
            "trailing" => WheelPosition::Trailing,
            w => return Err(format!("wheel `{w}` is neither leading nor trailing")),
        };
        let claim =
            Claim::parse(&self.claim).ok_or_else(|| format!("claim `{}` unknown", self.claim))?;
        let space: Space = serde_json::from_str(&self.space)
            .map_err(|e| format!("space `{}`: {e}", self.space))?;
        let boxes = boxes_from_bytes(&self.boxes).ok_or_else(|| {
            format!(
                "{} bytes of cells are not whole, ordered boxes",
                self.boxes.len()
            )
        })?;
        if boxes.len() as i64 != self.cells {
            return Err(format!(
                "{} cells stored, {} counted",
                boxes.len(),
                self.cells
            ));
        }
        let severity = match self.severity {
            (Some(lo), Some(hi)) => Some(SeverityRange {
                lowest: severity_of(&lo).ok_or_else(|| format!("severity `{lo}`"))?,
                highest: severity_of(&hi).ok_or_else(|| format!("severity `{hi}`"))?,
            }),
            _ => None,
        };
        if let (Some(a), Some(b)) = self.dynamic_ratio {
            if !(a.is_finite() && b.is_finite() && a <= b) {
                return Err(format!("dynamic ratio [{a}, {b}] is not an ordered range"));
            }
        }
        if !self.time_s.is_finite() {
            return Err("time is not a finite number".into());
        }
        Ok(StoredPass {
            pass_id: self.pass_id,
            time: self.time,
            time_s: self.time_s,
            measurement: self.measurement,
            speed_km_per_h: self.speed,
            bank_speed_km_per_h: self.bank_speed,
            bank_id: self.bank_id,
            wheel: WheelPass {
                wheel,
                claim,
                l0_mm: self.l0.0.zip(self.l0.1).map(|(a, b)| [a, b]),
                severity,
                space,
                limit_l0_mm: self.limit,
                boxes,
                dynamic_ratio: self
                    .dynamic_ratio
                    .0
                    .zip(self.dynamic_ratio.1)
                    .map(|(a, b)| [a, b]),
            },
        })
    }
}

pub(crate) fn severity_of(s: &str) -> Option<Severity> {
    [
        Severity::None,
        Severity::Monitor,
        Severity::Inspect,
        Severity::Urgent,
    ]
    .into_iter()
    .find(|c| c.as_str() == s)
}

/// The classes of a stored range (`severity_lowest`, `severity_highest`), none when either is
/// absent or not a class name (the lists' reading; [`RawRow::parse`] refuses a bad name).
pub(crate) fn severity_range(lo: Option<&str>, hi: Option<&str>) -> Option<SeverityRange> {
    let lowest = severity_of(lo?)?;
    let highest = severity_of(hi?)?;
    Some(SeverityRange { lowest, highest })
}
