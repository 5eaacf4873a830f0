//! The diagnosis acceptance suite (issue #5), all cases: measurements with one effect hidden,
//! clean ones and one outside the library, identified on a bank built without effects, then
//! diagnosed. Prints the score table (effect × case → named? gap before/after) and writes
//! `suite.json`.
//!
//! `cargo run --release -p wheelflat-studies --bin diagnose_suite -- BANK_DIR OUT_DIR [FILTER] [LOCAL_INSTANCES]`
//! BANK_DIR is built with the narrow (CI-sized) profile, 2,000 instances, when missing.
//! `NOISE=table` keeps the table's independent noise (no estimate from the record).
//! `… -- --summary OUT_DIR/suite.json` prints the acceptance figures of a finished run.

use std::path::PathBuf;
use wheelflat::bank::{self, Bank, GenerateOptions, Quiet, StorageFormat};
use wheelflat::identify::Identifier;
use wheelflat::model::Calibration;
use wheelflat_studies::suite;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("--summary") {
        let path = args.get(1).map_or("suite-out/suite.json", String::as_str);
        let outcomes: Vec<suite::Outcome> = serde_json::from_str(&std::fs::read_to_string(path)?)?;
        summary(&outcomes);
        return Ok(());
    }
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
            tables: false,
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
        let opts = wheelflat::diagnose::Options {
            local_instances: local,
            local_bank_dir: Some(out.join(format!("local-{i}"))),
            noise_from_data: std::env::var("NOISE").map_or(true, |v| v != "table"),
            ..Default::default()
        };
        let (o, d) = match suite::run_case_with(&identifier, &cal, case, &opts) {
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
        if let Some(e) = &d.noise {
            println!(
                "      noise: σ table {:.3} kN, estimated {:?} kN, ρ {:.3} ({} samples), used {:.3} kN; finer model: {}",
                e.sigma_table_kn, e.sigma_estimated_kn, e.rho, e.samples, e.sigma_used_kn, o.finer
            );
        }
        if let Some(n) = &d.naming {
            for c in n.ranking.iter().take(4) {
                let params: Vec<String> = c
                    .parameters
                    .iter()
                    .map(|p| format!("{} {:.4}", p.name, p.value))
                    .collect();
                println!(
                    "      {:<20} {:<34} BIC {:>12.1} χ² {:>12.1} outside {:>4} joint {} | {} | flat {:.1} {:.3} {:.3} {:.4}",
                    c.kind, c.location, c.bic, c.chi2, c.samples_outside, c.joint,
                    params.join(", "), c.flat[0], c.flat[1], c.flat[2], c.flat[3]
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
        let named = if o.named.is_empty() {
            "—".to_string()
        } else {
            o.named
                .iter()
                .map(|e| format!("{e:?}"))
                .collect::<Vec<_>>()
                .join(" + ")
        };
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
                suite::Hidden::Pair(..) => "two, library".to_string(),
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
    summary(&outcomes);
    Ok(())
}

/// Issue 15's acceptance figures over the cases run.
fn summary(outcomes: &[suite::Outcome]) {
    use suite::Hidden;
    let is_second = |o: &&suite::Outcome| o.second_flat_l0_mm.is_some();
    let singles: Vec<_> = outcomes
        .iter()
        .filter(|o| matches!(o.hidden, Hidden::Effect(_)))
        .filter(|o| !is_second(o))
        .collect();
    let seconds: Vec<_> = outcomes.iter().filter(is_second).collect();
    let pairs: Vec<_> = outcomes
        .iter()
        .filter(|o| matches!(o.hidden, Hidden::Pair(..)))
        .collect();
    let quiet: Vec<_> = outcomes
        .iter()
        .filter(|o| matches!(o.hidden, Hidden::Clean | Hidden::NotInLibrary(_)))
        .collect();
    let count = |v: &[&suite::Outcome]| v.iter().filter(|o| o.pass).count();
    let second_inside = seconds
        .iter()
        .filter(|o| {
            o.pass && matches!(o.second_flat_l0_mm, Some((t, Some([lo, hi]))) if lo <= t && t <= hi)
        })
        .count();
    let named: Vec<_> = outcomes.iter().filter(|o| !o.named.is_empty()).collect();
    let shrunk = named
        .iter()
        .filter(|o| o.gap_after_kn.is_some_and(|a| a * 3.0 <= o.gap_before_kn))
        .count();
    let mut seconds_taken: Vec<f64> = outcomes.iter().map(|o| o.seconds).collect();
    seconds_taken.sort_by(f64::total_cmp);
    println!(
        "\n{} cases ({} measured with the finer model)",
        outcomes.len(),
        outcomes.iter().filter(|o| o.finer).count()
    );
    println!(
        "single effects named right (kind, place within a sleeper or 0.2 m): {} of {}",
        count(&singles),
        singles.len()
    );
    println!(
        "second flats named, true L0 inside the reported range: {second_inside} of {}",
        seconds.len()
    );
    println!(
        "pairs with both named: {} of {}",
        count(&pairs),
        pairs.len()
    );
    println!(
        "clean and out-of-library with nothing named: {} of {} ({} with AR(1) noise)",
        count(&quiet),
        quiet.len(),
        quiet
            .iter()
            .filter(|o| o.noise.is_some_and(|n| n.rho > 0.0) && matches!(o.hidden, Hidden::Clean))
            .count()
    );
    println!(
        "gap after ≥ 3× smaller: {shrunk} of {} cases with an effect named",
        named.len()
    );
    if let (Some(first), Some(last)) = (seconds_taken.first(), seconds_taken.last()) {
        println!(
            "time per case: median {:.0} s, {first:.0}–{last:.0} s",
            seconds_taken[seconds_taken.len() / 2]
        );
    }
}
