//! `wheelflat synth`: a field-like measurement of one bogie or a whole train, with its truth.

use super::args::{parse_effect, parse_flat_on, SynthArgs};
use super::{load_calibration, write_file};
use anyhow::{Context, Result};
use std::path::Path;
use wheelflat::identify::synth::{synthesize_on, FieldNoise, PassSurfaces, Synthetic};
use wheelflat::model::CheckedCalibration;
use wheelflat::report::response::flat_title;
use wheelflat::train::{default_flats, synthesize_train, TrainSpec};

/// Adds the `--effect`s to the calibration, then synthesises one bogie or (`--train`) a
/// train, writing the measurement and its truth.
/// Writes a synthetic measurement's CSV and its truth JSON.
pub(super) fn write_measurement(syn: &Synthetic, csv: &Path, truth: &Path) -> Result<()> {
    write_file(csv, syn.csv.as_bytes())?;
    let json = serde_json::to_string_pretty(&syn.truth).expect("truth serialises");
    write_file(truth, json.as_bytes())
}

pub(super) fn run(a: &SynthArgs) -> Result<()> {
    let mut cal = load_calibration(a.calibration.as_deref())?;
    if !a.effects.is_empty() {
        let mut doc = cal.document().clone();
        for e in &a.effects {
            doc.effects.push(parse_effect(e)?);
        }
        cal = doc.check().context("the effects given with --effect")?;
    }
    let spec = a.surfaces.spec()?;
    if a.train {
        if a.noise_scale.to_bits() != 1.0f64.to_bits() || a.noise_ar1.to_bits() != 0.0f64.to_bits()
        {
            anyhow::bail!("--noise-scale and --noise-ar1 are for one bogie; a train recording (--train) carries the table's noise");
        }
        if !spec.wheel_traces.is_empty()
            || spec.rail_trace.is_some()
            || !spec.out_of_round.is_empty()
        {
            anyhow::bail!("--wheel-profile, --rail-profile and --out-of-round are for one bogie; a train (--train) takes --roughness (each bogie's wheels drawn anew) and --rail-roughness");
        }
        return train(a, &cal, spec);
    }
    // A good wheel (`--no-flat`) too: a rough tread, an out-of-round wheel, a measured profile.
    let flat = a.flat.flat()?;
    let noise = FieldNoise {
        scale: a.noise_scale,
        ar1: a.noise_ar1,
    };
    let surfaces = if spec.is_empty() {
        None
    } else {
        Some(PassSurfaces::of(&spec, &cal).context("the surfaces asked for")?)
    };
    let syn = synthesize_on(
        &cal,
        flat.as_ref(),
        surfaces.as_ref(),
        a.seed,
        !a.no_trigger,
        noise,
    )?;
    let truth_path = a
        .truth
        .clone()
        .unwrap_or_else(|| a.out.with_extension("truth.json"));
    write_measurement(&syn, &a.out, &truth_path)?;
    let what = match &flat {
        Some(f) => format!("{} (L0 {:.1} mm)", flat_title(Some(f)), syn.truth.l0_mm),
        None => "a good wheel".to_string(),
    };
    let on = syn
        .truth
        .surfaces
        .iter()
        .map(|n| {
            format!(
                " on {}: {} ({:.1} µm rms)",
                n.wheel.map_or("the rail", |w| w.name()),
                n.source,
                n.rms_um
            )
        })
        .collect::<String>();
    println!(
        "synthetic measurement of {what}{on}{}, seed {}: wrote {} and {}",
        if cal.effects.is_empty() {
            String::new()
        } else {
            format!(" with hidden effects {:?}", cal.effects)
        },
        a.seed,
        a.out.display(),
        truth_path.display()
    );
    Ok(())
}

/// `synth --train`: the recording, its trigger file and the truth.
fn train(
    a: &SynthArgs,
    cal: &CheckedCalibration,
    surfaces: wheelflat::model::surface::SurfaceSpec,
) -> Result<()> {
    let flats = if a.flat_on.is_empty() {
        // The default flats that fit a train of this length (a short train has fewer).
        default_flats()
            .into_iter()
            .filter(|f| f.bogie <= a.bogies)
            .collect()
    } else {
        a.flat_on
            .iter()
            .map(|t| parse_flat_on(t, a.bogies))
            .collect::<Result<Vec<_>>>()?
    };
    let mut spec = TrainSpec::twelve_bogies(flats, a.seed);
    spec.bogies = a.bogies;
    if !a.bogie_speeds.is_empty() && a.bogie_speeds.len() != a.bogies {
        anyhow::bail!(
            "--bogie-speeds gives {} speeds for {} bogies: one per bogie",
            a.bogie_speeds.len(),
            a.bogies
        );
    }
    if !a.bogie_loads.is_empty() && a.bogie_loads.len() != a.bogies {
        anyhow::bail!(
            "--bogie-loads gives {} loads for {} bogies: give one per bogie",
            a.bogie_loads.len(),
            a.bogies
        );
    }
    if let Some(f) = a
        .bogie_loads
        .iter()
        .find(|f| !(f.is_finite() && (0.05..=5.0).contains(*f)))
    {
        anyhow::bail!("--bogie-loads: {f} is not a car-body mass factor in [0.05, 5]");
    }
    spec.loads = a.bogie_loads.clone();
    spec.speeds_km_per_h = a.bogie_speeds.clone();
    spec.surfaces = (!surfaces.is_empty()).then_some(surfaces);
    let syn = synthesize_train(cal, &spec)?;
    let triggers = a.out.with_extension("triggers.csv");
    let truth = a
        .truth
        .clone()
        .unwrap_or_else(|| a.out.with_extension("truth.json"));
    write_file(&a.out, syn.csv.as_bytes())?;
    write_file(&triggers, syn.triggers_csv.as_bytes())?;
    let json = serde_json::to_string_pretty(&syn.truth).expect("truth serialises");
    write_file(&truth, json.as_bytes())?;
    println!(
        "synthetic train of {} bogies, flats on {}, seed {}: wrote {}, {} and {}",
        a.bogies,
        syn.truth
            .flats
            .iter()
            .map(|f| format!("bogie {} {} (L0 {:.1} mm)", f.0, f.1.name(), f.6))
            .collect::<Vec<_>>()
            .join(", "),
        a.seed,
        a.out.display(),
        triggers.display(),
        truth.display()
    );
    Ok(())
}
