//! Where a void site's bank time goes, and whether folding could still save it
//! (docs/calibration.md, "The family's build time"; issue 57).
//!
//! For a calibrated site (its `calibrated.toml`, sensor gains left out: a gain scales a sensor
//! and folds exactly), prints:
//! 1. the steps of an instance: coarse steps before its first fine zone (the flat-free start
//!    every instance of a member shares) against all its steps, over 200 instances spread over
//!    the 50,000 of the population;
//! 2. the fold's error at this site: for five flats at X_b = 12, 12.35, 12.69 m on either
//!    wheel and shifts k = 1…3 bays, the largest difference over the samples of the sensors'
//!    sleepers (15…19) between sensor s's window for the flat at X_b + k·bay and
//!    - *plain*: the window k sleepers before s for the flat at X_b (what a folded bank reads);
//!    - *increment*: the same with the flat-free response swapped, `w_{s−k} − f_{s−k} + f_s`
//!      (the flat's increment folded, each sensor's own flat-free part kept).
//!
//! `cargo run --release -p wheelflat-studies --bin void_fold SITE/calibrated.toml`
use wheelflat::bank::Population;
use wheelflat::model::calibration::PadSensor;
use wheelflat::model::{Calibration, Effect, Flat, Record, Simulator, WheelPosition};

fn main() {
    let path = std::env::args()
        .nth(1)
        .expect("usage: void_fold SITE/calibrated.toml");
    let text = std::fs::read_to_string(&path).expect("the calibration file");
    let mut c = Calibration::from_toml_str(&text).expect("a calibration");
    c.population.fold_to_one_bay = false;
    c.effects
        .retain(|e| !matches!(e, Effect::SensorGain { .. }));
    steps(&c);
    fold_error(c);
}

/// Part 1: the share of an instance's steps before its first fine zone.
fn steps(c: &Calibration) {
    let cal = c.clone().check().expect("a valid calibration");
    let sim = Simulator::new(&cal).expect("the site's model");
    let t_end_s = cal.end_sample() as f64 / cal.output.sample_rate_hz;
    let population = Population::new(&cal.population, 50_000, 0);
    let (mut before, mut all, mut fine) = (0usize, 0usize, 0usize);
    let n = 200;
    for k in 0..n {
        let flat = population
            .instance(k * 50_000 / n)
            .flat(cal.vehicle.flat_wheel)
            .expect("population flats are valid");
        let first_s = sim
            .schedule(Some(&flat), t_end_s)
            .fine_zones_s
            .iter()
            .map(|z| z.0)
            .fold(f64::INFINITY, f64::min);
        before += (first_s / cal.dt_coarse_s()).floor().max(0.0) as usize;
        let r = sim.run(Some(&flat), Record::default()).expect("simulates");
        all += r.steps[0] + r.steps[1];
        fine += r.steps[1];
    }
    println!(
        "{n} instances: {:.0} steps each, {:.1} % of them fine; coarse steps before the first fine zone (the shared flat-free start): {:.1} % of all steps\n",
        all as f64 / n as f64,
        100.0 * fine as f64 / all as f64,
        100.0 * before as f64 / all as f64
    );
}

/// Part 2: the fold's error at the site, plain and with the flat-free part swapped.
fn fold_error(mut c: Calibration) {
    c.sensors.pad = (12..=19)
        .map(|k| PadSensor {
            name: format!("p{k}"),
            sleeper: k,
        })
        .collect();
    let cal = c.check().expect("a valid calibration");
    let sim = Simulator::new(&cal).expect("the site's model");
    let bay = cal.track.sleeper_spacing_m;
    let w = cal.output.window_samples;
    let free = sim.run(None, Record::default()).expect("simulates");
    let window = |r: &wheelflat::model::Response, s: usize| {
        r.window(s, cal.window_start_sample(s), w).to_vec()
    };
    let flats = [
        (60.0, 0.5, 0.1),
        (20.0, 1.0, 0.0),
        (200.0, 0.2, 0.05),
        (10.0, 0.1, 0.0),
        (40.0, 0.3, 0.0),
    ];
    println!("| flat (L × d × c, mm) | plain: largest (kN) | increment: largest (kN) | its sensor's sleeper | peak (kN) |");
    println!("|---|---|---|---|---|");
    let mut worst = [0.0f64; 2];
    for &(l, d, cc) in &flats {
        let (mut plain, mut inc, mut at, mut peak) = (0.0f64, 0.0f64, 0, 0.0f64);
        for wheel in [WheelPosition::Leading, WheelPosition::Trailing] {
            for xb in [12.0, 12.35, 12.69] {
                let on = |x: f64| {
                    Flat::from_mm(l, d, cc, x)
                        .expect("a valid flat")
                        .on_wheel(wheel)
                };
                let base = sim
                    .run(Some(&on(xb)), Record::default())
                    .expect("simulates");
                for k in 1..=3usize {
                    let r = sim
                        .run(Some(&on(xb + bay * k as f64)), Record::default())
                        .expect("simulates");
                    // Sensors' sleepers 15…19 are indices 3…7 of the pads 12…19.
                    for s in 3..cal.sensors.pad.len() {
                        let (real, virt) = (window(&r, s), window(&base, s - k));
                        let (f_s, f_sk) = (window(&free, s), window(&free, s - k));
                        for i in 0..w {
                            plain = plain.max((real[i] - virt[i]).abs() / 1e3);
                            let e = (real[i] - (virt[i] - f_sk[i] + f_s[i])).abs() / 1e3;
                            if e > inc {
                                (inc, at) = (e, 12 + s);
                            }
                            peak = peak.max(real[i].abs() / 1e3);
                        }
                    }
                }
            }
        }
        worst = [worst[0].max(plain), worst[1].max(inc)];
        println!("| {l} × {d} × {cc} | {plain:.2} | {inc:.2} | {at} | {peak:.1} |");
    }
    println!(
        "\nlargest: plain {:.2} kN, increment {:.2} kN",
        worst[0], worst[1]
    );
}
