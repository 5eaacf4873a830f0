//! What `/metrics` counts, read a little at a time: the passes, refusals and failures stored
//! after the last rows a reader has counted (row ids only grow), so that a scrape reads only
//! what is new since the one before.

use super::row::severity_of;
use super::{Db, DbError};
use crate::identify::Severity;
use rusqlite::params;

/// The rows stored after a reader's last count.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Tally {
    /// The largest pass id counted.
    pub last_pass_id: i64,
    /// The largest failure id counted.
    pub last_failure_id: i64,
    /// Passes answered (stored), one a bogie.
    pub answered: u64,
    /// Passes refused.
    pub refused: u64,
    /// Passes failed.
    pub failed: u64,
    /// The answer times of the new passes that have one (ms).
    pub answer_ms: Vec<f64>,
    /// The newest pass time among them (Unix seconds).
    pub newest_time_s: Option<f64>,
    /// Each named wheel of the new passes with its class acted on at its newest of them,
    /// in pass order (a later entry of a wheel replaces an earlier one).
    pub wheel_classes: Vec<(String, Option<Severity>)>,
}

impl Db {
    /// The passes and failures stored after pass `after_pass_id` and failure
    /// `after_failure_id` (a file older than schema 3 has no answer times; one of schema 1 no
    /// failures).
    pub fn tally_after(&self, after_pass_id: i64, after_failure_id: i64) -> Result<Tally, DbError> {
        let mut t = Tally {
            last_pass_id: after_pass_id,
            last_failure_id: after_failure_id,
            ..Tally::default()
        };
        let answer = if self.version >= 3 {
            "answer_ms"
        } else {
            "NULL"
        };
        let mut st = self
            .conn
            .prepare_cached(&format!(
                "SELECT id, time_s, {answer} FROM passes WHERE id > ?1 ORDER BY id"
            ))
            .map_err(|e| self.sql(e))?;
        let rows = st
            .query_map([after_pass_id], |r| {
                Ok((
                    r.get::<_, i64>(0)?,
                    r.get::<_, f64>(1)?,
                    r.get::<_, Option<f64>>(2)?,
                ))
            })
            .map_err(|e| self.sql(e))?;
        for row in rows {
            let (id, time_s, ms) = row.map_err(|e| self.sql(e))?;
            t.last_pass_id = t.last_pass_id.max(id);
            t.answered += 1;
            t.answer_ms.extend(ms.filter(|m| m.is_finite()));
            t.newest_time_s = Some(t.newest_time_s.map_or(time_s, |n: f64| n.max(time_s)));
        }
        let mut st = self
            .conn
            .prepare_cached(
                "SELECT wheel_id, severity_highest FROM wheel_passes
                 WHERE pass_id > ?1 AND pass_id <= ?2 AND wheel_id IS NOT NULL ORDER BY pass_id",
            )
            .map_err(|e| self.sql(e))?;
        let rows = st
            .query_map(params![after_pass_id, t.last_pass_id], |r| {
                Ok((r.get::<_, String>(0)?, r.get::<_, Option<String>>(1)?))
            })
            .map_err(|e| self.sql(e))?;
        for row in rows {
            let (wheel, class) = row.map_err(|e| self.sql(e))?;
            let class = class.as_deref().and_then(severity_of);
            t.wheel_classes.push((wheel, class));
        }
        if self.version >= 2 {
            let mut st = self
                .conn
                .prepare_cached("SELECT id, outcome FROM failures WHERE id > ?1 ORDER BY id")
                .map_err(|e| self.sql(e))?;
            let rows = st
                .query_map([after_failure_id], |r| {
                    Ok((r.get::<_, i64>(0)?, r.get::<_, String>(1)?))
                })
                .map_err(|e| self.sql(e))?;
            for row in rows {
                let (id, outcome) = row.map_err(|e| self.sql(e))?;
                t.last_failure_id = t.last_failure_id.max(id);
                match outcome.as_str() {
                    "refused" => t.refused += 1,
                    _ => t.failed += 1,
                }
            }
        }
        Ok(t)
    }
}
