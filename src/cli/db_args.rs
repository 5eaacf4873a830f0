//! `--db`, the same for every command that stores passes (`identify`, `train`, `watch`).

use anyhow::Result;
use clap::Args;
use std::path::PathBuf;
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
}

impl DbArgs {
    /// The database opened (refused, by name, before any work when it is not one); none
    /// without `--db`.
    pub(super) fn open(&self) -> Result<Option<Db>> {
        Ok(self
            .db
            .as_deref()
            .map(wheelflat::pass::store::open_db)
            .transpose()?)
    }
}
