//! `wheelflat train`: every wheel of a whole train pass, as a table.

use anyhow::Result;
use clap::Args;
use std::path::PathBuf;
use wheelflat::history::Db;
use wheelflat::pass::train::{self as train_pass, Stored, TrainPass};

// `train`.
#[derive(Debug, Args)]
pub(super) struct TrainArgs {
    /// Bank directory (of the site profile, the default: both wheels, X_p over a revolution).
    #[arg(long, default_value = "bank")]
    pub bank: PathBuf,
    /// The recording: CSV `time_s,<sensor>_kn,…` over the whole train pass.
    #[arg(long)]
    pub recording: PathBuf,
    /// Trigger times, one per wheel passing the laser (`time_s` column).
    #[arg(long)]
    pub triggers: PathBuf,
    /// Report folder: `train.csv`, `train.json`, `train.html`.
    #[arg(long)]
    pub out: PathBuf,
    #[command(flatten)]
    pub refine: super::refine_args::RefineArgs,
    /// The consist: a CSV `bogie_id` with one id per bogie in running order, naming the
    /// wheels (`<bogie_id>/leading`, `…/trailing`) in the table and the results database.
    #[arg(long)]
    pub consist: Option<PathBuf>,
    #[command(flatten)]
    pub store: super::db_args::DbArgs,
}

/// Reads the recording and triggers, identifies every bogie, writes `train.csv`, `.json` and
/// `.html` and prints the table.
pub(super) fn run(a: &TrainArgs) -> Result<()> {
    let mut store = a.store.open(None)?;
    let result = train_pass_of(a, store.db.as_mut());
    if let (Err(e), Some(db)) = (&result, store.db.as_mut()) {
        super::history::store_failure(db, &a.recording, e);
    }
    // The alarms this pass raised, sent now; those that fail wait in the outbox.
    if let Err(e) = store.send_once(String::new) {
        eprintln!("warning: {e:#}");
    }
    result
}

/// [`run`] once the results database (when asked for) is open.
fn train_pass_of(a: &TrainArgs, db: Option<&mut Db>) -> Result<()> {
    let mut members = super::open_members(&a.bank, None)?;
    let pass = train_pass::identify_train(
        &mut members,
        &a.recording,
        &a.triggers,
        a.consist.as_deref(),
        a.refine.settings(),
    )?;
    if let Some(db) = db {
        let stored = train_pass::store_train(
            db,
            &members,
            &pass,
            &[&a.recording, &a.triggers],
            Some(&a.out),
        )?;
        println!("{}", stored_line(db, &pass, stored));
    }
    let result = &pass.result;
    let written = train_pass::write_train(result, &a.out)?;
    print!("{}", wheelflat::report::train::table_text(result));
    let flats = result
        .wheels
        .iter()
        .filter(|w| w.flat == wheelflat::identify::FlatVerdict::Yes)
        .count();
    println!(
        "{} bogies, {} wheels: {flats} with a flat; identified in {:.0} ms ({:.0} ms per bogie)",
        result.bogies.len(),
        result.wheels.len(),
        result.total_ms,
        result.total_ms / result.bogies.len().max(1) as f64
    );
    println!("{}", wheelflat::report::train::speeds_line(result));
    println!("{}", wheelflat::report::train::loads_line(result));
    println!("severity rule: {}", result.severity_rule);
    for w in &result.warnings {
        println!("warning: {w}");
    }
    println!(
        "wrote {}, {} and {}",
        written[0].display(),
        written[1].display(),
        written[2].display()
    );
    Ok(())
}

/// The line saying how many of a train's bogie passes were stored.
fn stored_line(db: &Db, pass: &TrainPass, stored: Stored) -> String {
    format!(
        "stored {} new bogie passes of {} in {} ({} named by the consist)",
        stored.new,
        pass.result.bogies.len(),
        db.path().display(),
        stored.named
    )
}
