//! A wheel's passes at every site fused into one answer (docs/fleet.md, "A wheel across
//! sites"). Each pass was judged by its own site's calibrated bank and carries its cells in
//! (L, d, c) mm, so passes of different sites fuse as passes of one site do
//! ([`crate::history::fuse`]). A site disagrees when its passes and the other sites' have
//! nothing in common while the others agree among themselves: it is named, not silently
//! outvoted.

use super::SitePass;
use crate::history::{fuse_grouped, Agreement, FusionRule, Joint, StoredPass, WheelPass};
use crate::report::history::HistoryReport;
use serde::Serialize;

/// What one site's passes say beside the others'.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SiteVerdict {
    /// The site.
    pub site: String,
    /// Its passes in the window.
    pub passes: usize,
    /// Whether its passes and the other sites' allow a common answer (strictly: every pass);
    /// none when only this site, or only it, says anything of the flat, or when the flat
    /// changed over time (the change is said instead).
    pub agrees: Option<bool>,
}

/// The joint answer across sites.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AcrossSites {
    /// The fused answer of every pass.
    pub joint: Joint,
    /// Each site, by name.
    pub sites: Vec<SiteVerdict>,
    /// The sites whose passes alone keep the others from a common answer.
    pub disagreeing: Vec<String>,
    /// The flat's change across sites in words, when the newest passes left the older ones
    /// (grew or smaller), naming the sites on both sides.
    pub change: Option<String>,
}

/// Fuses `passes` (oldest first) under `rule`, φ and the L0 class limits, site by site.
pub fn across_sites(
    passes: &[SitePass],
    rule: FusionRule,
    phi: f64,
    urgent_l0_mm: f64,
    inspect_l0_mm: f64,
) -> AcrossSites {
    let wheels: Vec<WheelPass> = passes.iter().map(|p| p.pass.wheel.clone()).collect();
    let mut names: Vec<&str> = passes.iter().map(|p| p.site.as_str()).collect();
    names.sort_unstable();
    names.dedup();
    let group_of: Vec<usize> = passes
        .iter()
        .map(|p| {
            names
                .binary_search(&p.site.as_str())
                .expect("a listed site")
        })
        .collect();
    let (joint, all_agree, without) = fuse_grouped(
        &wheels,
        rule,
        phi,
        urgent_l0_mm,
        inspect_l0_mm,
        &group_of,
        names.len(),
    );
    // A flat that changed over time explains passes that share nothing: no site is named.
    let changed = matches!(joint.agreement, Agreement::Changed { .. });
    let mut sites = Vec::new();
    let mut disagreeing = Vec::new();
    for (g, &s) in names.iter().enumerate() {
        let n = passes.iter().filter(|p| p.site == s).count();
        let informative = passes
            .iter()
            .any(|p| p.site == s && p.pass.wheel.claim.informative());
        let agrees = match (informative, without[g], all_agree) {
            _ if changed => None,
            (false, _, _) | (_, None, _) => None,
            (true, Some(_), Some(true)) => Some(true),
            // The others agree among themselves, and not with this site.
            (true, Some(true), _) => Some(false),
            // The others disagree among themselves: this site is not the one out.
            (true, Some(false), _) => Some(true),
        };
        if agrees == Some(false) {
            disagreeing.push(s.to_string());
        }
        sites.push(SiteVerdict {
            site: s.to_string(),
            passes: n,
            agrees,
        });
    }
    let change = match &joint.agreement {
        Agreement::Changed { since, grew } => {
            let used = &joint.passes_used;
            let informative: Vec<usize> = (0..passes.len())
                .filter(|&i| passes[i].pass.wheel.claim.informative())
                .collect();
            let split = informative.get(*since).copied();
            split.map(|first_new| {
                let before: Vec<&str> = passes[..first_new]
                    .iter()
                    .map(|p| p.site.as_str())
                    .collect();
                let after: Vec<&str> = used.iter().map(|&i| passes[i].site.as_str()).collect();
                format!(
                    "{} between {} (older passes) and {} (the newest)",
                    if *grew { "grew" } else { "smaller" },
                    uniq(&before),
                    uniq(&after)
                )
            })
        }
        _ => None,
    };
    AcrossSites {
        joint,
        sites,
        disagreeing,
        change,
    }
}

/// A wheel's passes at every site as `history` reports them — each pass's file named by its
/// site (`north: a.csv`) — with the joint answer and the sites' verdicts; the limits are
/// `[[inspect, urgent] L0 mm, [inspect, urgent] dynamic ratio]`.
pub fn across_report(
    wheel_id: &str,
    passes: &[SitePass],
    rule: FusionRule,
    phi: f64,
    limits: [[f64; 2]; 2],
) -> (HistoryReport, AcrossSites) {
    let across = across_sites(passes, rule, phi, limits[0][1], limits[0][0]);
    let named: Vec<StoredPass> = passes
        .iter()
        .map(|p| {
            let mut s = p.pass.clone();
            s.measurement = format!("{}: {}", p.site, s.measurement);
            s
        })
        .collect();
    let report = HistoryReport::new(wheel_id, &named, across.joint.clone(), limits);
    (report, across)
}

/// Distinct names, in first-seen order, joined.
fn uniq(names: &[&str]) -> String {
    let mut out: Vec<&str> = Vec::new();
    for n in names {
        if !out.contains(n) {
            out.push(n);
        }
    }
    out.join(", ")
}
