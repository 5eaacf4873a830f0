//! What a physics-varied pass looks like to the bank (issue 56): `cargo run --release -p
//! wheelflat-studies --bin physics_gap -- CASES SEED`.
//!
//! CASES flats drawn uniformly over the default (site) population are simulated twice,
//! noise-free: with the bank's calibration at its own mesh (what the bank predicts for the
//! true flat) and at the converged reference with the vehicle, contact and track drawn as
//! physics (the paper's Table 3 and beyond: wheel, bogie masses and bogie inertia ×[0.95,
//! 1.05], primary stiffness and damping ×[0.9, 1.1], the Hertz flexibility G ×[0.9, 1.1], pad
//! damping ×[0.7, 1.3], sleeper mass ×[0.9, 1.1]). Per sensor window the physics pass is fitted
//! by one gain on the bank's prediction (least squares), and the residual left after it is
//! split into the samples near a strike (as the landing study draws them) and the rest.
//! Printed: the gains' spread, and the residual's quantiles over |g| (away from strikes) and
//! over the window's peak departure from the good wheel (near strikes); both with and without
//! the gain (the gain taken out or not).
use rayon::prelude::*;
use wheelflat::bank::schema::sensor_axes;
use wheelflat::model::{Calibration, Flat, Record, Simulator};
use wheelflat_studies::study;
use wheelflat_testkit::landing::near_strikes;

fn quantiles(mut v: Vec<f64>) -> String {
    if v.is_empty() {
        return "—".into();
    }
    v.sort_by(f64::total_cmp);
    let q = |p: f64| v[((v.len() - 1) as f64 * p).round() as usize];
    format!(
        "{:.4} / {:.4} / {:.4} / {:.4}",
        q(0.5),
        q(0.9),
        q(0.99),
        v[v.len() - 1]
    )
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let cases: usize = args.get(1).map_or(24, |a| a.parse().expect("CASES"));
    let seed: u64 = args.get(2).map_or(5, |a| a.parse().expect("SEED"));
    let base = Calibration::default();
    let cal = base.clone().check().expect("defaults");
    let axes = sensor_axes(&cal);
    let flats: Vec<Flat> = study::uniform_flats(&cal.population, cases, seed);
    let sim_bank = Simulator::new(&cal).expect("bank model");
    let good_bank = sim_bank.run(None, Record::default()).expect("good wheel");
    type Case = (
        Vec<f64>,
        Vec<(f64, f64, bool)>,
        Vec<(f64, bool)>,
        Vec<[f64; 4]>,
        bool,
    );
    // Per case: per sensor (gain, and per sample (residual after gain / residual without,
    // the scale it is judged against, near a strike)).
    let out: Vec<Case> = flats
        .par_iter()
        .enumerate()
        .map(|(k, f)| {
            let mut state = seed.wrapping_mul(1000).wrapping_add(k as u64);
            let phys = study::physics(&base, &mut state).converged_reference();
            let phys = phys.check().expect("physics in range");
            let r_p = Simulator::new(&phys)
                .expect("model")
                .run(Some(f), Record::default())
                .expect("run");
            let r_b = sim_bank.run(Some(f), Record::default()).expect("run");
            let near = near_strikes(&cal, &r_b, f);
            let mut gains = Vec::new();
            let mut samples = Vec::new();
            let mut plain = Vec::new();
            let mut detail = Vec::new();
            let lost = r_b.contact_loss_s.iter().any(|&t| t > 0.0);
            for (s, a) in axes.iter().enumerate() {
                let g = r_b.window(s, a.first_sample, a.samples);
                let y = r_p.window(s, a.first_sample, a.samples);
                let ff = good_bank.window(s, a.first_sample, a.samples);
                let gain = g.iter().zip(y).map(|(g, y)| g * y).sum::<f64>()
                    / g.iter().map(|g| g * g).sum::<f64>();
                gains.push(gain);
                let peak_dep = g
                    .iter()
                    .zip(ff)
                    .map(|(g, f)| (g - f).abs())
                    .fold(0.0, f64::max)
                    .max(1.0);
                for j in 0..g.len() {
                    let scale = if near[s][j] {
                        peak_dep
                    } else {
                        g[j].abs().max(1e3)
                    };
                    samples.push(((y[j] - gain * g[j]) / scale, scale, near[s][j]));
                    plain.push(((y[j] - g[j]) / scale, near[s][j]));
                    let step = [j.saturating_sub(1), (j + 1).min(g.len() - 1)]
                        .iter()
                        .map(|&i| (g[i] - g[j]).abs())
                        .fold(0.0, f64::max);
                    detail.push([
                        (y[j] - gain * g[j]).abs() / 1e3,
                        g[j].abs() / 1e3,
                        (g[j] - ff[j]).abs() / 1e3,
                        step / 1e3,
                    ]);
                }
            }
            (gains, samples, plain, detail, lost)
        })
        .collect();
    let gains: Vec<f64> = out.iter().flat_map(|c| c.0.iter().copied()).collect();
    let lo = gains.iter().copied().fold(f64::MAX, f64::min);
    let hi = gains.iter().copied().fold(f64::MIN, f64::max);
    println!("{cases} flats, seed {seed}: per-sensor gain (bank mesh → physics) {lo:.4} … {hi:.4}");
    // The spread of the gains within a pass (one vehicle: do its sensors share one gain?).
    let within: Vec<f64> = out
        .iter()
        .map(|c| {
            let lo = c.0.iter().copied().fold(f64::MAX, f64::min);
            let hi = c.0.iter().copied().fold(f64::MIN, f64::max);
            hi - lo
        })
        .collect();
    println!(
        "spread of the five sensors' gains within a pass (median / 90 / 99 % / max): {}",
        quantiles(within)
    );
    let pick = |near: bool| -> Vec<f64> {
        out.iter()
            .flat_map(|c| c.1.iter().filter(|s| s.2 == near).map(|s| s.0.abs()))
            .collect()
    };
    println!(
        "after the gain: |residual| / |g| away from strikes (median / 90 / 99 % / max): {}",
        quantiles(pick(false))
    );
    println!(
        "after the gain: |residual| / peak departure near strikes: {}",
        quantiles(pick(true))
    );
    let plain = |near: bool| -> Vec<f64> {
        out.iter()
            .flat_map(|c| c.2.iter().filter(move |v| v.1 == near).map(|v| v.0.abs()))
            .collect()
    };
    println!(
        "no gain: |physics − bank| / |g| away from strikes: {}",
        quantiles(plain(false))
    );
    println!(
        "no gain: |physics − bank| / peak departure near strikes: {}",
        quantiles(plain(true))
    );

    // Passes whose every sample lies inside a model-form bound a·|g| + b·|g − g_ff| (+ half
    // the step for a flat that lands, the bank's landing allowance), and the largest excess.
    for &(a, b, cn) in &[
        (0.0, 0.0, 0.0),
        (0.02, 0.05, 0.0),
        (0.05, 0.1, 0.0),
        (0.0, 0.0, 2.5),
        (0.01, 0.05, 1.5),
        (0.02, 0.05, 1.0),
        (0.02, 0.1, 1.0),
        (0.02, 0.1, 1.5),
        (0.03, 0.1, 1.0),
    ] {
        let judge = |landing: bool| {
            let set: Vec<&Case> = out.iter().filter(|c| c.4 == landing).collect();
            let excess: Vec<f64> = set
                .iter()
                .map(|c| {
                    c.3.iter()
                        .map(|d| {
                            d[0] - cn - a * d[1] - b * d[2] - if c.4 { 0.5 * d[3] } else { 0.0 }
                        })
                        .fold(f64::MIN, f64::max)
                })
                .collect();
            let inside = excess.iter().filter(|&&e| e <= 0.0).count();
            let within_noise = excess.iter().filter(|&&e| e <= 1.0).count();
            let worst = excess.iter().copied().fold(f64::MIN, f64::max);
            format!(
                "{inside}/{} inside, {within_noise} within 1 kN, largest excess {worst:.2} kN",
                set.len()
            )
        };
        println!(
            "model form a = {a}, b = {b}, c = {cn} kN: kept contact {}; landing {}",
            judge(false),
            judge(true)
        );
    }
}
