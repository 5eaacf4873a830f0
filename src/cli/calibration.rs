//! `wheelflat calibration`: the built-in calibration of a profile as TOML.

use super::args::Profile;
use super::write_file;
use anyhow::{Context, Result};
use std::path::{Path, PathBuf};
use wheelflat::diagnose::noise::{self, NoiseAboveTable};
use wheelflat::model::Calibration;

/// Prints the profile's calibration (at the converged reference's mesh and step with
/// `converged`; with converged landings around the sensors with `landings`), or writes it
/// to `out`.
pub(super) fn run(
    out: Option<&Path>,
    profile: Profile,
    converged: bool,
    landings: bool,
) -> Result<()> {
    let cal = match profile {
        Profile::Paper => Calibration::paper_profile(),
        Profile::Site => Calibration::default(),
        Profile::Narrow => Calibration::narrow_profile(),
    };
    let text = if converged {
        cal.converged_reference()
    } else if landings {
        cal.with_converged_landings()
    } else {
        cal
    }
    .to_operator_toml_string();
    emit(out, &text)
}

/// Writes `text` to `out`, or prints it.
fn emit(out: Option<&Path>, text: &str) -> Result<()> {
    match out {
        Some(p) => write_file(p, text.as_bytes()),
        None => {
            print!("{text}");
            Ok(())
        }
    }
}

/// `wheelflat calibration --noise-from PASS… --bank BANK`: the bank's calibration with the
/// uncertainty table's noise entry widened to the noise measured from the passes, when it is
/// above the table (never narrowed).
pub(super) fn site_noise(out: Option<&Path>, bank: &Path, passes: &[PathBuf]) -> Result<()> {
    let mut members = super::open_members(bank, None)?;
    let mut residuals: Vec<Vec<f64>> = Vec::new();
    let mut base = None;
    for pass in passes {
        let (m, k) = super::read_measurement(&mut members, pass, None, false)?;
        let id = members.get(k);
        residuals.extend(
            noise::pass_residuals(id, &m)
                .with_context(|| format!("measuring the noise of {}", pass.display()))?,
        );
        base.get_or_insert_with(|| id.bank().metadata().calibration.clone());
    }
    let keep: Vec<Vec<bool>> = residuals.iter().map(|r| vec![true; r.len()]).collect();
    let (sigma, rho, samples) = noise::estimate(&residuals, &keep).with_context(|| {
        format!(
            "too few samples to measure the noise from {} pass(es): at least {} flat-free samples are needed",
            passes.len(),
            noise::MIN_SAMPLES
        )
    })?;
    let mut cal = base.context("no pass read")?;
    let table = &mut cal.identification.uncertainty;
    let finding = NoiseAboveTable::of(sigma, rho, table);
    let header = match &finding {
        Some(f) => {
            f.apply(table);
            format!(
                "# Site noise measured from {} pass(es), {samples} samples: sigma {sigma:.3} kN, lag-1 rho {rho:.2}\n# above the table's {:.3} kN: \"{}\" widened from [{:.2}, {:.2}] to [{:.2}, {:.2}] kN.\n",
                passes.len(), f.sigma_table_kn, f.entry, f.bounds_kn[0], f.bounds_kn[1], f.suggested_kn[0], f.suggested_kn[1]
            )
        }
        None => format!(
            "# Site noise measured from {} pass(es), {samples} samples: sigma {sigma:.3} kN, lag-1 rho {rho:.2}\n# within the table (above it from {:.2} x the table's sigma): the table is kept.\n",
            passes.len(),
            noise::ABOVE_TABLE
        ),
    };
    eprint!("{}", header.replace("# ", ""));
    emit(out, &format!("{header}{}", cal.to_operator_toml_string()))
}
