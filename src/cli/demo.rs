//! `wheelflat demo`: the main job on built-in defaults, step by step, through the same
//! functions as the commands (typed arguments, nothing parsed twice).

use super::args::GenerateArgs;
use super::{
    bank, create_output_folder, identify, load_calibration, open_identifier, simulate, write_file,
};
use anyhow::Result;
use std::path::Path;
use wheelflat::identify::refine::RefineSettings;
use wheelflat::identify::{synth, Extras};
use wheelflat::model::{Flat, Record, Simulator};
use wheelflat::report::response::{flat_title, response_csv, response_summary};

/// The demo's field case: a flat between the bank's instances, errors seeded.
const DEMO_FLAT: (f64, f64, f64, f64, u64) = (62.0, 0.55, 0.05, 12.156, 3);

/// Simulates a good and a flat wheel, builds (or reuses) the bank, makes a synthetic field
/// measurement and identifies it, writing everything into `out`.
pub(super) fn run(out: &Path, bank_dir: &Path, instances: usize) -> Result<()> {
    create_output_folder(out)?;
    let cal = load_calibration(None)?;
    let sim = Simulator::new(&cal)?;
    println!(
        "wheelflat demo: built-in calibration (docs/model.md defaults), outputs in {}",
        out.display()
    );
    println!("\n1. Simulate");
    for (name, flat) in [
        ("good-wheel", None),
        ("flat-60mm", Some(Flat::from_mm(60.0, 0.5, 0.1, 12.4)?)),
    ] {
        let resp = sim.run(flat.as_ref(), Record { contact: true })?;
        let csv = out.join(format!("{name}.csv"));
        let png = out.join(format!("{name}.png"));
        write_file(&csv, response_csv(&cal, &resp).as_bytes())?;
        simulate::draw(&cal, &resp, &flat_title(flat.as_ref()), &png)?;
        println!("\n{}", flat_title(flat.as_ref()));
        print!("{}", response_summary(&cal, &resp));
        println!("wrote {} and {}", csv.display(), png.display());
    }

    println!(
        "\n2. Bank ({instances} instances in {})",
        bank_dir.display()
    );
    bank::generate(
        &GenerateArgs::defaults(bank_dir.to_path_buf(), instances),
        true,
    )?;

    let (l, d, c, xp, seed) = DEMO_FLAT;
    let flat = Flat::from_mm(l, d, c, xp)?;
    println!("\n3. Synthetic field measurement");
    let syn = synth::synthesize(&cal, &flat, seed, true)?;
    let measured = out.join("measurement.csv");
    let truth_path = out.join("measurement.truth.json");
    super::synth::write_measurement(&syn, &measured, &truth_path)?;
    println!(
        "{} (L0 {:.1} mm), errors drawn inside the uncertainty table with seed {seed}: wrote {} and {}",
        flat_title(Some(&flat)),
        syn.truth.l0_mm,
        measured.display(),
        truth_path.display()
    );

    println!("\n4. Identify");
    let (identifier, m) = open_identifier(bank_dir, &measured, None, None, false)?;
    let mut id = identifier.identify(
        &m,
        None,
        Extras {
            baselines: true,
            curves: true,
            as_recorded: false,
        },
    )?;
    // The refined answer beside the bank-only one (`identify --refine`).
    wheelflat::pass::single::refine_into(&identifier, &mut id, RefineSettings::default())?;
    identify::report(&id, &out.join("identification"), Some(&syn.truth))
}
