//! What naming a missing effect found ([`super::name`], [`super::select`]): the fitted
//! parameters, the candidates, the forward step to a second effect, the ranking and verdict.

use super::fit::Role;
use crate::model::{Effect, EffectKind};
use serde::{Deserialize, Serialize};

/// A fitted parameter.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Estimate {
    /// Name and unit.
    pub name: String,
    /// Value at the optimum.
    pub value: f64,
    /// Standard deviation from the curvature of χ² (NaN where it could not be had).
    pub sd: f64,
    /// What it stands for (not written: what the diagnosis reads back while it runs).
    #[serde(skip)]
    pub role: Role,
    /// The first effect's of a pair, its label prefixed `first: ` (not written).
    #[serde(skip)]
    pub of_first: bool,
}

/// One effect fitted to the measurement.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Candidate {
    /// Effect kind (`voided_sleeper`, …), `none` for the flat alone.
    pub kind: CandidateKind,
    /// Where it acts, for people.
    pub location: String,
    /// The effect at its fitted parameters (None for the flat alone).
    pub effect: Option<Effect>,
    /// The effect's fitted parameters as fitted (e.g. log factors), with standard deviations.
    pub parameters: Vec<Estimate>,
    /// Flat `[L (mm), d (mm), c (mm), X_p (m)]` of the fit.
    pub flat: [f64; 4],
    /// χ² at the optimum.
    pub chi2: f64,
    /// Continuous parameters fitted (flat and effect).
    pub k: usize,
    /// Families of the kind (M).
    pub families: usize,
    /// BIC.
    pub bic: f64,
    /// Whether the flat was refitted with the effect (stage 3) or held (stage 2).
    pub joint: bool,
    /// Goodness of fit: the Wilson–Hilferty `z` of χ² with N − k degrees of freedom.
    pub chi2_z: f64,
    /// `chi2_z ≤` [`super::name::ADEQUATE_Z`]: what the fit leaves is noise.
    pub adequate: bool,
    /// Samples of the fitted model's raw prediction outside the Šídák thresholds (for
    /// information: the thresholds bound the sensor factors, the fit estimates them).
    pub samples_outside: usize,
    /// RMS excess over the thresholds, all samples (kN).
    pub gap_rms_kn: f64,
    /// RMS of `a_s g − y` over all samples (kN): what the fit leaves after each sensor's
    /// systematic factor.
    pub fit_rms_kn: f64,
    /// Profiled sensor factors.
    pub gains: Vec<f64>,
    /// Index of its family (for the forward selection; not written out).
    #[serde(skip)]
    pub family: usize,
    /// The flat as fitted, apparent impact position (not written out).
    #[serde(skip)]
    pub apparent: [f64; 4],
}

/// What a candidate adds to the flat: nothing (`none`: the flat alone) or an effect of a
/// kind. Written as the kind's name, `none` for nothing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(into = "String", try_from = "String")]
pub enum CandidateKind {
    /// The flat alone.
    None,
    /// An effect of this kind.
    Effect(EffectKind),
}

impl CandidateKind {
    /// The name written: the kind's, or `none`.
    pub fn as_str(self) -> &'static str {
        match self {
            CandidateKind::None => "none",
            CandidateKind::Effect(k) => k.as_str(),
        }
    }
}

impl std::fmt::Display for CandidateKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl From<CandidateKind> for String {
    fn from(k: CandidateKind) -> String {
        k.as_str().to_string()
    }
}

impl TryFrom<String> for CandidateKind {
    type Error = String;
    // Err(String): serde's `try_from` wants a displayable error; the stored text is named in it.
    fn try_from(s: String) -> Result<CandidateKind, String> {
        if s == "none" {
            return Ok(CandidateKind::None);
        }
        EffectKind::ALL
            .into_iter()
            .find(|k| k.as_str() == s)
            .map(CandidateKind::Effect)
            .ok_or_else(|| format!("`{s}` is no effect kind nor `none`"))
    }
}

/// The ranking and the verdict.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Naming {
    /// The criterion, in words.
    pub criterion: String,
    /// Samples compared (N).
    pub samples: usize,
    /// The flat alone, fitted.
    pub no_effect: Candidate,
    /// All effects fitted, best BIC first (one entry per kind and location).
    pub ranking: Vec<Candidate>,
    /// Index into `ranking` of the effect named, if one is.
    pub named: Option<usize>,
    /// How well the best candidate's place is known ([`super::name`]).
    #[serde(default)]
    pub place: Option<String>,
    /// BIC of the flat alone minus the best's.
    pub evidence_over_none: f64,
    /// BIC of the runner-up (another kind or location) minus the best's.
    pub evidence_over_runner_up: f64,
    /// The verdict in words.
    pub verdict: String,
    /// Simulations run.
    pub simulations: usize,
    /// The forward step to a second effect, when the best single one left more than noise.
    #[serde(default)]
    pub second: Option<SecondStep>,
    /// The L0 range of a named second flat (mm; [`super::library::second_flat_l0_mm`]).
    #[serde(default)]
    pub second_flat_l0_mm: Option<[f64; 2]>,
}

impl Naming {
    /// The effects named: both of a named pair, else the one named, else none.
    pub fn named_effects(&self) -> Vec<Effect> {
        match (&self.second, self.named) {
            (Some(s), _) if s.named => s.effects.clone(),
            (_, Some(i)) => self.ranking[i].effect.iter().cloned().collect(),
            _ => Vec::new(),
        }
    }

    /// The flat `[L, d, c (mm), X_p (m)]` fitted with the named effects (None: none named).
    pub fn named_flat(&self) -> Option<[f64; 4]> {
        match (&self.second, self.named) {
            (Some(s), _) if s.named => s.ranking.first().map(|c| c.flat),
            (_, Some(i)) => Some(self.ranking[i].flat),
            _ => None,
        }
    }
}

/// The forward step's outcome.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SecondStep {
    /// The first effect (the best single one).
    pub first: Candidate,
    /// The pairs fitted, best BIC first; each entry describes the *second* effect, with the
    /// pair's χ², BIC and fit quality.
    pub ranking: Vec<Candidate>,
    /// Both effects of the best pair at its joint fit (first, second).
    pub effects: Vec<Effect>,
    /// BIC of the first effect alone minus the best pair's.
    pub evidence_over_first: f64,
    /// BIC of the second effect alone (the best fit of its kind and place, with the flat)
    /// minus the best pair's.
    pub evidence_over_second: f64,
    /// Whether the pair is named.
    pub named: bool,
    /// The verdict in words.
    pub verdict: String,
}
