//! `wheelflat train`: every wheel of a whole train pass, as a table.

use super::args::TrainArgs;
use super::{create_output_folder, write_file};
use crate::bank;
use crate::identify::{Identifier, Measurement};
use anyhow::{Context, Result};

/// Reads the recording and triggers, identifies every bogie, writes `train.csv`, `.json` and
/// `.html` and prints the table.
pub(super) fn run(a: &TrainArgs) -> Result<()> {
    let b = bank::Bank::open(&a.bank)
        .with_context(|| format!("cannot open bank {}", a.bank.display()))?;
    crate::train::check_coverage(&b, &a.bank)?;
    let cal = b
        .metadata()
        .calibration
        .clone()
        .check()
        .context("the bank's stored calibration")?;
    let rate = b.metadata().sensors[0].sample_rate_hz;
    let text = std::fs::read_to_string(&a.recording)
        .with_context(|| format!("cannot read recording {}", a.recording.display()))?;
    let recording = Measurement::from_csv(&a.recording, &text, rate)?;
    let ttext = std::fs::read_to_string(&a.triggers)
        .with_context(|| format!("cannot read triggers {}", a.triggers.display()))?;
    let times = crate::train::read_triggers(&a.triggers, &ttext)?;
    let bogies = crate::train::bogies_from_triggers(&cal, &a.triggers, &times)?;
    let identifier = Identifier::new(b, cal.identification.clone())?;
    let result = crate::train::identify_train(&identifier, &recording, &bogies)?;
    create_output_folder(&a.out)?;
    let csv = a.out.join("train.csv");
    let json = a.out.join("train.json");
    let html = a.out.join("train.html");
    write_file(&csv, crate::report::train::table_csv(&result).as_bytes())?;
    write_file(
        &json,
        serde_json::to_string_pretty(&result)
            .expect("train result serialises")
            .as_bytes(),
    )?;
    write_file(&html, crate::report::train::table_html(&result).as_bytes())?;
    print!("{}", crate::report::train::table_text(&result));
    let flats = result.wheels.iter().filter(|w| w.flat == "yes").count();
    println!(
        "{} bogies, {} wheels: {flats} with a flat; identified in {:.0} ms ({:.0} ms per bogie)",
        result.bogies.len(),
        result.wheels.len(),
        result.total_ms,
        result.total_ms / result.bogies.len().max(1) as f64
    );
    println!("severity rule: {}", result.severity_rule);
    for w in &result.warnings {
        println!("warning: {w}");
    }
    println!(
        "wrote {}, {} and {}",
        csv.display(),
        json.display(),
        html.display()
    );
    Ok(())
}
