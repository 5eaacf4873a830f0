//! Writing a pass, or a pass that gave no answer, in one transaction with the alarms it raises
//! (`Db::raise_alarms`, [`super::alarms`]): the pass and its alarms are committed together or
//! not at all.

use super::db::failures::Failure;
use super::db::{rfc3339, Db, DbError};
use super::record::{boxes_to_bytes, PassRecord};
use rusqlite::{params, OptionalExtension, Transaction, TransactionBehavior};

/// The longest reason stored (characters; a longer one is cut, saying so).
pub(crate) const MAX_REASON_CHARS: usize = 4000;

impl Db {
    /// Stores a pass and its two wheels in one transaction, with the alarms it raises
    /// ([`Db::raise_alarms`]). `Ok(false)`: the pass was stored before (same key), nothing
    /// written.
    pub fn insert(&mut self, rec: &PassRecord) -> Result<bool, DbError> {
        let path = self.path().to_path_buf();
        let sql = |source| DbError::Sqlite {
            path: path.clone(),
            source,
        };
        // Unchecked: the alarms' rules read the wheel's passes through `self` inside it.
        let tx =
            Transaction::new_unchecked(&self.conn, TransactionBehavior::Immediate).map_err(sql)?;
        let known: Option<i64> = tx
            .query_row(
                "SELECT id FROM passes WHERE key = ?1",
                [&rec.meta.key],
                |r| r.get(0),
            )
            .optional()
            .map_err(sql)?;
        if known.is_some() {
            return Ok(false);
        }
        let m = &rec.meta;
        let time = rfc3339(m.time_s);
        tx.execute(
            "INSERT INTO passes (key, time, time_s, measurement, bank_id, speed_km_per_h, bank_speed_km_per_h, load_kn, bogie_id, summary, result_dir, answer_ms) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12)",
            params![
                m.key,
                time,
                m.time_s,
                m.measurement,
                m.bank_id,
                m.speed_km_per_h,
                m.bank_speed_km_per_h,
                m.load_kn,
                m.bogie_id,
                m.summary,
                m.result_dir,
                m.answer_ms
            ],
        )
        .map_err(sql)?;
        let pass_id = tx.last_insert_rowid();
        for w in &rec.wheels {
            let space = serde_json::to_string(&w.space).expect("a space serialises");
            tx.execute(
                "INSERT INTO wheel_passes (pass_id, wheel, wheel_id, claim, l0_min_mm, l0_max_mm, severity_lowest, severity_highest, limit_l0_mm, space, cells, boxes, dynamic_ratio_min, dynamic_ratio_max) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14)",
                params![
                    pass_id,
                    w.wheel.name(),
                    m.bogie_id.as_ref().map(|b| format!("{b}/{}", w.wheel.name())),
                    w.claim.as_str(),
                    w.l0_mm.map(|r| r[0]),
                    w.l0_mm.map(|r| r[1]),
                    w.severity.map(|s| s.lowest.as_str()),
                    w.severity.map(|s| s.highest.as_str()),
                    w.limit_l0_mm,
                    space,
                    w.boxes.len() as i64,
                    boxes_to_bytes(&w.boxes),
                    w.dynamic_ratio.map(|r| r[0]),
                    w.dynamic_ratio.map(|r| r[1])
                ],
            )
            .map_err(sql)?;
        }
        if let Some(plan) = &self.alarms {
            super::alarms::raise_for_pass(self, plan, pass_id, rec)?;
        }
        tx.commit().map_err(sql)?;
        Ok(true)
    }

    /// Stores a pass that gave no answer, with the alarm it raises ([`Db::raise_alarms`]), in
    /// one transaction.
    pub fn insert_failure(&mut self, f: &Failure) -> Result<(), DbError> {
        let reason: String = if f.reason.chars().count() > MAX_REASON_CHARS {
            let cut: String = f.reason.chars().take(MAX_REASON_CHARS).collect();
            format!("{cut} … (cut at {MAX_REASON_CHARS} characters)")
        } else {
            f.reason.clone()
        };
        let tx = Transaction::new_unchecked(&self.conn, TransactionBehavior::Immediate)
            .map_err(|e| self.sql(e))?;
        self.conn
            .execute(
                "INSERT INTO failures (time, time_s, measurement, bogie_id, outcome, reason) VALUES (?1, ?2, ?3, ?4, ?5, ?6)",
                params![
                    rfc3339(f.time_s),
                    f.time_s,
                    f.measurement,
                    f.bogie_id,
                    f.kind.as_str(),
                    reason
                ],
            )
            .map_err(|e| self.sql(e))?;
        let id = self.conn.last_insert_rowid();
        if let Some(plan) = &self.alarms {
            super::alarms::raise_for_refusal(self, plan, id, f)?;
        }
        tx.commit().map_err(|e| self.sql(e))?;
        Ok(())
    }
}
