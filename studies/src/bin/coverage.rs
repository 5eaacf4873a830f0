//! Coverage study on a bank (issue #4's acceptance, full-size version):
//! `cargo run --release -p wheelflat-studies --bin coverage -- BANK_DIR [CASES] [SEED] [KAPPA]`
//! (`NO_BASELINES=1` leaves the baselines out, `NO_DEPARTURES=1` the departure rule).
//! Prints one line per case and the summary: how often the truth lies inside the candidate
//! model set's (L, d) ranges, the median L0 width, the CMS sizes, for the EIP and the baselines.
use std::path::Path;
use wheelflat::bank::Bank;
use wheelflat::identify::Identifier;
use wheelflat_studies::coverage;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let dir = args
        .get(1)
        .expect("usage: coverage BANK_DIR [CASES] [SEED] [KAPPA]");
    let cases: usize = args
        .get(2)
        .map_or(50, |s| s.parse().expect("CASES is a number"));
    let seed: u64 = args
        .get(3)
        .map_or(11, |s| s.parse().expect("SEED is a number"));
    let bank = Bank::open(Path::new(dir)).expect("open bank");
    let cal = bank
        .metadata()
        .calibration
        .clone()
        .check()
        .expect("stored calibration is valid");
    let mut settings = cal.identification.clone();
    if let Some(k) = args.get(4) {
        settings.bank_resolution = k.parse().expect("KAPPA is a number");
    }
    // NO_DEPARTURES=1: sizing without the departure rule (as before issue 36).
    if std::env::var_os("NO_DEPARTURES").is_some() {
        settings.falsify_at_departures = false;
    }
    let id = Identifier::new(bank, settings).expect("identifier");
    let baselines = std::env::var_os("NO_BASELINES").is_none();
    let results = coverage::run(&id, &cal, cases, seed, baselines).expect("study");
    println!("case  L_mm    d_mm   X_p_m   L0_mm | EIP pts CMS covered L0 | equidistant CMS covered | random mean | RM L0");
    for r in &results {
        println!(
            "{:>4} {:6.1} {:6.3} {:7.3} {:6.1} | {:>3} {:>6} {:>5} {:?} | {:>6} {:>5} | {:8.1} | {:5.1}",
            r.case, r.truth[0], r.truth[1], r.truth[2], r.truth[3], r.points, r.eip.0, r.eip.1, r.eip.2.map(|w| [w[0].round(), w[1].round()]),
            r.equidistant.0, r.equidistant.1, r.random_mean, r.rm_l0_mm
        );
    }
    let (c, w, s) = coverage::summarise(&results, |r| r.eip);
    let (ec, ew, es) = coverage::summarise(&results, |r| r.equidistant);
    let rm_err: Vec<f64> = results
        .iter()
        .map(|r| (r.rm_l0_mm - r.truth[3]).abs())
        .collect();
    let rm_med = {
        let mut v = rm_err.clone();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let random: f64 = results.iter().map(|r| r.random_mean).sum::<f64>() / results.len() as f64;
    println!("EIP: coverage {c:.2}, median L0 width {w:.1} mm, median CMS {s}");
    println!("equidistant: coverage {ec:.2}, median L0 width {ew:.1} mm, median CMS {es}");
    println!("random subsets: mean CMS {random:.1}; residual minimisation: median |L0 error| {rm_med:.1} mm");
}
