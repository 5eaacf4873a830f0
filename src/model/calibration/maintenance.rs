//! `[maintenance]`: the severity classes' limits, an operator's rulebook, checked once and
//! put into the identification settings the rule reads.

use super::check::{invalid, positive};
use super::{CalibrationError, IdentificationParams, MaintenanceRule};
use serde::{Deserialize, Serialize};

/// The severity classes' limits (`[maintenance]`): on the fresh-flat length L0 by default
/// (25 mm inspect, 40 mm urgent), or on the dynamic ratio with `rule = "impact"`. A limit
/// itself belongs to the graver class. Keys left out take the defaults.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MaintenanceParams {
    /// What the classes are read from: `"l0"` or `"impact"`.
    pub rule: MaintenanceRule,
    /// From this upper L0 bound (mm) the wheel is inspected.
    pub inspect_l0_mm: f64,
    /// From this upper L0 bound (mm) the wheelset is removed within 24 hours.
    pub urgent_l0_mm: f64,
    /// Impact rule: the dynamic ratio from which the wheel is inspected.
    pub inspect_dynamic_ratio: f64,
    /// Impact rule: the dynamic ratio from which the wheelset is removed within 24 hours.
    pub urgent_dynamic_ratio: f64,
}

impl Default for MaintenanceParams {
    fn default() -> MaintenanceParams {
        MaintenanceParams::of(&IdentificationParams::default())
    }
}

/// The keys of `[identification]` that `[maintenance]` replaces (read still, as legacy keys;
/// never written by [`Calibration::to_operator_toml_string`]).
pub(super) const LEGACY_IDENTIFICATION_KEYS: [&str; 5] = [
    "maintenance_rule",
    "inspect_l0_mm",
    "urgent_l0_mm",
    "inspect_dynamic_ratio",
    "urgent_dynamic_ratio",
];

impl MaintenanceParams {
    /// Both limits positive, the inspection limit below the urgent one (each rule's).
    pub(super) fn check(&self) -> Result<(), CalibrationError> {
        positive("maintenance.inspect_l0_mm", self.inspect_l0_mm)?;
        positive("maintenance.urgent_l0_mm", self.urgent_l0_mm)?;
        if self.inspect_l0_mm >= self.urgent_l0_mm {
            return Err(invalid(
                "maintenance.inspect_l0_mm",
                self.inspect_l0_mm,
                &format!(
                    "must lie below maintenance.urgent_l0_mm ({}): the inspection class lies below the urgent one",
                    self.urgent_l0_mm
                ),
            ));
        }
        positive(
            "maintenance.inspect_dynamic_ratio",
            self.inspect_dynamic_ratio,
        )?;
        if self.inspect_dynamic_ratio >= self.urgent_dynamic_ratio {
            return Err(invalid(
                "maintenance.inspect_dynamic_ratio",
                self.inspect_dynamic_ratio,
                &format!(
                    "must lie below maintenance.urgent_dynamic_ratio ({})",
                    self.urgent_dynamic_ratio
                ),
            ));
        }
        Ok(())
    }

    /// The limits the settings hold now (the legacy `[identification]` keys, or a
    /// `[maintenance]` already applied to them).
    pub fn of(id: &IdentificationParams) -> MaintenanceParams {
        MaintenanceParams {
            rule: id.maintenance_rule,
            inspect_l0_mm: id.inspect_l0_mm,
            urgent_l0_mm: id.urgent_l0_mm,
            inspect_dynamic_ratio: id.inspect_dynamic_ratio,
            urgent_dynamic_ratio: id.urgent_dynamic_ratio,
        }
    }

    /// The limits into the settings the rule reads.
    pub(super) fn apply(&self, id: &mut IdentificationParams) {
        id.maintenance_rule = self.rule;
        id.inspect_l0_mm = self.inspect_l0_mm;
        id.urgent_l0_mm = self.urgent_l0_mm;
        id.inspect_dynamic_ratio = self.inspect_dynamic_ratio;
        id.urgent_dynamic_ratio = self.urgent_dynamic_ratio;
    }
}

#[cfg(test)]
mod tests {
    use super::{MaintenanceParams, LEGACY_IDENTIFICATION_KEYS};
    use crate::model::Calibration;

    #[test]
    fn the_operator_form_states_the_limits_in_maintenance_and_reads_back_the_same() {
        // Limits stated the legacy way, under [identification].
        let mut c = Calibration::default();
        c.identification.urgent_l0_mm = 50.0;
        let text = c.to_operator_toml_string();
        let id = text.split("[identification]").nth(1).unwrap();
        let id = id.split("\n[").next().unwrap();
        for key in LEGACY_IDENTIFICATION_KEYS {
            assert!(
                !id.contains(&format!("\n{key} =")),
                "{key} left in [identification]"
            );
        }
        let back = Calibration::from_toml_str(&text).unwrap();
        let urgent = back.maintenance.as_ref().unwrap().urgent_l0_mm;
        assert!((urgent - 50.0).abs() < 1e-12, "{urgent}");
        // The same settings once checked (the rule reads them from the settings).
        let (a, b) = (c.check().unwrap(), back.check().unwrap());
        assert_eq!(a.identification, b.identification);
        assert_eq!(a.model_toml_string(), b.model_toml_string());
        // A stated [maintenance] wins over the legacy keys and is written as stated.
        let mut d = Calibration::default();
        d.identification.urgent_l0_mm = 50.0;
        d.maintenance = Some(MaintenanceParams {
            urgent_l0_mm: 45.0,
            ..MaintenanceParams::default()
        });
        let back = Calibration::from_toml_str(&d.to_operator_toml_string()).unwrap();
        let urgent = back.check().unwrap().identification.urgent_l0_mm;
        assert!((urgent - 45.0).abs() < 1e-12, "{urgent}");
    }
}
