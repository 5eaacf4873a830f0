//! The diagnosis acceptance suite (issue #5), all cases: measurements with one effect hidden,
//! clean ones and one outside the library, identified on a bank built without effects, then
//! diagnosed. Prints the score table (effect × case → named? gap before/after) and writes
//! `suite.json`.
//!
//! `cargo run --release --example diagnose_suite -- BANK_DIR OUT_DIR [FILTER] [LOCAL_INSTANCES]`
//! BANK_DIR is built with the narrow (CI-sized) profile, 2,000 instances, when missing.

use std::path::PathBuf;
use wheelflat::bank::{self, Bank, GenerateOptions, Quiet, StorageFormat};
use wheelflat::diagnose::suite;
use wheelflat::identify::Identifier;
use wheelflat::model::Calibration;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let bank_dir = PathBuf::from(args.first().map_or("suite-bank", String::as_str));
    let out = PathBuf::from(args.get(1).map_or("suite-out", String::as_str));
    let filter = args.get(2).cloned().unwrap_or_default();
    let local: usize = args.get(3).map_or(Ok(1000), |s| s.parse())?;
    let cal = Calibration::narrow_profile().check()?;
    if !bank_dir.exists() {
        let opts = GenerateOptions {
            instances: 2000,
            seed: 0,
            shard_size: 1000,
            machine_shard: None,
            format: StorageFormat::default(),
            simulate_missing: true,
        };
        bank::generate(&cal, &bank_dir, &opts, &Quiet)?;
    }
    let identifier = Identifier::new(Bank::open(&bank_dir)?, cal.identification.clone())?;
    std::fs::create_dir_all(&out)?;
    let mut outcomes = Vec::new();
    for (i, case) in suite::cases().iter().enumerate() {
        if !case.name.contains(&filter) {
            continue;
        }
        let (o, d) = match suite::run_case(
            &identifier,
            &cal,
            case,
            &out.join(format!("local-{i}")),
            local,
        ) {
            Ok(r) => r,
            Err(e) => {
                println!("{:<42} ERROR {e}", case.name);
                continue;
            }
        };
        println!(
            "{:<42} {:<5} gap {:.3} → {} kN  outside {} → {}  ({:.0} s, {} sims)\n    {}",
            o.case,
            if o.pass { "PASS" } else { "FAIL" },
            o.gap_before_kn,
            o.gap_after_kn.map_or("—".into(), |g| format!("{g:.3}")),
            o.outside_before,
            o.outside_after.map_or("—".into(), |g| g.to_string()),
            o.seconds,
            o.simulations,
            o.verdict
        );
        if let Some(n) = &d.naming {
            for c in n.ranking.iter().take(4) {
                println!(
                    "      {:<20} {:<34} BIC {:>12.1} χ² {:>12.1} outside {:>4} joint {}",
                    c.kind, c.location, c.bic, c.chi2, c.samples_outside, c.joint
                );
            }
            println!(
                "      {:<20} {:<34} BIC {:>12.1} χ² {:>12.1} outside {:>4}",
                "none", "", n.no_effect.bic, n.no_effect.chi2, n.no_effect.samples_outside
            );
        }
        outcomes.push(o);
    }
    std::fs::write(
        out.join("suite.json"),
        serde_json::to_string_pretty(&outcomes)?,
    )?;
    println!("\n| case | hidden | named | pass | gap before (kN) | gap after (kN) | ratio | outside before → after |");
    println!("|---|---|---|---|---|---|---|---|");
    for o in &outcomes {
        let named = o
            .named
            .as_ref()
            .map_or("—".to_string(), |e| format!("{e:?}"));
        let ratio = match o.gap_after_kn {
            Some(a) if a > 0.0 => format!("{:.1}×", o.gap_before_kn / a),
            Some(_) => "∞".into(),
            None => "—".into(),
        };
        println!(
            "| {} | {} | {} | {} | {:.3} | {} | {} | {} → {} |",
            o.case,
            match &o.hidden {
                suite::Hidden::Clean => "nothing".into(),
                suite::Hidden::Effect(_) => "library".to_string(),
                suite::Hidden::NotInLibrary(s) => s.clone(),
            },
            named,
            if o.pass { "yes" } else { "NO" },
            o.gap_before_kn,
            o.gap_after_kn.map_or("—".into(), |g| format!("{g:.3}")),
            ratio,
            o.outside_before,
            o.outside_after.map_or("—".into(), |g| g.to_string())
        );
    }
    let hidden: Vec<_> = outcomes
        .iter()
        .filter(|o| matches!(o.hidden, suite::Hidden::Effect(_)))
        .collect();
    let right = hidden.iter().filter(|o| o.pass).count();
    println!(
        "\nnamed right: {right} of {}; clean/out-of-library passed: {} of {}",
        hidden.len(),
        outcomes
            .iter()
            .filter(|o| !matches!(o.hidden, suite::Hidden::Effect(_)) && o.pass)
            .count(),
        outcomes.len() - hidden.len()
    );
    Ok(())
}
