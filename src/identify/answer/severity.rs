//! The maintenance rule, in one place: how urgent a flat is from the fresh-flat length L0 it
//! may have, and the words that go with it (the identification's verdict and hint, the
//! train table's severity and its rule).
//!
//! The rule reads the upper bound of L0 over the candidate model set, the conservative end
//! (an under-estimated flat is the safety risk): from `urgent_l0_mm` the wheelset is removed
//! from service within 24 hours, from `inspect_l0_mm` the wheel is inspected, below that it
//! is monitored. A good wheel is `none`; a wheel whose model class is refuted is inspected.

use crate::identify::answer::result::ParamRanges;
use crate::model::calibration::{IdentificationParams, MaintenanceRule};
use serde::{Deserialize, Serialize};
use std::fmt;

/// A wheel's flat verdict in a pass. Serialises (JSON, CSV) as `no`, `yes`, `unknown` or
/// `not seen`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum FlatVerdict {
    /// No flat: the pass sees this wheel and no flat on it.
    #[serde(rename = "no")]
    No,
    /// A flat, sized.
    #[serde(rename = "yes")]
    Yes,
    /// The model class is refuted for this bogie: something the model lacks is there.
    #[serde(rename = "unknown")]
    Unknown,
    /// No flat detected, but these sensors cannot see this wheel's flats at this pass.
    #[serde(rename = "not seen")]
    NotSeen,
}

impl FlatVerdict {
    /// The name files and people use: `no`, `yes`, `unknown` or `not seen`.
    pub fn as_str(self) -> &'static str {
        match self {
            FlatVerdict::No => "no",
            FlatVerdict::Yes => "yes",
            FlatVerdict::Unknown => "unknown",
            FlatVerdict::NotSeen => "not seen",
        }
    }
}

impl fmt::Display for FlatVerdict {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.pad(self.as_str())
    }
}

/// How urgent a wheel is, ordered from harmless to urgent. Serialises (JSON, CSV) as its
/// lower-case name: `none`, `monitor`, `inspect`, `urgent`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Severity {
    /// No flat can be told from the measurement (the good-wheel check passes).
    None,
    /// A flat below the inspection limit: keep watching it.
    Monitor,
    /// Inspect the wheel at the next opportunity (also when the model is refuted).
    Inspect,
    /// Remove the wheelset from service within 24 hours.
    Urgent,
}

impl Severity {
    /// The rule on the upper L0 bound (mm): `urgent` from `urgent_l0_mm`, `inspect` from
    /// `inspect_l0_mm`, else `monitor`.
    pub fn of_upper_l0(upper_l0_mm: f64, urgent_l0_mm: f64, inspect_l0_mm: f64) -> Severity {
        if upper_l0_mm >= urgent_l0_mm {
            Severity::Urgent
        } else if upper_l0_mm >= inspect_l0_mm {
            Severity::Inspect
        } else {
            Severity::Monitor
        }
    }

    /// The rule on the upper dynamic ratio: `urgent` from `urgent_ratio`, `inspect` from
    /// `inspect_ratio`, else `monitor`.
    pub fn of_upper_ratio(upper: f64, urgent_ratio: f64, inspect_ratio: f64) -> Severity {
        Severity::of_upper_l0(upper, urgent_ratio, inspect_ratio)
    }

    /// The settings' rule ([`MaintenanceRule`]) on a set's ranges: the impact rule where the
    /// ranges carry an impact, else the L0 rule.
    pub fn of_ranges(r: &ParamRanges, s: &IdentificationParams) -> Severity {
        match (s.maintenance_rule, r.impact) {
            (MaintenanceRule::Impact, Some(i)) => Severity::of_upper_ratio(
                i.dynamic_ratio[1],
                s.urgent_dynamic_ratio,
                s.inspect_dynamic_ratio,
            ),
            _ => Severity::of_upper_l0(r.l0_mm[1], s.urgent_l0_mm, s.inspect_l0_mm),
        }
    }

    /// The maintenance hint of a set's ranges under the settings' rule, with the rule stated.
    pub fn hint_of_ranges(r: &ParamRanges, s: &IdentificationParams) -> String {
        let (MaintenanceRule::Impact, Some(i)) = (s.maintenance_rule, r.impact) else {
            return Severity::maintenance_hint(Some(r.l0_mm[1]), s);
        };
        let upper = i.dynamic_ratio[1];
        match Severity::of_ranges(r, s) {
            Severity::Urgent => format!("Remove the wheelset from service within 24 hours: the largest dynamic ratio that fits the measurement ({upper:.2}) reaches the urgent limit of {:.2} (rule: upper dynamic-ratio bound ≥ urgent_dynamic_ratio).", s.urgent_dynamic_ratio),
            Severity::Inspect => format!("Inspect the wheel at the next opportunity: the largest dynamic ratio that fits ({upper:.2}) is between the inspection limit {:.2} and the urgent limit {:.2}.", s.inspect_dynamic_ratio, s.urgent_dynamic_ratio),
            Severity::Monitor | Severity::None => format!("Monitor: the largest dynamic ratio that fits ({upper:.2}) is below the inspection limit of {:.2}.", s.inspect_dynamic_ratio),
        }
    }

    /// One wheel of the train table, from its flat verdict and the L0 range of its flat:
    /// `none` without a flat, the L0 rule with one, `inspect` when the model is refuted
    /// (something the model lacks is on the wheel or the track) or the wheel is not seen.
    pub fn of_wheel(
        flat: FlatVerdict,
        l0_mm: Option<[f64; 2]>,
        urgent_l0_mm: f64,
        inspect_l0_mm: f64,
    ) -> Severity {
        match (flat, l0_mm) {
            (FlatVerdict::No, _) => Severity::None,
            (FlatVerdict::Yes, Some([_, hi])) => {
                Severity::of_upper_l0(hi, urgent_l0_mm, inspect_l0_mm)
            }
            _ => Severity::Inspect,
        }
    }

    /// The name files and people use: `none`, `monitor`, `inspect` or `urgent`.
    pub fn as_str(self) -> &'static str {
        match self {
            Severity::None => "none",
            Severity::Monitor => "monitor",
            Severity::Inspect => "inspect",
            Severity::Urgent => "urgent",
        }
    }

    /// The maintenance hint of one identification, with the rule stated: from the upper L0
    /// bound of its candidate model set, or `None` when every instance is falsified.
    pub fn maintenance_hint(upper_l0_mm: Option<f64>, s: &IdentificationParams) -> String {
        let Some(upper) = upper_l0_mm else {
            return "No flat size can be given: inspect the wheelset and the track at the sensors before relying on this system.".into();
        };
        match Severity::of_upper_l0(upper, s.urgent_l0_mm, s.inspect_l0_mm) {
            Severity::Urgent => format!("Remove the wheelset from service within 24 hours: the largest L0 that fits the measurement ({upper:.0} mm) reaches the urgent limit of {:.0} mm (rule: upper L0 bound ≥ urgent_l0_mm).", s.urgent_l0_mm),
            Severity::Inspect => format!("Inspect the wheel at the next opportunity: the largest L0 that fits ({upper:.0} mm) is between the inspection limit {:.0} mm and the urgent limit {:.0} mm.", s.inspect_l0_mm, s.urgent_l0_mm),
            // The L0 rule gives no `none`: a flat that fits is at least monitored.
            Severity::Monitor | Severity::None => format!("Monitor: the largest L0 that fits ({upper:.0} mm) is below the inspection limit of {:.0} mm.", s.inspect_l0_mm),
        }
    }

    /// The train table's rule in words.
    pub fn train_rule(s: &IdentificationParams) -> String {
        format!(
        "none: no flat detected (every sample within the good wheel's bounds: the table's absolute errors plus {} kN and {} % of the force, after each sensor's gain, and each pass's roughness bound unless round wheels on a smooth rail are stated); an out-of-round wheel named is none too; otherwise by the upper L0 bound of the wheel's candidate model set: urgent (remove within 24 h) from {} mm, inspect from {} mm, monitor below; inspect when every instance is falsified (the model is refuted)",
        s.detection_allowance_kn, 100.0 * s.detection_allowance_fraction, s.urgent_l0_mm, s.inspect_l0_mm
    )
    }
}

/// The classes an answer's range spans, from the lowest to the highest, and the one acted on
/// (the highest: an answer is right or conservative by construction). `decisive` when it spans
/// one class. Serialises as `{"lowest": "inspect", "highest": "urgent"}`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct SeverityRange {
    /// The mildest class the answer allows.
    pub lowest: Severity,
    /// The gravest class it allows: the one acted on.
    pub highest: Severity,
}

impl SeverityRange {
    /// One class.
    pub fn single(s: Severity) -> SeverityRange {
        SeverityRange {
            lowest: s,
            highest: s,
        }
    }

    /// The classes an L0 range `[lo, hi]` (mm) spans under the L0 limits.
    pub fn of_l0(l0_mm: [f64; 2], urgent_l0_mm: f64, inspect_l0_mm: f64) -> SeverityRange {
        SeverityRange {
            lowest: Severity::of_upper_l0(l0_mm[0], urgent_l0_mm, inspect_l0_mm),
            highest: Severity::of_upper_l0(l0_mm[1], urgent_l0_mm, inspect_l0_mm),
        }
    }

    /// The classes a set's ranges span under the settings' rule (the impact rule on the
    /// dynamic-ratio range where the ranges carry one, else the L0 rule).
    pub fn of_ranges(r: &ParamRanges, s: &IdentificationParams) -> SeverityRange {
        match (s.maintenance_rule, r.impact) {
            (MaintenanceRule::Impact, Some(i)) => SeverityRange {
                lowest: Severity::of_upper_ratio(
                    i.dynamic_ratio[0],
                    s.urgent_dynamic_ratio,
                    s.inspect_dynamic_ratio,
                ),
                highest: Severity::of_upper_ratio(
                    i.dynamic_ratio[1],
                    s.urgent_dynamic_ratio,
                    s.inspect_dynamic_ratio,
                ),
            },
            _ => SeverityRange::of_l0(r.l0_mm, s.urgent_l0_mm, s.inspect_l0_mm),
        }
    }

    /// The classes of one identification's answer: `none` for a good wheel, `inspect` for a
    /// refuted model class, `monitor` for a flat below the population (its L0 below the
    /// population's floor, read by the L0 rule), else the candidate set's range.
    pub fn of_answer(
        detected: bool,
        ranges: Option<&ParamRanges>,
        below_population_floor_l0_mm: Option<f64>,
        s: &IdentificationParams,
    ) -> SeverityRange {
        match (detected, below_population_floor_l0_mm, ranges) {
            (false, _, _) => SeverityRange::single(Severity::None),
            (true, Some(floor), _) => SeverityRange::single(Severity::of_upper_l0(
                floor,
                s.urgent_l0_mm,
                s.inspect_l0_mm,
            )),
            (true, None, Some(r)) => SeverityRange::of_ranges(r, s),
            (true, None, None) => SeverityRange::single(Severity::Inspect),
        }
    }

    /// The smallest range holding both.
    pub fn union(self, other: SeverityRange) -> SeverityRange {
        SeverityRange {
            lowest: self.lowest.min(other.lowest),
            highest: self.highest.max(other.highest),
        }
    }

    /// One class: the answer tells the class.
    pub fn decisive(self) -> bool {
        self.lowest == self.highest
    }

    /// The class acted on: the highest.
    pub fn acted_on(self) -> Severity {
        self.highest
    }

    /// The classes spanned in a short form for tables: `urgent`, `inspect-urgent`.
    pub fn short(self) -> String {
        if self.decisive() {
            self.highest.to_string()
        } else {
            format!("{}-{}", self.lowest, self.highest)
        }
    }

    /// The classes spanned and the action: `urgent`, or `inspect or urgent — act as urgent`.
    pub fn words(self) -> String {
        let classes: Vec<&str> = [
            Severity::None,
            Severity::Monitor,
            Severity::Inspect,
            Severity::Urgent,
        ]
        .into_iter()
        .filter(|c| (self.lowest..=self.highest).contains(c))
        .map(Severity::as_str)
        .collect();
        match classes.as_slice() {
            [one] => one.to_string(),
            [init @ .., last] => format!("{} or {last} — act as {}", init.join(", "), self.highest),
            [] => self.highest.to_string(),
        }
    }
}

impl fmt::Display for SeverityRange {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.pad(&self.words())
    }
}

impl fmt::Display for Severity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.pad(self.as_str())
    }
}

/// A severity equals its name (`Severity::Urgent == "urgent"`), as the files write it.
impl PartialEq<&str> for Severity {
    fn eq(&self, other: &&str) -> bool {
        self.as_str() == *other
    }
}

/// The verdict and hint of a detected flat smaller than the population's: its L0 is below the
/// population's smallest, which the L0 rule then reads as the upper bound.
pub(crate) fn below_population_words(
    population: &ParamRanges,
    s: &IdentificationParams,
) -> (String, String) {
    let floor = population.l0_mm[0];
    (
        format!(
            "A flat is detected, smaller than every flat of the bank's population: each instance predicts a larger departure from the good wheel than measured. Its L0 lies below the population's smallest, {floor:.0} mm (sizes below that are not in the bank)."
        ),
        Severity::maintenance_hint(Some(floor), s),
    )
}

/// The human verdict and the maintenance hint (rule stated in the text).
pub(crate) fn summarise(
    r: &Option<ParamRanges>,
    count: usize,
    n: usize,
    m: usize,
    s: &IdentificationParams,
) -> (String, String) {
    match r {
        None => (
            format!(
                "Every one of the {n} model instances is falsified at {m} comparison points (φ = {}): the model class itself is refuted. The measurement shows something the model lacks; run `wheelflat diagnose` to locate and name it.",
                s.phi
            ),
            Severity::maintenance_hint(None, s),
        ),
        Some(r) => {
            let impact = r.impact.map_or(String::new(), |i| {
                format!(
                    " Peak wheel–rail force in [{:.0}, {:.0}] kN at this speed and load (dynamic ratio [{:.2}, {:.2}]).",
                    i.peak_contact_kn[0], i.peak_contact_kn[1], i.dynamic_ratio[0], i.dynamic_ratio[1]
                )
            });
            let wheel = match r.flat_wheels.as_slice() {
                [w] => format!(" on the {} wheel", w.name()),
                _ => " on either wheel".to_string(),
            };
            let summary = format!(
                "{count} of {n} model instances survive {m} comparison points (φ = {}): flat length L in [{:.0}, {:.0}] mm, depth d in [{:.2}, {:.2}] mm, fresh-flat length L0 in [{:.0}, {:.0}] mm, impact at X_p in [{:.2}, {:.2}] m{wheel}.{impact}",
                s.phi, r.length_mm[0], r.length_mm[1], r.depth_mm[0], r.depth_mm[1], r.l0_mm[0], r.l0_mm[1], r.impact_position_m[0], r.impact_position_m[1]
            );
            let hint = Severity::hint_of_ranges(r, s);
            (summary, hint)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn severity_follows_the_stated_rule() {
        // Moved from `train::severity`, which is now `Severity::of_wheel`.
        let severity = Severity::of_wheel;
        let (no, yes) = (FlatVerdict::No, FlatVerdict::Yes);
        assert_eq!(severity(no, None, 40.0, 25.0), "none");
        assert_eq!(severity(yes, Some([30.0, 41.0]), 40.0, 25.0), "urgent");
        assert_eq!(severity(yes, Some([20.0, 30.0]), 40.0, 25.0), "inspect");
        assert_eq!(severity(yes, Some([18.0, 24.0]), 40.0, 25.0), "monitor");
        assert_eq!(severity(FlatVerdict::Unknown, None, 40.0, 25.0), "inspect");
    }

    #[test]
    fn the_limits_themselves_belong_to_the_graver_class() {
        assert_eq!(Severity::of_upper_l0(40.0, 40.0, 25.0), Severity::Urgent);
        assert_eq!(Severity::of_upper_l0(25.0, 40.0, 25.0), Severity::Inspect);
        assert_eq!(Severity::of_upper_l0(24.999, 40.0, 25.0), Severity::Monitor);
        assert!(Severity::None < Severity::Monitor && Severity::Inspect < Severity::Urgent);
    }

    #[test]
    fn serialises_to_the_names_the_files_have_always_used() {
        for (s, name) in [
            (Severity::None, "none"),
            (Severity::Monitor, "monitor"),
            (Severity::Inspect, "inspect"),
            (Severity::Urgent, "urgent"),
        ] {
            assert_eq!(serde_json::to_string(&s).unwrap(), format!("\"{name}\""));
            assert_eq!(
                serde_json::from_str::<Severity>(&format!("\"{name}\"")).unwrap(),
                s
            );
            assert_eq!(s.to_string(), name);
            assert_eq!(format!("{s:<8}|"), format!("{name:<8}|"));
        }
    }

    #[test]
    fn a_range_names_its_classes_and_acts_on_the_highest() {
        let r = SeverityRange::of_l0([30.0, 45.0], 40.0, 25.0);
        assert_eq!((r.lowest, r.highest), (Severity::Inspect, Severity::Urgent));
        assert!(!r.decisive());
        assert_eq!(r.acted_on(), Severity::Urgent);
        assert_eq!(r.words(), "inspect or urgent — act as urgent");
        assert_eq!(r.short(), "inspect-urgent");
        let wide = SeverityRange::of_l0([20.0, 45.0], 40.0, 25.0);
        assert_eq!(wide.words(), "monitor, inspect or urgent — act as urgent");
        let one = SeverityRange::of_l0([41.0, 55.0], 40.0, 25.0);
        assert!(one.decisive());
        assert_eq!(one.words(), "urgent");
        // Other limits (an operator's rulebook) move the classes.
        let other = SeverityRange::of_l0([30.0, 45.0], 50.0, 20.0);
        assert_eq!(other.words(), "inspect");
        let s = IdentificationParams::default();
        assert_eq!(
            SeverityRange::of_answer(false, None, None, &s),
            SeverityRange::single(Severity::None)
        );
        assert_eq!(
            SeverityRange::of_answer(true, None, None, &s),
            SeverityRange::single(Severity::Inspect)
        );
        assert_eq!(
            SeverityRange::of_answer(true, None, Some(19.0), &s),
            SeverityRange::single(Severity::Monitor)
        );
        assert_eq!(
            serde_json::to_string(&r).unwrap(),
            r#"{"lowest":"inspect","highest":"urgent"}"#
        );
    }

    #[test]
    fn the_hint_states_the_rule_and_the_bound() {
        let s = IdentificationParams::default(); // urgent 40 mm, inspect 25 mm
        let hint = |upper| Severity::maintenance_hint(upper, &s);
        assert!(hint(Some(41.2)).starts_with("Remove the wheelset from service within 24 hours"));
        assert!(hint(Some(41.2)).contains("(41 mm) reaches the urgent limit of 40 mm"));
        assert!(hint(Some(30.0)).starts_with("Inspect the wheel at the next opportunity"));
        assert!(hint(Some(20.0)).starts_with("Monitor: the largest L0 that fits (20 mm)"));
        assert!(hint(None).starts_with("No flat size can be given"));
    }
}
