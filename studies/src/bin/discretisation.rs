//! The bank mesh's discretisation error, measured against the converged reference (issue 32;
//! docs/identification.md, "Discretisation error"):
//! `cargo run --release -p wheelflat-studies --bin discretisation -- BANK CASES SEED OUT.csv`.
//!
//! CASES flats drawn uniformly over the bank's whole population (L, d, c with c < d/2, X_p)
//! are simulated twice, at the bank's mesh and step and at `Calibration::converged_reference`,
//! without noise. For every sample of every sensor window where either run departs from the
//! flat-free template by more than 0.2 kN, one CSV row: the case, its flat, whether the
//! converged run lost contact, the sensor, the sample, the bank's prediction `g`, the
//! reference `r`, the flat-free template `free`, and the bank's local step `slope`
//! (the largest difference to a neighbouring sample). Prints the per-case largest
//! |g − r| over |g − free| by contact group. Cases run on the rayon pool.
use wheelflat_studies::study;

use rayon::prelude::*;
use std::io::Write;
use wheelflat::bank::Bank;
use wheelflat::model::{Flat, Record, Simulator};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 5 {
        panic!("usage: discretisation BANK CASES SEED OUT.csv");
    }
    let bank = Bank::open(std::path::Path::new(&args[1])).expect("bank");
    let cases: usize = args[2].parse().expect("CASES");
    let seed: u64 = args[3].parse().expect("SEED");
    let meta = bank.metadata();
    let cal = meta.calibration.clone().check().expect("calibration");
    let conv = cal.converged_reference().check().expect("converged");
    let axes = meta.sensors.clone();
    let free: Vec<Vec<f32>> = meta.flat_free_kn.clone();
    let pop = cal.population.clone();
    let sim_b = Simulator::new(&cal).expect("bank model");
    let sim_c = Simulator::new(&conv).expect("converged model");
    let flats: Vec<Flat> = study::uniform_flats(&pop, cases, seed);
    let rows: Vec<(String, f64, bool)> = flats
        .par_iter()
        .enumerate()
        .map(|(case, f)| {
            let rb = sim_b.run(Some(f), Record::default()).expect("bank run");
            let rc = sim_c.run(Some(f), Record::default()).expect("converged run");
            let lost = rc.contact_loss_s.iter().any(|&t| t > 0.0);
            let mut out = String::new();
            let mut worst: f64 = 0.0;
            for (si, a) in axes.iter().enumerate() {
                let g: Vec<f64> = rb
                    .window(si, a.first_sample, a.samples)
                    .iter()
                    .map(|v| (v / 1e3) as f32 as f64)
                    .collect();
                let r: Vec<f64> = rc
                    .window(si, a.first_sample, a.samples)
                    .iter()
                    .map(|v| v / 1e3)
                    .collect();
                for j in 0..g.len() {
                    let fr = free[si][j] as f64;
                    if (g[j] - fr).abs() < 0.2 && (r[j] - fr).abs() < 0.2 {
                        continue;
                    }
                    let prev = if j > 0 { (g[j] - g[j - 1]).abs() } else { 0.0 };
                    let next = if j + 1 < g.len() {
                        (g[j + 1] - g[j]).abs()
                    } else {
                        0.0
                    };
                    let dep = (g[j] - fr).abs().max(0.5);
                    worst = worst.max((g[j] - r[j]).abs() / dep);
                    out.push_str(&format!(
                        "{case},{:.2},{:.4},{:.4},{:.4},{},{},{j},{:.4},{:.4},{:.4},{:.4},{:.3},{:.3}\n",
                        f.length_m() * 1e3,
                        f.depth_m() * 1e3,
                        f.curvature_m() * 1e3,
                        f.impact_position_m(),
                        u8::from(lost),
                        a.name,
                        g[j],
                        r[j],
                        fr,
                        prev.max(next),
                        rb.peak_contact_force_n.iter().copied().fold(0.0, f64::max) / 1e3,
                        rc.peak_contact_force_n.iter().copied().fold(0.0, f64::max) / 1e3,
                    ));
                }
            }
            (out, worst, lost)
        })
        .collect();
    let mut file = std::fs::File::create(&args[4]).expect("output file");
    writeln!(
        file,
        "case,L_mm,d_mm,c_mm,xp_m,lost,sensor,j,g_kn,r_kn,free_kn,slope_kn,peak_b_kn,peak_c_kn"
    )
    .unwrap();
    for (text, ..) in &rows {
        file.write_all(text.as_bytes()).unwrap();
    }
    for lost in [false, true] {
        let mut w: Vec<f64> = rows.iter().filter(|r| r.2 == lost).map(|r| r.1).collect();
        w.sort_by(f64::total_cmp);
        let q = |p: f64| w.get(((w.len() as f64 * p) as usize).min(w.len().saturating_sub(1)));
        println!(
            "lost contact {lost}: {} cases; per-case largest |g-r|/|g-free|: median {:?}, 90 % {:?}, 95 % {:?}, max {:?}",
            w.len(),
            q(0.5),
            q(0.9),
            q(0.95),
            w.last()
        );
    }
}
