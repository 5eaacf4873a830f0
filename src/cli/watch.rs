//! `wheelflat watch`: a resident identifier for a wayside system.
//!
//! The bank stays open (memory map, parameters, neighbour cells, threshold tables) and each
//! measurement that appears in the inbox costs only its own identification. The contract:
//! - **Only complete files.** A measurement is a regular `*.csv` file whose name does not
//!   start with a dot; writers write under another name (`.name.csv`, `name.csv.part`) and
//!   rename into place, so a file is never read half-written.
//! - **Train passes.** A recording `NAME.csv` with a trigger file `NAME.triggers.csv` beside
//!   it is a whole train (`wheelflat train`): the trigger file is placed first, the recording
//!   last, and the pair is identified when the recording appears. The result is
//!   `OUT/NAME/train.json` (with `train.csv` and `train.html`) and both files move together.
//! - **Exactly once.** After its pass the input is moved to `done/` or, with a
//!   `<name>.error.txt` saying why, to `failed/`; the result `OUT/<stem>/identification.json`
//!   is written atomically before the input moves. A crash between the two leaves the input in
//!   the inbox and the next start identifies it again (the result is replaced whole).
//! - **One bank per pass.** `CURRENT` is looked at before every measurement; a regenerated bank
//!   is opened between measurements, never during one. A bank that cannot be opened is logged
//!   and the open one kept.
//! - **Clean stop.** SIGTERM or SIGINT ends the loop after the measurement in progress.
//! - **Alarms** (`--alarms`, docs/alarms.md): raised in each pass's transaction, posted by a
//!   sender thread of their own (a receiver that hangs never holds a pass up); with `--once`
//!   the sender finishes its round, and one more is made, before the exit. A test hook,
//!   [`HOLD_ALARMS_ENV`], keeps every alarm in the outbox (the kill test's "between the
//!   commit and the send").
//! - **Metrics** (`--metrics ADDR`): `/metrics` from the results database, on a thread.

use super::args::WatchArgs;
use super::db_args::{outcome_line, Store};
use super::stamp;
use anyhow::{Context, Result};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};
use wheelflat::bank::family::Family;
use wheelflat::history::Db;
use wheelflat::identify::Members;

/// Test hook: when set (to anything), `watch` sends no alarm — they wait in the outbox — so a
/// test can kill it between a pass's commit and the send (docs/alarms.md, "Tests").
pub(super) const HOLD_ALARMS_ENV: &str = "WHEELFLAT_TEST_HOLD_ALARMS";

/// What marks a recording as a train pass: `NAME.csv` with `NAME` + this beside it.
const TRIGGERS_SUFFIX: &str = ".triggers.csv";
/// A train pass's consist (its bogies' ids), beside it like the triggers: `NAME` + this.
const CONSIST_SUFFIX: &str = ".consist.csv";

/// The open bank or family (members opened as passes need them) and what identifies its
/// version ([`Family::key`]).
struct Open {
    key: String,
    members: Members,
}

impl Open {
    /// Brings the member a pass is first compared with into memory (every page of its shards
    /// read once), so the first pass is as fast as the next: its log line. A family's other
    /// members come in with their first pass.
    fn warm(&mut self) -> String {
        let t = Instant::now();
        match self.members.any() {
            Ok(id) => {
                let bytes = id.bank().warm();
                format!(
                    "{} bank in memory: {} MB in {:.0} ms",
                    stamp(),
                    bytes >> 20,
                    t.elapsed().as_secs_f64() * 1e3
                )
            }
            Err(e) => format!("{} bank not brought into memory: {e}", stamp()),
        }
    }

    /// The version in words, for the log: the bank's version directory, or the family.
    fn name(&self) -> String {
        let f = self.members.family();
        match (f.band, f.loads) {
            (Some(band), Some(loads)) => format!("family {} ({band} × {loads})", f.dir.display()),
            (Some(band), None) => format!("family {} ({band})", f.dir.display()),
            (None, _) => f.members[0]
                .current
                .version
                .file_name()
                .unwrap_or_default()
                .to_string_lossy()
                .to_string(),
        }
    }
}

fn open(a: &WatchArgs) -> Result<Open> {
    let members = wheelflat::pass::input::open_members(&a.bank, a.calibration.as_deref())?;
    Ok(Open {
        key: members.family().key.clone(),
        members,
    })
}

/// Measurements waiting in the inbox, oldest name first.
fn waiting(inbox: &Path) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for entry in
        std::fs::read_dir(inbox).with_context(|| format!("cannot list {}", inbox.display()))?
    {
        let entry = entry.with_context(|| format!("cannot list {}", inbox.display()))?;
        let name = entry.file_name().to_string_lossy().to_string();
        let is_file = entry.file_type().map(|t| t.is_file()).unwrap_or(false);
        if is_file
            && !name.starts_with('.')
            && name.ends_with(".csv")
            && !name.ends_with(TRIGGERS_SUFFIX)
            && !name.ends_with(CONSIST_SUFFIX)
        {
            out.push(entry.path());
        }
    }
    out.sort();
    Ok(out)
}

/// Identifies one measurement (or, with `triggers`, one train pass) and writes its result;
/// the verdict line.
fn identify_one(
    open: &mut Open,
    path: &Path,
    beside: &Beside,
    a: &WatchArgs,
    out: &Path,
    db: Option<&mut Db>,
) -> Result<String> {
    if let Some(triggers) = &beside.triggers {
        let pass = wheelflat::pass::train::identify_train(
            &mut open.members,
            path,
            triggers,
            beside.consist.as_deref(),
            a.refine.settings(),
        )?;
        wheelflat::pass::train::write_train(&pass.result, out)?;
        // Stored before the inputs move: a crash between the two stores nothing twice.
        if let Some(db) = db {
            wheelflat::pass::train::store_train(
                db,
                &open.members,
                &pass,
                &[path, triggers],
                Some(out),
            )?;
        }
        let result = &pass.result;
        let flats: Vec<String> = result
            .wheels
            .iter()
            .filter(|w| w.flat != wheelflat::identify::FlatVerdict::No)
            .map(|w| format!("bogie {} {} {}", w.bogie, w.wheel.name(), w.severity))
            .collect();
        return Ok(format!(
            "train of {} bogies: {}",
            result.bogies.len(),
            if flats.is_empty() {
                "no flat".to_string()
            } else {
                flats.join(", ")
            }
        ));
    }
    let refine = a.refine.settings();
    let request = wheelflat::pass::single::Request {
        sensors: a.sensors.as_deref(),
        extras: wheelflat::identify::Extras::NONE,
        refine,
        out,
    };
    let pass = wheelflat::pass::single::identify_file(&mut open.members, path, request, db)?;
    let (id, m) = (&pass.id, &pass.measurement);
    let refined = id
        .refinement
        .as_ref()
        .and_then(|r| r.ranges.as_ref())
        .map(|r| format!(" Refined: L0 in [{:.0}, {:.0}] mm.", r.l0_mm[0], r.l0_mm[1]))
        .unwrap_or_default();
    // The load read and the bank's, a wheel: `34.8 kN (bank 34.8 kN)`.
    let load = id
        .load
        .as_ref()
        .map(|l| {
            format!(
                ", {:.1} kN a wheel (bank {:.1} kN)",
                l.wheel_load_kn, l.bank_wheel_load_kn
            )
        })
        .unwrap_or_default();
    let severity = id
        .refinement
        .as_ref()
        .and_then(|r| r.severity)
        .or(id.severity)
        .map(|c| format!(" Severity: {}.", c.words()))
        .unwrap_or_default();
    let bogie = m
        .bogie_id
        .as_deref()
        .map(|b| format!(" bogie {b},"))
        .unwrap_or_default();
    Ok(format!(
        "{bogie} {} km/h against the {} km/h bank{load}: {}{refined}{severity}",
        m.speed_km_per_h.unwrap_or(f64::NAN),
        id.speed.bank_km_per_h,
        id.summary
    )
    .trim_start()
    .to_string())
}

/// The files a recording brings beside it: a train pass's triggers and consist.
struct Beside {
    triggers: Option<PathBuf>,
    consist: Option<PathBuf>,
}

impl Beside {
    fn of(path: &Path, stem: &str) -> Beside {
        let near = |suffix: &str| {
            let p = path.with_file_name(format!("{stem}{suffix}"));
            p.is_file().then_some(p)
        };
        let triggers = near(TRIGGERS_SUFFIX);
        Beside {
            consist: triggers.as_ref().and_then(|_| near(CONSIST_SUFFIX)),
            triggers,
        }
    }

    fn files(&self) -> impl Iterator<Item = &PathBuf> {
        self.triggers.iter().chain(self.consist.iter())
    }
}

/// Moves `path` into `dir` (same file system: a rename).
fn move_into(path: &Path, dir: &Path) -> Result<PathBuf> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let to = dir.join(path.file_name().expect("a listed file has a name"));
    std::fs::rename(path, &to)
        .with_context(|| format!("cannot move {} to {}", path.display(), to.display()))?;
    Ok(to)
}

/// Runs the loop until a signal (or, with `--once`, until the inbox is empty).
pub(super) fn run(a: &WatchArgs) -> Result<()> {
    let stop = Arc::new(AtomicBool::new(false));
    for sig in [signal_hook::consts::SIGTERM, signal_hook::consts::SIGINT] {
        signal_hook::flag::register(sig, Arc::clone(&stop))
            .context("cannot install the signal handlers")?;
    }
    for dir in [&a.inbox, &a.out] {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    let (done, failed) = (a.inbox.join("done"), a.inbox.join("failed"));
    // The results database and the alarms' configuration, opened once (refused before any
    // pass when either is wrong).
    let Store { mut db, sender } = a.store.open(a.calibration.as_deref())?;
    if let (Some(addr), Some(path)) = (a.metrics, &a.store.db) {
        let cal = super::load_calibration(a.calibration.as_deref())?;
        let settings = wheelflat::serve::Settings::new(
            path.clone(),
            Some(a.bank.clone()),
            &cal.identification,
            None,
        );
        let bound = wheelflat::serve::run_metrics(settings, addr)?;
        println!("{} metrics at http://{bound}/metrics", stamp());
    }
    let hold = std::env::var_os(HOLD_ALARMS_ENV).is_some();
    let alarms_on = sender.is_some();
    let sender = sender.map(Arc::new).filter(|_| !hold);
    let sender_stop = Arc::new(AtomicBool::new(false));
    let sending = match (&sender, &a.store.db) {
        (Some(s), Some(path)) => {
            let (s, path, stop) = (Arc::clone(s), path.clone(), Arc::clone(&sender_stop));
            let thread = std::thread::Builder::new()
                .name("alarms".into())
                .spawn(move || {
                    s.run(
                        &path,
                        &stop,
                        |o| println!("{} {}", stamp(), outcome_line(o)),
                        |e| println!("{} alarms: {e}", stamp()),
                    )
                });
            Some(thread.context("cannot start the alarms' sender")?)
        }
        _ => None,
    };
    let ship_stop = Arc::new(AtomicBool::new(false));
    let fleet = a.fleet.target()?;
    if fleet.is_some() && a.store.db.is_none() {
        anyhow::bail!("--fleet ships the results database: give --db too");
    }
    let shipping = match (&fleet, &a.store.db) {
        (Some(target), Some(path)) if !a.once => {
            let (mut shipper, path, stop) = (
                wheelflat::fleet::Shipper::new(target.clone()),
                path.clone(),
                Arc::clone(&ship_stop),
            );
            println!(
                "{} shipping to {} every {} s",
                stamp(),
                target.shown(),
                super::ship::DEFAULT_EVERY_S
            );
            let thread = std::thread::Builder::new()
                .name("ship".into())
                .spawn(move || {
                    super::ship::follow(
                        &mut shipper,
                        &path,
                        wheelflat::fleet::ship::DEFAULT_BATCH,
                        Duration::from_secs(super::ship::DEFAULT_EVERY_S),
                        &stop,
                        |l| println!("{} {l}", stamp()),
                    )
                });
            Some(thread.context("cannot start the shipper")?)
        }
        _ => None,
    };
    let mut current = open(a)?;
    println!(
        "{} watching {} with bank {} (poll {} ms)",
        stamp(),
        a.inbox.display(),
        current.name(),
        a.poll_ms
    );
    println!("{}", current.warm());
    let mut seen = 0usize;
    while !stop.load(Ordering::Relaxed) {
        if let (true, Some(db)) = (alarms_on, db.as_mut()) {
            match wheelflat::alarm::drift::raise_if_drifted(db, &a.bank) {
                Ok(true) => println!("{} alarm raised: the nightly check found drift", stamp()),
                Ok(false) => {}
                Err(e) => println!("{} cannot raise the drift alarm: {e}", stamp()),
            }
        }
        let files = waiting(&a.inbox)?;
        if files.is_empty() {
            if a.once {
                break;
            }
            std::thread::sleep(Duration::from_millis(a.poll_ms));
        }
        for path in files {
            if stop.load(Ordering::Relaxed) {
                break;
            }
            // Between measurements: follow a regenerated bank.
            match Family::current_key(&a.bank) {
                Ok(k) if k != current.key => match open(a) {
                    Ok(mut o) => {
                        println!("{} bank switched to {}", stamp(), o.name());
                        println!("{}", o.warm());
                        current = o;
                    }
                    Err(e) => println!(
                        "{} cannot open the new bank {} ({e:#}); keeping {}",
                        stamp(),
                        a.bank.display(),
                        current.name()
                    ),
                },
                Ok(_) => {}
                Err(e) => println!("{} cannot read the bank pointer: {e:#}", stamp()),
            }
            let name = path
                .file_name()
                .expect("listed")
                .to_string_lossy()
                .to_string();
            let stem = name.trim_end_matches(".csv").to_string();
            let beside = Beside::of(&path, &stem);
            let t = Instant::now();
            let result = identify_one(
                &mut current,
                &path,
                &beside,
                a,
                &a.out.join(&stem),
                db.as_mut(),
            );
            let ms = t.elapsed().as_secs_f64() * 1e3;
            seen += 1;
            match result {
                Ok(verdict) => {
                    for t in beside.files() {
                        move_into(t, &done)?;
                    }
                    move_into(&path, &done)?;
                    println!(
                        "{} {name} ok {ms:.1} ms [{}] {verdict}",
                        stamp(),
                        current.name()
                    );
                }
                Err(e) => {
                    // The reason first, then the input: a failed/ file always has its reason.
                    std::fs::create_dir_all(&failed)
                        .with_context(|| format!("cannot create {}", failed.display()))?;
                    let note = failed.join(format!("{name}.error.txt"));
                    super::write_file(&note, format!("{e:#}\n").as_bytes())?;
                    for t in beside.files() {
                        move_into(t, &failed)?;
                    }
                    move_into(&path, &failed)?;
                    if let Some(db) = db.as_mut() {
                        super::history::store_failure(db, &path, &e);
                    }
                    println!("{} {name} FAILED {ms:.1} ms: {e:#}", stamp());
                }
            }
        }
    }
    // `--once`: the sender's round finished, then one more (a SIGTERM leaves what is unsent
    // in the outbox for the next start: nothing is lost, and the stop is not held up).
    if a.once {
        sender_stop.store(true, Ordering::Relaxed);
        if let Some(thread) = sending {
            let _ = thread.join();
        }
        if !hold {
            Store {
                db,
                sender: sender.and_then(Arc::into_inner),
            }
            .send_once(|| format!("{} ", stamp()))?;
        }
    }
    ship_stop.store(true, Ordering::Relaxed);
    if let Some(thread) = shipping {
        let _ = thread.join();
    }
    // `--once`: one shipping round at the end; an unreachable store is said, not an error
    // (the passes are in the site's database for the next round).
    if let (true, Some(target), Some(path)) = (a.once, fleet, &a.store.db) {
        let mut shipper = wheelflat::fleet::Shipper::new(target);
        let t = std::time::Instant::now();
        match super::ship::round(&mut shipper, path, wheelflat::fleet::ship::DEFAULT_BATCH) {
            Ok((site, s)) => println!(
                "{} {}",
                stamp(),
                super::ship::shipped_line(&site, &s, t.elapsed())
            ),
            Err(e) => println!(
                "{} cannot ship: {e}; the site keeps its passes for the next round",
                stamp()
            ),
        }
    }
    println!("{} stopping after {seen} measurements", stamp());
    Ok(())
}
