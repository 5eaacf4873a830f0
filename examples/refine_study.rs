//! Refinement study (issue 11): the bank-only answer and the refined one
//! (`wheelflat::identify::refine`) on seeded cases over the whole population.
//! `cargo run --release --example refine_study -- BANK CASES SEED [same|finer] [SIMULATIONS] [ROUNDS]`
//! (`finer`: measurements simulated with 8 elements per bay and half the time steps).
//! `SHOW=CASE` prints that case's rounds.
//!
//! (The box-filling refinement measured on 2026-11-23 is this file's earlier version, in git
//! history before 2026-11-25; docs/decisions.md has its numbers.)
#[path = "common/study.rs"]
mod study;

use study::Study;
use wheelflat::identify::coverage::{self, judge, method_line, severity_class, Judged};
use wheelflat::identify::refine::{refine, RefineMode, RefineSettings, WholeRecord};
use wheelflat::identify::{Extras, Identifier};
use wheelflat::model::Simulator;

fn main() {
    let study = Study::from_args("[SIMULATIONS] [ROUNDS]");
    let (cases, seed) = (study.cases, study.seed);
    let settings = RefineSettings {
        simulations: study.arg(5, 640),
        rounds: study.arg(6, 2),
        kappa: std::env::var("KAPPA").ok().map(|v| v.parse().unwrap()),
        mode: match std::env::var("WITNESS") {
            Ok(m) => RefineMode::Witnesses {
                margin: m.parse().unwrap(),
            },
            Err(_) => RefineMode::Cells,
        },
        // WHOLE=0: every sample; WHOLE=w: extremes over ±w; WHOLE=s: smoothed samples.
        whole_record: std::env::var("WHOLE").ok().map(|w| match w.as_str() {
            "0" => WholeRecord::Samples,
            "s" => WholeRecord::Smoothed,
            w => WholeRecord::Extremes(w.parse().unwrap()),
        }),
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
    for (case, flat) in coverage::truths(&cal, cases, seed).iter().enumerate() {
        let (m, t) = coverage::case(&meas_cal, flat, seed, case).unwrap();
        let out = id.identify(&m, None, Extras::NONE).unwrap();
        let r = refine(&id, &sim, &out, settings).unwrap();
        let b = judge(out.falsifications[0].ranges.as_ref(), &t, false, insp, urg);
        let n = judge(r.ranges.as_ref(), &t, false, insp, urg);
        let cls = severity_class(t.l0_mm, insp, urg);
        println!(
            "{case:>3} L {:6.1} d {:.3} X {:.3} L0 {:5.1} cls {cls} | bank {} [{:5.1},{:5.1}] cls {} cms {} | refined {} [{:5.1},{:5.1}] cls {} rounds {:?}{} {:.0} ms",
            t.length_mm, t.depth_mm, t.impact_position_m, t.l0_mm,
            u8::from(b.0), b.1[0], b.1[1], b.2, out.cms.len(),
            u8::from(n.0), n.1[0], n.1[1], n.2,
            r.rounds.iter().map(|x| x.survivors).collect::<Vec<_>>(),
            if r.stopped_early { " (stopped early)" } else { "" },
            r.time_ms
        );
        if std::env::var("SHOW").is_ok_and(|v| v == case.to_string()) {
            for (i, x) in r.rounds.iter().enumerate() {
                eprintln!("round {i}: {x:?}");
            }
        }
        truth.push((t.l0_mm, cls));
        base.push(b);
        refined.push(n);
        times.push(r.time_ms);
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
