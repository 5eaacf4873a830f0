//! Fusing the passes of one wheel: the flat's (L, d, c) must fit every pass, wherever each
//! pass struck the rail and at whatever speed, so the joint answer is what the passes allow
//! together.
//!
//! Each pass allows a set of hypotheses: no flat, a flat below the population, and flat sizes
//! — the union of its surviving cells in (L, d, c), marked on a grid over the population
//! (a grid cell is allowed when a surviving cell touches it: never narrower than the pass).
//! A pass with no flat detected allows no flat, a flat below the population, and flats below
//! its detection limit; a pass that puts the flat on the other wheel allows no flat here. A
//! refuted or unseen pass says nothing and is named, not counted.
//!
//! The rule ([`FusionRule`]): `robust` (the default) keeps what every pass allows but at most
//! k, from three passes on — k the passes that may have lost the truth, each with probability
//! 1 − φ, with probability at least φ together ([`allowed_misses`]: one for 3–7 passes at
//! φ = 0.95, two for 8–16) — so a pass that lost the truth cannot take it out of the joint
//! answer; `all` keeps what every pass allows. When
//! the passes have nothing in common the answer says why instead of coming out empty: the
//! newest passes that agree, against older ones wholly below (the flat **grew**) or above
//! (**smaller**: re-profiled, or a pass that lost the flat), else the one pass out, else that
//! they disagree — acting on the highest class any of them allows.

use super::grid::{all_of, at_least, Grid, Hyp};
use super::record::{Claim, WheelPass};
use crate::identify::{Severity, SeverityRange};
use serde::{Deserialize, Serialize};

/// How passes are combined.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FusionRule {
    /// What every pass allows.
    All,
    /// With three passes or more, what every pass allows but the few that may have lost the
    /// truth ([`allowed_misses`]).
    #[default]
    Robust,
}

impl FusionRule {
    /// The name on the command line and in the JSON.
    pub fn as_str(self) -> &'static str {
        match self {
            FusionRule::All => "all",
            FusionRule::Robust => "robust",
        }
    }
}

/// How the passes relate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", tag = "kind")]
pub enum Agreement {
    /// Every pass allows the joint answer.
    Consistent,
    /// One pass has nothing in common with the others (it lost the flat, or shows something
    /// the model lacks); the answer is the others'.
    OddPass {
        /// Its place in the window (0: the oldest).
        pass: usize,
    },
    /// The newest passes agree with one another and not with the older ones: the flat
    /// changed after pass `since − 1`; the answer is the newest passes'.
    Changed {
        /// The first pass of the newest run.
        since: usize,
        /// `true`: grew (the newest L0 wholly above the older); `false`: smaller.
        grew: bool,
    },
    /// No pass but one agrees with the others, and no change explains it.
    Disagree,
    /// No pass says anything of this wheel (all refuted or unseen).
    NoInformation,
}

/// The joint answer of a wheel's passes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Joint {
    /// The rule applied.
    pub rule: FusionRule,
    /// How the passes relate.
    pub agreement: Agreement,
    /// The passes whose hypotheses the answer is made of (places in the window).
    pub passes_used: Vec<usize>,
    /// Passes left out because they say nothing (refuted or unseen).
    pub passes_silent: Vec<usize>,
    /// The answer allows a good wheel.
    pub no_flat: bool,
    /// The answer allows a flat below the population's smallest.
    pub below: bool,
    /// The flat sizes allowed, when any: L, d, c and L0 ranges (mm).
    pub length_mm: Option<[f64; 2]>,
    /// d (mm).
    pub depth_mm: Option<[f64; 2]>,
    /// c (mm).
    pub curvature_mm: Option<[f64; 2]>,
    /// L0 (mm), from the depth range.
    pub l0_mm: Option<[f64; 2]>,
    /// The classes the answer spans and the one acted on.
    pub severity: Option<SeverityRange>,
    /// The answer in words.
    pub words: String,
    #[serde(skip)]
    set: Option<(Grid, Hyp)>,
}

impl Joint {
    /// Whether the answer allows a flat of (L, d, c) (mm) — a good wheel with `None`.
    pub fn allows(&self, flat: Option<[f64; 3]>) -> bool {
        let Some((grid, h)) = &self.set else {
            return false;
        };
        match flat {
            None => h.none,
            Some(x) if x[1] < grid.space.depth_mm[0] => h.below,
            Some(x) => grid.index(x).is_some_and(|i| h.get(i)),
        }
    }
}

/// How many of `n` passes may have lost the truth, each with probability 1 − φ, with
/// probability at least φ together: the smallest k with P(more than k lost) ≤ 1 − φ
/// (binomial); none for one or two passes (then every pass must allow the answer).
pub(crate) fn allowed_misses(n: usize, phi: f64) -> usize {
    if n < 3 {
        return 0;
    }
    let p = (1.0 - phi).clamp(0.0, 1.0);
    let mut term = (1.0 - p).powi(n as i32); // P(0 lost)
    let mut cumulative = term;
    for k in 0..n {
        if 1.0 - cumulative <= 1.0 - phi + 1e-12 {
            return k;
        }
        // P(k + 1 lost) from P(k lost).
        term *= (n - k) as f64 / (k + 1) as f64 * p / (1.0 - p).max(f64::MIN_POSITIVE);
        cumulative += term;
    }
    n - 1
}

/// Fuses one wheel's passes (oldest first) under `rule` and the passes' identification
/// probability `phi`, with the L0 class limits (mm).
pub fn fuse(
    passes: &[WheelPass],
    rule: FusionRule,
    phi: f64,
    urgent_l0_mm: f64,
    inspect_l0_mm: f64,
) -> Joint {
    fuse_grouped(passes, rule, phi, urgent_l0_mm, inspect_l0_mm, &[], 0).0
}

/// [`fuse`], and for passes labelled with their group (`group_of[i] < groups`, a site each)
/// whether they all share a hypothesis and whether each group's others do
/// ([`super::groups::from_marks`]) — from the same grid and the same marks
/// of each pass's cells (computed once: they are most of a fusion's time).
pub fn fuse_grouped(
    passes: &[WheelPass],
    rule: FusionRule,
    phi: f64,
    urgent_l0_mm: f64,
    inspect_l0_mm: f64,
    group_of: &[usize],
    groups: usize,
) -> (Joint, Option<bool>, Vec<Option<bool>>) {
    let silent: Vec<usize> = (0..passes.len())
        .filter(|&i| !passes[i].claim.informative())
        .collect();
    let used: Vec<usize> = (0..passes.len())
        .filter(|&i| passes[i].claim.informative())
        .collect();
    let mut joint = Joint {
        rule,
        agreement: Agreement::NoInformation,
        passes_used: Vec::new(),
        passes_silent: silent.clone(),
        no_flat: false,
        below: false,
        length_mm: None,
        depth_mm: None,
        curvature_mm: None,
        l0_mm: None,
        severity: None,
        words: String::new(),
        set: None,
    };
    if used.is_empty() {
        // Refuted passes are inspected; unseen ones give no class.
        joint.severity = passes
            .iter()
            .filter_map(|p| p.severity)
            .reduce(SeverityRange::union);
        joint.words = format!(
            "no joint answer: none of the {} passes says anything of this wheel's flat (refuted or not seen)",
            passes.len()
        );
        return (joint, None, vec![None; groups]);
    }
    let refs: Vec<&WheelPass> = used.iter().map(|&i| &passes[i]).collect();
    let grid = Grid::over(&refs);
    let hyps: Vec<Hyp> = refs.iter().map(|p| Hyp::of(p, &grid)).collect();
    let (all_agree, without) = if groups > 0 {
        let labels: Vec<usize> = used.iter().map(|&i| group_of[i]).collect();
        super::groups::from_marks(&hyps, &labels, groups)
    } else {
        (None, Vec::new())
    };
    let n = hyps.len();
    let strict = all_of(hyps.iter(), &grid);
    let robust = |idx: &[usize]| -> Hyp {
        let hs: Vec<&Hyp> = idx.iter().map(|&i| &hyps[i]).collect();
        match (rule, hs.len()) {
            (FusionRule::Robust, m) if m >= 3 => at_least(&hs, m - allowed_misses(m, phi), &grid),
            _ => all_of(hs.into_iter(), &grid),
        }
    };
    let all: Vec<usize> = (0..n).collect();
    let (agreement, members, set) = if !strict.is_empty() {
        (Agreement::Consistent, all.clone(), robust(&all))
    } else {
        explain(&hyps, &grid, robust)
    };
    // Without a pass that found a flat, the answer is a good wheel's, as one clean pass's is:
    // flats below the detection limit are allowed (they are not ruled out), not acted on.
    let found = |i: &usize| {
        matches!(
            refs[*i].claim,
            Claim::Flat | Claim::FlatOrOther | Claim::Below
        )
    };
    let any_found = members.iter().any(found);
    let mut severity = if any_found {
        class_of(&set, &grid, urgent_l0_mm, inspect_l0_mm)
    } else {
        Some(SeverityRange::single(Severity::None))
    };
    // A single newest pass cannot overturn older ones downwards: act on the highest of both.
    if let Agreement::Changed { since, grew: false } = agreement {
        if n - since < 2 {
            let older = all_of(hyps[..since].iter(), &grid);
            severity = match (
                severity,
                class_of(&older, &grid, urgent_l0_mm, inspect_l0_mm),
            ) {
                (Some(a), Some(b)) => Some(a.union(b)),
                (a, b) => a.or(b),
            };
        }
    }
    if matches!(agreement, Agreement::Disagree) {
        severity = passes
            .iter()
            .filter_map(|p| p.severity)
            .chain(severity)
            .reduce(SeverityRange::union);
    }
    let ranges = set.ranges(&grid);
    joint.agreement = agreement;
    joint.passes_used = members.iter().map(|&i| used[i]).collect();
    joint.no_flat = set.none;
    joint.below = set.below;
    joint.length_mm = ranges.map(|r| r[0]);
    joint.depth_mm = ranges.map(|r| r[1]);
    joint.curvature_mm = ranges.map(|r| r[2]);
    joint.l0_mm = set.l0(&grid);
    joint.severity = severity;
    joint.words = words(&joint, &used, passes.len(), any_found);
    joint.set = Some((grid, set));
    (joint, all_agree, without)
}

/// A run of consecutive passes that agree: from pass `first` to the next run's first (or
/// the window's end), and the hypotheses they share.
struct Run {
    first: usize,
    shared: Hyp,
}

/// Why the passes have nothing in common, and the answer then: a change (newest run against
/// older passes wholly below or above it), one pass out, or disagreement (every hypothesis any
/// pass allows).
fn explain(
    hyps: &[Hyp],
    grid: &Grid,
    robust: impl Fn(&[usize]) -> Hyp,
) -> (Agreement, Vec<usize>, Hyp) {
    let n = hyps.len();
    // The window cut into runs that agree, from the newest back: each run as long as its
    // passes have something in common.
    let mut runs: Vec<Run> = Vec::new();
    let mut end = n;
    while end > 0 {
        let mut first = end - 1;
        let mut acc = hyps[first].clone();
        while first > 0 {
            let next = acc.and(&hyps[first - 1]);
            if next.is_empty() {
                break;
            }
            acc = next;
            first -= 1;
        }
        runs.push(Run { first, shared: acc });
        end = first;
    }
    runs.reverse();
    // A change: every run wholly above (grew) or below (smaller) the one before it in L0.
    if runs.len() >= 2 {
        let l0: Vec<Option<[f64; 2]>> = runs.iter().map(|r| r.shared.l0(grid)).collect();
        if l0.iter().all(Option::is_some) {
            let l0: Vec<[f64; 2]> = l0.into_iter().flatten().collect();
            let grew = l0
                .windows(2)
                .all(|w| w[1][0] >= w[0][1] && w[1][1] > w[0][1]);
            let shrank = l0
                .windows(2)
                .all(|w| w[1][1] <= w[0][0] && w[1][0] < w[0][0]);
            if grew || shrank {
                let since = runs[runs.len() - 1].first;
                let run: Vec<usize> = (since..n).collect();
                return (
                    Agreement::Changed { since, grew },
                    run.clone(),
                    robust(&run),
                );
            }
        }
    }
    // What all passes but i share, for every i, from running ANDs from each end (n passes,
    // not n²: a window may hold a thousand).
    let mut before: Vec<Option<Hyp>> = vec![None];
    for h in hyps {
        let next = before
            .last()
            .and_then(Option::as_ref)
            .map_or_else(|| h.clone(), |b| b.and(h));
        before.push(Some(next));
    }
    let mut after: Vec<Option<Hyp>> = vec![None];
    for h in hyps.iter().rev() {
        let next = after
            .last()
            .and_then(Option::as_ref)
            .map_or_else(|| h.clone(), |a| a.and(h));
        after.push(Some(next));
    }
    after.reverse(); // after[i]: the passes from i on
    let but = |i: usize| match (&before[i], &after[i + 1]) {
        (Some(a), Some(b)) => a.and(b),
        (Some(x), None) | (None, Some(x)) => x.clone(),
        (None, None) => Hyp::empty(grid),
    };
    let outs: Vec<(usize, Hyp)> = (0..n)
        .map(|i| (i, but(i)))
        .filter(|(_, h)| !h.is_empty())
        .collect();
    if let [(i, set)] = outs.as_slice() {
        let rest: Vec<usize> = (0..n).filter(|j| j != i).collect();
        return (Agreement::OddPass { pass: *i }, rest, set.clone());
    }
    let every: Vec<&Hyp> = hyps.iter().collect();
    (
        Agreement::Disagree,
        (0..n).collect(),
        at_least(&every, 1, grid),
    )
}

/// The classes a set spans.
fn class_of(h: &Hyp, grid: &Grid, urgent: f64, inspect: f64) -> Option<SeverityRange> {
    let mut r: Option<SeverityRange> = None;
    let mut add = |s: SeverityRange| r = Some(r.map_or(s, |r| r.union(s)));
    if h.none {
        add(SeverityRange::single(Severity::None));
    }
    if h.below {
        add(SeverityRange::of_l0(
            [0.0, grid.space.floor_l0_mm()],
            urgent,
            inspect,
        ));
    }
    if let Some(d) = h.ranges(grid).map(|x| x[1]) {
        add(SeverityRange::of_l0(
            [grid.space.l0_mm(d[0]), grid.space.l0_mm(d[1])],
            urgent,
            inspect,
        ));
    }
    r
}

/// The joint answer in words; `used` maps places among the informative passes to the window.
fn words(j: &Joint, used: &[usize], total: usize, found: bool) -> String {
    let name = |i: usize| format!("pass {}", used[i] + 1);
    let mut allowed = Vec::new();
    if j.no_flat {
        allowed.push("no flat".to_string());
    }
    if j.below {
        allowed.push("a flat below the population".to_string());
    }
    if let (Some(l), Some(l0)) = (j.length_mm, j.l0_mm.filter(|_| j.depth_mm.is_some())) {
        let d = j.depth_mm.expect("a flat set has its depth range");
        allowed.push(format!(
            "a flat of L in [{:.0}, {:.0}] mm, d in [{:.2}, {:.2}] mm (L0 up to {:.0} mm)",
            l[0], l[1], d[0], d[1], l0[1]
        ));
    }
    let answer = if !found && j.no_flat {
        format!(
            "no flat detected at any pass{}",
            j.l0_mm
                .filter(|r| r[1] > 0.0)
                .map_or(String::new(), |r| format!(
                    " (flats of L0 up to {:.0} mm are not ruled out)",
                    r[1]
                ))
        )
    } else if allowed.is_empty() {
        "nothing".to_string()
    } else {
        allowed.join(", or ")
    };
    let severity = j.severity.map_or("no class".into(), |s| s.words());
    let silent = if j.passes_silent.is_empty() {
        String::new()
    } else {
        let names: Vec<String> = j
            .passes_silent
            .iter()
            .map(|i| format!("pass {}", i + 1))
            .collect();
        format!(" ({} left out: refuted or not seen)", names.join(", "))
    };
    let head = match &j.agreement {
        Agreement::Consistent => format!(
            "{} of {total} passes fused ({} rule){silent}",
            used.len(),
            j.rule.as_str()
        ),
        Agreement::OddPass { pass } => format!(
            "{} has nothing in common with the other passes (it lost the flat, or shows something the model lacks); the others fused{silent}",
            name(*pass)
        ),
        Agreement::Changed { since, grew: true } => format!(
            "CHANGED: the flat grew after {} — the passes since agree with one another, not with the older ones; the answer is theirs{silent}",
            name(since - 1)
        ),
        Agreement::Changed { since, grew: false } => format!(
            "CHANGED: smaller since {} (re-profiled, or a pass that lost the flat); the answer is the passes since, acting on the older class until two passes agree{silent}",
            name(*since)
        ),
        Agreement::Disagree => format!(
            "the passes disagree (no pass but one, and no change, explains it): every answer any pass allows is kept{silent}"
        ),
        Agreement::NoInformation => "no pass says anything of this wheel".into(),
    };
    format!("{head}: {answer} — {severity}")
}

#[cfg(test)]
mod tests;
