//! `wheelflat identify` and `wheelflat compare`: one measurement against a bank.

use super::args::{CompareArgs, IdentifyArgs};
use super::open_measured;
use anyhow::{Context, Result};
use std::path::Path;
use wheelflat::identify::synth::Truth;
use wheelflat::identify::{Extras, Identification};
use wheelflat::pass::input::{open_members, read_measurement};
use wheelflat::pass::single::{identify_in, Request};
use wheelflat::report::tables::{comparison_table, identification_text};

/// Identifies; writes `identification.json` and prints the verdict before anything else, then
/// with `--report` the figures and the HTML report.
pub(super) fn identify(a: &IdentifyArgs) -> Result<()> {
    // A database (or alarms configuration) that cannot be opened is refused before any work.
    let mut store = a.store.open(a.input.calibration.as_deref())?;
    let result = identify_pass(a, store.db.as_mut());
    if let (Err(e), Some(db)) = (&result, store.db.as_mut()) {
        super::history::store_failure(db, &a.input.measured, e);
    }
    // The alarms this pass raised, sent now; those that fail wait in the outbox.
    if let Err(e) = store.send_once(String::new) {
        eprintln!("warning: {e:#}");
    }
    result
}

/// [`identify`] once the results database (when asked for) is open.
fn identify_pass(a: &IdentifyArgs, db: Option<&mut wheelflat::history::Db>) -> Result<()> {
    let i = &a.input;
    let mut members = open_members(&i.bank, i.calibration.as_deref())?;
    let (m, k) = read_measurement(&mut members, &i.measured, i.speed, false)?;
    let extras = if a.report {
        Extras {
            baselines: !a.no_baselines,
            curves: !a.no_baselines,
            as_recorded: false,
        }
    } else {
        Extras::NONE
    };
    let request = Request {
        sensors: i.sensors.as_deref(),
        extras,
        refine: a.refine.settings(),
        out: &a.out,
    };
    let path = a.store.db.as_deref();
    let pass = identify_in(&mut members, k, m, &i.measured, request, db)?;
    if let (Some(new), Some(path)) = (pass.stored, path) {
        let bogie = pass.measurement.bogie_id.as_deref();
        println!("{}", super::history::stored_line(path, bogie, new));
    }
    if a.report {
        return report(&pass.id, &a.out, None);
    }
    print!("{}", identification_text(&pass.id));
    println!(
        "wrote {}; figures and report.html: wheelflat report --from {}",
        pass.json.display(),
        pass.json.display()
    );
    Ok(())
}

/// `wheelflat report`: the figures and HTML of an identification JSON.
pub(super) fn report_from_json(from: &Path, out: Option<&Path>) -> Result<()> {
    let text = super::read_text(from, super::MAX_JSON_BYTES, "identification")?;
    let id: Identification = serde_json::from_str(&text).with_context(|| {
        format!(
            "{} is not an identification.json written by wheelflat identify or watch",
            from.display()
        )
    })?;
    let dir = match out {
        Some(d) => d.to_path_buf(),
        None => from
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."))
            .to_path_buf(),
    };
    let (figures, html) = wheelflat::report::identify::write_figures_and_html(&id, &dir)
        .with_context(|| format!("cannot write the report in {}", dir.display()))?;
    println!("wrote {} ({} figures)", html.display(), figures.len());
    Ok(())
}

/// Writes an identification's report into `dir` and prints its summary and comparison table.
pub(super) fn report(id: &Identification, dir: &Path, truth: Option<&Truth>) -> Result<()> {
    let files = wheelflat::report::identify::write_identification_report(id, dir)
        .with_context(|| format!("cannot write the report in {}", dir.display()))?;
    print!("{}", identification_text(id));
    print!("{}", comparison_table(id, truth));
    println!(
        "wrote {} and {} ({} figures)",
        files.json.display(),
        files.html.display(),
        files.figures.len()
    );
    Ok(())
}

/// Identifies with the baselines and prints the comparison table (against the truth when
/// given).
pub(super) fn compare(a: &CompareArgs) -> Result<()> {
    let i = &a.input;
    let (identifier, m) = open_measured(i, false)?;
    let truth = match &a.truth {
        Some(p) => {
            let text = super::read_text(p, super::MAX_SMALL_FILE_BYTES, "truth file")?;
            Some(
                serde_json::from_str::<Truth>(&text)
                    .with_context(|| format!("in truth file {}", p.display()))?,
            )
        }
        None => None,
    };
    let id = identifier.identify(
        &m,
        i.sensors.as_deref(),
        Extras {
            baselines: true,
            curves: false,
            as_recorded: false,
        },
    )?;
    print!("{}", comparison_table(&id, truth.as_ref()));
    Ok(())
}
