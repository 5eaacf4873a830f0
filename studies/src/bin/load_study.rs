//! Issue 35's load measurements (docs/bank.md "Every load"): how far off a bank's car-body mass
//! may a pass be, and how well does the record tell its load?
//! `cargo run --release -p wheelflat-studies --bin load_study -- BANK CASES SEED CACHE F[,F…]|A:B [V1:V2]`
//!
//! Seeded cases over the bank's whole population (its calibration's; a family's middle
//! member's), simulated with the converged reference and perturbed per the paper's Eq. 1
//! (seed SEED + case), cached in CACHE. `F,F…`: every case at each car-body factor F of the
//! bank's mass (one folder each). `A:B [V1:V2]`: each case at its own factor drawn uniformly in
//! [A, B] (and speed in [V1, V2] km/h), as a site sees them. Every case goes through what
//! `identify` does: its speed and the load its record shows pick the member
//! (`Members::member_for_pass`; a load outside the band is refused and counted), then the
//! member identifies it. Printed: coverage, refuted, refused, median L0 width, and the load
//! read from the record against the truth's (within 3 %, the interval holding it).
//! `NEAREST=1`: the member nearest the pass's load however far (none refused), which measures
//! what an offset costs.
use wheelflat_studies::study;

use rayon::prelude::*;
use std::path::{Path, PathBuf};
use wheelflat::identify::synth::{synthesize, Truth};
use wheelflat::identify::Members;
use wheelflat::identify::Severity;
use wheelflat::identify::{Extras, Measurement};
use wheelflat::model::CheckedCalibration;
use wheelflat_studies::coverage::{self, judge, method_line, severity_class, Judged};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 6 {
        panic!("usage: load_study BANK CASES SEED CACHE F[,F…]|A:B [V1:V2]");
    }
    let mut members = Members::open(Path::new(&args[1]), None).expect("bank or family");
    let cal = members
        .any()
        .expect("a member")
        .bank()
        .metadata()
        .calibration
        .clone();
    // The family's factors multiply the calibration's mass: the members' base.
    let base = match members.family().loads {
        Some(l) => {
            let mut c = cal.clone();
            c.vehicle.car_body_mass_kg = l.car_body_mass_kg;
            c
        }
        None => cal,
    }
    .check()
    .expect("calibration");
    let cases: usize = args[2].parse().expect("CASES");
    let seed: u64 = args[3].parse().expect("SEED");
    let cache = PathBuf::from(&args[4]);
    let truths = coverage::truths_within(&base, cases, seed, 0.0);
    let (insp, urg, top) = coverage::severity_limits(&base);
    let draw = args[5].contains(':');
    // `NEAREST=1`: the nearest member however far (no refusal), to measure an offset's cost.
    let nearest = std::env::var("NEAREST").is_ok_and(|v| v == "1");
    // (folder, per case: car-body factor and speed)
    let sets: Vec<(String, Vec<(f64, f64)>)> = if draw {
        let ab: Vec<f64> = args[5]
            .split(':')
            .map(|x| x.parse().expect("A:B"))
            .collect();
        let v: Vec<f64> = args.get(6).map_or(vec![base.run.speed_km_per_h; 2], |s| {
            s.split(':').map(|x| x.parse().expect("V1:V2")).collect()
        });
        let mut state = seed ^ 0x5EED_10AD;
        let per: Vec<(f64, f64)> = (0..cases)
            .map(|_| {
                let f = ab[0] + (ab[1] - ab[0]) * study::uniform(&mut state);
                // Speeds to 0.1 km/h, as a site's trigger pair states them.
                let s = v[0] + (v[1] - v[0]) * study::uniform(&mut state);
                (f, (s * 10.0).round() / 10.0)
            })
            .collect();
        vec![(
            format!("draw-{}-{}", args[5], args.get(6).map_or("", |s| s)),
            per,
        )]
    } else {
        args[5]
            .split(',')
            .map(|f| {
                let f: f64 = f.parse().expect("F");
                (format!("F-{f}"), vec![(f, base.run.speed_km_per_h); cases])
            })
            .collect()
    };
    for (name, per) in sets {
        let dir = cache.join(&name);
        std::fs::create_dir_all(&dir).expect("cache folder");
        simulate(&base, &truths, &per, seed, &dir);
        let (mut truth, mut judged) = (Vec::new(), Vec::<Judged>::new());
        let (mut refuted, mut refused, mut within3, mut inside) = (0, 0, 0, 0);
        let mut errors = Vec::new();
        for (k, &(f, v)) in per.iter().enumerate() {
            let csv = dir.join(format!("case-{k}.csv"));
            let text = std::fs::read_to_string(&csv).unwrap();
            let t: Truth = serde_json::from_str(
                &std::fs::read_to_string(dir.join(format!("case-{k}.truth.json"))).unwrap(),
            )
            .unwrap();
            let true_kn = at(&base, f, v).vehicle.static_wheel_load_n() / 1e3;
            let rate = members.family().sample_rate_hz;
            let m = Measurement::from_csv(&csv, &text, rate).expect("csv");
            let member = match members.member_for_pass(&m, None, nearest) {
                Ok(j) => j,
                Err(e) => {
                    refused += 1;
                    println!("case {k}: F {f:.3} v {v}: refused: {e}");
                    continue;
                }
            };
            let out = members
                .get(member)
                .identify(&m, None, Extras::NONE)
                .expect("identified");
            let load = out.load.as_ref().expect("a load");
            let err = load.wheel_load_kn / true_kn - 1.0;
            within3 += usize::from(err.abs() <= 0.03);
            inside += usize::from(load.interval_kn[0] <= true_kn && true_kn <= load.interval_kn[1]);
            errors.push(err);
            refuted += usize::from(out.model_class_refuted());
            let b = if out.below_population() {
                Judged {
                    holds: t.l0_mm < out.population.l0_mm[0],
                    l0_mm: [0.0, out.population.l0_mm[0]],
                    class: Severity::Monitor,
                }
            } else {
                judge(out.cms_ranges(), &t, false, insp, urg)
            };
            if !b.holds || out.model_class_refuted() {
                println!(
                    "case {k}: F {f:.3} v {v} true {true_kn:.1} kN read {:.1} kN, member {:.1} kN: {} L0 {:.1} in [{:.1}, {:.1}]",
                    load.wheel_load_kn,
                    load.bank_wheel_load_kn,
                    if out.model_class_refuted() { "REFUTED" } else { "missed" },
                    t.l0_mm,
                    b.l0_mm[0],
                    b.l0_mm[1]
                );
            }
            truth.push((t.l0_mm, severity_class(t.l0_mm, insp, urg)));
            judged.push(b);
        }
        errors.sort_by(f64::total_cmp);
        let q = |p: f64| errors[((errors.len() - 1) as f64 * p).round() as usize] * 100.0;
        println!(
            "{name}: {} cases, refused {refused}, refuted {refuted}; load within 3 % {within3}/{}, inside its interval {inside}/{}; error 5/50/95 % {:+.1} / {:+.1} / {:+.1} %",
            per.len(),
            errors.len(),
            errors.len(),
            q(0.05),
            q(0.5),
            q(0.95)
        );
        println!("{}", method_line("  bank-only", &truth, &judged, top));
    }
}

/// The base calibration at car-body factor `f` and speed `v`.
fn at(base: &CheckedCalibration, f: f64, v: f64) -> CheckedCalibration {
    let mut doc = base.document().clone();
    doc.vehicle.car_body_mass_kg *= f;
    doc.run.speed_km_per_h = v;
    doc.check().expect("calibration at F and v")
}

/// Simulates (once) every case of `per` into `dir`, with the converged reference.
fn simulate(
    base: &CheckedCalibration,
    truths: &[wheelflat::model::Flat],
    per: &[(f64, f64)],
    seed: u64,
    dir: &Path,
) {
    truths.par_iter().enumerate().for_each(|(k, flat)| {
        let csv = dir.join(format!("case-{k}.csv"));
        if csv.exists() {
            return;
        }
        let (f, v) = per[k];
        let model = coverage::converged_model(&at(base, f, v));
        let syn = synthesize(&model, flat, seed.wrapping_add(k as u64), true).expect("sim");
        std::fs::write(
            dir.join(format!("case-{k}.truth.json")),
            serde_json::to_string_pretty(&syn.truth).unwrap(),
        )
        .unwrap();
        // Written whole or not at all: a run stopped midway leaves no half case behind.
        let part = dir.join(format!("case-{k}.csv.part"));
        std::fs::write(&part, &syn.csv).unwrap();
        std::fs::rename(&part, &csv).unwrap();
    });
}
