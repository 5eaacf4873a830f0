//! Whole-train reliability study (issue #6): seeded synthetic 12-bogie trains with flats on
//! bogie 2 leading, bogie 7 trailing and bogie 11 leading, identified against a train-profile
//! bank: `cargo run --release -p wheelflat-studies --bin train_study -- BANK_DIR [SEEDS] [FIRST_SEED]`.
//! Prints per seed the wheels reported with a flat, and the totals: flats found on the right
//! wheel, truths inside the reported L0 range, false flats on good wheels, time per train;
//! `ENV_K=0`: without the envelope points. `REFINE=N`: every wheel with a flat refined with N
//! simulations (`train --refine`); then also the refined ranges' coverage, median widths and
//! severity against the bank-only ones.
use wheelflat_studies::study;

use std::path::Path;
use wheelflat::identify::{Identifier, Measurement};
use wheelflat::train::{self, TrainSpec};
use wheelflat_studies::coverage::severity_class;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let dir = args
        .get(1)
        .expect("usage: train_study BANK_DIR [SEEDS] [FIRST_SEED]");
    let seeds: u64 = args.get(2).map_or(20, |s| s.parse().expect("SEEDS"));
    let first: u64 = args.get(3).map_or(1, |s| s.parse().expect("FIRST_SEED"));
    let (bank, cal) = study::open_bank(dir);
    train::check_coverage(&bank, Path::new(dir)).expect("a bank that covers a train");
    let mut settings = cal.identification.clone();
    if let Ok(n) = std::env::var("MC_SAMPLES") {
        settings.monte_carlo_samples = n.parse().expect("MC_SAMPLES is a number");
    }
    if let Ok(n) = std::env::var("ENV_K") {
        settings.envelope_windows_per_sensor = n.parse().expect("ENV_K is a number");
    }
    let (insp, urg) = (settings.inspect_l0_mm, settings.urgent_l0_mm);
    let refine: Option<usize> = std::env::var("REFINE")
        .ok()
        .map(|n| n.parse().expect("REFINE"));
    // Per flat found on its wheel: true L0, its class, the bank-only range and class, the
    // refined range.
    type Found = (f64, usize, [f64; 2], usize, Option<[f64; 2]>);
    let mut wheels: Vec<Found> = Vec::new();
    let id = Identifier::new(bank, settings).expect("identifier");
    let flats = train::default_flats();
    let (mut found, mut inside, mut false_flats, mut exact, mut ms) = (0, 0, 0, 0, 0.0);
    for seed in first..first + seeds {
        let syn = train::synthesize_train(&cal, &TrainSpec::twelve_bogies(flats.clone(), seed))
            .expect("synthesize");
        let m = Measurement::from_csv(Path::new("train.csv"), &syn.csv, 2500.0).expect("csv");
        let times = train::read_triggers(Path::new("t.csv"), &syn.triggers_csv).expect("t");
        let bogies = train::bogies_from_triggers(&cal, Path::new("t.csv"), &times).expect("b");
        let ids = vec![&id; bogies.len()];
        let mut r = train::identify_bogies(&ids, &m, &bogies).expect("train");
        if let Some(n) = refine {
            let settings = wheelflat::identify::refine::RefineSettings {
                simulations: n,
                ..Default::default()
            };
            train::refine_wheels(&mut r, &ids, settings).expect("refine");
        }
        ms += r.total_ms;
        let (mut f, mut i, mut ff) = (0, 0, 0);
        let mut line = Vec::new();
        for w in &r.wheels {
            let truth = flats
                .iter()
                .find(|t| t.bogie == w.bogie && t.wheel == w.wheel);
            match (truth, w.flat.as_str()) {
                (Some(t), "yes") => {
                    f += 1;
                    let l0 = t.flat.fresh_length_m(cal.vehicle.wheel_radius_m) * 1e3;
                    let [lo, hi] = w.l0_mm.expect("a flat has a range");
                    if lo <= l0 && l0 <= hi {
                        i += 1;
                    }
                    let class = severity_class(l0, insp, urg);
                    let bank_class = severity_class(hi, insp, urg);
                    wheels.push((l0, class, [lo, hi], bank_class, w.refined_l0_mm));
                    line.push(format!("{}{:?}[{lo:.0},{hi:.0}]", w.bogie, w.wheel));
                }
                (None, "no") => {}
                (None, other) => {
                    ff += 1;
                    line.push(format!("FALSE {}{:?} ({other})", w.bogie, w.wheel));
                }
                (Some(_), other) => line.push(format!("MISSED {}{:?} ({other})", w.bogie, w.wheel)),
            }
        }
        if f == 3 && i == 3 && ff == 0 {
            exact += 1;
        }
        found += f;
        inside += i;
        false_flats += ff;
        println!("seed {seed:>3}: {:.0} ms  {}", r.total_ms, line.join("  "));
    }
    let n = seeds as f64;
    println!(
        "{seeds} trains: flats found on the right wheel {found}/{}, truth L0 inside the range {inside}/{found}, false flats on good wheels {false_flats}/{}, trains exactly right {exact}/{seeds}, mean {:.0} ms per train",
        3 * seeds,
        21 * seeds,
        ms / n
    );
    if refine.is_some() {
        let median = |mut v: Vec<f64>| {
            v.sort_by(f64::total_cmp);
            v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
        };
        let inside = |r: [f64; 2], x: f64| r[0] <= x && x <= r[1];
        let k = wheels.len().max(1) as f64;
        let refined: Vec<(f64, usize, [f64; 2])> = wheels
            .iter()
            .map(|w| (w.0, w.1, w.4.unwrap_or(w.2)))
            .collect();
        println!(
            "bank-only: L0 inside {:.3}, median width {:.1} mm, severity right {:.2}, under-called {}",
            wheels.iter().filter(|w| inside(w.2, w.0)).count() as f64 / k,
            median(wheels.iter().map(|w| w.2[1] - w.2[0]).collect()),
            wheels.iter().filter(|w| w.3 == w.1).count() as f64 / k,
            wheels.iter().filter(|w| w.3 < w.1).count()
        );
        println!(
            "refined: L0 inside {:.3}, median width {:.1} mm, severity right {:.2}, under-called {}",
            refined.iter().filter(|w| inside(w.2, w.0)).count() as f64 / k,
            median(refined.iter().map(|w| w.2[1] - w.2[0]).collect()),
            refined
                .iter()
                .filter(|w| severity_class(w.2[1], insp, urg) == w.1)
                .count() as f64
                / k,
            refined
                .iter()
                .filter(|w| severity_class(w.2[1], insp, urg) < w.1)
                .count()
        );
    }
}
