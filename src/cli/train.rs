//! `wheelflat train`: every wheel of a whole train pass, as a table.

use super::args::TrainArgs;
use super::{create_output_folder, write_file};
use crate::identify::family::Members;
use crate::identify::{Identifier, Measurement};
use crate::train::TrainResult;
use anyhow::{Context, Result};
use std::path::{Path, PathBuf};

/// Reads the recording and triggers, identifies every bogie, writes `train.csv`, `.json` and
/// `.html` and prints the table.
pub(super) fn run(a: &TrainArgs) -> Result<()> {
    let mut members = super::open_members(&a.bank, None)?;
    let refine = a.refine.then_some(crate::identify::refine::RefineSettings {
        simulations: a.refine_simulations,
        ..Default::default()
    });
    let result = identify_pass(&mut members, &a.recording, &a.triggers, refine)?;
    create_output_folder(&a.out)?;
    let written = write_outputs(&result, &a.out)?;
    print!("{}", crate::report::train::table_text(&result));
    let flats = result.wheels.iter().filter(|w| w.flat == "yes").count();
    println!(
        "{} bogies, {} wheels: {flats} with a flat; identified in {:.0} ms ({:.0} ms per bogie)",
        result.bogies.len(),
        result.wheels.len(),
        result.total_ms,
        result.total_ms / result.bogies.len().max(1) as f64
    );
    println!("{}", crate::report::train::speeds_line(&result));
    println!("{}", crate::report::train::loads_line(&result));
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

/// One train pass, a recording and its trigger file, against a bank or a bank family: each
/// bogie's speed (from its trigger pair) picks the member it is compared with, which must
/// cover a train ([`crate::train::check_coverage`]). With `refine`, every wheel with a flat
/// is refined ([`crate::train::refine_wheels`]).
pub(super) fn identify_pass(
    members: &mut Members,
    recording: &Path,
    triggers: &Path,
    refine: Option<crate::identify::refine::RefineSettings>,
) -> Result<TrainResult> {
    let rate = members.family().sample_rate_hz;
    let text = super::read_text(recording, super::MAX_MEASUREMENT_BYTES, "recording")?;
    let m = Measurement::from_csv(recording, &text, rate)?;
    let ttext = super::read_text(triggers, super::MAX_TRIGGER_BYTES, "trigger file")?;
    let times = crate::train::read_triggers(triggers, &ttext)?;
    let cal = members
        .any()?
        .bank()
        .metadata()
        .calibration
        .clone()
        .check()
        .context("the bank's stored calibration")?;
    let bogies = crate::train::bogies_from_triggers(&cal, triggers, &times)?;
    let mut picked = Vec::with_capacity(bogies.len());
    for (b, bogie) in bogies.iter().enumerate() {
        // The bogie's speed, then the load its part of the record shows, pick the member.
        let mut at_bogie = m.clone();
        at_bogie.laser_trigger_s = Some(bogie.triggers_s[0]);
        at_bogie.speed_km_per_h = Some(bogie.speed_km_per_h);
        let k = members
            .member_for_pass(&at_bogie, None, false)
            .with_context(|| {
                format!(
                    "{}: bogie {} (lines {} and {})",
                    triggers.display(),
                    b + 1,
                    2 * b + 2,
                    2 * b + 3
                )
            })?;
        if !picked.contains(&k) {
            crate::train::check_coverage(members.get(k).bank(), &members.family().members[k].dir)?;
        }
        picked.push(k);
    }
    let identifiers: Vec<&Identifier> = picked.iter().map(|&k| members.get(k)).collect();
    let mut result = crate::train::identify_train(&identifiers, &m, &bogies)?;
    if let Some(settings) = refine {
        crate::train::refine_wheels(&mut result, &identifiers, settings)?;
    }
    Ok(result)
}

/// Writes `train.csv`, `train.json` and `train.html` into `out` (each atomically); their
/// paths.
pub(super) fn write_outputs(result: &TrainResult, out: &Path) -> Result<[PathBuf; 3]> {
    let csv = out.join("train.csv");
    let json = out.join("train.json");
    let html = out.join("train.html");
    write_file(&csv, crate::report::train::table_csv(result).as_bytes())?;
    write_file(
        &json,
        serde_json::to_string_pretty(result)
            .expect("train result serialises")
            .as_bytes(),
    )?;
    write_file(&html, crate::report::train::table_html(result).as_bytes())?;
    Ok([csv, json, html])
}
