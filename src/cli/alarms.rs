//! `wheelflat alarms`: the outbox of a results database listed — what waits, what failed and
//! is retried, what was sent — and, with `--send`, one delivery round first.

use super::db_args::outcome_line;
use anyhow::{bail, Result};
use clap::Args;
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;
use wheelflat::alarm::{AlarmConfig, Sender};
use wheelflat::history::{AlarmStatus, Db};

// `alarms`.
#[derive(Debug, Args)]
pub(super) struct AlarmsArgs {
    /// The results database `identify`, `train` and `watch` wrote with `--db`.
    #[arg(long)]
    pub db: PathBuf,
    /// Only the alarms of this status.
    #[arg(long, value_enum)]
    pub status: Option<StatusArg>,
    /// The newest N (1–100000).
    #[arg(long, default_value_t = 50, value_parser = clap::value_parser!(u64).range(1..=100_000))]
    pub last: u64,
    /// Deliver what is due first (one round, in order per destination), with the webhooks
    /// and secrets of `--alarms`.
    #[arg(long, requires = "alarms")]
    pub send: bool,
    /// The alarms' configuration (`alarms.toml`), for `--send`.
    #[arg(long)]
    pub alarms: Option<PathBuf>,
}

/// An outbox status on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(super) enum StatusArg {
    /// Not tried yet.
    Pending,
    /// Tried and failed; tried again later.
    Failed,
    /// Delivered (a 2xx answered it).
    Sent,
}

/// `wheelflat alarms`.
pub(super) fn run(a: &AlarmsArgs) -> Result<()> {
    let db = Db::open_existing(&a.db)?;
    if a.send {
        let Some(path) = &a.alarms else {
            bail!("--send needs --alarms FILE (the webhooks and their secrets)");
        };
        let sender = Sender::new(AlarmConfig::read(path)?);
        let round = sender.round(&db, &AtomicBool::new(false), |o| {
            println!("{}", outcome_line(o))
        })?;
        println!(
            "sent {}, failed {}, {} destination(s) waiting (not due, or not in {})",
            round.sent,
            round.failed,
            round.waiting,
            path.display()
        );
    }
    let status = a.status.map(|s| match s {
        StatusArg::Pending => AlarmStatus::Pending,
        StatusArg::Failed => AlarmStatus::Failed,
        StatusArg::Sent => AlarmStatus::Sent,
    });
    let c = db.alarm_counts()?;
    println!(
        "{}: {} pending, {} failed (retried), {} sent",
        a.db.display(),
        c.pending,
        c.failed,
        c.sent
    );
    for r in db.alarms(status, a.last as usize)? {
        let when = match (r.status, &r.sent) {
            (AlarmStatus::Sent, Some(t)) => format!("sent {t}"),
            (AlarmStatus::Failed, _) => format!("next try {}", r.next_attempt),
            _ => "not tried".to_string(),
        };
        println!(
            "{:>6} {} {:<8} {:<17} {:<24} to {} ({} tries, {when}){}",
            r.id,
            r.created,
            r.status.as_str(),
            r.rule.as_str(),
            r.wheel_id.as_deref().unwrap_or("-"),
            r.destination,
            r.attempts,
            r.last_error
                .as_deref()
                .map(|e| format!(": {e}"))
                .unwrap_or_default()
        );
    }
    Ok(())
}
