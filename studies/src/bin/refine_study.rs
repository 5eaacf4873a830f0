//! Refinement study (issue 11): the bank-only answer and the refined one
//! (`wheelflat::identify::refine`) on seeded cases over the whole population.
//! `cargo run --release -p wheelflat-studies --bin refine_study -- BANK CASES SEED [same|finer] [SIMULATIONS] [ROUNDS]`
//! (`finer`: measurements simulated with 8 elements per bay and half the time steps).
//! (`converged`: measurements simulated with `Calibration::converged_reference`.)
//! `SHOW=CASE` prints that case's rounds; `INSET=0` draws the truths over the whole population
//! (default 0.05: 5 % of each range kept from the edges). The summary is repeated for the
//! cases whose flat lost contact and for the others.
//!
//! (The box-filling refinement measured on 2026-11-23 is this file's earlier version, in git
//! history before 2026-11-25; docs/decisions.md has its numbers. The witness search
//! (`WITNESS=margin`) and the whole-record last round (`WHOLE=0|w|s`) were measured with this
//! program at commit 1e7f4f2, before issue 34 took those variants out of the product.)
use wheelflat_studies::study;

use study::Study;
use wheelflat::identify::refine::{refine, RefineSettings};
use wheelflat::identify::{Extras, Identifier};
use wheelflat::model::Simulator;
use wheelflat_studies::coverage::{self, judge, method_line, severity_class, Judged};

fn main() {
    let study = Study::from_args("[SIMULATIONS] [ROUNDS]");
    let (cases, seed) = (study.cases, study.seed);
    let settings = RefineSettings {
        simulations: study.arg(5, 640),
        rounds: study.arg(6, 2),
        kappa: std::env::var("KAPPA").ok().map(|v| v.parse().unwrap()),
        ends_weight: std::env::var("ENDS").map_or(4, |w| w.parse().unwrap()),
        ..RefineSettings::default()
    };
    let Study {
        bank,
        cal,
        meas_cal,
        ..
    } = study;
    let (insp, urg, top) = coverage::severity_limits(&cal);
    let sim = Simulator::new(&cal).unwrap();
    let id = Identifier::new(bank, cal.identification.clone()).unwrap();
    let mut truth: Vec<(f64, usize)> = Vec::new();
    let (mut base, mut refined): (Vec<Judged>, Vec<Judged>) = (Vec::new(), Vec::new());
    let mut times: Vec<f64> = Vec::new();
    let inset: f64 = std::env::var("INSET").map_or(0.05, |v| v.parse().unwrap());
    let mut lost: Vec<bool> = Vec::new();
    for (case, flat) in coverage::truths_within(&cal, cases, seed, inset)
        .iter()
        .enumerate()
    {
        let (m, t) = coverage::case(&meas_cal, flat, seed, case).unwrap();
        let out = id.identify(&m, None, Extras::NONE).unwrap();
        let r = refine(&id, &sim, &out, settings).unwrap();
        // A flat not detected was not sized: no ranges, no CMS.
        let z = out.sizing.as_ref();
        let bank_ranges = z.and_then(|z| z.falsifications.first()?.ranges.as_ref());
        let b = judge(bank_ranges, &t, false, insp, urg);
        let n = judge(r.ranges.as_ref(), &t, false, insp, urg);
        let cls = severity_class(t.l0_mm, insp, urg);
        println!(
            "{case:>3} L {:6.1} d {:.3} X {:.3} L0 {:5.1} off {:4.1} ms cls {cls} | bank {} [{:5.1},{:5.1}] cls {} cms {} | refined {} [{:5.1},{:5.1}] cls {} rounds {:?}{} {:.0} ms",
            t.length_mm, t.depth_mm, t.impact_position_m, t.l0_mm, t.contact_loss_ms,
            u8::from(b.holds), b.l0_mm[0], b.l0_mm[1], b.class_index(), z.map_or(0, |z| z.cms.len()),
            u8::from(n.holds), n.l0_mm[0], n.l0_mm[1], n.class_index(),
            r.rounds.iter().map(|x| x.survivors).collect::<Vec<_>>(),
            if r.stopped_early { " (stopped early)" } else { "" },
            r.time_ms
        );
        if std::env::var("SHOW").is_ok_and(|v| v == case.to_string()) {
            for (i, x) in r.rounds.iter().enumerate() {
                eprintln!("round {i}: {x:?}");
            }
        }
        lost.push(t.contact_loss_ms > 0.0);
        truth.push((t.l0_mm, cls));
        base.push(b);
        refined.push(n);
        times.push(r.time_ms);
    }
    for (group, want) in [("lost contact", true), ("kept contact", false)] {
        let pick = |v: &[Judged]| -> Vec<Judged> {
            v.iter()
                .zip(&lost)
                .filter(|(_, &l)| l == want)
                .map(|(j, _)| *j)
                .collect()
        };
        let t: Vec<(f64, usize)> = truth
            .iter()
            .zip(&lost)
            .filter(|(_, &l)| l == want)
            .map(|(t, _)| *t)
            .collect();
        if t.is_empty() {
            continue;
        }
        println!("{group}: {} cases", t.len());
        println!("{}", method_line("  bank-only", &t, &pick(&base), top));
        println!("{}", method_line("  refined", &t, &pick(&refined), top));
    }
    times.sort_by(f64::total_cmp);
    println!("{}", method_line("bank-only", &truth, &base, top));
    println!(
        "{}",
        method_line(
            &format!(
                "refined ({} simulations, {} rounds)",
                settings.simulations, settings.rounds
            ),
            &truth,
            &refined,
            top
        )
    );
    println!(
        "refinement time: median {:.0} ms, max {:.0} ms",
        times[times.len() / 2],
        times[times.len() - 1]
    );
}
