//! Where a landing's discretisation error comes from (issue 46; docs/identification.md,
//! "Discretisation error"): `cargo run --release -p wheelflat-studies --bin landing_study --
//! CASES SEED [E:C:F …]`.
//!
//! CASES flats drawn uniformly over the default (site) population are simulated without
//! noise at the converged reference and at each mesh/step variant `E:C:F` (elements a bay,
//! coarse steps a sample, fine steps a coarse one; the bank's own first). Per variant and per
//! case, the largest |variant − reference| over every sample of every sensor window, over the
//! reference's peak pad force, for the cases whose reference loses contact and for the rest:
//! its median, 90, 99 % and largest, and the variant's run time. The goal of issue 46: ≤ 1 % of
//! the peak at the 99th percentile.
use rayon::prelude::*;
use std::time::Instant;
use wheelflat::bank::schema::sensor_axes;
use wheelflat::model::{Calibration, Flat, Record, Simulator};
use wheelflat_studies::study::uniform;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        panic!("usage: landing_study CASES SEED [E:C:F …]");
    }
    let cases: usize = args[1].parse().expect("CASES");
    let seed: u64 = args[2].parse().expect("SEED");
    let base = Calibration::default();
    let cal = base.clone().check().expect("defaults");
    let axes = sensor_axes(&cal);
    let conv = base.converged_reference().check().expect("converged");
    let i = &base.integration;
    let mut variants = vec![format!(
        "{}:{}:{}",
        i.elements_per_bay, i.coarse_steps_per_sample, i.fine_steps_per_coarse
    )];
    variants.extend(args[3..].iter().cloned());
    let pop = cal.population.clone();
    let mut state = seed.max(1);
    let flats: Vec<Flat> = (0..cases)
        .map(|_| {
            let mut u = |r: [f64; 2]| r[0] + uniform(&mut state) * (r[1] - r[0]);
            let l = u(pop.length_mm);
            let d = u(pop.depth_mm);
            let c = u(pop.curvature_mm).min(0.49 * d);
            let x = u(pop.impact_position_m);
            Flat::from_mm(l, d, c, x).expect("a flat of the population")
        })
        .collect();
    let window = |r: &wheelflat::model::Response| -> Vec<Vec<f64>> {
        axes.iter()
            .enumerate()
            .map(|(s, a)| r.window(s, a.first_sample, a.samples).to_vec())
            .collect()
    };
    let sim_c = Simulator::new(&conv).expect("converged model");
    let clock = Instant::now();
    let reference: Vec<(Vec<Vec<f64>>, bool)> = flats
        .par_iter()
        .map(|f| {
            let r = sim_c
                .run(Some(f), Record::default())
                .expect("converged run");
            let lost = r.contact_loss_s.iter().any(|&t| t > 0.0);
            (window(&r), lost)
        })
        .collect();
    println!(
        "reference (40:20:{}): {cases} cases in {:.1} s, {} lose contact",
        conv.integration.fine_steps_per_coarse,
        clock.elapsed().as_secs_f64(),
        reference.iter().filter(|r| r.1).count()
    );
    for v in &variants {
        let parts: Vec<usize> = v.split(':').map(|x| x.parse().expect("E:C:F")).collect();
        let mut d = base.clone();
        d.integration.elements_per_bay = parts[0];
        d.integration.coarse_steps_per_sample = parts[1];
        d.integration.fine_steps_per_coarse = parts[2];
        let sim = Simulator::new(&d.check().expect("variant")).expect("variant model");
        let clock = Instant::now();
        let worst: Vec<(f64, bool)> = flats
            .par_iter()
            .zip(&reference)
            .map(|(f, (r, lost))| {
                let g = window(&sim.run(Some(f), Record::default()).expect("run"));
                let peak = r.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
                let err = g
                    .iter()
                    .flatten()
                    .zip(r.iter().flatten())
                    .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
                (err / peak, *lost)
            })
            .collect();
        let secs = clock.elapsed().as_secs_f64();
        for lost in [true, false] {
            let mut w: Vec<f64> = worst.iter().filter(|x| x.1 == lost).map(|x| x.0).collect();
            w.sort_by(f64::total_cmp);
            let q = |p: f64| 100.0 * w[((w.len() - 1) as f64 * p).round() as usize];
            if w.is_empty() {
                continue;
            }
            println!(
                "{v:>9} {}: {} cases, largest |variant − reference| / peak: median {:.2} %, 90 % {:.2} %, 99 % {:.2} %, max {:.2} % ({secs:.1} s for all {cases})",
                if lost { "losing contact " } else { "keeping contact" },
                w.len(),
                q(0.5),
                q(0.9),
                q(0.99),
                q(1.0)
            );
        }
    }
}
