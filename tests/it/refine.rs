//! Refinement (`identify --refine`, issue 11): on a CI-sized bank it keeps the truth and
//! narrows the answer, it is the same on any thread count, its settings have ranges, and the
//! CLI reports it beside the bank-only answer.

use crate::common;
use crate::common::{cached_bank, narrow_calibration, wheelflat, CachedBank};
use wheelflat::bank::Bank;
use wheelflat::identify::refine::{refine, RefineSettings, RefineStrategy};
use wheelflat::identify::{Extras, Identifier};
use wheelflat::model::Simulator;
use wheelflat_testkit::coverage::{self, judge, severity_limits};

/// Truths held and L0 widths of one kind of answer over seeded cases.
#[derive(Default)]
struct Tally {
    covered: usize,
    widths: Vec<f64>,
}

impl Tally {
    /// Counts an answer (`ranges`) against its truth.
    fn add(
        &mut self,
        ranges: Option<&wheelflat::identify::result::ParamRanges>,
        t: &wheelflat::identify::synth::Truth,
        insp: f64,
        urg: f64,
    ) {
        let j = judge(ranges, t, false, insp, urg);
        self.covered += usize::from(j.holds);
        if j.l0_mm[1].is_finite() {
            self.widths.push(j.l0_mm[1] - j.l0_mm[0]);
        }
    }

    /// The median L0 width (NaN with none).
    fn median_width(&mut self) -> f64 {
        self.widths.sort_by(f64::total_cmp);
        self.widths
            .get(self.widths.len() / 2)
            .copied()
            .unwrap_or(f64::NAN)
    }
}

/// A CI-sized bank, 2,000 instances of the narrow profile.
fn small_bank() -> &'static CachedBank {
    cached_bank("refine-bank", narrow_calibration, 2000, 1000)
}

fn identifier() -> Identifier {
    let (dir, cal) = small_bank();
    Identifier::new(Bank::open(dir).unwrap(), cal.identification.clone()).unwrap()
}

/// The CI-sized version of the refinement's acceptance figures: 30 seeded cases, 320
/// simulations a case in 2 rounds. Measured on this bank (2-core development machine,
/// 2026-11-25): see the numbers printed and docs/performance.md ("Refinement"). The limits —
/// coverage ≥ 0.9 (3 misses of 30 allowed) and a median refined L0 width at most 0.8 of the
/// bank-only one — were set after that measurement; the bank-only answer fails the second by
/// construction, so the test tells the two apart.
///
/// The mechanism is tested without issue 32's discretisation allowance: with it (the default)
/// the refinement cannot rule out the deep flats that land either and narrows less on this
/// landing-heavy narrow bank — bank-only 1.000 / 11.5 mm, refined 0.967 / 9.9 mm here
/// (2026-11-26; the full bank's figures in docs/identification.md, "Discretisation error").
///
/// Since issue 63 the spread strategy is not the default; this test is in the acceptance tier
/// (the default tier's `settling_the_bounds_narrows_the_answer_and_keeps_the_truth` runs the
/// spread refinement on the same cases and checks its coverage).
#[test]
#[ignore = "acceptance: the spread refinement against the bank-only answer, 30 cases"]
fn refinement_keeps_the_truth_and_narrows_the_answer() {
    let (dir, cal) = small_bank();
    let (insp, urg, _) = severity_limits(cal);
    let mut without = cal.identification.clone();
    without.discretisation_fraction = 0.0;
    let id = Identifier::new(Bank::open(dir).unwrap(), without).unwrap();
    let sim = Simulator::new(cal).unwrap();
    let settings = RefineSettings {
        strategy: RefineStrategy::Spread,
        simulations: 320,
        ..RefineSettings::default()
    };
    let mut tally = [Tally::default(), Tally::default()];
    let truths = coverage::truths(cal, 30, 11);
    for (case, flat) in truths.iter().enumerate() {
        let (m, t) = coverage::case(cal, flat, 11, case).unwrap();
        let out = id.identify(&m, None, Extras::NONE).unwrap();
        let r = refine(&id, &sim, &out, settings).unwrap();
        let survivors = out.sizing.as_ref().map_or(0, |z| z.cms.len());
        assert_eq!(r.simulations, if survivors == 0 { 0 } else { 320 });
        tally[0].add(out.cms_ranges(), &t, insp, urg);
        tally[1].add(r.ranges.as_ref(), &t, insp, urg);
    }
    let (w_bank, w_refined) = (tally[0].median_width(), tally[1].median_width());
    let covered = [tally[0].covered, tally[1].covered];
    let n = truths.len() as f64;
    println!(
        "bank-only: coverage {:.3}, median L0 width {w_bank:.1} mm; refined: coverage {:.3}, median L0 width {w_refined:.1} mm",
        covered[0] as f64 / n,
        covered[1] as f64 / n
    );
    assert!(
        covered[1] as f64 / n >= 0.9,
        "refined coverage {}",
        covered[1]
    );
    assert!(
        w_refined <= 0.8 * w_bank,
        "refined width {w_refined} mm against the bank's {w_bank} mm"
    );
}

/// Issue 63: settling the L0 bounds (the default strategy) answers narrower than spreading
/// the same budget over every surviving cell (the refinement before it), and keeps the truth
/// as often. 30 seeded cases on the CI-sized bank with the discretisation allowance (the
/// default), at most 320 simulations a case either way. Measured on this bank (2-core
/// development machine, 2026-11-29, κ ¼): spread coverage 1.000, median L0 width 8.9 mm, 9,600
/// simulations; bounds 0.967, 7.1 mm, 6,080 simulations. The limits — coverage ≥ 0.9 for both
/// and the settled median L0 width at most 0.85 of the spread one's — were set after that
/// measurement; today's refinement (spread) fails the second by construction.
#[test]
fn settling_the_bounds_narrows_the_answer_and_keeps_the_truth() {
    let (_, cal) = small_bank();
    let (insp, urg, _) = severity_limits(cal);
    let id = identifier();
    let sim = Simulator::new(cal).unwrap();
    let strategies = [RefineStrategy::Spread, RefineStrategy::Bounds];
    let (mut tally, mut sims) = ([Tally::default(), Tally::default()], [0usize; 2]);
    let truths = coverage::truths(cal, 30, 11);
    for (case, flat) in truths.iter().enumerate() {
        let (m, t) = coverage::case(cal, flat, 11, case).unwrap();
        let out = id.identify(&m, None, Extras::NONE).unwrap();
        for (k, strategy) in strategies.into_iter().enumerate() {
            let settings = RefineSettings {
                strategy,
                simulations: 320,
                ..RefineSettings::default()
            };
            let r = refine(&id, &sim, &out, settings).unwrap();
            assert!(r.simulations <= 320, "case {case}: {}", r.simulations);
            sims[k] += r.simulations;
            if let (RefineStrategy::Bounds, Some(ranges)) = (strategy, r.ranges.as_ref()) {
                assert!(r.bounds_settled.is_some(), "case {case}");
                // The kept flats lie inside the answer (their cells around them).
                let (kept, l0) = (r.kept_l0_mm.unwrap(), ranges.l0_mm);
                assert!(
                    l0[0] <= kept[0] + 1e-9 && kept[1] <= l0[1] + 1e-9,
                    "case {case}"
                );
            }
            tally[k].add(r.ranges.as_ref(), &t, insp, urg);
        }
    }
    let (w_spread, w_bounds) = (tally[0].median_width(), tally[1].median_width());
    let covered = [tally[0].covered, tally[1].covered];
    let n = truths.len() as f64;
    println!(
        "spread: coverage {:.3}, median L0 width {w_spread:.1} mm, {} simulations; bounds: coverage {:.3}, median L0 width {w_bounds:.1} mm, {} simulations",
        covered[0] as f64 / n,
        sims[0],
        covered[1] as f64 / n,
        sims[1]
    );
    for (k, c) in covered.iter().enumerate() {
        assert!(*c as f64 / n >= 0.9, "{:?} coverage {c}", strategies[k]);
    }
    assert!(
        w_bounds <= 0.85 * w_spread,
        "settled width {w_bounds} mm against the spread {w_spread} mm"
    );
}

/// Reproducible: the same refinement on one thread and on two (the simulations run on the
/// rayon pool in batches) gives the same answer to the bit.
#[test]
fn refinement_is_the_same_on_any_thread_count() {
    let (_, cal) = small_bank();
    let id = identifier();
    let sim = Simulator::new(cal).unwrap();
    let flat = &coverage::truths(cal, 3, 5)[1];
    let (m, _) = coverage::case(cal, flat, 5, 1).unwrap();
    let out = id.identify(&m, None, Extras::NONE).unwrap();
    let settings = RefineSettings {
        simulations: 96,
        ..RefineSettings::default()
    };
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| refine(&id, &sim, &out, settings).unwrap())
    };
    let (a, b) = (run(1), run(2));
    assert!(a.ranges.is_some());
    assert_eq!(a.ranges, b.ranges);
    assert_eq!(a.rounds, b.rounds);
}

#[test]
fn refinement_settings_have_ranges() {
    for (simulations, rounds, what) in [
        (0, 2, "refine simulations = 0"),
        (20_001, 2, "refine simulations = 20001"),
        (640, 0, "refine rounds = 0"),
        (640, 9, "refine rounds = 9"),
    ] {
        let s = RefineSettings {
            simulations,
            rounds,
            ..RefineSettings::default()
        };
        let e = s.check().unwrap_err().to_string();
        assert!(e.contains(what), "{e}");
    }
    // The bounds strategy's own settings (issue 63).
    for (per_round, tolerance_mm, what) in [
        (4, 0.5, "refine simulations a round = 4"),
        (2000, 0.5, "refine simulations a round = 2000"),
        (64, 0.01, "refine bound tolerance (mm) = 0.01"),
        (64, f64::NAN, "refine bound tolerance (mm) = NaN"),
    ] {
        let s = RefineSettings {
            per_round,
            tolerance_mm,
            ..RefineSettings::default()
        };
        let e = s.check().unwrap_err().to_string();
        assert!(e.contains(what), "{e}");
    }
    assert!(RefineSettings::default().check().is_ok());
}

/// `identify --refine` prints the refined answer after the bank-only one and writes it into
/// identification.json; a budget out of range is refused naming it.
#[test]
fn identify_refine_reports_beside_the_bank_only_answer() {
    let (dir, cal) = small_bank();
    let tmp = tempfile::tempdir().unwrap();
    let csv = tmp.path().join("m.csv");
    std::fs::write(&csv, common::narrow_measurement(cal, 3, true)).unwrap();
    let identify = |out: &std::path::Path, simulations: &str| {
        wheelflat()
            .args(["identify", "--bank"])
            .arg(dir)
            .arg("--measured")
            .arg(&csv)
            .arg("--out")
            .arg(out)
            .args(["--refine", "--refine-simulations", simulations])
            .output()
            .unwrap()
    };
    let out = tmp.path().join("out");
    let run = identify(&out, "64");
    let text = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let bank_line = text
        .find("model instances survive")
        .expect("bank-only verdict");
    let refined_line = text.find("refined: ").expect("refined verdict");
    assert!(bank_line < refined_line, "{text}");
    assert!(text.contains("refined verdict: "), "{text}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("identification.json")).unwrap())
            .unwrap();
    assert_eq!(json["refinement"]["simulations"], 64);
    assert!(json["refinement"]["ranges"]["l0_mm"].is_array());

    let refused = identify(&tmp.path().join("out2"), "0");
    assert!(!refused.status.success());
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(err.contains("refine simulations = 0"), "{err}");
    assert!(!tmp.path().join("out2").join("identification.json").exists());
}

/// `watch --refine` refines every answer: the result JSON carries the refinement and the log
/// line its L0 range.
#[test]
fn watch_refine_refines_each_answer() {
    let (dir, cal) = small_bank();
    let tmp = tempfile::tempdir().unwrap();
    let inbox = tmp.path().join("inbox");
    std::fs::create_dir_all(&inbox).unwrap();
    std::fs::write(
        inbox.join("m.csv"),
        common::narrow_measurement(cal, 5, true),
    )
    .unwrap();
    let out = tmp.path().join("out");
    let run = wheelflat()
        .args(["watch", "--once", "--bank"])
        .arg(dir)
        .arg("--inbox")
        .arg(&inbox)
        .arg("--out")
        .arg(&out)
        .args(["--refine", "--refine-simulations", "48"])
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{log}{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(
        log.contains("m.csv ok") && log.contains("Refined: L0 in ["),
        "{log}"
    );
    let json: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("m").join("identification.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(json["refinement"]["simulations"], 48);
}

/// Issue 56, landings resolved by simulation (`refine_landings`): the same refinement with a
/// landing budget simulates landing flats at the L0 bounds on the landings calibration and only
/// removes flats from what it would answer without, within its budget, saying so; the ranges
/// stay inside the ones without.
#[test]
fn the_landing_check_only_removes_flats_within_its_budget() {
    let (_, cal) = small_bank();
    let id = identifier();
    let sim = Simulator::new(cal).unwrap();
    let with = |landings| RefineSettings {
        simulations: 160,
        landings: Some(landings),
        ..RefineSettings::default()
    };
    let mut simulated = 0;
    for (case, flat) in coverage::truths(cal, 6, 17).iter().enumerate() {
        let (m, _) = coverage::case(cal, flat, 17, case).unwrap();
        let out = id.identify(&m, None, Extras::NONE).unwrap();
        let plain = refine(&id, &sim, &out, with(0)).unwrap();
        let checked = refine(&id, &sim, &out, with(16)).unwrap();
        assert_eq!(plain.landings_simulated, 0);
        assert!(checked.landings_simulated <= 16, "case {case}");
        assert_eq!(
            checked.simulations,
            plain.simulations + checked.landings_simulated,
            "case {case}"
        );
        simulated += checked.landings_simulated;
        let (Some(a), Some(b)) = (plain.ranges.as_ref(), checked.ranges.as_ref()) else {
            continue;
        };
        // Only removed: every flat it drops counted (when it would drop every survivor, the
        // answer before the check stands).
        if checked.survivors < plain.survivors {
            assert_eq!(
                checked.survivors + checked.landings_removed,
                plain.survivors,
                "case {case}"
            );
        } else {
            assert_eq!(checked.survivors, plain.survivors, "case {case}");
        }
        assert!(
            a.l0_mm[0] <= b.l0_mm[0] && b.l0_mm[1] <= a.l0_mm[1],
            "case {case}"
        );
        if checked.landings_simulated > 0 {
            assert!(
                checked.summary.contains("landings calibration"),
                "{}",
                checked.summary
            );
        }
    }
    assert!(simulated > 0, "some case has landing flats at its bounds");
}
