//! A wheel's page: its trend (each pass's L0 range, the joint band, the class limits), its
//! passes, and the joint answer in words — the numbers `wheelflat history` prints for the
//! same window and rule.

use super::layout::{l0_words, range_badges};
use super::state::{AppState, Settings};
use crate::history::{fuse, Db, DbError, FusionRule, Joint, Window};
use crate::report::history::HistoryReport;
use maud::{html, Markup};
use serde::{Deserialize, Serialize};

/// The passes the joint answer is made of when the query names none (`history`'s default).
pub(super) const JOINT_LAST: usize = 5;
/// The widest window a query may ask for (hours: ten years, `history`'s bound).
pub(super) const MAX_HOURS: f64 = 87_600.0;
/// The most passes a wheel page shows (`history`'s bound).
pub(super) const MAX_LAST: usize = crate::history::db::MAX_WINDOW_PASSES;

/// The wheel page's query: `?id=<bogie>/leading&last=5&hours=…&rule=robust`.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(super) struct WheelQuery {
    /// The wheel, `<bogie_id>/leading` or `…/trailing`.
    pub(super) id: String,
    /// The newest N passes (1–1000; 5 when not given).
    pub(super) last: Option<usize>,
    /// Only the passes within this many hours of the wheel's newest.
    pub(super) hours: Option<f64>,
    /// `robust` (the default) or `all`.
    pub(super) rule: Option<Rule>,
    /// The token (read by the access check, ignored here).
    #[serde(rename = "token", default, skip_serializing)]
    pub(super) _token: Option<serde::de::IgnoredAny>,
}

/// The fusion rule in a query.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub(super) enum Rule {
    /// [`FusionRule::Robust`].
    Robust,
    /// [`FusionRule::All`].
    All,
}

impl WheelQuery {
    /// The query's values within their ranges, or the reason it is refused.
    // Err(String): answered as 400 with the message.
    pub(super) fn check(&self) -> Result<(), String> {
        if self.id.is_empty() || self.id.chars().count() > 300 {
            return Err("id: a wheel id of 1–300 characters".into());
        }
        if let Some(n) = self.last {
            if !(1..=MAX_LAST).contains(&n) {
                return Err(format!("last={n}: 1–{MAX_LAST} passes"));
            }
        }
        if let Some(h) = self.hours {
            if !(h > 0.0 && h <= MAX_HOURS) {
                return Err(format!(
                    "hours={h}: the window must lie in (0, {MAX_HOURS}]"
                ));
            }
        }
        Ok(())
    }
}

/// The wheel page's numbers (the JSON at `/api/wheel`): `history`'s report of the window,
/// with each pass's row id.
#[derive(Debug, Clone, Serialize)]
pub(super) struct WheelView {
    /// The passes, the joint answer, the class limits (`history --out`'s `history.json`).
    #[serde(flatten)]
    pub(super) report: HistoryReport,
    /// Each pass's row id, in the order of `passes` (its page: `/pass/<id>`).
    pub(super) pass_ids: Vec<i64>,
    /// The query applied.
    pub(super) query: WheelQuery,
}

/// The joint answer of a wheel's newest [`JOINT_LAST`] passes (the robust rule), none for a
/// wheel with no pass.
pub(super) fn joint_of(db: &Db, s: &Settings, wheel_id: &str) -> Result<Option<Joint>, DbError> {
    let passes = db.wheel_passes(
        wheel_id,
        Window {
            last: JOINT_LAST,
            hours: None,
        },
    )?;
    if passes.is_empty() {
        return Ok(None);
    }
    let wheels: Vec<_> = passes.iter().map(|p| p.wheel.clone()).collect();
    let [inspect, urgent] = s.limits_l0_mm;
    Ok(Some(fuse(
        &wheels,
        FusionRule::Robust,
        s.phi,
        urgent,
        inspect,
    )))
}

/// Reads the wheel page's numbers; none for a wheel with no pass.
pub(super) fn wheel_view(state: &AppState, q: WheelQuery) -> Result<Option<WheelView>, DbError> {
    let s = &state.settings;
    let window = Window {
        last: q.last.unwrap_or(JOINT_LAST),
        hours: q.hours,
    };
    let passes = state.read(|db| db.wheel_passes(&q.id, window))?;
    if passes.is_empty() {
        return Ok(None);
    }
    let rule = match q.rule.unwrap_or(Rule::Robust) {
        Rule::Robust => FusionRule::Robust,
        Rule::All => FusionRule::All,
    };
    let [inspect, urgent] = s.limits_l0_mm;
    let wheels: Vec<_> = passes.iter().map(|p| p.wheel.clone()).collect();
    let joint = fuse(&wheels, rule, s.phi, urgent, inspect);
    Ok(Some(WheelView {
        report: HistoryReport::new(
            &q.id,
            &passes,
            joint,
            [s.limits_l0_mm, s.limits_dynamic_ratio],
        ),
        pass_ids: passes.iter().map(|p| p.pass_id).collect(),
        query: q,
    }))
}

/// The wheel page's main part.
pub(super) fn wheel_html(v: &WheelView) -> Markup {
    let r = &v.report;
    let q = form_urlencoded::Serializer::new(String::new())
        .append_pair("id", &r.wheel)
        .append_pair("last", &v.query.last.unwrap_or(JOINT_LAST).to_string())
        .finish();
    let hours = v
        .query
        .hours
        .map(|h| format!("&hours={h}"))
        .unwrap_or_default();
    let rule = match v.query.rule {
        Some(Rule::All) => "&rule=all",
        _ => "",
    };
    html! {
        h1 { "Wheel " (r.wheel) }
        p id="joint" {
            "Joint answer over " (r.passes.len()) " passes: L0 " (l0_words(r.joint.l0_mm)) " "
            (range_badges(r.joint.severity)) ". " (r.joint.words)
        }
        p.note {
            "Window: the newest " (v.query.last.unwrap_or(JOINT_LAST)) " passes"
            @if let Some(h) = v.query.hours { " within " (h) " h of the newest" }
            ", rule " (r.joint.rule.as_str()) ". Show the newest "
            @for n in [5usize, 20, 100] {
                a href={"/wheel?" (form_urlencoded::Serializer::new(String::new()).append_pair("id", &r.wheel).append_pair("last", &n.to_string()).finish())} { (n) } " "
            }
            "(" a href={"/api/wheel?" (q) (hours) (rule)} { "JSON" } ")."
        }
        div.figure { img.figure src={"/wheel/trend.svg?" (q) (hours) (rule)} alt={"trend of wheel " (r.wheel)} width="1200" height="900"; }
        h2 { "Passes (oldest first)" }
        table id="wheel-passes" {
            tr { th { "#" } th { "time" } th { "km/h" } th { "claim" } th { "L0" } th { "classes" } th { "dynamic ratio" } th { "cells" } th { "in the joint answer" } }
            @for (i, p) in r.passes.iter().enumerate() {
                tr {
                    td.num { (p.pass) }
                    td { a href={"/pass/" (v.pass_ids[i])} { (p.time) } }
                    td.num { (super::layout::number(p.speed_km_per_h, 1)) }
                    td { (p.claim.as_str()) }
                    td { (l0_words(p.l0_mm)) }
                    td { (range_badges(p.severity)) }
                    td { (p.dynamic_ratio.map_or("—".into(), |d| format!("[{:.2}, {:.2}]", d[0], d[1]))) }
                    td.num { (p.cells) }
                    td { @if r.joint.passes_used.contains(&i) { "used" } @else if r.joint.passes_silent.contains(&i) { "silent" } @else { "left out" } }
                }
            }
        }
    }
}
