//! Where a warm identifier's time goes, lap by lap: identifies each measurement CSV `runs`
//! times in one process and prints the median of every lap of `timings_ms`, for RPS1+RPS2
//! and for every sensor. `cargo bench --bench identify_laps -- BANK RUNS CSV...`
use std::path::Path;
use wheelflat::bank::Bank;
use wheelflat::identify::{Extras, Identifier, Measurement};

fn main() {
    let args: Vec<String> = std::env::args()
        .filter(|a| a != "--bench")
        .skip(1)
        .collect();
    let [bank, runs, csvs @ ..] = args.as_slice() else {
        // A probe, not a criterion bench: without its inputs (a plain `cargo bench`) it says so.
        eprintln!("identify_laps: a timing probe; run `cargo bench --bench identify_laps -- BANK RUNS CSV...`");
        return;
    };
    let runs: usize = runs.parse().expect("RUNS: a count");
    let bank = Bank::open(Path::new(bank)).expect("bank");
    let cal = bank.metadata().calibration.clone();
    let rate = cal.output.sample_rate_hz;
    let id = Identifier::new(bank, cal.identification.clone()).expect("identifier");
    let pair = vec!["rps1".to_string(), "rps2".to_string()];
    for (label, sensors) in [("rps1,rps2", Some(pair.as_slice())), ("five", None)] {
        let mut laps: Vec<(String, Vec<f64>)> = Vec::new();
        for csv in csvs {
            let text = std::fs::read_to_string(csv).expect("csv");
            let m = Measurement::from_csv(Path::new(csv), &text, rate).expect("measurement");
            for _ in 0..runs {
                let r = id.identify(&m, sensors, Extras::NONE).expect("identify");
                for (i, (name, ms)) in r.timings_ms.iter().enumerate() {
                    if laps.len() <= i {
                        laps.push((name.clone(), Vec::new()));
                    }
                    laps[i].1.push(*ms);
                }
            }
        }
        let median = |v: &mut Vec<f64>| {
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        let mut total = 0.0;
        let line: Vec<String> = laps
            .iter_mut()
            .map(|(name, v)| {
                let m = median(v);
                total += m;
                format!("{name} {m:.2}")
            })
            .collect();
        println!(
            "{label}: {} | sum of medians {total:.1} ms",
            line.join(", ")
        );
    }
}
