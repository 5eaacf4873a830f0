//! How well does a whole-bay shift stand in for a change of the impact position X_p by one
//! sleeper bay? For flats at X_b and X_b + k·(sleeper spacing), k = 1…3, on either wheel, the
//! largest difference between sensor s's window for X_b + k·bay and sensor (s − k)'s window
//! for X_b, in kN, over every sample (the pads at sleepers 12…19):
//! `cargo run --release -p wheelflat-studies --bin fold_error [kmh]`
use wheelflat::model::calibration::PadSensor;
use wheelflat::model::{Calibration, Flat, Record, Simulator, WheelPosition};

fn main() {
    let kmh: f64 = std::env::args()
        .nth(1)
        .map_or(50.0, |a| a.parse().expect("km/h"));
    let mut c = Calibration::paper_profile();
    c.run.speed_km_per_h = kmh;
    c.sensors.pad = (12..=19)
        .map(|k| PadSensor {
            name: format!("p{k}"),
            sleeper: k,
        })
        .collect();
    // PAD=n moves everything n bays away from the left clamped end (and adds 2n bays).
    let pad: usize = std::env::var("PAD").map_or(0, |v| v.parse().expect("bays"));
    c.track.bays += pad * std::env::var("SIDES").map_or(2, |v| v.parse::<usize>().expect("1 or 2"));
    c.run.leading_wheel_start_m += pad as f64 * c.track.sleeper_spacing_m;
    c.sensors.laser_trigger_m += pad as f64 * c.track.sleeper_spacing_m;
    for p in &mut c.sensors.pad {
        p.sleeper += pad;
    }
    let shift_m = pad as f64 * c.track.sleeper_spacing_m;
    let conv = std::env::var("CONVERGED").is_ok();
    if conv {
        c = c.converged_reference();
    }
    let cal = c.check().expect("valid");
    let sim = Simulator::new(&cal).unwrap();
    let bay = cal.track.sleeper_spacing_m;
    let w = cal.output.window_samples;
    println!(
        "| flat | wheel | X_b (m) | k | max |diff| (kN) | peak (kN) | window shift (samples) |"
    );
    println!("|---|---|---|---|---|---|---|");
    // FLAT="L d c X_b" studies one flat instead of the four.
    let flats: Vec<(f64, f64, f64)> = vec![
        (60.0, 0.5, 0.1),
        (20.0, 1.0, 0.0),
        (200.0, 0.2, 0.05),
        (10.0, 0.1, 0.0),
    ];
    let one: Option<Vec<f64>> = std::env::var("FLAT").ok().map(|v| {
        v.split_whitespace()
            .map(|x| x.parse().expect("FLAT: four numbers"))
            .collect()
    });
    let (flats, xbs) = match &one {
        Some(f) => (vec![(f[0], f[1], f[2])], vec![f[3]]),
        None => (flats, vec![12.0, 12.35, 12.69]),
    };
    for &(l, d, cc) in &flats {
        for wheel in [WheelPosition::Leading, WheelPosition::Trailing] {
            for &xb in &xbs {
                let base = Flat::from_mm(l, d, cc, xb + shift_m)
                    .unwrap()
                    .on_wheel(wheel);
                let rb = sim.run(Some(&base), Record::default()).unwrap();
                for k in 1..=3usize {
                    let f = Flat::from_mm(l, d, cc, xb + shift_m + bay * k as f64)
                        .unwrap()
                        .on_wheel(wheel);
                    let r = sim.run(Some(&f), Record::default()).unwrap();
                    let mut worst: f64 = 0.0;
                    let mut peak: f64 = 0.0;
                    let mut shift = 0i64;
                    for s in k..cal.sensors.pad.len() {
                        let real = r.window(s, cal.window_start_sample(s), w);
                        let virt = rb.window(s - k, cal.window_start_sample(s - k), w);
                        shift = cal.window_start_sample(s) as i64
                            - cal.window_start_sample(s - k) as i64;
                        for (a, b) in real.iter().zip(virt) {
                            worst = worst.max((a - b).abs() / 1e3);
                            peak = peak.max(a.abs() / 1e3);
                        }
                    }
                    println!("| {l}×{d}×{cc} | {wheel:?} | {xb} | {k} | {worst:.4} | {peak:.1} | {shift} |");
                }
            }
        }
    }
}
