//! Where a landing's discretisation error comes from (issue 46; docs/identification.md,
//! "Discretisation error"): `cargo run --release -p wheelflat-studies --bin landing_study --
//! CASES SEED [E:C:F …]`.
//!
//! CASES flats drawn uniformly over the default (site) population are simulated without
//! noise at the converged reference and at each mesh/step variant `E:C:F` (elements a bay,
//! coarse steps a sample, fine steps a coarse one; the bank's own first) or `E:C:F:R:M` (and
//! R elements a bay from M bays before the first sensor's sleeper to M bays after the last). Per variant and per
//! case, the largest |variant − reference| over the reference's peak pad force, at the samples
//! near a strike and its landing (1 ms before the strike to 5 ms after the flat has passed:
//! `near`) and over every sample of every sensor window (`all`), for the cases whose reference
//! loses contact and for the rest: median, 90, 99 % and largest, and the variant's run time.
//! The goal of issue 46: ≤ 1 % of the peak at the 99th percentile around the landing.
use rayon::prelude::*;
use std::time::Instant;
use wheelflat::bank::schema::sensor_axes;
use wheelflat::model::calibration::RefinedSpan;
use wheelflat::model::{Calibration, Flat, Record, Simulator};
use wheelflat_studies::study;
use wheelflat_testkit::landing::near_strikes;

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
    let flats: Vec<Flat> = study::uniform_flats(&pop, cases, seed);
    let window = |r: &wheelflat::model::Response| -> Vec<Vec<f64>> {
        axes.iter()
            .enumerate()
            .map(|(s, a)| r.window(s, a.first_sample, a.samples).to_vec())
            .collect()
    };
    let sim_c = Simulator::new(&conv).expect("converged model");
    let clock = Instant::now();
    // Per case: the windows, whether contact was lost, and per window which samples lie near
    // a strike (1 ms before it to 5 ms after the flat has passed).
    type Reference = (Vec<Vec<f64>>, bool, Vec<Vec<bool>>);
    let reference: Vec<Reference> = flats
        .par_iter()
        .map(|f| {
            let r = sim_c
                .run(Some(f), Record::default())
                .expect("converged run");
            let lost = r.contact_loss_s.iter().any(|&t| t > 0.0);
            let near = near_strikes(&cal, &r, f);
            (window(&r), lost, near)
        })
        .collect();
    println!(
        "reference (40:20:{}): {cases} cases in {:.1} s, {} lose contact",
        conv.integration.fine_steps_per_coarse,
        clock.elapsed().as_secs_f64(),
        reference.iter().filter(|r| r.1).count()
    );
    for v in &variants {
        let parts: Vec<usize> = v
            .split(':')
            .map(|x| x.parse().expect("E:C:F[:R:M]"))
            .collect();
        let mut d = base.clone();
        d.integration.elements_per_bay = parts[0];
        d.integration.coarse_steps_per_sample = parts[1];
        d.integration.fine_steps_per_coarse = parts[2];
        // E:C:F:R:M — R elements a bay from M bays before the first sensor's sleeper to M
        // bays after the last.
        if let [_, _, _, r, m] = parts[..] {
            let s = cal.track.sleeper_spacing_m;
            let sleepers = cal.sensors.pad.iter().map(|p| p.sleeper);
            let (lo, hi) = (sleepers.clone().min().unwrap(), sleepers.max().unwrap());
            d.integration.refine = vec![RefinedSpan {
                from_m: lo.saturating_sub(m) as f64 * s,
                to_m: (hi + m) as f64 * s,
                elements_per_bay: r,
            }];
        }
        let sim = Simulator::new(&d.check().expect("variant")).expect("variant model");
        let clock = Instant::now();
        // Per case: the largest error near a strike and anywhere, over the peak; lost.
        let worst: Vec<([f64; 2], bool)> = flats
            .par_iter()
            .zip(&reference)
            .map(|(f, (r, lost, near))| {
                let g = window(&sim.run(Some(f), Record::default()).expect("run"));
                let peak = r.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
                let mut err = [0.0f64; 2];
                for ((gs, rs), ns) in g.iter().zip(r).zip(near) {
                    for ((a, b), &n) in gs.iter().zip(rs).zip(ns) {
                        let e = (a - b).abs();
                        err[1] = err[1].max(e);
                        if n {
                            err[0] = err[0].max(e);
                        }
                    }
                }
                ([err[0] / peak, err[1] / peak], *lost)
            })
            .collect();
        let secs = clock.elapsed().as_secs_f64();
        for lost in [true, false] {
            for (k, what) in ["near", "all"].iter().enumerate() {
                let mut w: Vec<f64> = worst
                    .iter()
                    .filter(|x| x.1 == lost)
                    .map(|x| x.0[k])
                    .collect();
                if w.is_empty() {
                    continue;
                }
                w.sort_by(f64::total_cmp);
                let q = |p: f64| 100.0 * w[((w.len() - 1) as f64 * p).round() as usize];
                println!(
                    "{v:>9} {} {what:>4}: {} cases, largest |variant − reference| / peak: median {:.2} %, 90 % {:.2} %, 99 % {:.2} %, max {:.2} % ({secs:.1} s for all {cases})",
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
}
