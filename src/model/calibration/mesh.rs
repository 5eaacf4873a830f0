//! Where the rail is meshed finer than `integration.elements_per_bay`
//! ([`IntegrationParams::refine`]): the element count of each bay, and the check of the spans.

use super::check::{invalid, within};
use super::{CalibrationError, IntegrationParams};
use serde::{Deserialize, Serialize};

/// A stretch of rail meshed finer ([`IntegrationParams::refine`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RefinedSpan {
    /// Start (m from the left rail end).
    pub from_m: f64,
    /// End (m).
    pub to_m: f64,
    /// Elements in every bay it overlaps (at least `elements_per_bay`).
    pub elements_per_bay: usize,
}

impl IntegrationParams {
    /// The element count of each of `bays` bays of `spacing_m`: `elements_per_bay`, or a
    /// refined span's where one overlaps the bay.
    pub fn bay_elements(&self, bays: usize, spacing_m: f64) -> Vec<usize> {
        (0..bays)
            .map(|b| {
                let (x0, x1) = (b as f64 * spacing_m, (b + 1) as f64 * spacing_m);
                self.refine
                    .iter()
                    .filter(|r| r.from_m < x1 && r.to_m > x0)
                    .map(|r| r.elements_per_bay)
                    .fold(self.elements_per_bay, usize::max)
            })
            .collect()
    }

    /// Checks the refined spans: each from below to, its element count from
    /// `elements_per_bay` to 64.
    pub(super) fn check_refine(&self) -> Result<(), CalibrationError> {
        for (i, r) in self.refine.iter().enumerate() {
            let key = format!("integration.refine[{i}]");
            if !(r.from_m.is_finite() && r.to_m.is_finite() && r.from_m < r.to_m) {
                return Err(invalid(
                    &key,
                    format!("{}–{} m", r.from_m, r.to_m),
                    "from_m must be below to_m",
                ));
            }
            within(
                &format!("{key}.elements_per_bay"),
                r.elements_per_bay as f64,
                self.elements_per_bay as f64,
                64.0,
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Calibration;

    #[test]
    fn a_span_refines_the_bays_it_overlaps_and_a_bad_one_is_refused_by_key() {
        let mut c = Calibration::default();
        let s = c.track.sleeper_spacing_m;
        c.integration.refine = vec![RefinedSpan {
            from_m: 2.5 * s,
            to_m: 4.0 * s,
            elements_per_bay: 16,
        }];
        // Bays 2 and 3 (from 2 s to 4 s); bay 4 starts where the span ends.
        let bays = c.integration.bay_elements(6, s);
        assert_eq!(bays, [4, 4, 16, 16, 4, 4]);
        c.clone().check().unwrap();
        // The text round-trips; without spans it is as before (no `refine` key).
        let back = Calibration::from_toml_str(&c.to_toml_string()).unwrap();
        assert_eq!(back.integration, c.integration);
        assert!(!Calibration::default()
            .to_toml_string()
            .contains("[[integration.refine]]"));
        c.integration.refine[0].elements_per_bay = 2;
        let msg = c.clone().check().unwrap_err().to_string();
        assert!(
            msg.contains("integration.refine[0].elements_per_bay"),
            "{msg}"
        );
        c.integration.refine[0] = RefinedSpan {
            from_m: 5.0,
            to_m: 4.0,
            elements_per_bay: 16,
        };
        let msg = c.check().unwrap_err().to_string();
        assert!(
            msg.contains("integration.refine[0]") && msg.contains("5–4 m"),
            "{msg}"
        );
    }
}
