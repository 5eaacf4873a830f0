//! The rows a site ships to the fleet store (docs/fleet.md): its passes with their wheels,
//! the passes refused or failed, and the alarms raised — each after a row id, in the order
//! they were stored. A wheel's row is checked as `history` reads it before it leaves
//! ([`RawRow::parse`]): a damaged row stops the shipping by name, never reaches the fleet.

use super::failures::Failure;
use super::row::RawRow;
use super::{Db, DbError};
use crate::history::record::PassMeta;
use rusqlite::params;

/// A stored pass as it leaves the site.
#[derive(Debug, Clone, PartialEq)]
pub struct ExportPass {
    /// Its row id at the site: the order the site stored it in.
    pub id: i64,
    /// When it was identified (RFC 3339; `meta.time_s` in Unix seconds).
    pub time: String,
    /// What the pass is besides its wheels, as it was stored.
    pub meta: PassMeta,
    /// Its wheels, leading then trailing.
    pub wheels: Vec<ExportWheel>,
}

/// One wheel of a pass as it leaves the site (the columns of `wheel_passes`).
#[derive(Debug, Clone, PartialEq)]
pub struct ExportWheel {
    /// `leading` or `trailing`.
    pub wheel: String,
    /// `<bogie_id>/<wheel>`, when the pass named its bogie.
    pub wheel_id: Option<String>,
    /// The claim's name.
    pub claim: String,
    /// L0 range (mm).
    pub l0_mm: (Option<f64>, Option<f64>),
    /// The classes' names.
    pub severity: (Option<String>, Option<String>),
    /// Detection limit (mm).
    pub limit_l0_mm: Option<f64>,
    /// The sizing space (JSON).
    pub space: String,
    /// Cells stored.
    pub cells: i64,
    /// The cells (`boxes_to_bytes`).
    pub boxes: Vec<u8>,
    /// Dynamic ratio range.
    pub dynamic_ratio: (Option<f64>, Option<f64>),
}

/// An alarm raised at the site (one row a destination), as it leaves the site: what was
/// raised, not how its delivery went (that stays the site's).
#[derive(Debug, Clone, PartialEq)]
pub struct ExportAlarm {
    /// Its row id at the site.
    pub id: i64,
    /// The destination's name.
    pub destination: String,
    /// The alarm's key (once per destination).
    pub key: String,
    /// The rule that raised it.
    pub rule: String,
    /// The wheel, when the rule is about one.
    pub wheel_id: Option<String>,
    /// The pass that raised it (its site row id).
    pub pass_id: Option<i64>,
    /// RFC 3339.
    pub created: String,
    /// Unix seconds.
    pub created_s: f64,
    /// The signed body (JSON).
    pub body: String,
}

/// The newest row ids of a site database: passes, failures, alarms (0 when none).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct NewestIds {
    /// `passes`.
    pub passes: i64,
    /// `failures` (0 in a version-1 file).
    pub failures: i64,
    /// `outbox` (0 before version 3).
    pub alarms: i64,
}

impl Db {
    /// The newest row ids (what a shipper has to reach).
    pub fn newest_ids(&self) -> Result<NewestIds, DbError> {
        let max = |table: &str| -> Result<i64, DbError> {
            self.conn
                .query_row(
                    &format!("SELECT coalesce(max(id), 0) FROM {table}"),
                    [],
                    |r| r.get(0),
                )
                .map_err(|e| self.sql(e))
        };
        Ok(NewestIds {
            passes: max("passes")?,
            failures: if self.version >= 2 {
                max("failures")?
            } else {
                0
            },
            alarms: if self.version >= 3 { max("outbox")? } else { 0 },
        })
    }

    /// The time (Unix seconds) of the pass with row id `id`, when stored.
    pub fn pass_time_s(&self, id: i64) -> Result<Option<f64>, DbError> {
        use rusqlite::OptionalExtension;
        self.conn
            .query_row("SELECT time_s FROM passes WHERE id = ?1", [id], |r| {
                r.get(0)
            })
            .optional()
            .map_err(|e| self.sql(e))
    }

    /// The passes with a row id above `after`, oldest first, at most `limit`, with their
    /// wheels; each wheel checked as `history` reads it ([`DbError::Corrupt`] names the pass).
    pub fn passes_after(&self, after: i64, limit: usize) -> Result<Vec<ExportPass>, DbError> {
        let (result_dir, answer_ms) = match self.version {
            1 => ("NULL", "NULL"),
            2 => ("result_dir", "NULL"),
            _ => ("result_dir", "answer_ms"),
        };
        let mut st = self
            .conn
            .prepare_cached(&format!(
                "SELECT id, key, time, time_s, measurement, bank_id, speed_km_per_h, bank_speed_km_per_h,
                        load_kn, bogie_id, summary, {result_dir}, {answer_ms}
                 FROM passes WHERE id > ?1 ORDER BY id LIMIT ?2"
            ))
            .map_err(|e| self.sql(e))?;
        let mut passes = st
            .query_map(params![after, limit as i64], |r| {
                Ok(ExportPass {
                    id: r.get(0)?,
                    time: r.get(2)?,
                    meta: PassMeta {
                        key: r.get(1)?,
                        time_s: r.get(3)?,
                        measurement: r.get(4)?,
                        bank_id: r.get(5)?,
                        speed_km_per_h: r.get(6)?,
                        bank_speed_km_per_h: r.get(7)?,
                        load_kn: r.get(8)?,
                        bogie_id: r.get(9)?,
                        summary: r.get(10)?,
                        result_dir: r.get(11)?,
                        answer_ms: r.get(12)?,
                    },
                    wheels: Vec::new(),
                })
            })
            .map_err(|e| self.sql(e))?
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| self.sql(e))?;
        let ratio = if self.version < 2 {
            "NULL, NULL"
        } else {
            "dynamic_ratio_min, dynamic_ratio_max"
        };
        let mut wheels = self
            .conn
            .prepare_cached(&format!(
                "SELECT wheel, wheel_id, claim, l0_min_mm, l0_max_mm, severity_lowest, severity_highest,
                        limit_l0_mm, space, cells, boxes, {ratio}
                 FROM wheel_passes WHERE pass_id = ?1 ORDER BY wheel"
            ))
            .map_err(|e| self.sql(e))?;
        for p in &mut passes {
            let rows = wheels
                .query_map([p.id], |r| {
                    Ok(ExportWheel {
                        wheel: r.get(0)?,
                        wheel_id: r.get(1)?,
                        claim: r.get(2)?,
                        l0_mm: (r.get(3)?, r.get(4)?),
                        severity: (r.get(5)?, r.get(6)?),
                        limit_l0_mm: r.get(7)?,
                        space: r.get(8)?,
                        cells: r.get(9)?,
                        boxes: r.get(10)?,
                        dynamic_ratio: (r.get(11)?, r.get(12)?),
                    })
                })
                .map_err(|e| self.sql(e))?;
            for w in rows {
                let w = w.map_err(|e| self.sql(e))?;
                check_wheel(p, &w).map_err(|what| DbError::Corrupt {
                    path: self.path().to_path_buf(),
                    pass: p.id,
                    what,
                })?;
                p.wheels.push(w);
            }
        }
        Ok(passes)
    }

    /// The passes refused or failed with a row id above `after`, oldest first, at most `limit`
    /// (none in a version-1 file), each checked as the site's pages read them.
    pub fn failures_after(&self, after: i64, limit: usize) -> Result<Vec<Failure>, DbError> {
        self.failures_where("id > ?1 ORDER BY id", &after, limit)
    }

    /// The alarms raised with a row id above `after`, oldest first, at most `limit` (none
    /// before version 3).
    pub fn alarms_after(&self, after: i64, limit: usize) -> Result<Vec<ExportAlarm>, DbError> {
        if self.version < 3 {
            return Ok(Vec::new());
        }
        let mut st = self
            .conn
            .prepare_cached(
                "SELECT id, destination, key, rule, wheel_id, pass_id, created, created_s, body
                 FROM outbox WHERE id > ?1 ORDER BY id LIMIT ?2",
            )
            .map_err(|e| self.sql(e))?;
        let rows = st
            .query_map(params![after, limit as i64], |r| {
                Ok(ExportAlarm {
                    id: r.get(0)?,
                    destination: r.get(1)?,
                    key: r.get(2)?,
                    rule: r.get(3)?,
                    wheel_id: r.get(4)?,
                    pass_id: r.get(5)?,
                    created: r.get(6)?,
                    created_s: r.get(7)?,
                    body: r.get(8)?,
                })
            })
            .map_err(|e| self.sql(e))?;
        rows.collect::<Result<_, _>>().map_err(|e| self.sql(e))
    }
}

/// A wheel row checked as `history` would read it (its values are not kept).
fn check_wheel(p: &ExportPass, w: &ExportWheel) -> Result<(), String> {
    RawRow {
        pass_id: p.id,
        time: p.time.clone(),
        time_s: p.meta.time_s,
        measurement: String::new(),
        speed: p.meta.speed_km_per_h,
        bank_speed: p.meta.bank_speed_km_per_h,
        bank_id: String::new(),
        wheel: w.wheel.clone(),
        claim: w.claim.clone(),
        l0: w.l0_mm,
        severity: w.severity.clone(),
        limit: w.limit_l0_mm,
        space: w.space.clone(),
        cells: w.cells,
        boxes: w.boxes.clone(),
        dynamic_ratio: w.dynamic_ratio,
    }
    .parse()
    .map(|_| ())
}
