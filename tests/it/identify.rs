//! Identification on a small bank: measurement checks, alignment, the EDMF promise on seeded
//! synthetic cases (coverage), EIP against random subsets.

use crate::common::{cached_bank, narrow_calibration, CachedBank};
use std::path::Path;
use wheelflat::bank::Bank;
use wheelflat::identify::result::AlignmentMethod;
use wheelflat::identify::{synth, Extras, Identifier, IdentifyError, Measurement};
use wheelflat::model::Flat;
use wheelflat_testkit::coverage;

/// A CI-sized bank, 2,000 instances of the narrow profile.
fn small_bank() -> &'static CachedBank {
    cached_bank("identify-bank", narrow_calibration, 2000, 1000)
}

fn identifier() -> Identifier {
    let (dir, cal) = small_bank();
    Identifier::new(Bank::open(dir).unwrap(), cal.identification.clone()).unwrap()
}

fn parse(text: &str) -> Result<Measurement, IdentifyError> {
    Measurement::from_csv(Path::new("field.csv"), text, 2500.0)
}

#[test]
fn bad_measurements_are_named_by_file_line_and_value() {
    let cases = [
        ("time_s,rps1_kn\n0.0,1.0\n0.0004,NaN\n", "field.csv, line 3: `rps1_kn` = `NaN` is not a finite number"),
        ("time_s,rps1_kn\n0.0,1.0\n0.0004,2.0\n0.0004,3.0\n", "line 4: time 0.0004 s does not increase"),
        ("time_s,rps1_kn\n0.0,1.0\n0.001,2.0\n", "line 3: time step 0.001000 s (1000.0 Hz) does not match the bank's sample rate 2500 Hz"),
        ("time_s,rps1_n\n0.0,1.0\n", "line 1: column `rps1_n` is in N"),
        ("time_s,rps1_kn\n0.0,1.0\n0.0004,20000.0\n", "reaches 20000: that looks like newtons"),
        ("time_s,rps1_kn\n0.0,1.0\n", "only 1 data rows"),
        ("t,rps1_kn\n0.0,1.0\n", "line 1: the header must start with `time_s`"),
        ("time_s,rps1_kn,rps2_kn\n0.0,1.0\n", "line 2: 2 fields, the header has 3"),
    ];
    for (text, expected) in cases {
        let e = parse(text).unwrap_err().to_string();
        assert!(e.contains(expected), "{e}\n  expected: {expected}");
    }
}

#[test]
fn unknown_or_missing_sensors_and_short_records_are_errors() {
    let id = identifier();
    let (_, cal) = small_bank();
    let flat = Flat::from_mm(60.0, 0.45, 0.05, 12.4).unwrap();
    let syn = synth::synthesize(cal, &flat, 3, true).unwrap();
    let renamed = syn.csv.replace("rps3_kn", "rps9_kn");
    let e = id
        .identify(&parse(&renamed).unwrap(), None, Extras::NONE)
        .unwrap_err()
        .to_string();
    assert!(e.contains("sensor `rps9` is not in the bank"), "{e}");
    let m = parse(&syn.csv).unwrap();
    let e = id
        .identify(&m, Some(&["rps7".to_string()]), Extras::NONE)
        .unwrap_err()
        .to_string();
    assert!(e.contains("`rps7` was asked for"), "{e}");
    // Cut the record short: the last windows are no longer covered.
    let short: String = syn
        .csv
        .lines()
        .take(900)
        .map(|l| format!("{l}\n"))
        .collect();
    let e = id
        .identify(&parse(&short).unwrap(), None, Extras::NONE)
        .unwrap_err()
        .to_string();
    assert!(e.contains("needs samples from"), "{e}");
}

#[test]
fn cross_correlation_finds_the_same_shift_as_the_laser_trigger() {
    let id = identifier();
    let (_, cal) = small_bank();
    let flat = Flat::from_mm(55.0, 0.4, 0.05, 12.42).unwrap();
    let with = synth::synthesize(cal, &flat, 5, true).unwrap();
    let without = synth::synthesize(cal, &flat, 5, false).unwrap();
    let a = id
        .identify(&parse(&with.csv).unwrap(), None, Extras::NONE)
        .unwrap();
    let b = id
        .identify(&parse(&without.csv).unwrap(), None, Extras::NONE)
        .unwrap();
    assert_eq!(a.alignment.method, AlignmentMethod::LaserTrigger);
    assert_eq!(b.alignment.method, AlignmentMethod::CrossCorrelation);
    // Written as they always were.
    let json = serde_json::to_value(&a.alignment).unwrap();
    assert_eq!(json["method"], "laser trigger");
    // The trigger gives the shift exactly; cross-correlation with the flat-free template to
    // within one sample (0.4 ms): the flat's impacts pull the correlation peak by a sample.
    assert!((a.alignment.shift_s - with.truth.shift_s).abs() < 1e-6);
    assert!(
        (b.alignment.shift_s - with.truth.shift_s).abs() < 0.41e-3,
        "{} vs {}",
        b.alignment.shift_s,
        with.truth.shift_s
    );
    assert!(b.alignment.correlation.unwrap() > 0.95);
}

/// Issue #4's acceptance test, CI-sized: 50 seeded synthetic cases with truths between the
/// bank's instances and errors drawn inside the uncertainty table. EDMF promises the truth
/// survives with probability φ = 0.95; on a finite bank that holds once each instance is judged
/// for its cell (`bank_resolution`, see `identify::cells`). Measured: coverage 0.98, median CMS
/// 82, random subsets 262 on average (README, "Identification").
/// Issue 11, CI-sized: the answer must come from the measurement, not from the population's
/// edge. On the same 40 seeded cases, the method (cells in the sensitivity-stretched metric,
/// envelope points at the impact spikes) must hold the truth in ≥ 95 % of them, give a median
/// L0 width of at most ¾ of the bank's L0 range, and bring the upper L0 bound below the bank's
/// top in at least half of the cases whose truth lies more than 2 mm under it; the method
/// before (cells in the plain unit cube, EIP alone) must fail the last two.
///
/// Measured on this bank (2026-11-24): method 1.00, 8.9 mm, 0.60 of 35; before 1.00, 12.8 mm
/// (the whole of this bank's L0 range, 31–43.8 mm), 0.00. The width and share limits were set
/// after that measurement: issue 11's own figures (13 mm, 0.80) are for the full default bank,
/// whose L0 range is 3× this one's (docs/performance.md, "Informative answers").
///
/// The mechanism is tested without issue 32's discretisation allowance (both sides): with it,
/// deep flats that land can no longer be ruled out on this landing-heavy narrow bank, and the
/// default settings give 1.00, 12.8 mm and 0.26 of 35 here (2026-11-26) — the allowance's
/// price, measured on the full bank in docs/identification.md ("Discretisation error").
#[test]
fn upper_l0_bound_comes_from_the_measurement_not_the_population_edge() {
    use wheelflat::bank::neighbours::neighbour_graph_weighted;
    use wheelflat_testkit::coverage::{judge, severity_limits};
    let (dir, cal) = small_bank();
    let (insp, urg, top) = severity_limits(cal);
    let mut settings = cal.identification.clone();
    settings.discretisation_fraction = 0.0;
    let new = Identifier::new(Bank::open(dir).unwrap(), settings.clone()).unwrap();
    let mut before_settings = settings;
    before_settings.envelope_windows_per_sensor = 0;
    let bank = Bank::open(dir).unwrap();
    let plain =
        neighbour_graph_weighted(&bank.read_parameters().unwrap(), &cal.population, [1.0; 4]);
    let before = Identifier::with_neighbours(bank, before_settings, Some(plain)).unwrap();
    let truths = coverage::truths(cal, 40, 11);
    let (mut covered, mut below, mut eligible) = ([0usize; 2], [0usize; 2], 0usize);
    let mut widths: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
    for (case, flat) in truths.iter().enumerate() {
        let (m, t) = coverage::case(cal, flat, 11, case).unwrap();
        let under = t.l0_mm < top - 2.0;
        eligible += usize::from(under);
        for (k, id) in [&new, &before].into_iter().enumerate() {
            let x = id.identify(&m, None, Extras::NONE).unwrap();
            let j = judge(x.cms_ranges(), &t, false, insp, urg);
            covered[k] += usize::from(j.holds);
            below[k] += usize::from(under && j.l0_mm[1] < top - 0.05);
            if j.l0_mm[1].is_finite() {
                widths[k].push(j.l0_mm[1] - j.l0_mm[0]);
            }
        }
    }
    let n = truths.len() as f64;
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
    };
    let (w0, w1) = (median(&mut widths[0]), median(&mut widths[1]));
    let share = |b: usize| b as f64 / eligible.max(1) as f64;
    println!(
        "method: coverage {:.3}, median L0 width {w0:.1} mm, upper below the top {:.2} of {eligible}",
        covered[0] as f64 / n,
        share(below[0])
    );
    println!(
        "before: coverage {:.3}, median L0 width {w1:.1} mm, upper below the top {:.2} of {eligible}",
        covered[1] as f64 / n,
        share(below[1])
    );
    let bottom = wheelflat::model::Flat::fresh_length_mm(
        cal.population.depth_mm[0],
        cal.vehicle.wheel_radius_m,
    );
    let range = top - bottom;
    assert!(covered[0] as f64 / n >= 0.95, "coverage {}", covered[0]);
    assert!(
        w0 <= 0.75 * range,
        "median width {w0} of a {range} mm range"
    );
    assert!(
        share(below[0]) >= 0.5,
        "upper bound below the top in {}",
        share(below[0])
    );
    // The same checks on the method before fail: the test can tell the two apart.
    assert!(
        w1 > 0.75 * range && share(below[1]) < 0.5,
        "before: {w1} mm, {}",
        share(below[1])
    );
}

#[test]
fn truth_is_covered_in_at_least_95_percent_of_seeded_cases() {
    let id = identifier();
    let (_, cal) = small_bank();
    let results = coverage::run(&id, cal, 50, 11, true).unwrap();
    let (cov, width, size) = coverage::summarise(&results, |r| r.eip);
    let (eq_cov, eq_width, eq_size) = coverage::summarise(&results, |r| r.equidistant);
    let random_mean: f64 =
        results.iter().map(|r| r.random_mean).sum::<f64>() / results.len() as f64;
    println!("EIP: coverage {cov:.2}, median L0 width {width:.1} mm, median CMS {size}");
    println!(
        "equidistant: coverage {eq_cov:.2}, median L0 width {eq_width:.1} mm, median CMS {eq_size}"
    );
    println!("random subsets: mean CMS {random_mean:.1}");
    // EDMF's promise at φ = 0.95 (issue #4).
    assert!(cov >= 0.95, "coverage {cov}");
    // The entropy-selected points keep far fewer instances than random subsets of the same
    // size (paper: 15 against 180): at most half as many on average.
    let eip_mean = results.iter().map(|r| r.eip.0 as f64).sum::<f64>() / results.len() as f64;
    println!("EIP mean CMS {eip_mean:.1}");
    assert!(
        eip_mean < 0.5 * random_mean,
        "EIP mean CMS {eip_mean} vs random {random_mean}"
    );
}

/// A pass of the independent converged implementation (`tests/data/independent/NAME`, copied
/// from shared/independent-passes: a separate code at 80 elements per bay, errors per Eq. 1).
fn independent(name: &str) -> Measurement {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/independent")
        .join(name)
        .join("measured.csv");
    Measurement::from_csv(&path, &std::fs::read_to_string(&path).unwrap(), 2500.0).unwrap()
}

/// Issue 36: before detection, a good wheel was sized like a flat (kept 9,600–24,700 of 50,000
/// instances and said "remove within 24 hours"). Now it is "no flat detected", with the
/// detection limit of the pass, and no sizing.
#[test]
fn a_good_wheel_is_not_an_urgent_wheel() {
    let id = identifier();
    let r = id
        .identify(&independent("good1"), None, Extras::NONE)
        .unwrap();
    let d = r.detection.as_ref().expect("detection runs first");
    assert!(!d.flat_detected, "{}", r.summary);
    assert!(r.summary.starts_with("No flat detected"), "{}", r.summary);
    assert!(r.sizing.is_none(), "a good wheel is not sized");
    assert_eq!(d.samples, 5 * 600, "every sample of every window is tested");
    // Inside by the allowance at least: the noise reaches its bound, the model error does not.
    let worst = d.worst().unwrap();
    assert!(worst.excess_kn < -0.1, "{worst:?}");
    // The limit is computed from the bank: the narrow population's L0 runs from 31 to 44 mm,
    // all of whose strikes at 12.3–12.5 m the five sensors see.
    let limit = d.limit.as_ref().expect("a limit with every 'no flat'");
    let l0 = limit.l0_mm.expect("a limit inside the population");
    assert!((30.0..45.0).contains(&l0), "{limit:?}");
    assert!(limit.share_detected > 0.9, "{limit:?}");
    assert_eq!(limit.bins.iter().map(|b| b.instances).sum::<usize>(), 2000);
}

/// Issue 36: the detection step against measurements that carry the bank's discretisation
/// error (the converged reference's mesh and step, errors per Eq. 1), at speeds across the
/// bank's ±3 %: good wheels pass, a flat of the population and a flat below it (d = 0.04 mm,
/// L0 = 11 mm; the independent tiny1: d = 0.073 mm) are detected.
#[test]
fn detection_separates_good_wheels_from_flats_of_a_converged_model() {
    let id = identifier();
    let (_, cal) = small_bank();
    for (k, speed) in [48.6, 50.0, 51.4].into_iter().enumerate() {
        let mut c = cal.document().converged_reference();
        c.run.speed_km_per_h = speed;
        let c = c.check().unwrap();
        let good = synth::synthesize_pass(&c, None, 100 + k as u64, true, synth::FieldNoise::TABLE)
            .unwrap();
        let r = id
            .identify(&parse(&good.csv).unwrap(), None, Extras::NONE)
            .unwrap();
        let d = r.detection.unwrap();
        assert!(
            !d.flat_detected,
            "good wheel at {speed} km/h: {:?}",
            d.worst()
        );
        for (l, dep, c_mm) in [(60.0, 0.45, 0.05), (12.0, 0.04, 0.0)] {
            let flat = Flat::from_mm(l, dep, c_mm, 12.41).unwrap();
            let syn = synth::synthesize_pass(
                &c,
                Some(&flat),
                7 + k as u64,
                true,
                synth::FieldNoise::TABLE,
            )
            .unwrap();
            let r = id
                .identify(&parse(&syn.csv).unwrap(), None, Extras::NONE)
                .unwrap();
            let d = r.detection.as_ref().unwrap();
            eprintln!("spike {l} {dep} {speed}: {:?}", d.spike);
            assert!(
                d.flat_detected,
                "flat L {l} d {dep} at {speed} km/h: {:?}",
                d.worst()
            );
            if dep < 0.3 {
                // Below the narrow population (d 0.3–0.6 mm, L0 from 31 mm): every instance
                // predicts a larger departure than measured. Measured 2026-11-26 at all three
                // speeds. The L0 rule reads the population's floor as the upper bound: 31 mm,
                // above this population's inspection limit (the default bank's floor, 18 mm,
                // gives "monitor").
                assert!(
                    r.below_population() && !r.model_class_refuted(),
                    "{}",
                    r.summary
                );
                assert!(
                    r.maintenance_hint.contains("(31 mm)"),
                    "{}",
                    r.maintenance_hint
                );
            } else {
                // Sized, the truth (L0 37.9 mm) inside, the impact reported beside L0: the
                // dynamic ratio is the peak force over the static wheel load (49.54 kN).
                let ranges = r.cms_ranges().expect("sized");
                assert!(
                    ranges.l0_mm[0] <= 37.9 && 37.9 <= ranges.l0_mm[1],
                    "{ranges:?}"
                );
                let impact = ranges
                    .impact
                    .expect("a format-3 bank stores the peak forces");
                for k in 0..2 {
                    let ratio = impact.peak_contact_kn[k] / 49.5405;
                    assert!((impact.dynamic_ratio[k] - ratio).abs() < 1e-4, "{impact:?}");
                }
                assert!(impact.dynamic_ratio[0] > 1.0, "{impact:?}");
                assert!(
                    r.summary.contains("Peak wheel–rail force in ["),
                    "{}",
                    r.summary
                );
            }
        }
    }
    let tiny = id
        .identify(&independent("tiny1"), None, Extras::NONE)
        .unwrap();
    assert!(tiny.detection.unwrap().flat_detected);
}

/// A CI-sized bank of flats that all lose contact and land (L 10–60 mm, d 0.5–1.0 mm), the
/// population issue 32 found the bank's discretisation error in.
fn landing_bank() -> &'static CachedBank {
    cached_bank(
        "identify-landing-bank",
        || {
            let mut c = wheelflat::model::Calibration::narrow_profile();
            c.population.length_mm = [10.0, 60.0];
            c.population.depth_mm = [0.5, 1.0];
            c.population.curvature_mm = [0.0, 0.2];
            c.check().unwrap()
        },
        2000,
        1000,
    )
}

/// Issue 32: measurements from the converged reference (40 elements per bay, Δt 2·10⁻⁵ s,
/// errors per Eq. 1) of flats that lose contact. The bank mesh lands them up to a sample
/// away, and before the discretisation allowance the truth was refuted in a fifth of such
/// cases on the default bank (docs/identification.md, "Discretisation error"). With it, the
/// truth stays inside the (L, d) ranges in at least 90 % of 24 cases (EDMF promises φ = 0.95;
/// 24 cases cannot show more than that), and no case is refuted. Without the allowance
/// (`discretisation_fraction` 0, today's thresholds before it) the same cases fall below that
/// (measured and stated in the docs, not asserted: the test is of the allowance).
#[test]
#[ignore = "acceptance: converged passes where flats land, a coverage study"]
fn coverage_survives_the_converged_reference_where_flats_land() {
    let (dir, cal) = landing_bank();
    let id = Identifier::new(Bank::open(dir).unwrap(), cal.identification.clone()).unwrap();
    assert!(
        id.discretisation().is_some(),
        "the default settings allow for the mesh"
    );
    let converged = coverage::converged_model(cal);
    let truths = coverage::truths_within(cal, 24, 32, 0.0);
    let cases: Vec<(Measurement, synth::Truth)> = {
        use rayon::prelude::*;
        truths
            .par_iter()
            .enumerate()
            .map(|(k, f)| coverage::case(&converged, f, 32, k).unwrap())
            .collect()
    };
    let lost = cases.iter().filter(|c| c.1.contact_loss_ms > 0.0).count();
    assert!(
        lost >= 20,
        "the landing population loses contact: {lost} of 24"
    );
    let (insp, urg, _) = coverage::severity_limits(cal);
    let mut covered = 0;
    for (m, t) in &cases {
        let out = id.identify(m, None, Extras::NONE).unwrap();
        let ranges = out.cms_ranges();
        assert!(ranges.is_some(), "a clean case refuted: {t:?}");
        covered += usize::from(coverage::judge(ranges, t, false, insp, urg).holds);
    }
    // Today's thresholds before the allowance, for the record (--nocapture).
    let mut before = cal.identification.clone();
    before.discretisation_fraction = 0.0;
    let old = Identifier::new(Bank::open(dir).unwrap(), before).unwrap();
    let old_covered = cases
        .iter()
        .filter(|(m, t)| {
            let out = old.identify(m, None, Extras::NONE).unwrap();
            coverage::judge(out.cms_ranges(), t, false, insp, urg).holds
        })
        .count();
    eprintln!(
        "landing cases: truth inside {covered} of 24 with the allowance, {old_covered} without"
    );
    assert!(covered >= 22, "truth inside in {covered} of 24");
}

/// Issue 56: what a pass shares is solved per instance. On the same seeded passes (errors per
/// Eq. 1: one model and one gain draw a sensor), the shared-gain stage keeps a subset of what
/// the per-point thresholds keep, never loses a truth they hold, and rules out instances in
/// most passes: today's per-point thresholds alone (`shared_gains = false`) keep more.
#[test]
fn one_gain_per_sensor_narrows_without_losing_the_truth() {
    let (dir, cal) = small_bank();
    let open = |shared: bool| {
        let mut s = cal.identification.clone();
        s.shared_gains = shared;
        Identifier::new(Bank::open(dir).unwrap(), s).unwrap()
    };
    let (on, off) = (open(true), open(false));
    let (mut narrower, mut held_on, mut held_off) = (0, 0, 0);
    let cases = 20;
    for (k, flat) in coverage::truths(cal, cases, 23).iter().enumerate() {
        let (m, t) = coverage::case(cal, flat, 23, k).unwrap();
        let a = on.identify(&m, None, Extras::NONE).unwrap();
        let b = off.identify(&m, None, Extras::NONE).unwrap();
        let cms = |r: &wheelflat::identify::Identification| -> Vec<u32> {
            r.sizing
                .as_ref()
                .map_or_else(Vec::new, |z| z.cms.iter().map(|c| c.instance).collect())
        };
        let (ca, cb) = (cms(&a), cms(&b));
        assert!(
            ca.iter().all(|i| cb.contains(i)),
            "case {k}: the shared stage only removes instances"
        );
        narrower += usize::from(ca.len() < cb.len());
        let holds = |r: &wheelflat::identify::Identification| {
            r.cms_ranges()
                .is_some_and(|x| coverage::holds_truth(x, &t, false))
        };
        held_on += usize::from(holds(&a));
        held_off += usize::from(holds(&b));
    }
    println!(
        "shared gains: narrower in {narrower} of {cases}, held {held_on} (per point: {held_off})"
    );
    assert!(held_on >= held_off, "held {held_on} against {held_off}");
    assert!(held_on * 100 >= 95 * cases, "held {held_on} of {cases}");
    assert!(narrower * 2 >= cases, "narrower in {narrower} of {cases}");
}
