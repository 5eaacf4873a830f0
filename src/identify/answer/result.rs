//! The machine-readable result of one identification (written as JSON, drawn by the report).

use crate::model::WheelPosition;
use serde::{Deserialize, Serialize};
use std::fmt;

pub use crate::identify::input::alignment::{Alignment, AlignmentMethod, SpeedUse};
pub use crate::identify::input::measurement::MeasuredSeries;

/// A candidate comparison point: a perceptually important point (PIP) of a measured series.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CandidatePoint {
    /// Index into the identification's series ([`crate::identify::Identification::series`]).
    pub series: usize,
    /// Sample index within the series' window.
    pub sample: usize,
    /// Bank time (s).
    pub time_s: f64,
    /// Measured force (kN).
    pub measured_kn: f64,
    /// Order in which PIP selection found it within its series (0 and 1: the end points).
    pub pip_order: usize,
    /// Entropy of the bank's predictions at this point (bits); bin width = threshold width
    /// plus twice the typical bank-resolution widening.
    pub entropy_bits: f64,
    /// Lower falsification threshold on `prediction − measurement` (kN), for the final number
    /// of comparison points (Šídák).
    pub threshold_low_kn: f64,
    /// Upper threshold (kN).
    pub threshold_high_kn: f64,
    /// Typical bank-resolution widening at this point: κ × the median spread of predictions
    /// between neighbouring instances (kN). Each instance is judged with its own spread.
    pub resolution_kn: f64,
}

/// The candidate model set of one wheel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WheelRanges {
    /// The wheel.
    pub wheel: WheelPosition,
    /// Surviving instances with the flat on it.
    pub cms_count: usize,
    /// Their parameter ranges (union of cells).
    pub ranges: ParamRanges,
}

/// Joint entropy as points are added greedily, for one set of sensors (paper Fig. 16).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EntropyCurve {
    /// Sensor set, e.g. `"rps1+rps2"`.
    pub label: String,
    /// Joint entropy (bits) after 1, 2, … points.
    pub joint_entropy_bits: Vec<f64>,
}

/// Parameters of one model instance.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InstanceParams {
    /// Instance number in the bank.
    pub instance: u32,
    /// Flat length L (mm).
    pub length_mm: f64,
    /// Flat depth d (mm).
    pub depth_mm: f64,
    /// Curvature c (mm).
    pub curvature_mm: f64,
    /// Impact position X_p (m).
    pub impact_position_m: f64,
    /// Fresh-flat length L0 = sqrt(8·d·R_w) (mm).
    pub l0_mm: f64,
    /// The wheel carrying the flat.
    pub flat_wheel: WheelPosition,
}

/// `[min, max]` of each parameter over a set of instances.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ParamRanges {
    /// L (mm).
    pub length_mm: [f64; 2],
    /// d (mm).
    pub depth_mm: [f64; 2],
    /// c (mm).
    pub curvature_mm: [f64; 2],
    /// X_p (m).
    pub impact_position_m: [f64; 2],
    /// L0 (mm).
    pub l0_mm: [f64; 2],
    /// The wheels that carry the flat in the set.
    pub flat_wheels: Vec<WheelPosition>,
    /// The impact the set's flats make at the bank's speed and load (from the bank's stored
    /// peak contact forces; absent where not known, e.g. the population's bounds).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub impact: Option<ImpactRange>,
}

/// The range of the impact a set of flats makes: the largest wheel–rail contact force of the
/// flat's wheel over a pass, and that over the static wheel load (the dynamic ratio wayside
/// impact detectors report).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ImpactRange {
    /// Peak wheel–rail force (kN).
    pub peak_contact_kn: [f64; 2],
    /// Peak over the static wheel load.
    pub dynamic_ratio: [f64; 2],
}

/// How a falsification chose its comparison points. Written as its name:
/// `EIP (joint entropy)` (then ` + envelope`, ` + departures` when they were used),
/// `random PIP subsets (mean of N)` or `equidistant points`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(into = "String", try_from = "String")]
pub enum Method {
    /// The method: the joint-entropy points (EIP), with the envelope points and the
    /// departure rule when they were used.
    Eip {
        /// Envelope points were reported.
        envelope: bool,
        /// Falsified at the departures too.
        departures: bool,
    },
    /// The baseline of random PIP subsets of the method's size (their mean).
    RandomSubsets {
        /// Subsets drawn.
        subsets: usize,
    },
    /// The baseline of equidistant points.
    Equidistant,
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let text = match *self {
            Method::Eip {
                envelope,
                departures,
            } => format!(
                "EIP (joint entropy){}{}",
                if envelope { " + envelope" } else { "" },
                if departures { " + departures" } else { "" }
            ),
            Method::RandomSubsets { subsets } => {
                format!("random PIP subsets (mean of {subsets})")
            }
            Method::Equidistant => "equidistant points".to_string(),
        };
        f.pad(&text)
    }
}

impl From<Method> for String {
    fn from(m: Method) -> String {
        m.to_string()
    }
}

impl TryFrom<String> for Method {
    type Error = String;

    // Err(String): serde's `try_from` wants a displayable error; the stored text is named in it.
    fn try_from(s: String) -> Result<Method, String> {
        if let Some(rest) = s.strip_prefix("EIP (joint entropy)") {
            let (envelope, rest) = match rest.strip_prefix(" + envelope") {
                Some(r) => (true, r),
                None => (false, rest),
            };
            let (departures, rest) = match rest.strip_prefix(" + departures") {
                Some(r) => (true, r),
                None => (false, rest),
            };
            if rest.is_empty() {
                return Ok(Method::Eip {
                    envelope,
                    departures,
                });
            }
        } else if let Some(n) = s
            .strip_prefix("random PIP subsets (mean of ")
            .and_then(|r| r.strip_suffix(')'))
        {
            if let Ok(subsets) = n.parse() {
                return Ok(Method::RandomSubsets { subsets });
            }
        } else if s == "equidistant points" {
            return Ok(Method::Equidistant);
        }
        Err(format!("unknown falsification method `{s}`"))
    }
}

/// Result of falsification with one set of comparison points.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Falsification {
    /// How its points were chosen.
    pub method: Method,
    /// Comparison points (indices into [`crate::identify::Sizing::candidates`], or for equidistant
    /// points their own list in `points_detail`).
    pub points: usize,
    /// Candidate model set size.
    pub cms_count: usize,
    /// Parameter ranges of the CMS (none when empty).
    pub ranges: Option<ParamRanges>,
}

/// Distribution of CMS sizes over random subsets of the PIPs (paper §4.5, Fig. 18).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RandomSubsets {
    /// Number of subsets drawn.
    pub subsets: usize,
    /// Points per subset (= number of EIP).
    pub size: usize,
    /// CMS size of every subset.
    pub cms_counts: Vec<usize>,
    /// Mean CMS size.
    pub mean: f64,
    /// Median CMS size.
    pub median: f64,
    /// Seed of the draw.
    pub seed: u64,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The methods are written as they always were, and read back.
    #[test]
    fn methods_are_written_by_their_names() {
        for (m, name) in [
            (
                Method::Eip {
                    envelope: false,
                    departures: false,
                },
                "EIP (joint entropy)",
            ),
            (
                Method::Eip {
                    envelope: true,
                    departures: true,
                },
                "EIP (joint entropy) + envelope + departures",
            ),
            (
                Method::Eip {
                    envelope: false,
                    departures: true,
                },
                "EIP (joint entropy) + departures",
            ),
            (
                Method::RandomSubsets { subsets: 2000 },
                "random PIP subsets (mean of 2000)",
            ),
            (Method::Equidistant, "equidistant points"),
        ] {
            let json = serde_json::to_string(&m).unwrap();
            assert_eq!(json, format!("\"{name}\""));
            assert_eq!(serde_json::from_str::<Method>(&json).unwrap(), m);
        }
        for bad in [
            "\"EIP (joint entropy) + more\"",
            "\"equidistant\"",
            "\"random PIP subsets (mean of x)\"",
        ] {
            let e = serde_json::from_str::<Method>(bad).unwrap_err().to_string();
            assert!(e.contains("unknown falsification method"), "{e}");
        }
        let a = serde_json::to_string(&AlignmentMethod::CrossCorrelation).unwrap();
        assert_eq!(a, "\"cross-correlation\"");
    }
}
