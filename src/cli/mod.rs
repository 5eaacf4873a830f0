//! The `wheelflat` command line: a thin layer that parses arguments, reads and writes files,
//! calls the library and prints what the report layer words. Errors carry context naming the
//! file and value (anyhow).
//!
//! - [`args`]: the clap grammar of every command and the parsers of compound arguments.
//! - [`progress`]: the progress bar or log lines of long jobs.
//! - one file per command or group: [`calibration`], [`simulate`], [`bank`] (generate,
//!   merge, info, verify, audit), [`synth`], [`identify`] (identify, report, compare),
//!   [`watch`], [`train`], [`audit`], [`diagnose`], [`demo`].

mod args;
mod audit;
mod bank;
mod calibration;
mod demo;
mod diagnose;
mod family;
mod flat_args;
mod history;
mod identify;
mod progress;
mod simulate;
mod synth;
mod train;
mod watch;

use crate::bank::family::Family;
use crate::bank::Bank;
use crate::identify::family::Members;
use crate::identify::{Identifier, Measurement};
use crate::model::{Calibration, CheckedCalibration};
use anyhow::{Context, Result};
use args::{BankCommand, Cli, Command};
use clap::Parser;
use std::path::Path;
use std::process::ExitCode;

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
            noise_from,
            bank,
        } => match bank {
            Some(bank) if !noise_from.is_empty() => {
                calibration::site_noise(out.as_deref(), &bank, &noise_from)
            }
            _ => calibration::run(out.as_deref(), profile, converged),
        },
        Command::Simulate(args) => simulate::run(&args),
        Command::Bank { command } => match command {
            BankCommand::Generate(a) => bank::generate(&a, true),
            BankCommand::Merge(a) => bank::generate(&a, false),
            BankCommand::Info { dir } => bank::info(&dir),
            BankCommand::Verify { dir } => bank::verify(&dir),
            BankCommand::Prune { dir, keep } => bank::prune(&dir, keep as usize),
            BankCommand::Audit {
                dir,
                sample,
                calibration,
            } => bank::audit(&dir, sample, calibration.as_deref()),
        },
        Command::Synth(a) => synth::run(&a),
        Command::Identify(a) => identify::identify(&a),
        Command::Report { from, out } => identify::report_from_json(&from, out.as_deref()),
        Command::Watch(a) => watch::run(&a),
        Command::Compare(a) => identify::compare(&a),
        Command::Audit(a) => audit::run(&a),
        Command::Diagnose(a) => diagnose::run(&a),
        Command::Train(a) => train::run(&a),
        Command::History(a) => history::run(&a),
        Command::Demo {
            out,
            bank,
            instances,
        } => demo::run(&out, &bank, instances),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// Size limits of the files wheelflat reads (bytes): a 5-sensor, 10 s measurement at 2.5 kHz
/// is about 2 MB, a whole train's recording a few times that, a calibration a few kB.
pub(crate) const MAX_MEASUREMENT_BYTES: u64 = 64 << 20;
/// A trigger file: one line per wheel.
pub(crate) const MAX_TRIGGER_BYTES: u64 = 1 << 20;
/// A calibration file, a truth file.
pub(crate) const MAX_SMALL_FILE_BYTES: u64 = 1 << 20;
/// An identification.json (its series and candidate model set).
pub(crate) const MAX_JSON_BYTES: u64 = 256 << 20;

/// Reads a text file that must be a regular file of at most `limit` bytes: a device, a pipe or
/// a directory (`/dev/zero` would read forever) and an oversized file are refused, naming the
/// file, before anything is read.
pub(crate) fn read_text(path: &Path, limit: u64, what: &str) -> Result<String> {
    let meta = std::fs::metadata(path)
        .with_context(|| format!("cannot read {what} {}", path.display()))?;
    if !meta.is_file() {
        anyhow::bail!(
            "{what} {} is not a regular file (a device, pipe or directory cannot be read as one)",
            path.display()
        );
    }
    if meta.len() > limit {
        anyhow::bail!(
            "{what} {}: {} bytes, more than the {limit} a {what} may have",
            path.display(),
            meta.len()
        );
    }
    let mut text = String::new();
    use std::io::Read as _;
    std::fs::File::open(path)
        .and_then(|f| f.take(limit + 1).read_to_string(&mut text))
        .with_context(|| format!("cannot read {what} {}", path.display()))?;
    if text.len() as u64 > limit {
        anyhow::bail!(
            "{what} {} grew past {limit} bytes while it was read",
            path.display()
        );
    }
    Ok(text)
}

/// Reads and checks a calibration file, or returns the built-in defaults.
pub fn load_calibration(path: Option<&Path>) -> Result<CheckedCalibration> {
    let Some(path) = path else {
        return Ok(Calibration::default().check()?);
    };
    let text = read_text(path, MAX_SMALL_FILE_BYTES, "calibration file")?;
    let doc = Calibration::from_toml_str(&text)
        .with_context(|| format!("in calibration file {}", path.display()))?;
    doc.check()
        .with_context(|| format!("in calibration file {}", path.display()))
}

/// Writes a file through [`crate::atomic::write_atomically`], naming it in the error (the
/// library's I/O error alone does not say which file).
fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    crate::atomic::write_atomically(path, bytes)
        .with_context(|| format!("cannot write {}", path.display()))
}

/// Creates an output folder (and its parents), naming it in the error.
fn create_output_folder(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir)
        .with_context(|| format!("cannot create output folder {}", dir.display()))
}

/// Opens the bank a measurement is compared with and reads the measurement: for a family, the
/// member at the pass's speed (the CSV's `# speed_km_per_h` line, or `speed` when it has
/// none; never assumed). The settings and uncertainty table come from `calibration` when
/// given, else from the bank.
fn open_identifier(
    bank_dir: &Path,
    measured: &Path,
    calibration: Option<&Path>,
    speed: Option<f64>,
) -> Result<(Identifier, Measurement)> {
    open_identifier_with(bank_dir, measured, calibration, speed, false)
}

/// [`open_identifier`]; with `nearest` (diagnosis), a stated speed beyond every member's band
/// opens the nearest member instead of refusing (the diagnosis then lets the record say its
/// speed).
fn open_identifier_with(
    bank_dir: &Path,
    measured: &Path,
    calibration: Option<&Path>,
    speed: Option<f64>,
    nearest: bool,
) -> Result<(Identifier, Measurement)> {
    let mut members = open_members(bank_dir, calibration)?;
    let (m, k) = read_measurement(&mut members, measured, speed, nearest)?;
    Ok((members.take(k), m))
}

/// Opens a bank or bank family for identification, with the settings of `calibration` when
/// given.
fn open_members(bank_dir: &Path, calibration: Option<&Path>) -> Result<Members> {
    let settings = match calibration {
        Some(p) => Some(load_calibration(Some(p))?.identification.clone()),
        None => None,
    };
    Members::open(bank_dir, settings)
        .with_context(|| format!("cannot open bank {}", bank_dir.display()))
}

/// Reads a measurement on the family's sample rate, with its speed stated (its line or
/// `speed`); the member its speed picks, opened (a speed outside the band names the file).
fn read_measurement(
    members: &mut Members,
    path: &Path,
    speed: Option<f64>,
    nearest: bool,
) -> Result<(Measurement, usize)> {
    let text = read_text(path, MAX_MEASUREMENT_BYTES, "measurement")?;
    let mut m = Measurement::from_csv(path, &text, members.family().sample_rate_hz)?;
    let v = m.pass_speed(speed)?;
    m.speed_km_per_h = Some(v);
    // Its speed, then the load its record shows, pick the member.
    let k = members
        .member_for_pass(&m, None, nearest)
        .with_context(|| format!("measurement {}", path.display()))?;
    Ok((m, k))
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
