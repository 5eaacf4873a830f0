//! What sizing found for a pass with a flat detected ([`Sizing`]): the comparison points, the
//! candidate model set and what falsified the rest. A pass without a flat has none, and
//! [`crate::identify::answer::identification::Identification::sizing`] says so with `None` instead of empty lists
//! and made-up probabilities.
//!
//! In `identification.json` the fields stand beside the others, as they always did; a pass
//! without sizing writes them empty, the selection's α as 0 and the per-point probability
//! as 1 ([`on_the_wire`]), so that readers of the file see the form they always saw.

use super::result::{CandidatePoint, EntropyCurve, Falsification, InstanceParams, ParamRanges};
use super::result::{RandomSubsets, WheelRanges};
use crate::identify::select::envelope::EnvelopePoint;
use serde::{Deserialize, Serialize};

/// Everything sizing found: the points compared, the candidate model set and the baselines.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Sizing {
    /// All candidate points (PIPs of all series).
    pub candidates: Vec<CandidatePoint>,
    /// Selected points (EIP), indices into `candidates`, in selection order.
    pub eip: Vec<usize>,
    /// Joint entropy after each EIP (bits).
    pub eip_joint_entropy_bits: Vec<f64>,
    /// Envelope points compared after the EIP (`identify::envelope`; absent in results
    /// written before they existed).
    #[serde(default)]
    pub envelope: Vec<EnvelopePoint>,
    /// Stop threshold α of the greedy selection (bits).
    pub alpha_bits: f64,
    /// Joint entropy curves for each sensor alone and for all together (when asked for).
    pub entropy_curves: Vec<EntropyCurve>,
    /// Šídák per-point probability `φ^(1/m)`.
    pub per_point_probability: f64,
    /// The candidate model set.
    pub cms: Vec<InstanceParams>,
    /// Falsification with the EIP (the method's answer, first) and the baselines.
    pub falsifications: Vec<Falsification>,
    /// The candidate model set split by the wheel carrying the flat.
    #[serde(default)]
    pub wheel_ranges: Vec<WheelRanges>,
    /// Residual minimisation without uncertainties over the EIP (paper §4.4; absent in
    /// results written before it was reported).
    #[serde(default)]
    pub residual_minimisation: Option<InstanceParams>,
    /// Random subsets of the PIPs (paper §4.5; when baselines are asked for).
    pub random_subsets: Option<RandomSubsets>,
    /// True when every instance was falsified: the model class itself is refuted.
    pub model_class_refuted: bool,
    /// Every instance of the bank predicts a larger departure from the good wheel than
    /// measured: the flat is smaller than the population's.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub below_population: bool,
    /// The shared-gain stage explained none of the survivors at every point read, so the
    /// per-point answer stands (docs/model.md, "Shared gains").
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub shared_gains_fallback: bool,
}

impl Sizing {
    /// The candidate model set's parameter ranges by the method (the first falsification; a
    /// union of cells); none when the set is empty.
    pub fn cms_ranges(&self) -> Option<&ParamRanges> {
        self.falsifications.first()?.ranges.as_ref()
    }

    /// The fields as a pass without sizing writes them: empty, α 0, per-point probability 1.
    fn not_sized() -> Sizing {
        Sizing {
            candidates: Vec::new(),
            eip: Vec::new(),
            eip_joint_entropy_bits: Vec::new(),
            envelope: Vec::new(),
            alpha_bits: 0.0,
            entropy_curves: Vec::new(),
            per_point_probability: 1.0,
            cms: Vec::new(),
            falsifications: Vec::new(),
            wheel_ranges: Vec::new(),
            residual_minimisation: None,
            random_subsets: None,
            model_class_refuted: false,
            below_population: false,
            shared_gains_fallback: false,
        }
    }

    /// The first field that a pass without sizing leaves empty but this one fills, if any.
    fn filled_without_falsification(&self) -> Option<String> {
        let lists = [
            ("candidates", self.candidates.len()),
            ("eip", self.eip.len()),
            ("eip_joint_entropy_bits", self.eip_joint_entropy_bits.len()),
            ("envelope", self.envelope.len()),
            ("entropy_curves", self.entropy_curves.len()),
            ("cms", self.cms.len()),
            ("wheel_ranges", self.wheel_ranges.len()),
        ];
        if let Some((key, n)) = lists.iter().find(|(_, n)| *n > 0) {
            return Some(format!("`{key}` holds {n} entries"));
        }
        let set = [
            (
                "residual_minimisation",
                self.residual_minimisation.is_some(),
            ),
            ("random_subsets", self.random_subsets.is_some()),
            ("model_class_refuted", self.model_class_refuted),
            ("below_population", self.below_population),
            ("shared_gains_fallback", self.shared_gains_fallback),
        ];
        if let Some((key, _)) = set.iter().find(|(_, on)| *on) {
            return Some(format!("`{key}` is set"));
        }
        // Exactly the values a pass without sizing writes (0 and 1 written and read back
        // exactly by serde_json), not "close to" them.
        let exactly = |x: f64, v: f64| x.to_bits() == v.to_bits();
        if !exactly(self.alpha_bits, 0.0) || !exactly(self.per_point_probability, 1.0) {
            return Some(format!(
                "`alpha_bits` is {} and `per_point_probability` {} (0 and 1 without sizing)",
                self.alpha_bits, self.per_point_probability
            ));
        }
        None
    }
}

/// `identification.json`'s form of [`crate::identify::answer::identification::Identification::sizing`]: the fields
/// beside the others (`#[serde(flatten, with = …)]`), filled for a sized pass and as
/// [`Sizing::not_sized`] writes them for one without. Read back, an empty `falsifications`
/// (sizing always judges by the method at least) is a pass without sizing, provided every
/// other field is as such a pass writes it; anything else is refused, naming the field.
pub(crate) mod on_the_wire {
    use super::Sizing;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    /// Writes the sizing's fields, or a pass without sizing's.
    pub(crate) fn serialize<S: Serializer>(
        sizing: &Option<Sizing>,
        s: S,
    ) -> Result<S::Ok, S::Error> {
        match sizing {
            Some(z) => z.serialize(s),
            None => Sizing::not_sized().serialize(s),
        }
    }

    /// Reads the fields back: `None` for a pass without sizing.
    pub(crate) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<Sizing>, D::Error> {
        let z = Sizing::deserialize(d)?;
        if !z.falsifications.is_empty() {
            return Ok(Some(z));
        }
        match z.filled_without_falsification() {
            None => Ok(None),
            Some(what) => Err(serde::de::Error::custom(format!(
                "`falsifications` is empty (a pass without sizing) but {what}: neither a sized answer nor one without sizing"
            ))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::answer::result::Method;
    use crate::model::WheelPosition;

    /// A record with the sizing's fields beside another, as in `identification.json`.
    #[derive(Debug, PartialEq, Serialize, Deserialize)]
    struct Record {
        phi: f64,
        #[serde(flatten, with = "on_the_wire")]
        sizing: Option<Sizing>,
    }

    fn sized() -> Sizing {
        let member = InstanceParams {
            instance: 7,
            length_mm: 40.0,
            depth_mm: 0.2,
            curvature_mm: 1.0,
            impact_position_m: 0.3,
            l0_mm: 38.0,
            flat_wheel: WheelPosition::Leading,
        };
        let ranges = ParamRanges {
            length_mm: [40.0, 40.0],
            depth_mm: [0.2, 0.2],
            curvature_mm: [1.0, 1.0],
            impact_position_m: [0.3, 0.3],
            l0_mm: [38.0, 38.0],
            flat_wheels: vec![WheelPosition::Leading],
            impact: None,
        };
        Sizing {
            eip: vec![0],
            eip_joint_entropy_bits: vec![1.5],
            alpha_bits: 0.01,
            per_point_probability: 0.95,
            cms: vec![member.clone()],
            falsifications: vec![Falsification {
                method: Method::Eip {
                    envelope: false,
                    departures: true,
                },
                points: 1,
                cms_count: 1,
                ranges: Some(ranges),
            }],
            residual_minimisation: Some(member),
            ..Sizing::not_sized()
        }
    }

    /// A pass without sizing writes the fields every reader knows (empty, α 0, probability
    /// 1), and reads back as `None`; a sized pass reads back as it was written.
    #[test]
    fn both_forms_are_written_as_before_and_read_back() {
        let none = Record {
            phi: 0.95,
            sizing: None,
        };
        let json = serde_json::to_value(&none).unwrap();
        for key in ["candidates", "eip", "cms", "falsifications", "wheel_ranges"] {
            assert_eq!(json[key], serde_json::json!([]), "{key}: {json}");
        }
        assert_eq!(json["alpha_bits"], 0.0);
        assert_eq!(json["per_point_probability"], 1.0);
        assert_eq!(json["model_class_refuted"], false);
        assert!(json["residual_minimisation"].is_null());
        assert!(json.get("below_population").is_none(), "{json}");
        assert_eq!(serde_json::from_value::<Record>(json).unwrap(), none);

        let some = Record {
            phi: 0.95,
            sizing: Some(sized()),
        };
        let text = serde_json::to_string(&some).unwrap();
        assert_eq!(serde_json::from_str::<Record>(&text).unwrap(), some);
    }

    /// An empty `falsifications` beside a filled field is neither form: refused, naming it.
    #[test]
    fn a_half_sized_record_is_refused_naming_the_field() {
        let mut json = serde_json::to_value(Record {
            phi: 0.95,
            sizing: Some(sized()),
        })
        .unwrap();
        json["falsifications"] = serde_json::json!([]);
        let e = serde_json::from_value::<Record>(json.clone())
            .unwrap_err()
            .to_string();
        assert!(e.contains("`eip` holds 1 entries"), "{e}");
        for key in ["eip", "eip_joint_entropy_bits", "cms"] {
            json[key] = serde_json::json!([]);
        }
        let e = serde_json::from_value::<Record>(json.clone())
            .unwrap_err()
            .to_string();
        assert!(e.contains("`residual_minimisation` is set"), "{e}");
        json["residual_minimisation"] = serde_json::Value::Null;
        let e = serde_json::from_value::<Record>(json)
            .unwrap_err()
            .to_string();
        assert!(e.contains("`alpha_bits` is 0.01"), "{e}");
    }
}
