//! The `wheelflat` command line: a thin layer that parses arguments, reads and writes files,
//! calls the library and prints what the report layer words. Errors carry context naming the
//! file and value (anyhow).
//!
//! - [`args`]: the clap grammar of every command and the parsers of compound arguments.
//! - [`progress`]: the progress bar or log lines of long jobs.
//! - one file per command or group: [`calibration`], [`simulate`], [`bank`] (generate,
//!   merge, info, verify, audit), [`synth`], [`identify`] (identify, report, compare),
//!   [`watch`], [`train`], [`audit`], [`diagnose`], [`calibrate`], [`demo`], [`serve`],
//!   [`alarms`]; the fleet store: [`fleet`] (`--fleet` and the owner's commands), [`ship`],
//!   [`found`].

mod alarms;
mod args;
mod audit;
mod bank;
mod calibrate;
mod calibration;
mod db_args;
mod demo;
mod demo_site;
mod diagnose;
mod family;
mod flat_args;
mod fleet;
mod format_args;
mod found;
mod history;
mod identify;
mod progress;
mod refine_args;
mod serve;
mod ship;
mod simulate;
mod surface_args;
mod synth;
mod train;
mod value_parsers;
mod watch;

use anyhow::{Context, Result};
use args::{BankCommand, Cli, Command};
use clap::Parser;
use std::path::Path;
use std::process::ExitCode;
use wheelflat::bank::family::Family;
use wheelflat::bank::Bank;
use wheelflat::pass::input::{
    load_calibration, open_identifier, open_members, read_measurement, read_text, MAX_JSON_BYTES,
    MAX_SMALL_FILE_BYTES,
};

/// Entry point of the binary.
pub fn main() -> ExitCode {
    // Like other Unix tools, end quietly when the reader of our output goes away
    // (`wheelflat bank info bank | head`) instead of panicking on a broken pipe.
    #[cfg(unix)]
    // SAFETY: called first thing in main, before any other thread exists; resetting a signal
    // disposition to its default has no other effect on the process.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Calibration {
            out,
            profile,
            converged,
            landings,
            noise_from,
            bank,
        } => match bank {
            Some(bank) if !noise_from.is_empty() => {
                calibration::site_noise(out.as_deref(), &bank, &noise_from)
            }
            _ => calibration::run(out.as_deref(), profile, converged, landings),
        },
        Command::Simulate(args) => simulate::run(&args),
        Command::Bank { command } => match command {
            BankCommand::Generate(a) => bank::generate(&a, true),
            BankCommand::Merge(a) => bank::generate(&a, false),
            BankCommand::Info { dir } => family::info(&dir),
            BankCommand::Verify { dir } => family::verify(&dir),
            BankCommand::Prune { dir, keep } => family::prune(&dir, keep as usize),
            BankCommand::Audit {
                dir,
                sample,
                calibration,
            } => family::audit(&dir, sample, calibration.as_deref()),
        },
        Command::Synth(a) => synth::run(&a),
        Command::Identify(a) => identify::identify(&a),
        Command::Report { from, out } => identify::report_from_json(&from, out.as_deref()),
        Command::Watch(a) => watch::run(&a),
        Command::Compare(a) => identify::compare(&a),
        Command::Audit(a) => audit::run(&a),
        Command::Diagnose(a) => diagnose::run(&a),
        Command::Calibrate(a) => match calibrate::run(&a) {
            Ok(0) => Ok(()),
            Ok(code) => return ExitCode::from(code as u8),
            Err(e) => Err(e),
        },
        Command::Train(a) => train::run(&a),
        Command::History(a) => history::run(&a),
        Command::Alarms(a) => alarms::run(&a),
        Command::Serve(a) => serve::run(&a),
        Command::Ship(a) => ship::run(&a),
        Command::Found(a) => found::run(&a),
        Command::Fleet(a) => fleet::run(&a),
        Command::Demo {
            out,
            bank,
            instances,
            serve,
            listen,
            alarms,
        } => demo::run(&out, &bank, instances).and_then(|()| match serve {
            true => demo_site::run(&out, &bank, listen, alarms.as_deref()),
            false => Ok(()),
        }),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// The time of a log line: RFC 3339 in UTC with milliseconds, e.g.
/// `2026-11-26T15:40:12.345Z` (readable, sortable, and parsed by every log tool).
pub(super) fn stamp() -> String {
    chrono::Utc::now().to_rfc3339_opts(chrono::SecondsFormat::Millis, true)
}

/// Writes a file through [`wheelflat::atomic::write_atomically`], naming it in the error (the
/// library's I/O error alone does not say which file).
fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    wheelflat::atomic::write_atomically(path, bytes)
        .with_context(|| format!("cannot write {}", path.display()))
}

/// Creates an output folder (and its parents), naming it in the error.
fn create_output_folder(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir)
        .with_context(|| format!("cannot create output folder {}", dir.display()))
}

/// Opens the bank (or family member) a command's measurement is compared with, and reads the
/// measurement (`nearest`: the nearest member however far, for diagnosis).
fn open_measured(
    i: &args::MeasuredArgs,
    nearest: bool,
) -> Result<(
    wheelflat::identify::Identifier,
    wheelflat::identify::Measurement,
)> {
    Ok(open_identifier(
        &i.bank,
        &i.measured,
        i.calibration.as_deref(),
        i.speed,
        nearest,
    )?)
}

/// Opens a bank, or the member of a bank family at `speed` (which a family needs; for a
/// single bank it is checked against the bank's speed when given).
fn open_bank_at(bank_dir: &Path, speed: Option<f64>) -> Result<Bank> {
    let (family, single) = Family::open(bank_dir)
        .with_context(|| format!("cannot open bank {}", bank_dir.display()))?;
    let k = match speed {
        Some(v) => family.member_for(v)?,
        None if single.is_some() => 0,
        None => anyhow::bail!(
            "{} is a bank family ({}): say which member with --speed",
            bank_dir.display(),
            family.band.map(|b| b.to_string()).unwrap_or_default()
        ),
    };
    match single {
        Some(b) => Ok(b),
        None => family.members[k].open().with_context(|| {
            format!(
                "cannot open the {} km/h member of bank family {}",
                family.members[k].speed_km_per_h,
                bank_dir.display()
            )
        }),
    }
}
