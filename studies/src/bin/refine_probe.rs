//! One pass refined with chosen settings, its rounds printed (issue 63's variants):
//! `cargo run --release -p wheelflat-studies --bin refine_probe -- BANK MEASURED.csv`
//! with `STRATEGY=bounds|spread`, `KAPPA=…`, `SIMS=…`, `PER_ROUND=…`, `TOL=…` in the
//! environment (the product's defaults otherwise).
use std::path::Path;
use wheelflat::identify::refine::{bank_simulator, refine, RefineSettings, RefineStrategy};
use wheelflat::identify::{Extras, Members};

fn env<T: std::str::FromStr>(name: &str) -> Option<T> {
    std::env::var(name).ok().and_then(|v| v.parse().ok())
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    anyhow::ensure!(args.len() >= 3, "usage: refine_probe BANK MEASURED.csv");
    let mut members = Members::open(Path::new(&args[1]), None)?;
    let (m, k) =
        wheelflat::pass::input::read_measurement(&mut members, Path::new(&args[2]), None, false)?;
    let identifier = members.get(k);
    let id = identifier.identify(&m, None, Extras::NONE)?;
    println!("{}", id.summary);
    let d = RefineSettings::default();
    let settings = RefineSettings {
        strategy: match std::env::var("STRATEGY").as_deref() {
            Ok("spread") => RefineStrategy::Spread,
            _ => RefineStrategy::Bounds,
        },
        kappa: env("KAPPA"),
        simulations: env("SIMS").unwrap_or(d.simulations),
        per_round: env("PER_ROUND").unwrap_or(d.per_round),
        tolerance_mm: env("TOL").unwrap_or(d.tolerance_mm),
        ..d
    };
    let sim = bank_simulator(identifier)?;
    let r = refine(identifier, &sim, &id, settings)?;
    for (i, x) in r.rounds.iter().enumerate() {
        let l0 = x.ranges.as_ref().map(|r| r.l0_mm);
        let dd = x.ranges.as_ref().map(|r| r.depth_mm);
        println!(
            "round {i}: simulated {} survivors {} L0 {:?} d {:?}",
            x.simulated, x.survivors, l0, dd
        );
    }
    println!("{}", r.summary);
    println!("kept (no cell) L0 {:?}", r.kept_l0_mm);
    Ok(())
}
