//! Severity bound (issue 11): in how many seeded cases does a flat of a *higher* severity class
//! than the truth fit the whole record exactly? Such a flat cannot be ruled out by the
//! measurement at all, so any answer that keeps every flat the measurement cannot exclude
//! over-calls that case.
//!
//! For each case the bank-only identification's candidate model set is searched, deepest first,
//! for a bank instance (an exact simulation, no cell widening) that passes **every sample of
//! every sensor window** within the thresholds at per-point probability `φ^(1/N)`, N the number
//! of samples (Šídák over the whole record; the prediction's own thresholds where it is the
//! larger force, as falsification judges). Bank instances only: simulated flats could add more,
//! so the count is a floor.
//!
//! `cargo run --release -p wheelflat-studies --bin severity_bound -- BANK CASES SEED [same|finer] [MAX_CHECKED]`
use wheelflat_studies::study;

use study::{Study, WholeCase};
use wheelflat_studies::coverage::{self, severity_class};

fn main() {
    let study = Study::from_args("[MAX_CHECKED]");
    let (cases, seed) = (study.cases, study.seed);
    let max_checked: usize = study.arg(5, 400);
    let (id, cal, meas_cal) = study.into_identifier();
    let (insp, urg, _) = coverage::severity_limits(&cal);
    let (mut higher, mut truth_class_only, mut nothing) = (0usize, 0usize, 0usize);
    for (case, flat) in coverage::truths(&cal, cases, seed).iter().enumerate() {
        let t0 = std::time::Instant::now();
        let c = WholeCase::new(&id, &meas_cal, flat, seed, case);
        let (out, t, cls, p, used) = (&c.out, &c.truth, c.class, c.p, &c.axes);
        let total: usize = out.series.iter().map(|s| s.values_kn.len()).sum();
        let mut members = out.sizing.as_ref().map_or_else(Vec::new, |z| z.cms.clone());
        members.sort_by(|x, y| y.l0_mm.total_cmp(&x.l0_mm));
        let mut found: Option<(u32, f64)> = None;
        let mut checked = 0;
        for s in members.iter().take(max_checked) {
            if severity_class(s.l0_mm, insp, urg) <= cls {
                break;
            }
            checked += 1;
            let stored = id.bank().read_instance(s.instance as usize).unwrap();
            let passes = out.series.iter().zip(used).all(|(ser, &ax)| {
                ser.values_kn
                    .iter()
                    .zip(&stored.forces_kn[ax])
                    .all(|(&y, &g)| {
                        let (lo, hi) = id.band(y, g as f64, p);
                        (lo..=hi).contains(&(g as f64 - y))
                    })
            });
            if passes {
                found = Some((s.instance, s.l0_mm));
                break;
            }
        }
        match found {
            Some(_) => higher += 1,
            None if checked == 0 => truth_class_only += 1,
            None => nothing += 1,
        }
        println!(
            "{case:>3} L {:6.1} d {:.3} c {:.3} L0 {:5.1} cls {cls} | CMS {} | {} ({} checked) {:.1} s",
            t.length_mm,
            t.depth_mm,
            t.curvature_mm,
            t.l0_mm,
            out.sizing.as_ref().map_or(0, |z| z.cms.len()),
            match found {
                Some((k, l0)) => format!(
                    "instance {k} (L0 {l0:.1} mm, class {}) fits all {total} samples",
                    severity_class(l0, insp, urg)
                ),
                None => "no instance of a higher class fits the whole record".into(),
            },
            checked,
            t0.elapsed().as_secs_f64()
        );
    }
    println!(
        "a bank instance of a higher class than the truth fits the whole record exactly: {higher} of {cases} cases (no candidate of a higher class: {truth_class_only}; candidates of a higher class, none fitting: {nothing}) -> severity right at most {:.2} for an answer that keeps every such flat",
        (cases - higher) as f64 / cases as f64
    );
}
