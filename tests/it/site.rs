//! Issue 31, every pass a site sees: the default population covers a whole wheel revolution and
//! both wheels, stored folded into one sleeper bay (docs/bank.md "Folded banks").

use crate::common;
use crate::common::{cached_bank, CachedBank};
use wheelflat::bank::Bank;
use wheelflat::identify::{Extras, Identifier};
use wheelflat::model::{Calibration, Flat, Record, Simulator, WheelPosition};
use wheelflat_testkit::coverage::{self, holds_truth};

/// The default calibration's population (both wheels, X_p over one revolution, folded) with
/// the narrow profile's flat sizes and 600-sample windows: CI-sized.
pub(crate) fn site_small() -> Calibration {
    let narrow = Calibration::narrow_profile();
    let mut c = Calibration::default();
    c.output.window_samples = narrow.output.window_samples;
    c.population.length_mm = narrow.population.length_mm;
    c.population.depth_mm = narrow.population.depth_mm;
    c.population.curvature_mm = narrow.population.curvature_mm;
    c
}

/// 3,000 stored instances, 12,000 as read.
pub(crate) fn site_bank() -> &'static CachedBank {
    cached_bank("site-small", || site_small().check().unwrap(), 3000, 750)
}

#[test]
fn a_folded_instance_reads_as_the_flat_one_to_three_bays_on() {
    // Instance k·N + i of a folded bank is stored instance i struck k bays later: its windows
    // are the simulation at that X_p, up to the rail's clamped ends (docs/bank.md measures
    // up to 0.03 kN for smooth flats, 0.2–1 kN for short deep ones; these are smooth).
    let (dir, cal) = site_bank();
    let bank = Bank::open(dir).unwrap();
    let n = bank.stored_instances();
    assert_eq!(bank.instances(), 4 * n);
    assert_eq!(bank.metadata().sensors.len(), cal.sensors.pad.len());
    let sim = Simulator::new(cal).unwrap();
    for v in [7, n + 11, 2 * n + 400, 3 * n + 2999] {
        let got = bank.read_instance(v).unwrap();
        let [l, d, c, x, _, wheel, _] = got.parameters;
        let (lo, hi) = (
            cal.population.impact_position_m[0],
            cal.population.impact_position_m[1],
        );
        assert!((lo..hi).contains(&x), "X_p {x} off the revolution");
        let flat = Flat::from_mm(l, d, c, x)
            .unwrap()
            .on_wheel(WheelPosition::from_code(wheel as u8));
        let r = sim.run(Some(&flat), Record::default()).unwrap();
        let lands = r.contact_loss_s.iter().sum::<f64>() > 0.0;
        let mut worst: f64 = 0.0;
        for (s, axis) in bank.metadata().sensors.iter().enumerate() {
            let direct = r.window(s, axis.first_sample, axis.samples);
            for (a, b) in got.forces_kn[s].iter().zip(direct) {
                worst = worst.max((f64::from(*a) - b / 1e3).abs());
            }
        }
        // studies/src/bin/fold_error.rs, 72 cases: flats that keep contact within 0.03 kN when 60 mm or
        // longer (0.27 kN for a 10 mm one; these are 40 mm or longer), flats that lose contact
        // within 0.97 kN: the rail's clamped ends, a strike nearer or farther from them.
        let tolerance = if lands { 1.0 } else { 0.1 };
        eprintln!(
            "instance {v}: L {l:.1} d {d:.3} X_p {x:.3}, lands {lands}: within {worst:.4} kN"
        );
        assert!(
            worst < tolerance,
            "instance {v}: folded windows off the direct simulation by {worst} kN"
        );
        // The same through the column reader.
        let col = bank.sample_index(1, 300);
        let mut out = vec![0.0f32; bank.instances()];
        bank.read_columns_flat(&[col], &mut out).unwrap();
        assert_eq!(out[v], got.forces_kn[1][300]);
    }
}

#[test]
fn every_pass_a_site_sees_is_answered_on_the_right_wheel_with_the_truth_kept() {
    // Twelve passes, own simulator, errors per the paper's Eq. 1, the flat anywhere on the
    // revolution and on either wheel. With the paper's population (the trailing wheel, X_p in
    // [12.3, 12.5] m, not folded) as the default, the passes on the leading wheel or outside
    // those 0.2 m are refuted: this test fails.
    let (dir, cal) = site_bank();
    let id = Identifier::new(Bank::open(dir).unwrap(), cal.identification.clone()).unwrap();
    // The truths: over a whole revolution from 12 m and both wheels, whatever the bank holds.
    let mut site = cal.document().clone();
    site.population.impact_position_m = [12.0, 12.0 + site.circumference_m()];
    site.population.flat_wheels = Some(vec![WheelPosition::Leading, WheelPosition::Trailing]);
    let truths = coverage::truths_within(&site.check().unwrap(), 12, 31, 0.05);
    let wheels: Vec<WheelPosition> = truths.iter().filter_map(|t| t.wheel()).collect();
    assert!(wheels.contains(&WheelPosition::Leading) && wheels.contains(&WheelPosition::Trailing));
    let spread = truths
        .iter()
        .map(|t| t.impact_position_m())
        .fold([f64::MAX, f64::MIN], |r, x| [r[0].min(x), r[1].max(x)]);
    assert!(spread[1] - spread[0] > 1.8, "truths over {spread:?} m");
    let (mut held, mut right) = (0, 0);
    for (k, flat) in truths.iter().enumerate() {
        let (m, t) = coverage::case(cal, flat, 31, k).unwrap();
        let out = id.identify(&m, None, Extras::NONE).unwrap();
        let r = out.cms_ranges();
        assert!(r.is_some(), "case {k} refuted: {}", out.summary);
        let r = r.unwrap();
        held += usize::from(holds_truth(r, &t, false));
        right += usize::from(t.flat_wheel.is_some_and(|w| r.flat_wheels == [w]));
    }
    eprintln!("truth held in {held} of 12, right wheel alone in {right} of 12");
    assert!(held >= 11, "truth held in {held} of 12");
    assert!(right >= 11, "right wheel named alone in {right} of 12");
}

#[test]
fn instances_are_counted_as_read_and_a_folded_speed_that_cannot_fold_still_simulates() {
    let dir = tempfile::tempdir().unwrap();
    // A folded bank stores one instance in four: the count must divide.
    let out = common::wheelflat()
        .args(["bank", "generate", "--instances", "10", "--out"])
        .arg(dir.path().join("bank"))
        .assert()
        .failure();
    let err = String::from_utf8_lossy(&out.get_output().stderr).to_string();
    assert!(
        err.contains("--instances 10") && err.contains("multiple of 4 (e.g. 12)"),
        "{err}"
    );
    assert!(!dir.path().join("bank").join("CURRENT").exists());
    // At 49 km/h a bay is 128.57 samples: a bank there cannot fold (refused, naming the speeds
    // that fit), but a pass there simulates from the same calibration.
    let mut c = Calibration::default();
    c.run.speed_km_per_h = 49.0;
    let cal = common::write_calibration(&c, dir.path());
    let out = common::wheelflat()
        .args(["bank", "generate", "--instances", "8", "--calibration"])
        .arg(&cal)
        .arg("--out")
        .arg(dir.path().join("bank49"))
        .assert()
        .failure();
    let err = String::from_utf8_lossy(&out.get_output().stderr).to_string();
    assert!(err.contains("128.571") && err.contains("48.8372"), "{err}");
    common::wheelflat()
        .args(["synth", "--wheel", "leading", "--calibration"])
        .arg(&cal)
        .arg("--out")
        .arg(dir.path().join("m49.csv"))
        .assert()
        .success();
    let truth = std::fs::read_to_string(dir.path().join("m49.truth.json")).unwrap();
    assert!(truth.contains("\"flat_wheel\": \"leading\""), "{truth}");
}

#[test]
#[ignore = "acceptance: a site bank, a gap diagnosed and the rebuild's calibration, ~3 min on 2 cores"]
fn a_model_gap_on_a_site_bank_is_named_and_the_calibration_to_rebuild_with_stays_folded() {
    // The local bank diagnose builds around the fitted flat is a few cells of X_p, not a
    // revolution: it is built unfolded; the calibration written for the user is the bank's own
    // (folded, the whole population) with the effect.
    let (dir, cal) = site_bank();
    let tmp = tempfile::tempdir().unwrap();
    let toml = common::write_calibration(cal.document(), tmp.path());
    let m = tmp.path().join("gap.csv");
    common::wheelflat()
        .args([
            "synth", "--l-mm", "60", "--d-mm", "0.45", "--c-mm", "0.05", "--xp-m", "13.6",
        ])
        .args(["--wheel", "leading", "--seed", "5"])
        .args([
            "--effect",
            "pad_stiffness:sleeper=16,factor=0.5",
            "--calibration",
        ])
        .arg(&toml)
        .arg("--out")
        .arg(&m)
        .assert()
        .success();
    // The pass's wheels are round, and stated so: under `auto` a round tread is bounded as a
    // disc-braked one (a pass cannot tell them apart, docs/detection.md, "Rough wheels"), and
    // the wider thresholds absorb this gap (measured: "no missing effect found", 0 of 3,000
    // samples outside, 2026-11-27; docs/diagnosis.md).
    let mut round = cal.document().clone();
    round.identification.wheel_roughness = wheelflat::model::calibration::WheelRoughness::Round;
    let round_dir = tmp.path().join("round");
    std::fs::create_dir_all(&round_dir).unwrap();
    let round_toml = common::write_calibration(&round, &round_dir);
    let out = tmp.path().join("diagnosis");
    let run = common::wheelflat()
        .args(["diagnose", "--local-instances", "400", "--calibration"])
        .arg(&round_toml)
        .arg("--bank")
        .arg(dir)
        .arg("--measured")
        .arg(&m)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let stdout = String::from_utf8_lossy(&run.get_output().stdout).to_string();
    assert!(
        stdout.contains("missing effect: pad_stiffness at sleeper 16"),
        "{stdout}"
    );
    let with = Calibration::from_toml_str(
        &std::fs::read_to_string(out.join("calibration-with-effect.toml")).unwrap(),
    )
    .unwrap();
    assert_eq!(with.population, cal.population);
    assert_eq!(with.effects.len(), 1);
}
