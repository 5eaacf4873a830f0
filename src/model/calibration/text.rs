//! The calibration as text: parsed, written as a bank stores it ([`Calibration::to_toml_string`],
//! which a bank's `calibration_sha256` is of), written as an operator edits it
//! ([`Calibration::to_operator_toml_string`]: the class limits in `[maintenance]`), and its
//! model part ([`Calibration::model_toml_string`], a bank's identity).

use super::maintenance::LEGACY_IDENTIFICATION_KEYS;
use super::{Calibration, CalibrationError, MaintenanceParams};

/// The header comment of a written calibration.
const HEADER: &str =
    "# wheelflat calibration: train-track model, sensors, sampling, integration and\n\
     # population ranges. Units are in the key names (SI, except speed in km/h and\n\
     # flat sizes in mm). Defaults follow docs/model.md; docs/calibration.md explains each key.\n\
     # contact.hertz_constant_n_per_m1_5, when absent, is computed from the wheel radius.\n\n";

impl Calibration {
    /// Parses a TOML document (no checking beyond syntax and key names).
    pub fn from_toml_str(text: &str) -> Result<Calibration, CalibrationError> {
        Ok(toml::from_str(text)?)
    }

    /// The model part of the document (everything but `[identification]` and
    /// `[maintenance]`) as canonical TOML: what determines simulated values, and so a bank's
    /// identity.
    pub fn model_toml_string(&self) -> String {
        // The `[identification]` and `[maintenance]` tables are left out altogether, so that
        // neither their values nor their defaults (which change between versions) enter a
        // bank's identity.
        let mut model = toml::Table::try_from(self).expect("calibration always serialises");
        model.remove("identification");
        model.remove("maintenance");
        toml::to_string_pretty(&model).expect("a TOML table always serialises")
    }

    /// The document as TOML, with a header comment.
    pub fn to_toml_string(&self) -> String {
        let body = toml::to_string_pretty(self).expect("calibration always serialises");
        format!("{HEADER}{body}")
    }

    /// The document as an operator edits it: the class limits in `[maintenance]` (the
    /// limits in force, wherever they were stated), none of the legacy `[identification]`
    /// keys it replaces. Reads back to the same settings. (A bank keeps the form
    /// [`Calibration::to_toml_string`] writes, which its stored hash is of.)
    pub fn to_operator_toml_string(&self) -> String {
        let mut c = self.clone();
        let limits = match &c.maintenance {
            Some(m) => m.clone(),
            None => MaintenanceParams::of(&c.identification),
        };
        c.maintenance = Some(limits);
        let mut doc = toml::Table::try_from(&c).expect("calibration always serialises");
        if let Some(toml::Value::Table(id)) = doc.get_mut("identification") {
            for key in LEGACY_IDENTIFICATION_KEYS {
                id.remove(key);
            }
        }
        let body = toml::to_string_pretty(&doc).expect("a TOML table always serialises");
        format!("{}{body}", HEADER)
    }
}
