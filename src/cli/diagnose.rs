//! `wheelflat diagnose`: name a model gap, add the effect, identify again.

use super::args::DiagnoseArgs;
use super::open_measured;
use super::progress::Progress;
use anyhow::{Context, Result};
use wheelflat::identify::Extras;
use wheelflat::report::tables::diagnosis_text;

/// Identifies, diagnoses (with progress for the local bank), writes the report and prints
/// the verdict, the stages and the ranking.
pub(super) fn run(a: &DiagnoseArgs) -> Result<()> {
    let i = &a.input;
    let (identifier, m) = open_measured(i, true)?;
    // The fits re-simulate at the bank's speed: they see the pass on the bank's time axis.
    let speed = wheelflat::identify::result::SpeedUse {
        pass_km_per_h: m.speed_km_per_h,
        bank_km_per_h: identifier.bank().metadata().calibration.run.speed_km_per_h,
    };
    let (m, note) = wheelflat::diagnose::on_bank_speed(&m, speed.bank_km_per_h)?;
    println!("{}", wheelflat::report::tables::speed_line(&speed));
    if let Some(note) = &note {
        println!("{note}");
    }
    let sensors = i.sensors.as_deref();
    // The record as recorded: diagnosis asks whether the model explains it.
    let id = identifier.identify(&m, sensors, Extras::AS_RECORDED)?;
    let Some(sizing) = &id.sizing else {
        return no_flat(&identifier, &m, &id, &a.out);
    };
    eprintln!(
        "identified: {} of {} instances kept; diagnosing (fits by re-simulation, a minute at most)",
        sizing.cms.len(),
        id.bank_instances
    );
    let opts = wheelflat::diagnose::Options {
        local_instances: a.local_instances,
        local_bank_dir: (!a.no_local_bank).then(|| a.out.join("local-bank")),
        ..Default::default()
    };
    let progress = Progress::new().with_terminal();
    let d = wheelflat::diagnose::diagnose(&identifier, &m, sensors, &id, &opts, &progress)?;
    let times: Vec<(String, f64, f64)> = id
        .series
        .iter()
        .map(|s| (s.sensor.clone(), s.t0_s, s.sample_rate_hz))
        .collect();
    let files = wheelflat::report::diagnose::write_diagnosis_report(&d, &times, &a.out)?;
    print!("{}", diagnosis_text(&d));
    let named = d
        .naming
        .as_ref()
        .map(|n| n.named_effects())
        .unwrap_or_default();
    for e in &named {
        if let wheelflat::model::Effect::SpeedDeviation { fraction } = e {
            println!(
                "the record's speed: {:.1} km/h (the bank's {} km/h × {:.3}; its speed line: {})",
                speed.bank_km_per_h * (1.0 + fraction),
                speed.bank_km_per_h,
                1.0 + fraction,
                speed
                    .pass_km_per_h
                    .map_or("none".to_string(), |v| format!("{v} km/h"))
            );
        }
    }
    println!(
        "wrote {}, {} and {}{}",
        files.json.display(),
        files.html.display(),
        files.figure.display(),
        files
            .calibration
            .map_or(String::new(), |p| format!(", {}", p.display()))
    );
    Ok(())
}

/// A pass with no flat detected has no model gap to locate: what is said is where its
/// departure from the round wheel lives, wheel or rail (`diagnose::surface`), written to
/// `surface.json` in `out` and printed.
fn no_flat(
    identifier: &wheelflat::identify::Identifier,
    m: &wheelflat::identify::Measurement,
    id: &wheelflat::identify::Identification,
    out: &std::path::Path,
) -> Result<()> {
    let origin = wheelflat::diagnose::surface::origin(identifier, m, id)?;
    println!("no flat detected: there is no model gap to locate");
    let Some(origin) = origin else {
        println!("departure from the round wheel: no sensor window holds both wheels' passages");
        return Ok(());
    };
    println!("departure from the round wheel: {}", origin.words());
    std::fs::create_dir_all(out)
        .with_context(|| format!("creating the output folder {}", out.display()))?;
    let path = out.join("surface.json");
    wheelflat::atomic::write_atomically(&path, serde_json::to_string_pretty(&origin)?.as_bytes())
        .with_context(|| format!("writing {}", path.display()))?;
    println!("wrote {}", path.display());
    Ok(())
}
