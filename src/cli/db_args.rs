//! `--db` and `--alarms`, the same for every command that stores passes (`identify`, `train`,
//! `watch`): the results database opened, and the alarms it raises and sends.

use anyhow::{Context, Result};
use clap::Args;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use wheelflat::alarm::{AlarmConfig, Outcome, Sender};
use wheelflat::history::Db;

/// Where the passes go.
#[derive(Debug, Args)]
pub(super) struct DbArgs {
    /// Also store each pass in this results database (SQLite; made when absent): a wheel's
    /// history when the pass names its bogie (`# bogie_id = …`, or a train's consist:
    /// `--consist`, `NAME.consist.csv` beside a recording in `watch`'s inbox); a pass refused
    /// or failed is noted with its reason (docs/history.md).
    #[arg(long)]
    pub db: Option<PathBuf>,
    /// Raise alarms by the rules of this file (`alarms.toml`: urgent, class-rose, flat-grew,
    /// refusals, calibration-drift) into the database's outbox, in each pass's transaction,
    /// and post them to its webhooks (docs/alarms.md). Checked before any work.
    #[arg(long, requires = "db")]
    pub alarms: Option<PathBuf>,
}

/// The results database opened, with its alarms' sender when `--alarms` was given.
pub(super) struct Store {
    /// The database, when `--db` was given.
    pub db: Option<Db>,
    /// The webhooks' sender, when `--alarms` was given.
    pub sender: Option<Sender>,
}

impl DbArgs {
    /// The database opened and, with `--alarms`, the configuration read and checked and its
    /// rules set on the database (both refused, by name, before any work when wrong); the
    /// class limits the flat-grew rule fuses with come from `calibration` (the defaults
    /// without one).
    pub(super) fn open(&self, calibration: Option<&Path>) -> Result<Store> {
        let alarms = self.alarms.as_deref().map(AlarmConfig::read).transpose()?;
        let mut db = self
            .db
            .as_deref()
            .map(wheelflat::pass::store::open_db)
            .transpose()?;
        if let (Some(config), Some(db)) = (&alarms, db.as_mut()) {
            let cal = super::load_calibration(calibration)?;
            let rules = &cal.identification;
            db.raise_alarms(config.plan([rules.inspect_l0_mm, rules.urgent_l0_mm], rules.phi));
        }
        Ok(Store {
            db,
            sender: alarms.map(Sender::new),
        })
    }
}

impl Store {
    /// One delivery round on this thread (`identify`, `train`, `watch --once`, `alarms
    /// --send`): each alarm due is posted (each try's line after `stamp`), in order per destination; what failed stays in the
    /// outbox for the next round.
    pub(super) fn send_once(&self, stamp: impl Fn() -> String) -> Result<()> {
        let (Some(sender), Some(db)) = (&self.sender, &self.db) else {
            return Ok(());
        };
        sender
            .round(db, &AtomicBool::new(false), |o| {
                println!("{}{}", stamp(), outcome_line(o))
            })
            .with_context(|| format!("cannot read the outbox of {}", db.path().display()))?;
        Ok(())
    }
}

/// An alarm's try in words (the destination by name: a URL may carry a token).
pub(super) fn outcome_line(o: &Outcome) -> String {
    match o {
        Outcome::Sent {
            id,
            destination,
            rule,
            wheel_id,
            status,
        } => format!(
            "alarm {id} ({rule}{}) sent to {destination}: {status}",
            wheel_id
                .as_deref()
                .map(|w| format!(", {w}"))
                .unwrap_or_default()
        ),
        Outcome::Failed {
            id,
            destination,
            attempts,
            error,
            retry_in_s,
        } => format!(
            "alarm {id} not sent to {destination} (try {attempts}: {error}); kept, next try in {retry_in_s:.0} s"
        ),
    }
}
