//! Convergence study behind the default mesh and time steps (README, "Convergence study").
//!
//! Runs five flats (good wheel; mid-size 60 mm × 0.5 mm; short and deep 20 mm × 1.0 mm, which
//! loses contact; long and shallow 200 mm × 0.2 mm; 40 mm × 0.3 mm) with a much finer
//! reference (16 elements per bay, dt 50 µs coarse / 2.5 µs fine, 20 ms fine zones) and with
//! each candidate setting, and prints a Markdown table: the RPS2 peak's deviation from the
//! reference and the largest sample deviation over all five sensors (both in % of the
//! reference peak), and the time per instance on one core.
//!
//! `cargo run --release -p wheelflat-studies --bin convergence [e nc nf after_ms]...` (`REF="e nc nf after_ms"`
//! sets the reference).

use std::time::Instant;
use wheelflat::model::{Calibration, CheckedCalibration, Flat, Record, Response, Simulator};

fn calibration(e: usize, nc: usize, nf: usize, after_ms: f64) -> CheckedCalibration {
    let mut c = Calibration::default();
    c.integration.elements_per_bay = e;
    c.integration.coarse_steps_per_sample = nc;
    c.integration.fine_steps_per_coarse = nf;
    c.integration.fine_after_strike_s = after_ms * 1e-3;
    c.check().expect("valid study settings")
}

fn peak(v: &[f64]) -> f64 {
    v.iter().copied().fold(f64::MIN, f64::max)
}

fn main() {
    let flats: Vec<(&str, Option<Flat>)> = vec![
        ("good wheel", None),
        ("60/0.5", Some(Flat::from_mm(60.0, 0.5, 0.1, 12.4).unwrap())),
        ("20/1.0", Some(Flat::from_mm(20.0, 1.0, 0.0, 12.4).unwrap())),
        (
            "200/0.2",
            Some(Flat::from_mm(200.0, 0.2, 0.05, 12.7).unwrap()),
        ),
        (
            "40/0.3",
            Some(Flat::from_mm(40.0, 0.3, 0.1, 12.05).unwrap()),
        ),
    ];
    let args: Vec<f64> = std::env::args()
        .skip(1)
        .map(|a| a.parse().expect("numbers"))
        .collect();
    let candidates: Vec<[f64; 4]> = if args.is_empty() {
        vec![
            [2.0, 1.0, 10.0, 10.0],
            [4.0, 1.0, 10.0, 5.0],
            [4.0, 1.0, 10.0, 10.0],
            [4.0, 1.0, 20.0, 10.0],
            [4.0, 2.0, 10.0, 10.0],
            [8.0, 1.0, 10.0, 10.0],
            [8.0, 2.0, 20.0, 10.0],
        ]
    } else {
        args.chunks_exact(4)
            .map(|c| [c[0], c[1], c[2], c[3]])
            .collect()
    };
    // REF="e nc nf after_ms" sets the reference (issue 32: the converged reference against a
    // still finer run).
    let r: Vec<f64> = std::env::var("REF").map_or(vec![16.0, 8.0, 20.0, 20.0], |v| {
        v.split_whitespace()
            .map(|x| x.parse().expect("REF: four numbers"))
            .collect()
    });
    let reference_cal = calibration(r[0] as usize, r[1] as usize, r[2] as usize, r[3]);
    let reference: Vec<Response> = flats
        .iter()
        .map(|(_, f)| {
            Simulator::new(&reference_cal)
                .unwrap()
                .run(f.as_ref(), Record::default())
                .unwrap()
        })
        .collect();
    let rps2 = reference_cal.sensor_index("rps2").unwrap();

    print!("| elements/bay | dt coarse (µs) | dt fine (µs) | fine after strike (ms) |");
    for (name, _) in &flats {
        print!(" {name}: RPS2 peak / max sample dev. (%) |");
    }
    println!(" ms per instance (mean) |");
    println!("|{}", "---|".repeat(5 + flats.len()));
    for c in candidates {
        let cal = calibration(c[0] as usize, c[1] as usize, c[2] as usize, c[3]);
        let sim = Simulator::new(&cal).unwrap();
        let mut ws = sim.workspace();
        print!(
            "| {} | {:.0} | {:.0} | {} |",
            c[0],
            cal.dt_coarse_s() * 1e6,
            cal.dt_fine_s() * 1e6,
            c[3]
        );
        let mut total_ms = 0.0;
        for ((_, f), r) in flats.iter().zip(&reference) {
            let t0 = Instant::now();
            let resp = sim
                .run_with(f.as_ref(), Record::default(), &mut ws)
                .unwrap();
            total_ms += t0.elapsed().as_secs_f64() * 1e3;
            let peak_dev =
                (peak(&resp.pad_force_n[rps2]) / peak(&r.pad_force_n[rps2]) - 1.0) * 100.0;
            let mut max_dev: f64 = 0.0;
            let mut max_peak: f64 = 0.0;
            for (a, b) in resp.pad_force_n.iter().zip(&r.pad_force_n) {
                max_peak = max_peak.max(peak(b));
                for (x, y) in a.iter().zip(b) {
                    max_dev = max_dev.max((x - y).abs());
                }
            }
            print!(" {peak_dev:+.2} / {:.2} |", max_dev / max_peak * 100.0);
        }
        println!(" {:.1} |", total_ms / flats.len() as f64);
    }
}
