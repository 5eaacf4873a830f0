//! `wheelflat ship` and `watch --fleet`: a site's results database sent on to the fleet store
//! (docs/fleet.md, "Shipping"), once or following it; an unreachable store is said once and
//! tried again, the site's SQLite keeping everything meanwhile.

use super::fleet::FleetArgs;
use anyhow::Result;
use clap::Args;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};
use wheelflat::fleet::{FleetError, Shipped, Shipper};
use wheelflat::history::Db;

/// How often `--follow` and `watch --fleet` ship (s) by default.
pub(super) const DEFAULT_EVERY_S: u64 = 5;
/// The longest wait between tries while the store is unreachable (s).
const MAX_BACKOFF_S: u64 = 60;

// `ship`.
#[derive(Debug, Args)]
pub(super) struct ShipArgs {
    /// The site's results database (`watch --db`), read only.
    #[arg(long)]
    pub db: PathBuf,
    #[command(flatten)]
    pub fleet: FleetArgs,
    /// Rows a transaction (1–5000).
    #[arg(long, default_value_t = wheelflat::fleet::ship::DEFAULT_BATCH as u64,
          value_parser = clap::value_parser!(u64).range(1..=5000))]
    pub batch: u64,
    /// Keep shipping what the site stores, every --every seconds, until SIGTERM or SIGINT
    /// (the systemd unit beside `watch`).
    #[arg(long)]
    pub follow: bool,
    /// With --follow: seconds between rounds (1–3600).
    #[arg(long, default_value_t = DEFAULT_EVERY_S, value_parser = clap::value_parser!(u64).range(1..=3600))]
    pub every: u64,
}

/// A round's outcome in words.
pub(super) fn shipped_line(site: &str, s: &Shipped, took: Duration) -> String {
    format!(
        "shipped {} passes ({} already there), {} refusals, {} alarms as site {site} in {} batches, {:.2} s ({:.0} passes/s); {} still at the site",
        s.passes,
        s.passes_known,
        s.failures,
        s.alarms,
        s.batches,
        took.as_secs_f64(),
        (s.passes + s.passes_known) as f64 / took.as_secs_f64().max(1e-9),
        s.pending
    )
}

/// One round: the site database opened read-only, everything the store lacks sent (also
/// `watch --once --fleet`'s last step).
pub(super) fn round(
    shipper: &mut Shipper,
    db: &Path,
    batch: usize,
) -> Result<(String, Shipped), FleetError> {
    let site = shipper.connect()?;
    let db = Db::open_read_only(db)?;
    let s = shipper.round(&db, batch, |_| {})?;
    Ok((site, s))
}

/// Ships until `stop`: a round every `every`, a line when something was shipped, the first
/// error of an outage said once (another error while it lasts said as "still not shipping";
/// tries again, backing off to a minute), the recovery said.
pub(super) fn follow(
    shipper: &mut Shipper,
    db: &Path,
    batch: usize,
    every: Duration,
    stop: &AtomicBool,
    log: impl Fn(String),
) {
    let mut failing: Option<String> = None;
    let mut wait = every;
    while !stop.load(Ordering::Relaxed) {
        let t = Instant::now();
        match round(shipper, db, batch) {
            Ok((site, s)) => {
                if failing.take().is_some() {
                    log(format!(
                        "fleet store {} reached again",
                        shipper.target().shown()
                    ));
                }
                if s.passes + s.passes_known + s.failures + s.alarms > 0 {
                    log(shipped_line(&site, &s, t.elapsed()));
                }
                wait = every;
            }
            Err(e) => {
                let msg = e.to_string();
                match &failing {
                    None => log(format!(
                        "cannot ship: {msg}; the site keeps its passes and tries again"
                    )),
                    Some(before) if *before != msg => log(format!("still not shipping: {msg}")),
                    Some(_) => {}
                }
                failing = Some(msg);
                wait = (wait * 2).min(Duration::from_secs(MAX_BACKOFF_S));
            }
        }
        let until = Instant::now() + wait;
        while Instant::now() < until && !stop.load(Ordering::Relaxed) {
            std::thread::sleep(Duration::from_millis(100));
        }
    }
}

/// `wheelflat ship`.
pub(super) fn run(a: &ShipArgs) -> Result<()> {
    let target = a.fleet.required()?;
    // The database checked before anything is sent (a file of another schema is refused by
    // name).
    drop(Db::open_read_only(&a.db)?);
    let mut shipper = Shipper::new(target);
    if a.follow {
        let stop = std::sync::Arc::new(AtomicBool::new(false));
        for sig in [signal_hook::consts::SIGTERM, signal_hook::consts::SIGINT] {
            signal_hook::flag::register(sig, std::sync::Arc::clone(&stop))?;
        }
        println!(
            "{} shipping {} to {} every {} s",
            super::stamp(),
            a.db.display(),
            shipper.target().shown(),
            a.every
        );
        follow(
            &mut shipper,
            &a.db,
            a.batch as usize,
            Duration::from_secs(a.every),
            &stop,
            |l| println!("{} {l}", super::stamp()),
        );
        println!("{} stopped", super::stamp());
        return Ok(());
    }
    let t = Instant::now();
    let (site, s) = round(&mut shipper, &a.db, a.batch as usize)?;
    println!("{}", shipped_line(&site, &s, t.elapsed()));
    Ok(())
}
