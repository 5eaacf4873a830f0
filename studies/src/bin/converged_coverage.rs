//! Coverage against the converged reference (issue 32; docs/identification.md,
//! "Discretisation error"):
//! `cargo run --release -p wheelflat-studies --bin converged_coverage -- BANK CASES SEED CACHE [same] [refine]`.
//!
//! CASES truths drawn over the bank's *whole* population (no margin from the edges), each
//! simulated with `Calibration::converged_reference` (`same`: the bank's own mesh and step) and
//! perturbed per the paper's Eq. 1 (`synth`, seed `SEED + case`). The measurements are written
//! to CACHE once (`case-K.csv`, `case-K.truth.json`) and read back on later runs, so variants
//! of the identification settings compare on the same passes. Each case is identified bank-only
//! (and, with `refine`, refined); one line per case, then coverage, refuted cases and the
//! median L0 width for the cases whose flat lost contact and for the others.
//! `WHEELS=round|auto|…` overrides `wheel_roughness`, `DISC=α` `discretisation_fraction`, `DISC_RATIO` `discretisation_dynamic_ratio`; `KAPPA=κ` the bank resolution; `SHARED=0` turns the shared-gain stage off.
use wheelflat_studies::study;

use rayon::prelude::*;
use std::path::PathBuf;
use wheelflat::identify::refine::{refine, RefineSettings};
use wheelflat::identify::synth::{synthesize, Truth};
use wheelflat::identify::Severity;
use wheelflat::identify::{Extras, Identifier, Measurement};
use wheelflat::model::Simulator;
use wheelflat_studies::coverage::{self, judge, method_line, severity_class, Judged};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 5 {
        panic!("usage: converged_coverage BANK CASES SEED CACHE [same] [refine]");
    }
    let (bank, cal) = study::open_bank(&args[1]);
    let cases: usize = args[2].parse().expect("CASES");
    let seed: u64 = args[3].parse().expect("SEED");
    let cache = PathBuf::from(&args[4]);
    let same = args.iter().skip(5).any(|a| a == "same");
    let with_refine = args.iter().skip(5).any(|a| a == "refine");
    let model = if same {
        cal.clone()
    } else {
        coverage::converged_model(&cal)
    };
    std::fs::create_dir_all(&cache).expect("cache folder");
    let truths = coverage::truths_within(&cal, cases, seed, 0.0);
    // The measurements, simulated once.
    truths.par_iter().enumerate().for_each(|(k, flat)| {
        let csv = cache.join(format!("case-{k}.csv"));
        if csv.exists() {
            return;
        }
        let syn = synthesize(&model, flat, seed.wrapping_add(k as u64), true).expect("simulated");
        study::write_case(&cache, k, &syn);
    });
    let mut settings = study::wheels_from_env(cal.identification.clone());
    if let Ok(a) = std::env::var("DISC") {
        settings.discretisation_fraction = a.parse().expect("DISC is a number");
    }
    if let Ok(q) = std::env::var("DISC_RATIO") {
        settings.discretisation_dynamic_ratio = q.parse().expect("DISC_RATIO is a number");
    }
    if let Ok(k) = std::env::var("KAPPA") {
        settings.bank_resolution = k.parse().expect("KAPPA is a number");
    }
    if let Ok(v) = std::env::var("SHARED") {
        settings.shared_gains = v != "0";
    }
    let id = Identifier::new(bank, settings).expect("identifier");
    let sim = Simulator::new(&cal).expect("bank model");
    let (insp, urg, top) = coverage::severity_limits(&cal);
    let mut rows: Vec<(Truth, Judged, Option<Judged>)> = Vec::new();
    // Per case: the wheel named alone and right, and X_p inside its range (bank-only).
    let mut wheel_right = 0;
    let mut wheel_wrong = 0;
    let mut xp_held = 0;
    for k in 0..cases {
        let csv = cache.join(format!("case-{k}.csv"));
        let text = std::fs::read_to_string(&csv).unwrap();
        let t: Truth = serde_json::from_str(
            &std::fs::read_to_string(cache.join(format!("case-{k}.truth.json"))).unwrap(),
        )
        .unwrap();
        let m = Measurement::from_csv(&csv, &text, cal.output.sample_rate_hz).expect("csv");
        let out = id.identify(&m, None, Extras::NONE).expect("identified");
        let b = if out.below_population() {
            let inside = t.l0_mm < out.population.l0_mm[0];
            Judged {
                holds: inside,
                l0_mm: [0.0, out.population.l0_mm[0]],
                class: Severity::Monitor,
            }
        } else {
            judge(out.cms_ranges(), &t, false, insp, urg)
        };
        if let Some(r) = out.cms_ranges() {
            wheel_right += usize::from(t.flat_wheel.is_some_and(|w| r.flat_wheels == [w]));
            wheel_wrong += usize::from(t.flat_wheel.is_some_and(|w| !r.flat_wheels.contains(&w)));
            let x = r.impact_position_m;
            xp_held += usize::from(x[0] <= t.impact_position_m && t.impact_position_m <= x[1]);
        }
        let r = with_refine.then(|| {
            let r = refine(&id, &sim, &out, RefineSettings::default()).expect("refined");
            judge(r.ranges.as_ref(), &t, false, insp, urg)
        });
        println!(
            "{k:>4} {:8} L {:6.1} d {:.3} c {:.3} X {:.3} L0 {:5.1} off {:4.1} ms | bank {} [{:5.1},{:5.1}] cms {}{}",
            t.flat_wheel.map_or("-", |w| w.name()),
            t.length_mm,
            t.depth_mm,
            t.curvature_mm,
            t.impact_position_m,
            t.l0_mm,
            t.contact_loss_ms,
            u8::from(b.holds),
            b.l0_mm[0],
            b.l0_mm[1],
            out.sizing.as_ref().map_or(0, |z| z.cms.len()),
            r.map_or(String::new(), |r| format!(
                " | refined {} [{:5.1},{:5.1}]",
                u8::from(r.holds),
                r.l0_mm[0],
                r.l0_mm[1]
            )),
        );
        rows.push((t, b, r));
    }
    println!(
        "right wheel named alone: {wheel_right} of {cases}, the other wheel alone: {wheel_wrong}; X_p inside its range: {xp_held} of {cases} (bank-only)"
    );
    for (group, lost) in [
        ("lost contact", true),
        ("kept contact", false),
        ("all", false),
    ] {
        let pick: Vec<&(Truth, Judged, Option<Judged>)> = rows
            .iter()
            .filter(|r| group == "all" || (r.0.contact_loss_ms > 0.0) == lost)
            .collect();
        let truth: Vec<(f64, usize)> = pick
            .iter()
            .map(|r| (r.0.l0_mm, severity_class(r.0.l0_mm, insp, urg)))
            .collect();
        println!("{group}: {} cases", pick.len());
        let base: Vec<Judged> = pick.iter().map(|r| r.1).collect();
        println!("{}", method_line("  bank-only", &truth, &base, top));
        if with_refine {
            let refined: Vec<Judged> = pick.iter().filter_map(|r| r.2).collect();
            println!("{}", method_line("  refined", &truth, &refined, top));
        }
    }
}
