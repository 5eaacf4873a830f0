//! Alarms: the rules that turn a stored pass (or a refusal, or a drifted calibration) into a
//! message for the people who act, and the outbox they wait in (docs/alarms.md).
//!
//! An alarm is raised **in the transaction of the pass that raised it**: the pass, its wheels
//! and one outbox row a destination are committed together or not at all, so a writer killed
//! at any point leaves neither a pass without its alarm nor an alarm without its pass. Sending
//! is another's work (`crate::alarm`): it reads the outbox, delivers in order per destination,
//! and marks each row `sent` on a 2xx. Each alarm has a key (SHA-256 of the pass's key, the
//! wheel and the rule) that a receiver uses to drop a message it got twice.
//!
//! - [`body`]: what a receiver is sent (schema version [`BODY_SCHEMA`]).
//! - [`outbox`]: the rows, their states and what the sender and the pages read.

mod body;
mod outbox;

pub use body::{AlarmBody, DriftLine, PassRef, RefusalCount, BODY_SCHEMA};
pub use outbox::{AlarmCounts, AlarmRow, AlarmStatus};

use super::db::failures::Failure;
use super::db::StoredPass;
use super::db::{now_s, rfc3339, Db, DbError, Window};
use super::fuse::{fuse, Agreement, FusionRule};
use super::record::PassRecord;
use super::rules::{AlarmPlan, Rule};
use crate::identify::Severity;
use sha2::{Digest, Sha256};

/// An alarm's key: the SHA-256 (hex) of what makes it itself.
fn key_of(parts: &[&str]) -> String {
    let mut h = Sha256::new();
    for p in parts {
        h.update((p.len() as u64).to_le_bytes());
        h.update(p.as_bytes());
    }
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

/// A body with its common fields set.
fn body(plan: &AlarmPlan, rule: Rule, key: String, words: String) -> AlarmBody {
    AlarmBody {
        schema: BODY_SCHEMA,
        key,
        rule,
        raised_at: rfc3339(now_s()),
        site: plan.site.clone(),
        words,
        wheel_id: None,
        wheel: None,
        pass: None,
        severity: None,
        previous_severity: None,
        l0_mm: None,
        joint_l0_mm: None,
        refusals: None,
        drift: None,
    }
}

/// The start of the newest run of passes that the fusion of `window` says grew: the first
/// pass's row id.
fn grew_since(window: &[StoredPass], plan: &AlarmPlan) -> Option<(i64, Option<[f64; 2]>)> {
    if window.is_empty() {
        return None;
    }
    let wheels: Vec<_> = window.iter().map(|p| p.wheel.clone()).collect();
    let [inspect, urgent] = plan.limits_l0_mm;
    let joint = fuse(&wheels, FusionRule::Robust, plan.phi, urgent, inspect);
    match joint.agreement {
        Agreement::Changed { since, grew: true } => Some((window[since].pass_id, joint.l0_mm)),
        _ => None,
    }
}

/// The alarms the pass `pass_id` (just inserted, inside its transaction) raises, into the
/// outbox on the same connection.
pub(super) fn raise_for_pass(
    db: &Db,
    plan: &AlarmPlan,
    pass_id: i64,
    rec: &PassRecord,
) -> Result<(), DbError> {
    let m = &rec.meta;
    for w in &rec.wheels {
        let wheel_id = m
            .bogie_id
            .as_ref()
            .map(|b| format!("{b}/{}", w.wheel.name()));
        let who = wheel_id
            .clone()
            .unwrap_or_else(|| format!("the {} wheel of {}", w.wheel.name(), m.measurement));
        let l0 = w
            .l0_mm
            .map(|r| format!(" (L0 {:.0}–{:.0} mm)", r[0], r[1]))
            .unwrap_or_default();
        let mut raised = Vec::new();
        let class = w.severity.map(|s| s.highest);
        if plan.on(Rule::Urgent) && class == Some(Severity::Urgent) {
            raised.push((Rule::Urgent, format!("{who} acted on as urgent{l0}")));
        }
        let history = match &wheel_id {
            Some(id) if plan.on(Rule::ClassRose) || plan.on(Rule::FlatGrew) => {
                let last = plan.window.max(1) + 1;
                db.wheel_passes(id, Window { last, hours: None })?
            }
            _ => Vec::new(),
        };
        // The wheel's passes, oldest first, this one last (written in this transaction).
        let n = history.len();
        let this_last = history.last().is_some_and(|p| p.pass_id == pass_id);
        let mut previous = None;
        if this_last && n >= 2 {
            previous = history[n - 2].wheel.severity;
            let before = previous.map(|s| s.highest);
            if plan.on(Rule::ClassRose) && before.is_some() && class > before {
                raised.push((
                    Rule::ClassRose,
                    format!(
                        "{who}: class rose from {} to {}{l0}",
                        before.map_or("none", |c| c.as_str()),
                        class.map_or("none", |c| c.as_str())
                    ),
                ));
            }
        }
        let mut joint_l0 = None;
        if this_last && plan.on(Rule::FlatGrew) {
            let window = plan.window.max(2);
            let now = grew_since(&history[n.saturating_sub(window)..], plan);
            let before = grew_since(&history[(n - 1).saturating_sub(window)..n - 1], plan);
            if let Some((since, joint)) = now {
                if before.map(|b| b.0) != Some(since) {
                    joint_l0 = joint;
                    let joint = joint
                        .map(|r| format!(", now L0 {:.0}–{:.0} mm", r[0], r[1]))
                        .unwrap_or_default();
                    raised.push((
                        Rule::FlatGrew,
                        format!("{who}: the flat grew over its newest passes{joint}"),
                    ));
                }
            }
        }
        for (rule, words) in raised {
            let key = key_of(&[&m.key, w.wheel.name(), rule.as_str()]);
            let mut b = body(plan, rule, key, words);
            b.wheel_id = wheel_id.clone();
            b.wheel = Some(w.wheel.name().to_string());
            b.pass = Some(PassRef {
                id: pass_id,
                key: m.key.clone(),
                time: rfc3339(m.time_s),
                measurement: m.measurement.clone(),
                bank_id: m.bank_id.clone(),
                speed_km_per_h: m.speed_km_per_h,
                summary: m.summary.clone(),
            });
            b.severity = w.severity;
            b.l0_mm = w.l0_mm;
            if rule == Rule::ClassRose {
                b.previous_severity = previous;
            }
            if rule == Rule::FlatGrew {
                b.joint_l0_mm = joint_l0;
            }
            db.insert_alarm(plan, &b, Some(pass_id))?;
        }
    }
    Ok(())
}

/// The alarm a refusal (just inserted as row `failure_id`, inside its transaction) raises:
/// the refusals of the last hour reached the plan's count, and none was raised within it.
pub(super) fn raise_for_refusal(
    db: &Db,
    plan: &AlarmPlan,
    failure_id: i64,
    f: &Failure,
) -> Result<(), DbError> {
    if !plan.on(Rule::Refusals) || f.kind != super::FailureKind::Refused {
        return Ok(());
    }
    let since = f.time_s - 3600.0;
    let count: i64 = db
        .conn
        .query_row(
            "SELECT count(*) FROM failures WHERE outcome = 'refused' AND time_s >= ?1",
            [since],
            |r| r.get(0),
        )
        .map_err(|e| db.sql(e))?;
    if (count as usize) < plan.refusals_per_hour.max(1) || db.raised_since(Rule::Refusals, since)? {
        return Ok(());
    }
    let key = key_of(&["refusals", &failure_id.to_string(), &f.time]);
    let words = format!(
        "{count} passes refused within the hour (the newest: {}: {})",
        f.measurement, f.reason
    );
    let mut b = body(plan, Rule::Refusals, key, words);
    b.refusals = Some(RefusalCount {
        count: count as usize,
        hours: 1.0,
        newest_measurement: f.measurement.clone(),
        newest_reason: f.reason.clone(),
    });
    db.insert_alarm(plan, &b, None)?;
    Ok(())
}

impl Db {
    /// Raises the alarm that the nightly check `check_file` (its bytes `content`) found
    /// `drift`, in a transaction of its own; once per check (its key is the file's name and
    /// content). Whether it is new (`false`: raised before, or the rule is off, or no plan).
    pub fn raise_drift(
        &mut self,
        check_file: &str,
        content: &[u8],
        drift: Vec<DriftLine>,
    ) -> Result<bool, DbError> {
        let Some(plan) = self.alarms.clone() else {
            return Ok(false);
        };
        if !plan.on(Rule::CalibrationDrift) || drift.is_empty() {
            return Ok(false);
        }
        let digest = crate::bank::schema::sha256_hex(content);
        let key = key_of(&["calibration-drift", check_file, &digest]);
        let known: bool = self
            .conn
            .query_row(
                "SELECT EXISTS (SELECT 1 FROM outbox WHERE key = ?1)",
                [&key],
                |r| r.get(0),
            )
            .map_err(|e| self.sql(e))?;
        if known {
            return Ok(false);
        }
        let words = format!(
            "the nightly check {check_file} found the site drifted: {}",
            drift
                .iter()
                .map(|d| format!("{} was {:.3}, now {:.3}", d.what, d.was, d.now[0]))
                .collect::<Vec<_>>()
                .join("; ")
        );
        let mut b = body(&plan, Rule::CalibrationDrift, key, words);
        b.drift = Some(body::Drift {
            check_file: check_file.to_string(),
            drifted: drift,
        });
        let tx = rusqlite::Transaction::new_unchecked(
            &self.conn,
            rusqlite::TransactionBehavior::Immediate,
        )
        .map_err(|e| self.sql(e))?;
        let new = self.insert_alarm(&plan, &b, None)?;
        tx.commit().map_err(|e| self.sql(e))?;
        Ok(new > 0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_rule_reads_back_by_its_name() {
        for r in Rule::ALL {
            assert_eq!(Rule::parse(r.as_str()), Some(r));
            let json = serde_json::to_string(&r).unwrap();
            assert_eq!(json, format!("\"{}\"", r.as_str()));
        }
        assert_eq!(Rule::parse("urgently"), None);
    }

    #[test]
    fn keys_differ_by_every_part() {
        let a = key_of(&["p", "leading", "urgent"]);
        assert_eq!(a.len(), 64);
        assert_ne!(a, key_of(&["p", "trailing", "urgent"]));
        assert_ne!(a, key_of(&["p", "leading", "class-rose"]));
        assert_ne!(key_of(&["ab", "c"]), key_of(&["a", "bc"]));
    }
}
