//! How far a rough good wheel's pad forces depart from the smooth wheel's, per roughness class
//! (docs/detection.md, "Rough wheels"):
//! `cargo run --release -p wheelflat-studies --bin roughness_study -- PASSES SEED [bank|converged] [raw|filtered] [rail|norail]`.
//!
//! Per wheel class (disc, composite, cast iron, its rough end) PASSES good-wheel passes, both
//! wheels drawn from the class (each its own seed), the rail at the EN ISO 3095 limit unless
//! `norail`, simulated at the mesh asked (default converged) through the contact filter asked
//! (default raw: the trace as the wheel's drop, as the independent implementation does). Per
//! pass and sensor the departure `Δ_k = F_rough,k − F_smooth,k` over the window; printed: the
//! percentiles over passes of `max_k |Δ_k|` (kN), of the same where the flat-free force is
//! under 2 kN, of `max_k |Δ_k| / F_smooth,k` where it is over 5 kN, and of the high-frequency
//! share (`Δ` minus its 5-sample moving average).
use rayon::prelude::*;
use wheelflat::model::surface::{rail_roughness, wheel_roughness, RoughnessClass};
use wheelflat::model::{
    Calibration, ContactFilter, RailSurface, Record, Simulator, Surfaces, WheelPosition,
    WheelSurface,
};

fn percentiles(mut v: Vec<f64>) -> String {
    v.sort_by(f64::total_cmp);
    let at = |p: f64| v[((p * (v.len() - 1) as f64).round() as usize).min(v.len() - 1)];
    format!(
        "p50 {:6.2}  p90 {:6.2}  p99 {:6.2}  max {:6.2}",
        at(0.5),
        at(0.9),
        at(0.99),
        at(1.0)
    )
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let passes: usize = args.get(1).map_or(40, |a| a.parse().expect("PASSES"));
    let seed: u64 = args.get(2).map_or(1, |a| a.parse().expect("SEED"));
    let flag = |w: &str| args.iter().skip(3).any(|a| a == w);
    let base = Calibration::default();
    let cal = if flag("bank") {
        base
    } else {
        base.converged_reference()
    }
    .check()
    .expect("calibration");
    let filter = if flag("filtered") {
        ContactFilter::DEFAULT
    } else {
        ContactFilter {
            patch: false,
            rolling_circle: false,
        }
    };
    let with_rail = !flag("norail");
    let sim = Simulator::new(&cal).expect("simulator");
    if flag("timing") {
        let t = std::time::Instant::now();
        let rail = rail_roughness(RoughnessClass::RailIso3095, cal.rail_length_m(), 1).unwrap();
        println!("rail draw {:.2} s", t.elapsed().as_secs_f64());
        let t = std::time::Instant::now();
        let w = wheel_roughness(RoughnessClass::CastIron, 0.4, 1).unwrap();
        println!("wheel draw {:.2} s", t.elapsed().as_secs_f64());
        let s = Surfaces {
            wheels: vec![WheelSurface {
                wheel: WheelPosition::Trailing,
                trace: w,
                touch_x_m: 5.0,
            }],
            rail: Some(RailSurface {
                start_x_m: 0.0,
                trace: rail,
            }),
        };
        for f in [
            ContactFilter {
                patch: false,
                rolling_circle: false,
            },
            ContactFilter::DEFAULT,
        ] {
            let t = std::time::Instant::now();
            let s2 = sim.clone().with_surfaces(&s, f).unwrap();
            println!("table {:?} {:.2} s", f, t.elapsed().as_secs_f64());
            let t = std::time::Instant::now();
            s2.run(None, Record::default()).unwrap();
            println!("run {:.2} s", t.elapsed().as_secs_f64());
        }
        return;
    }
    let smooth = sim.run(None, Record::default()).expect("smooth run");
    let r = cal.vehicle.wheel_radius_m;
    let rail_len = cal.rail_length_m();
    println!(
        "{} passes a class, {} mesh, {} contact filter, rail {}",
        passes,
        if flag("bank") { "bank" } else { "converged" },
        if flag("filtered") {
            "patch + rolling circle"
        } else {
            "no"
        },
        if with_rail {
            "at the EN ISO 3095 limit"
        } else {
            "smooth"
        }
    );
    // `railonly`: round wheels on the rail (the rail's part alone).
    let classes: Vec<Option<RoughnessClass>> = if flag("railonly") {
        vec![None]
    } else {
        RoughnessClass::WHEELS.into_iter().map(Some).collect()
    };
    for class in classes {
        let rows: Vec<[f64; 7]> = (0..passes)
            .into_par_iter()
            .flat_map_iter(|p| {
                let s = seed.wrapping_mul(1000).wrapping_add(p as u64);
                let wheels = [WheelPosition::Leading, WheelPosition::Trailing]
                    .iter()
                    .enumerate()
                    .filter_map(|(i, &w)| {
                        class.map(|c| WheelSurface {
                            wheel: w,
                            trace: wheel_roughness(c, r, s * 4 + i as u64).expect("wheel"),
                            touch_x_m: 5.0 + 1.3 * i as f64,
                        })
                    })
                    .collect();
                let surfaces = Surfaces {
                    wheels,
                    rail: with_rail.then(|| RailSurface {
                        start_x_m: 0.0,
                        trace: rail_roughness(RoughnessClass::RailIso3095, rail_len, s * 4 + 3)
                            .expect("rail"),
                    }),
                };
                let rough = sim
                    .clone()
                    .with_surfaces(&surfaces, filter)
                    .expect("surfaces")
                    .run(None, Record::default())
                    .expect("run");
                (0..cal.sensors.pad.len())
                    .map(|i| {
                        let start = cal.window_start_sample(i);
                        let n = cal.output.window_samples;
                        let a = rough.window(i, start, n);
                        let b = smooth.window(i, start, n);
                        let raw: Vec<f64> = a.iter().zip(b).map(|(x, y)| (x - y) / 1e3).collect();
                        let graw: Vec<f64> = b.iter().map(|y| y / 1e3).collect();
                        // SMOOTH=n: the statistics of the n-sample moving averages.
                        // SMOOTH=ma3|ma5|b5: the statistics through that average (default: none).
                        let weights: Vec<f64> = match std::env::var("SMOOTH").as_deref() {
                            Ok("ma3") => vec![1.0 / 3.0; 3],
                            Ok("ma5") => vec![0.2; 5],
                            Ok("b5") => wheelflat::model::average::BINOMIAL5.to_vec(),
                            _ => vec![1.0],
                        };
                        let ma =
                            |x: &[f64]| wheelflat::model::average::centred_average(x, &weights);
                        let (d, g) = (ma(&raw), ma(&graw));
                        let max_all = d.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                        let max_low = d
                            .iter()
                            .zip(&g)
                            .filter(|(_, g)| g.abs() < 2.0)
                            .fold(0.0f64, |m, (v, _)| m.max(v.abs()));
                        let max_ratio = d
                            .iter()
                            .zip(&g)
                            .filter(|(_, g)| g.abs() > 5.0)
                            .fold(0.0f64, |m, (v, g)| m.max(v.abs() / g.abs()));
                        let hf = (2..d.len() - 2)
                            .map(|k| (d[k] - d[k - 2..=k + 2].iter().sum::<f64>() / 5.0).abs())
                            .fold(0.0f64, f64::max);
                        let lf = |h: usize| {
                            (h..d.len() - h)
                                .map(|k| {
                                    (d[k - h..=k + h].iter().sum::<f64>() / (2 * h + 1) as f64)
                                        .abs()
                                })
                                .fold(0.0f64, f64::max)
                        };
                        // Per-sample quantile inputs: the 0.999 quantile over this window's samples.
                        let mut rel: Vec<f64> = d
                            .iter()
                            .zip(&g)
                            .filter(|(_, g)| g.abs() > 5.0)
                            .map(|(v, g)| v.abs() / g.abs())
                            .collect();
                        rel.sort_by(f64::total_cmp);
                        let q = |v: &[f64], p: f64| {
                            v[((p * (v.len() - 1) as f64) as usize).min(v.len() - 1)]
                        };
                        let mut low: Vec<f64> = d
                            .iter()
                            .zip(&g)
                            .filter(|(_, g)| g.abs() < 2.0)
                            .map(|(v, _)| v.abs())
                            .collect();
                        low.sort_by(f64::total_cmp);
                        let _ = (hf, lf(1), lf(2), lf(3));
                        [
                            max_all,
                            max_low,
                            max_ratio,
                            q(&rel, 0.9),
                            q(&rel, 0.99),
                            q(&low, 0.9),
                            q(&low, 0.99),
                        ]
                    })
                    .collect::<Vec<_>>()
            })
            .collect();
        let col = |j: usize| rows.iter().map(|r| r[j]).collect::<Vec<f64>>();
        println!(
            "{} (spectrum rms {:.1} µm), {} sensor windows:",
            class.map_or("round wheels", |c| c.name()),
            class.map_or(0.0, |c| c.rms_m() * 1e6),
            rows.len()
        );
        println!("  max |Δ| (kN)                {}", percentiles(col(0)));
        println!("  max |Δ| where F < 2 kN      {}", percentiles(col(1)));
        println!("  max |Δ|/F where F > 5 kN    {}", percentiles(col(2)));
        println!("  per window q0.90 |Δ|/F (F>5) {}", percentiles(col(3)));
        println!("  per window q0.99 |Δ|/F (F>5) {}", percentiles(col(4)));
        println!("  per window q0.90 |Δ| (F<2)   {}", percentiles(col(5)));
        println!("  per window q0.99 |Δ| (F<2)   {}", percentiles(col(6)));
    }
}
