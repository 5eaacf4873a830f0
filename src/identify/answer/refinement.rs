//! [`Refinement`]: the refined answer (`identify --refine`), reported beside the bank-only one.

use super::result::ParamRanges;
use crate::model::WheelPosition;
use serde::{Deserialize, Serialize};

/// One round of a refinement.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RefineRound {
    /// Flats simulated in the round.
    pub simulated: usize,
    /// Seeds plus new flats that survive.
    pub survivors: usize,
    /// The round's answer (None when nothing survived).
    pub ranges: Option<ParamRanges>,
}

/// The refined answer, reported beside the bank-only one.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Refinement {
    /// The union of the last surviving round's cells.
    pub ranges: Option<ParamRanges>,
    /// Flats that stand for it (the last surviving round's survivors).
    pub survivors: usize,
    /// Simulations run.
    pub simulations: usize,
    /// Every round.
    pub rounds: Vec<RefineRound>,
    /// True when a round kept nothing and an earlier answer stands.
    pub stopped_early: bool,
    /// Wall time (ms).
    pub time_ms: f64,
    /// The refined answer in words.
    pub summary: String,
    /// The maintenance hint from the refined upper L0 bound (rule stated), or why the bank-only
    /// answer's stands.
    pub maintenance_hint: String,
    /// The classes the refined answer spans (absent when the bank-only verdict stands).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub severity: Option<crate::identify::answer::severity::SeverityRange>,
    /// The surviving flats' cells in (L, d, c) — `[L_lo, L_hi, d_lo, d_hi, c_lo, c_hi]`
    /// (mm), clamped to the population — and their wheels, for the results database (not in
    /// the JSON; empty when the bank-only answer stands).
    #[serde(skip)]
    pub cells: Vec<([f64; 6], WheelPosition)>,
    /// Landing flats simulated on the landings calibration at the L0 bounds (docs/
    /// identification.md, "Landings resolved").
    #[serde(default)]
    pub landings_simulated: usize,
    /// ... of which ruled out without the landing allowance.
    #[serde(default)]
    pub landings_removed: usize,
    /// Whether each L0 bound (lower, upper) was settled by the check within its budget
    /// (absent: no check ran).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub landings_settled: Option<[bool; 2]>,
    /// How the simulations were spent.
    #[serde(default)]
    pub strategy: RefineStrategy,
    /// With the bounds strategy: whether the L0 bounds stopped moving (else the budget ended
    /// the refinement).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bounds_settled: Option<bool>,
    /// The L0 (mm) of the shallowest and deepest kept flats themselves, without their cells:
    /// the part of the answer that simulated flats passing the pass already occupy.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kept_l0_mm: Option<[f64; 2]>,
}

/// How a refinement spends its simulations (docs/identification.md, "Refinement").
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RefineStrategy {
    /// Rounds sampling every surviving cell, the cells reaching deepest and shallowest in d
    /// more often (the earlier refinement; docs/identification.md, "Refinement").
    #[default]
    Spread,
    /// Rounds sampling only the cells that decide the L0 bounds, every flat simulated kept in
    /// the local population, until the bounds stop moving (docs/identification.md, "Bounds
    /// settled").
    Bounds,
}

impl Refinement {
    /// A refinement with nothing in it yet: no ranges, no survivor, no round, no words.
    pub(crate) fn empty() -> Refinement {
        Refinement {
            ranges: None,
            survivors: 0,
            simulations: 0,
            rounds: Vec::new(),
            stopped_early: false,
            time_ms: 0.0,
            summary: String::new(),
            maintenance_hint: String::new(),
            severity: None,
            cells: Vec::new(),
            landings_simulated: 0,
            landings_removed: 0,
            landings_settled: None,
            strategy: RefineStrategy::Spread,
            bounds_settled: None,
            kept_l0_mm: None,
        }
    }
}
