//! The passes that gave no answer: refused (wheelflat declined the input: a speed or load
//! outside every bank, a file out of its bounds) or failed (something broke: a bank that
//! would not open, a disk that would not take the result), each with its reason, so that the
//! people who watch a site see them beside the answered passes.

use super::{rfc3339, Db, DbError};
use rusqlite::params;
use serde::Serialize;

/// Why a pass gave no answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum FailureKind {
    /// wheelflat declined the input (its reason says which value and why).
    Refused,
    /// Something broke on the way (a file, the bank, the disk).
    Failed,
}

impl FailureKind {
    /// The name the database and the JSON use.
    pub fn as_str(self) -> &'static str {
        match self {
            FailureKind::Refused => "refused",
            FailureKind::Failed => "failed",
        }
    }

    fn parse(s: &str) -> Option<FailureKind> {
        [FailureKind::Refused, FailureKind::Failed]
            .into_iter()
            .find(|k| k.as_str() == s)
    }
}

/// A pass that gave no answer.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Failure {
    /// Row id (0 before it is stored).
    pub id: i64,
    /// When (RFC 3339, UTC; set when stored).
    pub time: String,
    /// The same in Unix seconds.
    pub time_s: f64,
    /// The measurement (or recording) file.
    pub measurement: String,
    /// The bogie, when the file named it before the pass failed.
    pub bogie_id: Option<String>,
    /// Refused or failed.
    pub kind: FailureKind,
    /// Why, in the words the command printed.
    pub reason: String,
}

impl Failure {
    /// A pass of `measurement` that gave no answer now, for [`Db::insert_failure`] (its row id
    /// and RFC 3339 time are the database's).
    pub fn now(measurement: String, kind: FailureKind, reason: String) -> Failure {
        let time_s = super::now_s();
        Failure {
            id: 0,
            time: rfc3339(time_s),
            time_s,
            measurement,
            bogie_id: None,
            kind,
            reason,
        }
    }
}

impl Db {
    /// The passes that gave no answer since `since_s` (Unix seconds), newest first, at most
    /// `limit` (none in a version-1 file, which did not keep them).
    pub fn failures_since(&self, since_s: f64, limit: usize) -> Result<Vec<Failure>, DbError> {
        self.failures_where(
            "time_s >= ?1 ORDER BY time_s DESC, id DESC",
            &since_s,
            limit,
        )
    }

    /// The failures `WHERE <clause> LIMIT limit` (the clause's one parameter `?1` is
    /// `bound`), each outcome checked (none in a version-1 file).
    pub(super) fn failures_where(
        &self,
        clause: &str,
        bound: &dyn rusqlite::ToSql,
        limit: usize,
    ) -> Result<Vec<Failure>, DbError> {
        if self.version < 2 {
            return Ok(Vec::new());
        }
        let mut st = self
            .conn
            .prepare_cached(&format!(
                "SELECT id, time, time_s, measurement, bogie_id, outcome, reason FROM failures
                 WHERE {clause} LIMIT ?2"
            ))
            .map_err(|e| self.sql(e))?;
        let rows = st
            .query_map(params![bound, limit as i64], |r| {
                Ok((
                    r.get::<_, i64>(0)?,
                    r.get::<_, String>(1)?,
                    r.get::<_, f64>(2)?,
                    r.get::<_, String>(3)?,
                    r.get::<_, Option<String>>(4)?,
                    r.get::<_, String>(5)?,
                    r.get::<_, String>(6)?,
                ))
            })
            .map_err(|e| self.sql(e))?;
        let mut out = Vec::new();
        for row in rows {
            let (id, time, time_s, measurement, bogie_id, kind, reason) =
                row.map_err(|e| self.sql(e))?;
            let kind = FailureKind::parse(&kind).ok_or_else(|| DbError::Corrupt {
                path: self.path().to_path_buf(),
                pass: id,
                what: format!("failure outcome `{kind}` unknown"),
            })?;
            out.push(Failure {
                id,
                time,
                time_s,
                measurement,
                bogie_id,
                kind,
                reason,
            });
        }
        Ok(out)
    }
}
