//! The alarms' rules and what a writer raises (`Db::raise_alarms`): which rules are on, where
//! alarms go, and what the flat-grew rule fuses with. The rules' work is in [`super::alarms`].

use serde::{Deserialize, Serialize};

/// A rule that raises an alarm.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Rule {
    /// A wheel acted on as urgent at a pass (every such pass).
    Urgent,
    /// A named wheel whose class acted on rose from its previous pass.
    ClassRose,
    /// A named wheel whose passes, fused (history's robust rule), say the flat grew: raised
    /// by the pass that first shows the growth.
    FlatGrew,
    /// As many refused passes within an hour as the plan says (once an hour at most).
    Refusals,
    /// The newest nightly check (`calibrate --check`) found the track or sensors drifted.
    CalibrationDrift,
}

impl Rule {
    /// Every rule, in the order of [`Rule::as_str`].
    pub const ALL: [Rule; 5] = [
        Rule::Urgent,
        Rule::ClassRose,
        Rule::FlatGrew,
        Rule::Refusals,
        Rule::CalibrationDrift,
    ];

    /// The name the configuration, the database and the body use.
    pub fn as_str(self) -> &'static str {
        match self {
            Rule::Urgent => "urgent",
            Rule::ClassRose => "class-rose",
            Rule::FlatGrew => "flat-grew",
            Rule::Refusals => "refusals",
            Rule::CalibrationDrift => "calibration-drift",
        }
    }

    /// The rule of a stored name.
    pub fn parse(s: &str) -> Option<Rule> {
        Rule::ALL.into_iter().find(|r| r.as_str() == s)
    }
}

/// What alarms a database raises and where they go: set on a writer with
/// [`Db::raise_alarms`].
#[derive(Debug, Clone, PartialEq)]
pub struct AlarmPlan {
    /// The rules on.
    pub rules: Vec<Rule>,
    /// The destinations' names: one outbox row each an alarm.
    pub destinations: Vec<String>,
    /// The site's name, put in every body, when given.
    pub site: Option<String>,
    /// [`Rule::Refusals`]: this many refused passes within an hour.
    pub refusals_per_hour: usize,
    /// The class limits on L0 (mm): inspect, urgent (the fusion's, for [`Rule::FlatGrew`]).
    pub limits_l0_mm: [f64; 2],
    /// The confidence the passes are fused at.
    pub phi: f64,
    /// How many of a wheel's newest passes [`Rule::FlatGrew`] fuses.
    pub window: usize,
}

impl AlarmPlan {
    pub(super) fn on(&self, rule: Rule) -> bool {
        self.rules.contains(&rule)
    }
}
