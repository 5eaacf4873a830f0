//! The outbox: one row an alarm and a destination, `pending` until tried, `failed` after a
//! failed try (and tried again later), `sent` once a 2xx answered it. Rows are sent in row
//! order per destination, the oldest unsent first.

use super::{AlarmBody, AlarmPlan, Rule};
use crate::history::db::{rfc3339, Db, DbError};
use rusqlite::{params, OptionalExtension};
use serde::{Deserialize, Serialize};

/// Where an alarm stands with one destination.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AlarmStatus {
    /// Not tried yet.
    Pending,
    /// The last try failed; it is tried again ([`AlarmRow::next_attempt_s`]).
    Failed,
    /// A 2xx answered it.
    Sent,
}

impl AlarmStatus {
    /// Every status, in the order of [`AlarmStatus::as_str`].
    pub const ALL: [AlarmStatus; 3] =
        [AlarmStatus::Pending, AlarmStatus::Failed, AlarmStatus::Sent];

    /// The name the database and the JSON use.
    pub fn as_str(self) -> &'static str {
        match self {
            AlarmStatus::Pending => "pending",
            AlarmStatus::Failed => "failed",
            AlarmStatus::Sent => "sent",
        }
    }

    /// The status of a stored name.
    pub fn parse(s: &str) -> Option<AlarmStatus> {
        AlarmStatus::ALL.into_iter().find(|k| k.as_str() == s)
    }
}

/// An outbox row.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AlarmRow {
    /// Row id: the order of sending per destination.
    pub id: i64,
    /// The destination's name (the configuration's `[[webhook]]`).
    pub destination: String,
    /// The alarm's key (the `Idempotency-Key`).
    pub key: String,
    /// The rule that raised it.
    pub rule: Rule,
    /// The wheel, when it is a named wheel's.
    pub wheel_id: Option<String>,
    /// The pass that raised it, when one did.
    pub pass_id: Option<i64>,
    /// When it was raised (RFC 3339).
    pub created: String,
    /// The same in Unix seconds.
    pub created_s: f64,
    /// Where it stands.
    pub status: AlarmStatus,
    /// Tries so far.
    pub attempts: u32,
    /// Not tried again before this (Unix seconds).
    pub next_attempt_s: f64,
    /// The same in RFC 3339.
    pub next_attempt: String,
    /// Why the last try failed, when it did.
    pub last_error: Option<String>,
    /// When a 2xx answered it (RFC 3339).
    pub sent: Option<String>,
    /// The body sent, exactly (the signature is over these bytes).
    #[serde(skip)]
    pub body: String,
}

/// How many rows stand where.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct AlarmCounts {
    /// Not tried yet.
    pub pending: usize,
    /// Tried and failed, to be tried again.
    pub failed: usize,
    /// Delivered.
    pub sent: usize,
}

/// The longest error kept with a row (characters).
const MAX_ERROR_CHARS: usize = 500;

const SELECT: &str = "SELECT id, destination, key, rule, wheel_id, pass_id, created, created_s, status, attempts, next_attempt_s, last_error, sent_s, body FROM outbox";

impl Db {
    /// Writes `body` into the outbox for each of `plan`'s destinations, on the connection's
    /// open transaction; rows new (an alarm of the same key is not written twice).
    pub(super) fn insert_alarm(
        &self,
        plan: &AlarmPlan,
        body: &AlarmBody,
        pass_id: Option<i64>,
    ) -> Result<usize, DbError> {
        let text = serde_json::to_string(body).expect("an alarm body serialises");
        let created_s = crate::history::db::now_s();
        let mut new = 0;
        for d in &plan.destinations {
            new += self
                .conn
                .execute(
                    "INSERT OR IGNORE INTO outbox (destination, key, rule, wheel_id, pass_id, created, created_s, body, status, attempts, next_attempt_s) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, 'pending', 0, ?7)",
                    params![
                        d,
                        body.key,
                        body.rule.as_str(),
                        body.wheel_id,
                        pass_id,
                        rfc3339(created_s),
                        created_s,
                        text
                    ],
                )
                .map_err(|e| self.sql(e))?;
        }
        Ok(new)
    }

    /// Whether an alarm of `rule` was raised since `since_s`.
    pub(super) fn raised_since(&self, rule: Rule, since_s: f64) -> Result<bool, DbError> {
        self.conn
            .query_row(
                "SELECT EXISTS (SELECT 1 FROM outbox WHERE rule = ?1 AND created_s >= ?2)",
                params![rule.as_str(), since_s],
                |r| r.get(0),
            )
            .map_err(|e| self.sql(e))
    }

    fn alarm_rows(&self, sql: &str, args: impl rusqlite::Params) -> Result<Vec<AlarmRow>, DbError> {
        let mut st = self.conn.prepare_cached(sql).map_err(|e| self.sql(e))?;
        let rows = st
            .query_map(args, |r| {
                Ok((
                    (
                        r.get::<_, i64>(0)?,
                        r.get::<_, String>(1)?,
                        r.get::<_, String>(2)?,
                        r.get::<_, String>(3)?,
                        r.get::<_, Option<String>>(4)?,
                        r.get::<_, Option<i64>>(5)?,
                        r.get::<_, String>(6)?,
                    ),
                    (
                        r.get::<_, f64>(7)?,
                        r.get::<_, String>(8)?,
                        r.get::<_, i64>(9)?,
                        r.get::<_, f64>(10)?,
                        r.get::<_, Option<String>>(11)?,
                        r.get::<_, Option<f64>>(12)?,
                        r.get::<_, String>(13)?,
                    ),
                ))
            })
            .map_err(|e| self.sql(e))?;
        let mut out = Vec::new();
        for row in rows {
            let (
                (id, destination, key, rule, wheel_id, pass_id, created),
                (created_s, status, attempts, next_attempt_s, last_error, sent_s, body),
            ) = row.map_err(|e| self.sql(e))?;
            let corrupt = |what: String| DbError::Corrupt {
                path: self.path().to_path_buf(),
                pass: pass_id.unwrap_or(0),
                what,
            };
            let rule = Rule::parse(&rule)
                .ok_or_else(|| corrupt(format!("alarm {id}: rule `{rule}` unknown")))?;
            let status = AlarmStatus::parse(&status)
                .ok_or_else(|| corrupt(format!("alarm {id}: status `{status}` unknown")))?;
            out.push(AlarmRow {
                id,
                destination,
                key,
                rule,
                wheel_id,
                pass_id,
                created,
                created_s,
                status,
                attempts: attempts.clamp(0, u32::MAX as i64) as u32,
                next_attempt_s,
                next_attempt: rfc3339(next_attempt_s),
                last_error,
                sent: sent_s.map(rfc3339),
                body,
            });
        }
        Ok(out)
    }

    /// The newest alarms (all of them, or those of `status`), newest first, at most `limit`
    /// (none in a file older than schema 3, which had no outbox).
    pub fn alarms(
        &self,
        status: Option<AlarmStatus>,
        limit: usize,
    ) -> Result<Vec<AlarmRow>, DbError> {
        if self.version < 3 {
            return Ok(Vec::new());
        }
        let limit = limit as i64;
        match status {
            Some(s) => self.alarm_rows(
                &format!("{SELECT} WHERE status = ?1 ORDER BY id DESC LIMIT ?2"),
                params![s.as_str(), limit],
            ),
            None => self.alarm_rows(
                &format!("{SELECT} ORDER BY id DESC LIMIT ?1"),
                params![limit],
            ),
        }
    }

    /// How many outbox rows stand where (none in a file older than schema 3).
    pub fn alarm_counts(&self) -> Result<AlarmCounts, DbError> {
        let mut c = AlarmCounts::default();
        if self.version < 3 {
            return Ok(c);
        }
        let mut st = self
            .conn
            .prepare_cached("SELECT status, count(*) FROM outbox GROUP BY status")
            .map_err(|e| self.sql(e))?;
        let rows = st
            .query_map([], |r| Ok((r.get::<_, String>(0)?, r.get::<_, i64>(1)?)))
            .map_err(|e| self.sql(e))?;
        for row in rows {
            let (s, n) = row.map_err(|e| self.sql(e))?;
            let n = n as usize;
            match AlarmStatus::parse(&s) {
                Some(AlarmStatus::Pending) => c.pending = n,
                Some(AlarmStatus::Failed) => c.failed = n,
                Some(AlarmStatus::Sent) => c.sent = n,
                None => {}
            }
        }
        Ok(c)
    }

    /// The destinations with an alarm not yet sent, by name.
    pub fn alarm_destinations_unsent(&self) -> Result<Vec<String>, DbError> {
        if self.version < 3 {
            return Ok(Vec::new());
        }
        let mut st = self
            .conn
            .prepare_cached(
                "SELECT DISTINCT destination FROM outbox WHERE status != 'sent' ORDER BY destination",
            )
            .map_err(|e| self.sql(e))?;
        let rows = st.query_map([], |r| r.get(0)).map_err(|e| self.sql(e))?;
        rows.collect::<Result<_, _>>().map_err(|e| self.sql(e))
    }

    /// The oldest alarm not yet sent to `destination`: the next to send there (nothing newer
    /// goes before it).
    pub fn next_unsent_alarm(&self, destination: &str) -> Result<Option<AlarmRow>, DbError> {
        if self.version < 3 {
            return Ok(None);
        }
        Ok(self
            .alarm_rows(
                &format!(
                    "{SELECT} WHERE destination = ?1 AND status != 'sent' ORDER BY id LIMIT 1"
                ),
                params![destination],
            )?
            .pop())
    }

    /// Marks alarm `id` sent at `now_s`.
    pub fn mark_alarm_sent(&self, id: i64, now_s: f64) -> Result<(), DbError> {
        self.conn
            .execute(
                "UPDATE outbox SET status = 'sent', attempts = attempts + 1, sent_s = ?2, last_error = NULL WHERE id = ?1",
                params![id, now_s],
            )
            .map_err(|e| self.sql(e))?;
        Ok(())
    }

    /// Marks a try of alarm `id` failed with `error`, not to be tried again before
    /// `next_attempt_s`.
    pub fn mark_alarm_failed(
        &self,
        id: i64,
        error: &str,
        next_attempt_s: f64,
    ) -> Result<(), DbError> {
        let error: String = error.chars().take(MAX_ERROR_CHARS).collect();
        self.conn
            .execute(
                "UPDATE outbox SET status = 'failed', attempts = attempts + 1, last_error = ?2, next_attempt_s = ?3 WHERE id = ?1 AND status != 'sent'",
                params![id, error, next_attempt_s],
            )
            .map_err(|e| self.sql(e))?;
        Ok(())
    }

    /// Whether `id` is still unsent (another sender may have sent it meanwhile).
    pub fn alarm_unsent(&self, id: i64) -> Result<bool, DbError> {
        Ok(self
            .conn
            .query_row("SELECT status FROM outbox WHERE id = ?1", [id], |r| {
                r.get::<_, String>(0)
            })
            .optional()
            .map_err(|e| self.sql(e))?
            .is_some_and(|s| s != "sent"))
    }
}
