//! Identifies one measurement from Rust, as `wheelflat identify` does without its reports:
//! opens a bank (memory-mapped, checked), reads a measurement CSV and prints what survives.
//! `cargo run --release --example identify_csv -- BANK MEASUREMENT.csv`
//!
//! With the demo's files (`cargo run --release -- demo` writes them):
//! `cargo run --release --example identify_csv -- $TMPDIR/wheelflat-demo/bank $TMPDIR/wheelflat-demo/measurement.csv`
use std::path::Path;
use std::process::ExitCode;
use wheelflat::bank::Bank;
use wheelflat::identify::{Extras, Identifier, Measurement};

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [bank, csv] = args.as_slice() else {
        eprintln!("usage: identify_csv BANK MEASUREMENT.csv");
        return ExitCode::from(2);
    };
    match run(Path::new(bank), Path::new(csv)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(bank: &Path, csv: &Path) -> Result<(), Box<dyn std::error::Error>> {
    // Opening checks the bank's manifest, schema and checksums before anything is read.
    let bank = Bank::open(bank)?;
    let cal = bank.metadata().calibration.clone();
    let text = std::fs::read_to_string(csv).map_err(|e| format!("{}: {e}", csv.display()))?;
    // Refused, naming file, line and value, when a row or a header is not what it should be.
    let m = Measurement::from_csv(csv, &text, cal.output.sample_rate_hz)?;
    let identifier = Identifier::new(bank, cal.identification.clone())?;
    // `None`: every sensor of the measurement the bank has; `Extras::NONE`: no baselines.
    let id = identifier.identify(&m, None, Extras::NONE)?;
    println!("{}", id.summary);
    if let Some(severity) = id.severity {
        println!("severity: {}", severity.words());
    }
    // `sizing`: present when a flat was detected and the bank searched.
    match &id.sizing {
        Some(z) => println!(
            "{} candidate models of {} survive; {} comparison points",
            z.cms.len(),
            id.bank_instances,
            z.eip.len() + z.envelope.len()
        ),
        None => println!("no flat detected: the pass was not sized"),
    }
    Ok(())
}
