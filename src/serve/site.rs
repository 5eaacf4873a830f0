//! The site page: the wheels that need action first (the class acted on at their newest pass
//! is inspect or urgent, or it changed from the pass before), with their joint answer; every
//! wheel, filterable by bogie, class and hours; the passes of the last hours with what each
//! said, and those refused or failed with their reason; the banks the passes used.

use super::layout::{class_badge, l0_words, number, range_badges, wheel_href};
use super::state::AppState;
use super::wheel::{joint_of, JOINT_LAST, MAX_HOURS};
use crate::history::{BankUse, DbError, Failure, PassRow, WheelRow};
use crate::identify::Severity;
use maud::{html, Markup};
use serde::{Deserialize, Serialize};

/// The most wheels the every-wheel table lists (the filter narrows it).
pub(super) const MAX_WHEELS_SHOWN: usize = 500;
/// The most wheels needing action listed with their joint answer.
pub(super) const MAX_ACTION_SHOWN: usize = 20;
/// The most passes (and, apart, refused or failed passes) listed.
pub(super) const MAX_PASSES_SHOWN: usize = 200;
/// The passes of this many hours when the query names none.
pub(super) const DEFAULT_HOURS: f64 = 24.0;

/// The site page's query: `?bogie=…&class=…&hours=…`.
#[derive(Debug, Clone, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(super) struct SiteQuery {
    /// Only wheels whose id contains this (case-sensitive; at most 200 characters).
    pub(super) bogie: Option<String>,
    /// Only wheels whose newest pass's class acted on is this one.
    pub(super) class: Option<Severity>,
    /// Only wheels seen, and passes made, in the last this many hours (the passes: 24 when
    /// not given).
    pub(super) hours: Option<f64>,
    /// The token (read by the access check, ignored here).
    #[serde(rename = "token", default, skip_serializing)]
    pub(super) _token: Option<serde::de::IgnoredAny>,
}

impl SiteQuery {
    /// The query's values within their ranges, or the reason it is refused.
    // Err(String): answered as 400 with the message.
    pub(super) fn check(&self) -> Result<(), String> {
        if let Some(h) = self.hours {
            if !(h > 0.0 && h <= MAX_HOURS) {
                return Err(format!(
                    "hours={h}: the window must lie in (0, {MAX_HOURS}]"
                ));
            }
        }
        if self.bogie.as_ref().is_some_and(|b| b.chars().count() > 200) {
            return Err("bogie: at most 200 characters".into());
        }
        Ok(())
    }
}

/// A wheel that needs action, with its joint answer over its newest passes.
#[derive(Debug, Clone, Serialize)]
pub(super) struct ActionRow {
    /// The wheel and its newest pass.
    pub(super) wheel: WheelRow,
    /// Its joint answer over its newest [`JOINT_LAST`] passes, when read.
    pub(super) joint: Option<crate::history::Joint>,
}

/// The bank the server was told the site uses, as read now.
#[derive(Debug, Clone, Serialize)]
pub(super) struct BankStatus {
    /// Its folder.
    pub(super) dir: String,
    /// Its version (the digest of its manifest), when it can be read.
    pub(super) version: Option<String>,
    /// Why it cannot be read, when it cannot.
    pub(super) unreadable: Option<String>,
}

/// The site page's numbers (the JSON at `/api/site`).
#[derive(Debug, Clone, Serialize)]
pub(super) struct SiteView {
    /// The results database.
    pub(super) database: String,
    /// When this view was read (RFC 3339).
    pub(super) read_at: String,
    /// Passes stored in all.
    pub(super) passes_stored: usize,
    /// The newest pass's time.
    pub(super) newest_pass: Option<String>,
    /// The class limits on L0 (mm): inspect, urgent.
    pub(super) limits_l0_mm: [f64; 2],
    /// The query applied.
    pub(super) query: SiteQuery,
    /// The window of the passes listed (hours).
    pub(super) hours: f64,
    /// The bank given to the server.
    pub(super) bank: Option<BankStatus>,
    /// Its family, calibration and newest nightly check ([`super::setup`]).
    pub(super) setup: Option<super::setup::SiteSetup>,
    /// The banks the passes of the window were compared with.
    pub(super) banks: Vec<BankUse>,
    /// Wheels that need action, gravest first (at most [`MAX_ACTION_SHOWN`]).
    pub(super) action: Vec<ActionRow>,
    /// How many wheels need action in all.
    pub(super) action_total: usize,
    /// Every wheel the filter keeps, by id (at most [`MAX_WHEELS_SHOWN`]).
    pub(super) wheels: Vec<WheelRow>,
    /// How many wheels the filter keeps in all.
    pub(super) wheels_total: usize,
    /// Wheels the database knows.
    pub(super) wheels_known: usize,
    /// The passes of the window, newest first.
    pub(super) passes: Vec<PassRow>,
    /// The passes of the window refused or failed, newest first.
    pub(super) failures: Vec<Failure>,
    /// The alarms: their counts and the newest ([`super::alarms`]).
    pub(super) alarms: super::alarms::AlarmsView,
}

/// Whether a wheel needs action: its newest class acted on is inspect or urgent, or the class
/// changed from the pass before.
fn needs_action(w: &WheelRow) -> bool {
    w.severity.is_some_and(|s| s.highest >= Severity::Inspect) || w.changed()
}

/// Reads the site page's numbers.
pub(super) fn site_view(state: &AppState, q: SiteQuery) -> Result<SiteView, DbError> {
    let s = &state.settings;
    let now = crate::history::db::now_s();
    let hours = q.hours.unwrap_or(DEFAULT_HOURS);
    let since = now - hours * 3600.0;
    state.read(|db| {
        let all = db.wheel_rows()?;
        let wheels_known = all.len();
        let mut action: Vec<WheelRow> = all.iter().filter(|w| needs_action(w)).cloned().collect();
        action.sort_by(|a, b| {
            let key = |w: &WheelRow| w.severity.map(|s| (s.highest, s.lowest));
            key(b)
                .cmp(&key(a))
                .then(b.last_time_s.total_cmp(&a.last_time_s))
        });
        let action_total = action.len();
        action.truncate(MAX_ACTION_SHOWN);
        let action = action
            .into_iter()
            .map(|w| {
                let joint =
                    state.joint(&w.wheel_id, w.last_pass_id, || joint_of(db, s, &w.wheel_id))?;
                Ok(ActionRow { wheel: w, joint })
            })
            .collect::<Result<Vec<_>, DbError>>()?;
        let mut wheels: Vec<WheelRow> = all
            .into_iter()
            .filter(|w| {
                q.bogie
                    .as_ref()
                    .is_none_or(|b| w.wheel_id.contains(b.as_str()))
            })
            .filter(|w| {
                q.class
                    .is_none_or(|c| w.severity.is_some_and(|s| s.highest == c))
            })
            .filter(|w| q.hours.is_none_or(|_| w.last_time_s >= since))
            .collect();
        let wheels_total = wheels.len();
        wheels.truncate(MAX_WHEELS_SHOWN);
        let bank = s.bank.as_ref().map(|dir| {
            let key = crate::bank::family::Family::current_key(dir);
            BankStatus {
                dir: dir.display().to_string(),
                version: key
                    .as_ref()
                    .ok()
                    .map(|k| k.lines().last().unwrap_or_default().to_string()),
                unreadable: key.err().map(|e| e.to_string()),
            }
        });
        Ok(SiteView {
            database: s.db.display().to_string(),
            read_at: crate::history::db::rfc3339(now),
            passes_stored: db.pass_count()?,
            newest_pass: db.newest_time_s()?.map(crate::history::db::rfc3339),
            limits_l0_mm: s.limits_l0_mm,
            hours,
            bank,
            setup: s.bank.as_deref().map(super::setup::setup),
            banks: db.banks_since(since)?,
            action,
            action_total,
            wheels,
            wheels_total,
            wheels_known,
            passes: db.passes_since(since, MAX_PASSES_SHOWN)?,
            failures: db.failures_since(since, MAX_PASSES_SHOWN)?,
            alarms: super::alarms::alarms_view(db, None, super::alarms::MAX_ALARMS_SHOWN)?,
            query: q,
        })
    })
}

/// What a pass said of its wheels, in one cell.
pub(super) fn outcome_cell(p: &PassRow) -> Markup {
    html! {
        @for w in &p.wheels {
            div { (w.wheel) ": " (w.claim.as_str()) " " (range_badges(w.severity))
                  @if w.l0_mm.is_some() { " L0 " (l0_words(w.l0_mm)) } }
        }
    }
}

/// The site page's main part.
pub(super) fn site_html(v: &SiteView) -> Markup {
    let [inspect, urgent] = v.limits_l0_mm;
    html! {
        h1 { "Site: " (v.database) }
        p.note {
            (v.passes_stored) " passes stored, " (v.wheels_known) " named wheels; newest pass "
            (v.newest_pass.as_deref().unwrap_or("—")) ". Classes on L0: inspect from "
            (format!("{inspect:.0}")) " mm, urgent from " (format!("{urgent:.0}")) " mm. Read at "
            (v.read_at) " (" a href="/api/site" { "JSON" } ")."
        }
        h2 { "Needs action (" (v.action_total) ")" }
        @if v.action.is_empty() {
            p { "No wheel's newest pass is inspect or urgent, and no class changed." }
        } @else {
            table id="action" {
                tr { th { "wheel" } th { "acted on" } th { "newest pass" } th { "its L0" }
                     th { "joint answer (newest " (JOINT_LAST) ")" } th { "changed" } }
                @for a in &v.action {
                    tr {
                        td { a href=(wheel_href(&a.wheel.wheel_id)) { (a.wheel.wheel_id) } }
                        td { (a.wheel.severity.map_or(html!{"—"}, |s| class_badge(s.highest))) }
                        td { a href={"/pass/" (a.wheel.last_pass_id)} { (a.wheel.last_time) } " " (a.wheel.claim.as_str()) }
                        td { (l0_words(a.wheel.l0_mm)) }
                        td { @match &a.joint {
                            Some(j) => { (l0_words(j.l0_mm)) " " (range_badges(j.severity)) br; span.note { (j.words) } }
                            None => "—",
                        } }
                        td { @if a.wheel.changed() {
                            span.changed { (a.wheel.previous_severity.map_or("—".into(), |s| s.highest.as_str().to_string())) " → "
                                (a.wheel.severity.map_or("—".into(), |s| s.highest.as_str().to_string())) }
                        } }
                    }
                }
            }
            @if v.action_total > v.action.len() { p.note { (v.action_total - v.action.len()) " more: filter the table below by class." } }
        }
        (super::alarms::alarms_html(&v.alarms))
        h2 { "Passes of the last " (format!("{:.0}", v.hours)) " h (" (v.passes.len()) ")" }
        @if !v.failures.is_empty() {
            table id="failures" {
                tr { th { "time" } th { "measurement" } th { "outcome" } th { "why" } }
                @for f in &v.failures {
                    tr { td { (f.time) } td { (f.measurement) }
                         td { span class={"badge " (f.kind.as_str())} { (f.kind.as_str()) } }
                         td { (f.reason) } }
                }
            }
            p {}
        }
        @if v.passes.is_empty() {
            p { "No pass in this window." }
        } @else {
            table id="passes" {
                tr { th { "time" } th { "bogie" } th { "km/h" } th { "what it says" } th { "bank" } }
                @for p in &v.passes {
                    tr {
                        td { a href={"/pass/" (p.pass_id)} { (p.time) } }
                        td { (p.bogie_id.as_deref().unwrap_or("—")) }
                        td.num { (number(p.speed_km_per_h, 1)) }
                        td { (outcome_cell(p)) }
                        td.note { (p.bank_id) }
                    }
                }
            }
        }
        h2 { "Every wheel (" (v.wheels_total) " of " (v.wheels_known) ")" }
        form.filter method="get" action="/" {
            label { "bogie contains" input name="bogie" value=(v.query.bogie.as_deref().unwrap_or("")); }
            label { "class acted on" select name="class" {
                option value="" { "any" }
                @for c in [Severity::None, Severity::Monitor, Severity::Inspect, Severity::Urgent] {
                    option value=(c.as_str()) selected[v.query.class == Some(c)] { (c.as_str()) }
                }
            } }
            label { "seen in the last hours" input name="hours" type="number" min="0" step="any"
                value=(v.query.hours.map(|h| h.to_string()).unwrap_or_default()); }
            button type="submit" { "filter" }
        }
        table id="wheels" {
            tr { th { "wheel" } th { "passes" } th { "newest pass" } th { "claim" } th { "L0" } th { "classes" } }
            @for w in &v.wheels {
                tr {
                    td { a href=(wheel_href(&w.wheel_id)) { (w.wheel_id) } }
                    td.num { (w.passes) }
                    td { a href={"/pass/" (w.last_pass_id)} { (w.last_time) } }
                    td { (w.claim.as_str()) }
                    td { (l0_words(w.l0_mm)) }
                    td { (range_badges(w.severity)) }
                }
            }
        }
        @if v.wheels_total > v.wheels.len() { p.note { "The first " (v.wheels.len()) " listed: narrow the filter for the rest." } }
        h2 { "Banks" }
        @if let Some(b) = &v.bank {
            p { "This site's bank: " (b.dir) ", version "
                @if let Some(k) = &b.version { code { (k) } }
                @if let Some(e) = &b.unreadable { span.changed { "cannot be read: " (e) } } }
        }
        @if v.banks.is_empty() { p.note { "No pass in this window." } } @else {
            table id="banks" {
                tr { th { "bank id" } th { "passes in the window" } th { "newest" } }
                @for b in &v.banks { tr { td { code { (b.bank_id) } } td.num { (b.passes) } td { (b.last_time) } } }
            }
        }
        @if let Some(x) = &v.setup { (super::setup::setup_html(x)) }
    }
}
