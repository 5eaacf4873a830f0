//! The alarms on the site page and at `/api/alarms`: how many wait, failed or were sent, and
//! the newest of them with where each stands (docs/alarms.md).

use super::layout::wheel_href;
use crate::history::{AlarmCounts, AlarmRow, AlarmStatus, Db, DbError};
use maud::{html, Markup};
use serde::{Deserialize, Serialize};

/// The newest alarms the site page lists.
pub(super) const MAX_ALARMS_SHOWN: usize = 20;
/// The most alarms `/api/alarms` lists.
pub(super) const MAX_ALARMS_LISTED: usize = 1000;

/// The alarms' part of the site page (and its JSON).
#[derive(Debug, Clone, Serialize)]
pub(super) struct AlarmsView {
    /// How many outbox rows stand where (one an alarm and a destination).
    pub(super) counts: AlarmCounts,
    /// The newest, newest first.
    pub(super) newest: Vec<AlarmRow>,
}

/// `/api/alarms`'s query: `?status=pending|failed|sent&last=N`.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct AlarmsQuery {
    /// Only the alarms of this status.
    pub(super) status: Option<AlarmStatus>,
    /// At most this many (1–1000; 100 when not given).
    pub(super) last: Option<usize>,
    /// The token (read by the access check, ignored here).
    #[serde(rename = "token", default)]
    pub(super) _token: Option<serde::de::IgnoredAny>,
}

impl AlarmsQuery {
    /// How many to list, or why the query is refused.
    // Err(String): answered as 400 with the message.
    pub(super) fn last(&self) -> Result<usize, String> {
        match self.last {
            None => Ok(100),
            Some(n) if (1..=MAX_ALARMS_LISTED).contains(&n) => Ok(n),
            Some(n) => Err(format!("last={n}: 1 to {MAX_ALARMS_LISTED}")),
        }
    }
}

/// The alarms' counts and the newest `limit` (of `status`, when given).
pub(super) fn alarms_view(
    db: &Db,
    status: Option<AlarmStatus>,
    limit: usize,
) -> Result<AlarmsView, DbError> {
    Ok(AlarmsView {
        counts: db.alarm_counts()?,
        newest: db.alarms(status, limit)?,
    })
}

/// The alarms' part of the site page.
pub(super) fn alarms_html(v: &AlarmsView) -> Markup {
    let c = v.counts;
    html! {
        h2 { "Alarms" }
        p {
            (c.pending) " pending, "
            @if c.failed > 0 { span.changed { (c.failed) " failing" } } @else { "0 failing" }
            ", " (c.sent) " sent (one a destination; " a href="/api/alarms" { "JSON" } ")."
        }
        @if !v.newest.is_empty() {
            table id="alarms" {
                tr { th { "raised" } th { "rule" } th { "wheel" } th { "to" } th { "status" } th { "tries" } th { "why not sent" } }
                @for a in &v.newest {
                    tr {
                        td { (a.created) }
                        td { (a.rule.as_str()) }
                        td { @match &a.wheel_id {
                            Some(w) => { a href=(wheel_href(w)) { (w) } }
                            None => { @if let Some(p) = a.pass_id { a href={"/pass/" (p)} { "pass " (p) } } @else { "—" } }
                        } }
                        td { (a.destination) }
                        td { span class={"badge " (a.status.as_str())} { (a.status.as_str()) } }
                        td.num { (a.attempts) }
                        td.note { (a.last_error.as_deref().unwrap_or("")) }
                    }
                }
            }
        }
    }
}
