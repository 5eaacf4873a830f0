//! What a site's page reads of the results database: every named wheel with its newest pass
//! (and the class before it), the passes of the last hours with what each said of its two
//! wheels, one pass whole, and the banks the passes were compared with. Read-only queries
//! over the indexes the schema has (a wheel's newest pass is its largest pass id).

use super::db::row::severity_range;
use super::db::{Db, DbError, StoredPass};
use super::record::Claim;
use crate::identify::SeverityRange;
use rusqlite::{params, OptionalExtension};
use serde::Serialize;

/// A named wheel and its newest pass.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WheelRow {
    /// `<bogie_id>/leading` or `…/trailing`.
    pub wheel_id: String,
    /// Passes stored.
    pub passes: usize,
    /// The newest pass's row id.
    pub last_pass_id: i64,
    /// Its time (RFC 3339).
    pub last_time: String,
    /// The same in Unix seconds.
    pub last_time_s: f64,
    /// What it said of the wheel.
    pub claim: Claim,
    /// Its L0 range (mm).
    pub l0_mm: Option<[f64; 2]>,
    /// Its classes.
    pub severity: Option<SeverityRange>,
    /// The classes of the pass before it (none for a wheel's first pass or an unseen one).
    pub previous_severity: Option<SeverityRange>,
}

impl WheelRow {
    /// The bogie, the wheel id without its position.
    pub fn bogie(&self) -> &str {
        self.wheel_id
            .rsplit_once('/')
            .map_or(self.wheel_id.as_str(), |(b, _)| b)
    }

    /// Whether the class acted on changed from the pass before.
    pub fn changed(&self) -> bool {
        match (self.previous_severity, self.severity) {
            (Some(a), Some(b)) => a.highest != b.highest,
            _ => false,
        }
    }
}

/// What one pass said of one wheel, in a list of passes.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WheelOutcome {
    /// `leading` or `trailing`.
    pub wheel: String,
    /// The claim.
    pub claim: Claim,
    /// Its L0 range (mm).
    pub l0_mm: Option<[f64; 2]>,
    /// Its classes.
    pub severity: Option<SeverityRange>,
}

/// A pass in a list of passes.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PassRow {
    /// Row id.
    pub pass_id: i64,
    /// When (RFC 3339).
    pub time: String,
    /// The same in Unix seconds.
    pub time_s: f64,
    /// The measurement file.
    pub measurement: String,
    /// The bogie, when named.
    pub bogie_id: Option<String>,
    /// The bank it was compared with.
    pub bank_id: String,
    /// Its speed (km/h).
    pub speed_km_per_h: Option<f64>,
    /// Its wheel load (kN).
    pub load_kn: Option<f64>,
    /// Its verdict in words.
    pub summary: String,
    /// Where its result was written (none in a version-1 file).
    pub result_dir: Option<String>,
    /// Leading, then trailing.
    pub wheels: Vec<WheelOutcome>,
}

/// One pass whole: its row and each wheel as `history` reads it (cells included).
#[derive(Debug, Clone, PartialEq)]
pub struct PassDetail {
    /// The pass.
    pub row: PassRow,
    /// Leading, then trailing, with their cells and sizing space.
    pub wheels: Vec<StoredPass>,
}

/// A bank the passes were compared with.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BankUse {
    /// Its id.
    pub bank_id: String,
    /// Passes compared with it in the window.
    pub passes: usize,
    /// The newest of them (RFC 3339).
    pub last_time: String,
}

const PASS_COLUMNS_V2: &str = "p.id, p.time, p.time_s, p.measurement, p.bogie_id, p.bank_id, p.speed_km_per_h, p.load_kn, p.summary, p.result_dir";
const PASS_COLUMNS_V1: &str = "p.id, p.time, p.time_s, p.measurement, p.bogie_id, p.bank_id, p.speed_km_per_h, p.load_kn, p.summary, NULL";

fn range(lo: Option<String>, hi: Option<String>) -> Option<SeverityRange> {
    severity_range(lo.as_deref(), hi.as_deref())
}

impl Db {
    fn pass_columns(&self) -> &'static str {
        if self.version < 2 {
            PASS_COLUMNS_V1
        } else {
            PASS_COLUMNS_V2
        }
    }

    fn corrupt(&self, pass: i64, what: String) -> DbError {
        DbError::Corrupt {
            path: self.path().to_path_buf(),
            pass,
            what,
        }
    }

    /// Every named wheel with its newest pass and the class of the pass before, by wheel id.
    pub fn wheel_rows(&self) -> Result<Vec<WheelRow>, DbError> {
        let mut st = self
            .conn
            .prepare_cached(
                "WITH last AS (
                   SELECT wheel_id, count(*) AS n, max(pass_id) AS pid FROM wheel_passes
                   WHERE wheel_id IS NOT NULL GROUP BY wheel_id)
                 SELECT l.wheel_id, l.n, p.id, p.time, p.time_s, w.claim, w.l0_min_mm, w.l0_max_mm,
                        w.severity_lowest, w.severity_highest, prev.severity_lowest, prev.severity_highest
                 FROM last l
                 JOIN wheel_passes w ON w.wheel_id = l.wheel_id AND w.pass_id = l.pid
                 JOIN passes p ON p.id = l.pid
                 LEFT JOIN wheel_passes prev ON prev.wheel_id = l.wheel_id AND prev.pass_id =
                   (SELECT max(pass_id) FROM wheel_passes x WHERE x.wheel_id = l.wheel_id AND x.pass_id < l.pid)
                 ORDER BY l.wheel_id",
            )
            .map_err(|e| self.sql(e))?;
        let rows = st
            .query_map([], |r| {
                Ok((
                    (
                        r.get::<_, String>(0)?,
                        r.get::<_, i64>(1)?,
                        r.get::<_, i64>(2)?,
                        r.get::<_, String>(3)?,
                        r.get::<_, f64>(4)?,
                        r.get::<_, String>(5)?,
                    ),
                    (r.get::<_, Option<f64>>(6)?, r.get::<_, Option<f64>>(7)?),
                    (
                        r.get::<_, Option<String>>(8)?,
                        r.get::<_, Option<String>>(9)?,
                    ),
                    (
                        r.get::<_, Option<String>>(10)?,
                        r.get::<_, Option<String>>(11)?,
                    ),
                ))
            })
            .map_err(|e| self.sql(e))?;
        let mut out = Vec::new();
        for row in rows {
            let ((wheel_id, n, pid, time, time_s, claim), l0, sev, prev) =
                row.map_err(|e| self.sql(e))?;
            let claim = Claim::parse(&claim)
                .ok_or_else(|| self.corrupt(pid, format!("claim `{claim}` unknown")))?;
            out.push(WheelRow {
                wheel_id,
                passes: n as usize,
                last_pass_id: pid,
                last_time: time,
                last_time_s: time_s,
                claim,
                l0_mm: l0.0.zip(l0.1).map(|(a, b)| [a, b]),
                severity: range(sev.0, sev.1),
                previous_severity: range(prev.0, prev.1),
            });
        }
        Ok(out)
    }

    /// The passes since `since_s` (Unix seconds), newest first, at most `limit`.
    pub fn passes_since(&self, since_s: f64, limit: usize) -> Result<Vec<PassRow>, DbError> {
        let sql = format!(
            "SELECT {} FROM passes p WHERE p.time_s >= ?1 ORDER BY p.time_s DESC, p.id DESC LIMIT ?2",
            self.pass_columns()
        );
        self.pass_rows(&sql, params![since_s, limit as i64])
    }

    /// One pass whole, or `None` when there is no pass of that id.
    pub fn pass_detail(&self, id: i64) -> Result<Option<PassDetail>, DbError> {
        let sql = format!(
            "SELECT {} FROM passes p WHERE p.id = ?1",
            self.pass_columns()
        );
        let Some(row) = self.pass_rows(&sql, params![id])?.into_iter().next() else {
            return Ok(None);
        };
        let wheels = self.stored_wheels_of(id)?;
        Ok(Some(PassDetail { row, wheels }))
    }

    /// The banks the passes since `since_s` were compared with, the most used first.
    pub fn banks_since(&self, since_s: f64) -> Result<Vec<BankUse>, DbError> {
        let mut st = self
            .conn
            .prepare_cached(
                "SELECT bank_id, count(*), max(time) FROM passes WHERE time_s >= ?1
                 GROUP BY bank_id ORDER BY count(*) DESC, bank_id",
            )
            .map_err(|e| self.sql(e))?;
        let rows = st
            .query_map([since_s], |r| {
                Ok(BankUse {
                    bank_id: r.get(0)?,
                    passes: r.get::<_, i64>(1)? as usize,
                    last_time: r.get(2)?,
                })
            })
            .map_err(|e| self.sql(e))?;
        rows.collect::<Result<_, _>>().map_err(|e| self.sql(e))
    }

    /// The newest pass's time (Unix seconds), none in an empty database.
    pub fn newest_time_s(&self) -> Result<Option<f64>, DbError> {
        self.conn
            .query_row("SELECT max(time_s) FROM passes", [], |r| r.get(0))
            .optional()
            .map(Option::flatten)
            .map_err(|e| self.sql(e))
    }

    fn pass_rows(&self, sql: &str, args: impl rusqlite::Params) -> Result<Vec<PassRow>, DbError> {
        let mut st = self.conn.prepare_cached(sql).map_err(|e| self.sql(e))?;
        let rows = st
            .query_map(args, |r| {
                Ok(PassRow {
                    pass_id: r.get(0)?,
                    time: r.get(1)?,
                    time_s: r.get(2)?,
                    measurement: r.get(3)?,
                    bogie_id: r.get(4)?,
                    bank_id: r.get(5)?,
                    speed_km_per_h: r.get(6)?,
                    load_kn: r.get(7)?,
                    summary: r.get(8)?,
                    result_dir: r.get(9)?,
                    wheels: Vec::new(),
                })
            })
            .map_err(|e| self.sql(e))?;
        let mut out: Vec<PassRow> = rows.collect::<Result<_, _>>().map_err(|e| self.sql(e))?;
        let mut st = self
            .conn
            .prepare_cached(
                "SELECT wheel, claim, l0_min_mm, l0_max_mm, severity_lowest, severity_highest
                 FROM wheel_passes WHERE pass_id = ?1 ORDER BY wheel",
            )
            .map_err(|e| self.sql(e))?;
        for p in &mut out {
            let rows = st
                .query_map([p.pass_id], |r| {
                    Ok((
                        r.get::<_, String>(0)?,
                        r.get::<_, String>(1)?,
                        r.get::<_, Option<f64>>(2)?,
                        r.get::<_, Option<f64>>(3)?,
                        r.get::<_, Option<String>>(4)?,
                        r.get::<_, Option<String>>(5)?,
                    ))
                })
                .map_err(|e| self.sql(e))?;
            for row in rows {
                let (wheel, claim, lo, hi, slo, shi) = row.map_err(|e| self.sql(e))?;
                let claim = Claim::parse(&claim)
                    .ok_or_else(|| self.corrupt(p.pass_id, format!("claim `{claim}` unknown")))?;
                p.wheels.push(WheelOutcome {
                    wheel,
                    claim,
                    l0_mm: lo.zip(hi).map(|(a, b)| [a, b]),
                    severity: range(slo, shi),
                });
            }
        }
        Ok(out)
    }
}
