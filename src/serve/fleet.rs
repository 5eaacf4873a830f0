//! `serve --fleet`: the fleet store as pages (a reader's login) — the wheels needing action
//! at any site first, each site's health, the newest findings; a wheel's passes at every
//! site on one trend with the joint answer and the site that disagrees; the workshop's
//! validation table; `/metrics` with each site's shipping lag (docs/fleet.md).
//!
//! The connections are kept in a small pool; a request's queries run on the blocking pool;
//! a connection the server closed (a restart) is dropped and the next request connects anew.

use crate::fleet::findings::{validate, Validation};
use crate::fleet::{
    across_report, AcrossSites, FindingRow, FleetError, FleetReader, FleetTarget, SiteHealth,
    WheelLatest,
};
use crate::history::{FusionRule, Window};
use crate::report::history::HistoryReport;
use serde::Serialize;
use std::sync::Mutex;

/// Wheels the fleet page lists as needing action.
pub(super) const ACTION_WHEELS: i64 = 200;
/// Findings the fleet page lists.
pub(super) const PAGE_FINDINGS: i64 = 20;
/// Findings the validation table reads.
pub(super) const TABLE_FINDINGS: i64 = 2000;
/// Passes of a wheel the wheel page fuses by default.
pub(super) const WHEEL_LAST: usize = 20;

/// What `serve --fleet` needs.
#[derive(Debug, Clone)]
pub struct FleetSettings {
    /// The store (a reader's login).
    pub target: FleetTarget,
    /// [inspect, urgent] L0 limits (mm).
    pub limits_l0_mm: [f64; 2],
    /// [inspect, urgent] dynamic-ratio limits.
    pub limits_dynamic_ratio: [f64; 2],
    /// φ.
    pub phi: f64,
    /// The token requests must show, when set.
    pub token: Option<super::Token>,
}

impl FleetSettings {
    /// The settings with a calibration's rulebook.
    pub fn new(
        target: FleetTarget,
        rules: &crate::model::calibration::IdentificationParams,
        token: Option<super::Token>,
    ) -> FleetSettings {
        FleetSettings {
            target,
            limits_l0_mm: [rules.inspect_l0_mm, rules.urgent_l0_mm],
            limits_dynamic_ratio: [rules.inspect_dynamic_ratio, rules.urgent_dynamic_ratio],
            phi: rules.phi,
            token,
        }
    }
}

/// The server's state.
pub(crate) struct FleetState {
    pub(crate) settings: FleetSettings,
    pool: Mutex<Vec<FleetReader>>,
}

impl FleetState {
    /// Connects once (refused now when the store cannot be reached or is of another schema).
    pub(crate) fn new(settings: FleetSettings) -> Result<FleetState, FleetError> {
        let first = FleetReader::connect(&settings.target)?;
        Ok(FleetState {
            settings,
            pool: Mutex::new(vec![first]),
        })
    }

    /// Runs `work` on a pooled connection (a new one when none is free).
    pub(crate) fn read<T>(
        &self,
        work: impl FnOnce(&mut FleetReader) -> Result<T, FleetError>,
    ) -> Result<T, FleetError> {
        let pooled = self.pool.lock().ok().and_then(|mut p| p.pop());
        let mut reader = match pooled {
            Some(r) if !r.is_closed() => r,
            _ => FleetReader::connect(&self.settings.target)?,
        };
        let out = work(&mut reader);
        if !reader.is_closed() {
            if let Ok(mut p) = self.pool.lock() {
                if p.len() < 4 {
                    p.push(reader);
                }
            }
        }
        out
    }
}

/// The fleet page's numbers.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct FleetView {
    /// When it was read (Unix seconds).
    pub now_s: f64,
    /// Named wheels in the store.
    pub wheels: i64,
    /// The wheels whose newest pass allows inspect or urgent: urgent first, newest first.
    pub action: Vec<WheelLatest>,
    /// Each site's health.
    pub sites: Vec<SiteHealth>,
    /// The newest findings.
    pub findings: Vec<FindingRow>,
}

pub(super) fn fleet_view(state: &FleetState) -> Result<FleetView, FleetError> {
    let now_s = crate::fleet::words::now_s();
    state.read(|r| {
        Ok(FleetView {
            now_s,
            wheels: r.wheel_count()?,
            action: r.action_wheels(ACTION_WHEELS)?,
            sites: r.sites(now_s)?,
            findings: r.findings(PAGE_FINDINGS)?,
        })
    })
}

/// A wheel across sites.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct FleetWheelView {
    /// The passes (each line's file named by its site) and the joint answer.
    pub report: HistoryReport,
    /// Each pass's site, in the report's order.
    pub sites_of_passes: Vec<String>,
    /// The sites' verdicts.
    pub across: AcrossSites,
}

pub(super) fn fleet_wheel_view(
    state: &FleetState,
    wheel_id: &str,
    last: usize,
) -> Result<Option<FleetWheelView>, FleetError> {
    let s = &state.settings;
    let passes = state.read(|r| r.wheel_passes(wheel_id, Window { last, hours: None }))?;
    if passes.is_empty() {
        return Ok(None);
    }
    let (report, across) = across_report(
        wheel_id,
        &passes,
        FusionRule::Robust,
        s.phi,
        [s.limits_l0_mm, s.limits_dynamic_ratio],
    );
    Ok(Some(FleetWheelView {
        report,
        sites_of_passes: passes.iter().map(|p| p.site.clone()).collect(),
        across,
    }))
}

/// The workshop's findings against the passes before them.
pub(super) fn findings_view(state: &FleetState, days: f64) -> Result<Validation, FleetError> {
    let s = &state.settings;
    state.read(|r| {
        let all: Vec<_> = r
            .findings(TABLE_FINDINGS)?
            .into_iter()
            .map(|f| f.finding)
            .collect();
        validate(r, &all, days, s.phi, s.limits_l0_mm)
    })
}

/// `/metrics` of the fleet: each site's shipping lag, pending passes and newest row; the
/// wheels needing action by class.
pub(super) fn fleet_metrics(state: &FleetState) -> Result<String, FleetError> {
    use super::metrics::{family, gauge, label};
    use prometheus::proto::MetricType;
    use prometheus::{Encoder, TextEncoder};
    let now_s = crate::fleet::words::now_s();
    let (sites, action) = state.read(|r| Ok((r.sites(now_s)?, r.action_wheels(ACTION_WHEELS)?)))?;
    let per_site = |f: &dyn Fn(&SiteHealth) -> Option<f64>| {
        sites
            .iter()
            .filter_map(|s| f(s).map(|x| gauge(vec![label("site", &s.site)], x)))
            .collect::<Vec<_>>()
    };
    let urgent = action
        .iter()
        .filter(|w| {
            w.severity
                .is_some_and(|s| s.highest == crate::identify::Severity::Urgent)
        })
        .count();
    let families = vec![
        family(
            "wheelflat_fleet_shipping_lag_seconds",
            "How far behind the fleet store is for the site: now minus its newest heartbeat with nothing pending, or minus its oldest pass still pending.",
            MetricType::GAUGE,
            per_site(&|s| s.lag_s),
        ),
        family(
            "wheelflat_fleet_pending_passes",
            "Passes still at the site at its newest heartbeat.",
            MetricType::GAUGE,
            per_site(&|s| s.pending.map(|p| p as f64)),
        ),
        family(
            "wheelflat_fleet_site_newest_pass_row",
            "The site's newest pass in the store (its row id at the site).",
            MetricType::GAUGE,
            per_site(&|s| Some(s.newest_seq as f64)),
        ),
        family(
            "wheelflat_fleet_refusals_24h",
            "Passes refused or failed at the site in the last 24 hours.",
            MetricType::GAUGE,
            per_site(&|s| Some(s.refusals_24h as f64)),
        ),
        family(
            "wheelflat_fleet_wheels_needing_action",
            "Wheels whose newest pass allows the class (listed up to the page's bound).",
            MetricType::GAUGE,
            vec![
                gauge(vec![label("class", "urgent")], urgent as f64),
                gauge(vec![label("class", "inspect")], (action.len() - urgent) as f64),
            ],
        ),
    ];
    let mut out = Vec::new();
    TextEncoder::new()
        .encode(&families, &mut out)
        .expect("the text encoder writes to memory");
    Ok(String::from_utf8(out).expect("the text format is UTF-8"))
}
