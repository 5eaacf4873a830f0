//! Delivery: the outbox's unsent alarms posted to their webhooks, in row order per destination,
//! at least once.
//!
//! A round takes each destination's oldest unsent alarm; when it is due it is posted (JSON,
//! signed, with its `Idempotency-Key`), marked `sent` on a 2xx and the next one taken, or
//! marked `failed` with its next try `first_retry_s · 2^(tries−1)` later (at most
//! `max_retry_s`) and the destination left until then — nothing newer overtakes it. An alarm
//! is marked sent only after its 2xx: a sender stopped between the two (SIGKILL, a crash)
//! sends it again on its next round, with the same key.

use super::config::{AlarmConfig, Webhook};
use super::sign::{signature, SIGNATURE_HEADER};
use crate::history::{AlarmRow, Db, DbError, BODY_SCHEMA};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

/// How often a resident sender looks at the outbox for new alarms.
pub const POLL: Duration = Duration::from_millis(100);

/// What a try of one alarm gave.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// A 2xx answered it.
    Sent {
        /// The row.
        id: i64,
        /// The destination.
        destination: String,
        /// The rule.
        rule: &'static str,
        /// The wheel, when a named wheel's.
        wheel_id: Option<String>,
        /// The status code.
        status: u16,
    },
    /// It failed; tried again later.
    Failed {
        /// The row.
        id: i64,
        /// The destination.
        destination: String,
        /// Tries so far.
        attempts: u32,
        /// Why (the status code, or the connection's error; never the secret).
        error: String,
        /// Seconds to the next try.
        retry_in_s: f64,
    },
}

/// What a round did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Round {
    /// Alarms delivered.
    pub sent: usize,
    /// Tries that failed.
    pub failed: usize,
    /// Destinations whose next alarm is not due yet, or that the configuration no longer
    /// names.
    pub waiting: usize,
}

/// Posts alarms to the configured webhooks.
pub struct Sender {
    config: AlarmConfig,
    agent: ureq::Agent,
}

impl Sender {
    /// A sender for `config`'s webhooks (requests time out after its `delivery.timeout`).
    pub fn new(config: AlarmConfig) -> Sender {
        let agent = ureq::Agent::config_builder()
            .timeout_global(Some(config.delivery.timeout))
            .http_status_as_error(false)
            .max_redirects(0)
            .user_agent(format!("wheelflat/{}", env!("CARGO_PKG_VERSION")))
            .build()
            .into();
        Sender { config, agent }
    }

    /// The configuration.
    pub fn config(&self) -> &AlarmConfig {
        &self.config
    }

    /// Posts one alarm: the status code of the answer, or why there was none.
    // Err(String): the connection's error in words, stored with the row and logged.
    fn post(&self, hook: &Webhook, row: &AlarmRow) -> Result<u16, String> {
        let body = row.body.as_bytes();
        let answer = self
            .agent
            .post(&hook.url)
            .header("Content-Type", "application/json")
            .header("Idempotency-Key", &row.key)
            .header("X-Wheelflat-Schema", BODY_SCHEMA.to_string())
            .header(SIGNATURE_HEADER, signature(hook.secret.bytes(), body))
            .send(body)
            .map_err(|e| e.to_string())?;
        Ok(answer.status().as_u16())
    }

    /// One round over every destination with unsent alarms, each in row order, until one
    /// fails or is not yet due (or `stop` is set); `seen` is told each try's outcome.
    pub fn round(
        &self,
        db: &Db,
        stop: &AtomicBool,
        mut seen: impl FnMut(&Outcome),
    ) -> Result<Round, DbError> {
        let mut round = Round::default();
        for destination in db.alarm_destinations_unsent()? {
            let Some(hook) = self.config.webhooks.iter().find(|w| w.name == destination) else {
                round.waiting += 1;
                continue;
            };
            while !stop.load(Ordering::Relaxed) {
                let Some(row) = db.next_unsent_alarm(&destination)? else {
                    break;
                };
                let now = crate::history::db::now_s();
                if row.next_attempt_s > now {
                    round.waiting += 1;
                    break;
                }
                let tried = self.post(hook, &row);
                let now = crate::history::db::now_s();
                match tried {
                    Ok(status) if (200..300).contains(&status) => {
                        db.mark_alarm_sent(row.id, now)?;
                        round.sent += 1;
                        seen(&Outcome::Sent {
                            id: row.id,
                            destination: destination.clone(),
                            rule: row.rule.as_str(),
                            wheel_id: row.wheel_id.clone(),
                            status,
                        });
                    }
                    other => {
                        let error = match other {
                            Ok(status) => format!("answered {status}"),
                            Err(e) => e,
                        };
                        let attempts = row.attempts + 1;
                        let wait = self.config.delivery.backoff_s(attempts);
                        db.mark_alarm_failed(row.id, &error, now + wait)?;
                        round.failed += 1;
                        seen(&Outcome::Failed {
                            id: row.id,
                            destination: destination.clone(),
                            attempts,
                            error,
                            retry_in_s: wait,
                        });
                        break;
                    }
                }
            }
        }
        Ok(round)
    }

    /// Delivers until `stop` is set: a round, then a wait of [`POLL`] (new alarms are picked
    /// up within it). Opens its own connection to `db_path`; a database error is told to
    /// `failed` and the round tried again after the wait.
    pub fn run(
        &self,
        db_path: &Path,
        stop: &AtomicBool,
        mut seen: impl FnMut(&Outcome),
        mut failed: impl FnMut(&DbError),
    ) {
        let mut db = None;
        while !stop.load(Ordering::Relaxed) {
            if db.is_none() {
                match Db::open_existing(db_path) {
                    Ok(d) => db = Some(d),
                    Err(e) => failed(&e),
                }
            }
            if let Some(d) = &db {
                if let Err(e) = self.round(d, stop, &mut seen) {
                    failed(&e);
                    db = None;
                }
            }
            std::thread::sleep(POLL);
        }
    }
}
