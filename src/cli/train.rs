//! `wheelflat train`: every wheel of a whole train pass, as a table.

use super::{create_output_folder, write_file};
use crate::identify::family::Members;
use crate::identify::{Identifier, Measurement};
use crate::train::TrainResult;
use anyhow::{Context, Result};
use clap::Args;
use std::path::{Path, PathBuf};

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
    /// Also refine every wheel with a flat (about 1.2 s a wheel on 2 cores); its severity is
    /// then taken from the refined L0 range (docs/train.md).
    #[arg(long)]
    pub refine: bool,
    /// Simulations of each wheel's refinement (1–20000).
    #[arg(long, default_value_t = 640, requires = "refine")]
    pub refine_simulations: usize,
    /// The consist: a CSV `bogie_id` with one id per bogie in running order, naming the
    /// wheels (`<bogie_id>/leading`, `…/trailing`) in the table and the results database.
    #[arg(long)]
    pub consist: Option<PathBuf>,
    /// Also store every bogie's pass in this results database (SQLite; made when absent).
    #[arg(long)]
    pub db: Option<PathBuf>,
}

/// Reads the recording and triggers, identifies every bogie, writes `train.csv`, `.json` and
/// `.html` and prints the table.
pub(super) fn run(a: &TrainArgs) -> Result<()> {
    let mut db = a.db.as_deref().map(super::history::open_db).transpose()?;
    let mut members = super::open_members(&a.bank, None)?;
    let refine = a.refine.then_some(crate::identify::refine::RefineSettings {
        simulations: a.refine_simulations,
        ..Default::default()
    });
    let (result, picked) = identify_pass(
        &mut members,
        &a.recording,
        &a.triggers,
        a.consist.as_deref(),
        refine,
    )?;
    if let Some(db) = &mut db {
        println!(
            "{}",
            store_pass(db, &members, &picked, &result, &[&a.recording, &a.triggers])?
        );
    }
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
    consist: Option<&Path>,
    refine: Option<crate::identify::refine::RefineSettings>,
) -> Result<(TrainResult, Vec<usize>)> {
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
    // The consist is checked before any bogie is identified.
    let ids = match consist {
        Some(p) => {
            let text = super::read_text(p, super::MAX_TRIGGER_BYTES, "consist file")?;
            Some(crate::history::consist::read_consist(
                p,
                &text,
                bogies.len(),
            )?)
        }
        None => None,
    };
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
    if let Some(ids) = ids {
        for (b, id) in ids.iter().enumerate() {
            result.bogies[b].bogie_id = Some(id.clone());
        }
        for w in &mut result.wheels {
            w.wheel_id = Some(format!("{}/{}", ids[w.bogie - 1], w.wheel.name()));
        }
    }
    Ok((result, picked))
}

/// Stores every bogie of a train pass in the results database (each bogie a pass, keyed by
/// the recording, its triggers and the bogie's place); the line saying so.
pub(super) fn store_pass(
    db: &mut crate::history::Db,
    members: &Members,
    picked: &[usize],
    result: &TrainResult,
    files: &[&Path],
) -> Result<String> {
    let time_s = crate::history::db::now_s();
    let (mut new, mut named) = (0, 0);
    for (b, bogie) in result.bogies.iter().enumerate() {
        let identifier = members.get(picked[b]);
        let meta = crate::history::PassMeta {
            key: super::history::pass_key(files, &format!("bogie {}", b + 1))?,
            time_s,
            measurement: format!("{} (bogie {})", result.recording, b + 1),
            bank_id: identifier.bank().metadata().bank_id.clone(),
            speed_km_per_h: Some(bogie.speed_km_per_h),
            bank_speed_km_per_h: bogie.bank_speed_km_per_h,
            load_kn: bogie.load.as_ref().map(|l| l.wheel_load_kn),
            bogie_id: bogie.bogie_id.clone(),
            summary: bogie
                .identification
                .as_ref()
                .map_or_else(|| "No flat detected.".to_string(), |id| id.summary.clone()),
        };
        let rec = crate::history::PassRecord::of_parts(
            meta,
            Some(&bogie.detection),
            bogie.identification.as_ref(),
            identifier,
        );
        new +=
            usize::from(db.insert(&rec).with_context(|| {
                format!("cannot store bogie {} of {}", b + 1, result.recording)
            })?);
        named += usize::from(bogie.bogie_id.is_some());
    }
    Ok(format!(
        "stored {new} new bogie passes of {} in {} ({named} named by the consist)",
        result.bogies.len(),
        db.path().display()
    ))
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
