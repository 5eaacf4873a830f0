//! The answer of one identification ([`Identification`]): the pass, the bank, what detection
//! and — for a pass with a flat detected — sizing found, the verdict in words and classes.
//! Written as `identification.json` ([`crate::identify::answer::json`]).

use super::refinement::Refinement;
use super::result::{Alignment, MeasuredSeries, ParamRanges, SpeedUse};
use super::sizing::Sizing;
use serde::{Deserialize, Serialize};

/// Everything one identification found.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Identification {
    /// The measurement file.
    pub measurement: String,
    /// The pass's speed and the bank's (absent in results written before it was stated).
    #[serde(default)]
    pub speed: SpeedUse,
    /// The wheel load the record shows, with its interval (absent in results written before
    /// it was read; [`crate::identify::detect::load`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub load: Option<crate::identify::detect::load::LoadEstimate>,
    /// Bank identity and size.
    pub bank_id: String,
    /// Instances in the bank.
    pub bank_instances: usize,
    /// Population bounds of the bank (axes of the parallel-coordinates plot).
    pub population: ParamRanges,
    /// Alignment to the bank's time axis.
    pub alignment: Alignment,
    /// The measured series used, on the bank's windows.
    pub series: Vec<MeasuredSeries>,
    /// PIP distance measure (`vertical`, `perpendicular`, `euclidean`).
    pub pip_distance: crate::identify::input::pip::PipDistance,
    /// PIPs per series.
    pub pips_per_series: usize,
    /// Target identification probability φ.
    pub phi: f64,
    /// What sizing found, for a pass with a flat detected; none for a pass without (its
    /// detection limit is in `detection`). In the JSON its fields stand beside the others,
    /// as they always did, with the placeholders of a pass without sizing
    /// ([`crate::identify::answer::sizing::on_the_wire`]).
    #[serde(flatten, with = "crate::identify::answer::sizing::on_the_wire")]
    pub sizing: Option<Sizing>,
    /// The detection step run before sizing (absent in results written before it existed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub detection: Option<crate::identify::detect::Detection>,
    /// The rough treads and rail the pass was judged with (absent in results written before
    /// they were allowed for; [`crate::identify::detect::roughness`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub roughness: Option<crate::identify::detect::roughness::RoughnessUse>,
    /// How the series (as stored here) met the bank's predictions: sample by sample, or
    /// through the 5-sample binomial average for a pass judged as rough ([`crate::identify::input::compare`];
    /// absent in results written before: sample by sample).
    #[serde(default)]
    pub comparison: crate::identify::input::compare::Comparison,
    /// One-paragraph verdict for people.
    pub summary: String,
    /// Maintenance hint (severity rule stated).
    pub maintenance_hint: String,
    /// The severity classes the answer spans and the one acted on (its highest); absent in
    /// results written before it was stated.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub severity: Option<crate::identify::answer::severity::SeverityRange>,
    /// Wall-clock of the stages (ms).
    pub timings_ms: Vec<(String, f64)>,
    /// The refined answer (`identify --refine`), beside the bank-only one above.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refinement: Option<Refinement>,
}

impl Identification {
    /// The candidate model set's parameter ranges by the method ([`Sizing::cms_ranges`]);
    /// none for a pass that was not sized (no flat detected) or whose set is empty.
    pub fn cms_ranges(&self) -> Option<&ParamRanges> {
        self.sizing.as_ref()?.cms_ranges()
    }

    /// Every instance was falsified: the model class is refuted (never for a pass that was
    /// not sized).
    pub fn model_class_refuted(&self) -> bool {
        self.sizing.as_ref().is_some_and(|z| z.model_class_refuted)
    }

    /// A flat was detected and sized as smaller than the population's (never for a pass that
    /// was not sized).
    pub fn below_population(&self) -> bool {
        self.sizing.as_ref().is_some_and(|z| z.below_population)
    }
}
