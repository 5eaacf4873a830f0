//! Diagnosis (issue #5), the *locate* step: on a CI-sized bank, a measurement with a hidden
//! effect shows its disagreement where the effect acts; clean data stays near the chance level.

use crate::common::{cached_bank, narrow_calibration, wheelflat_path, CachedBank};
use std::path::{Path, PathBuf};
use wheelflat::bank::Bank;
use wheelflat::diagnose;
use wheelflat::identify::{synth, Extras, Identifier, Measurement};
use wheelflat::model::{CheckedCalibration, Effect, Flat};

/// A CI-sized bank (the identification tests' calibration), 2,000 instances.
fn small_bank() -> CachedBank {
    cached_bank("diagnose-bank", narrow_calibration, 2000, 1000).clone()
}

fn locate(id: &Identifier, cal: &CheckedCalibration, effects: Vec<Effect>) -> diagnose::Located {
    let mut doc = cal.document().clone();
    doc.effects = effects;
    let hidden = doc.check().unwrap();
    let flat = Flat::from_mm(58.0, 0.47, 0.04, 12.41).unwrap();
    let syn = synth::synthesize(&hidden, &flat, 5, true).unwrap();
    let m = Measurement::from_csv(Path::new("m.csv"), &syn.csv, 2500.0).unwrap();
    let ident = id.identify(&m, None, Extras::AS_RECORDED).unwrap();
    let sizing = ident
        .sizing
        .as_ref()
        .expect("the flat is detected and sized");
    diagnose::locate(id, &ident, sizing).unwrap()
}

#[test]
fn a_hidden_sensor_gain_is_located_on_its_sensor_and_clean_data_is_quiet() {
    let (dir, cal) = small_bank();
    let id = Identifier::new(Bank::open(&dir).unwrap(), cal.identification.clone()).unwrap();
    let clean = locate(&id, &cal, vec![]);
    let gain = locate(
        &id,
        &cal,
        vec![Effect::SensorGain {
            sensor: "rps2".into(),
            factor: 1.4,
        }],
    );
    for (name, l) in [("clean", &clean), ("rps2 gain ×1.4", &gain)] {
        println!(
            "{name}: instance {}, {} samples outside (chance {:.1}), RMS {:.2} kN",
            l.instance, l.samples_outside, l.expected_by_chance, l.rms_residual_kn
        );
        for s in &l.sensors {
            println!(
                "  {}: {} outside (chance {:.1}), RMS {:.2} kN, {} windows",
                s.sensor,
                s.samples_outside,
                s.expected_by_chance,
                s.rms_residual_kn,
                s.windows.len()
            );
        }
    }
    // Clean data: the thresholds hold φ over all samples together; none outside here.
    assert_eq!(clean.samples_outside, 0, "clean data left the thresholds");
    // The hidden gain: most of the disagreement on rps2, in a window where the bogie is over it.
    let rps2 = gain.sensors.iter().find(|s| s.sensor == "rps2").unwrap();
    let others = gain
        .sensors
        .iter()
        .filter(|s| s.sensor != "rps2")
        .map(|s| s.samples_outside)
        .max()
        .unwrap();
    assert!(
        rps2.samples_outside > 5 * others.max(1),
        "rps2 {} vs others {others}",
        rps2.samples_outside
    );
    let x_rps2 = cal.sensor_position_m(1);
    let w = &rps2.windows[0];
    assert!(
        w.bogie_centre_m[0] - 2.5 <= x_rps2 && x_rps2 <= w.bogie_centre_m[1] + 2.5,
        "window {:?} vs rps2 at {x_rps2} m",
        w.bogie_centre_m
    );
}

#[test]
fn a_hidden_voided_sleeper_is_located_at_its_sleeper() {
    let (dir, cal) = small_bank();
    let id = Identifier::new(Bank::open(&dir).unwrap(), cal.identification.clone()).unwrap();
    // Sleeper 17 carries rps3.
    let l = locate(
        &id,
        &cal,
        vec![Effect::VoidedSleeper {
            sleeper: 17,
            gap_mm: 0.3,
        }],
    );
    let by = |name: &str| l.sensors.iter().find(|s| s.sensor == name).unwrap();
    for s in &l.sensors {
        println!(
            "  {}: {} outside, RMS {:.2} kN",
            s.sensor, s.samples_outside, s.rms_residual_kn
        );
    }
    let rps3 = by("rps3");
    let most = l.sensors.iter().max_by_key(|s| s.samples_outside).unwrap();
    assert_eq!(
        most.sensor, "rps3",
        "the most disagreement is at the voided sleeper's sensor"
    );
    assert!(rps3.samples_outside > 20);
    // The worst window is while the bogie passes sleeper 17: its bogie-centre span lies
    // within a half wheelbase and a bay of the sleeper.
    let x17 = 17.0 * cal.track.sleeper_spacing_m;
    let w = &rps3.windows[0];
    let reach = cal.vehicle.half_wheelbase_m + cal.track.sleeper_spacing_m;
    println!(
        "worst window: bogie centre {:?} m, sleeper 17 at {x17:.2} m",
        w.bogie_centre_m
    );
    assert!(
        w.bogie_centre_m[1] >= x17 - reach && w.bogie_centre_m[0] <= x17 + reach,
        "window {:?} vs sleeper 17 at {x17} m",
        w.bogie_centre_m
    );
}

/// The CI-sized subset of the acceptance suite: the first case of every effect kind, the first
/// clean case and the effect outside the library, on the 2,000-instance bank, with local banks
/// of 400 instances. The full suite is `studies/src/bin/diagnose_suite.rs`.
#[test]
#[ignore = "acceptance: fifteen diagnoses with local banks, ~7 min on 2 cores"]
fn the_suite_subset_names_hidden_effects_and_stays_quiet_otherwise() {
    use wheelflat_testkit::suite::{self, Hidden};
    let (dir, cal) = small_bank();
    let id = Identifier::new(Bank::open(&dir).unwrap(), cal.identification.clone()).unwrap();
    let mut seen_kinds: Vec<std::mem::Discriminant<Effect>> = Vec::new();
    let (mut clean_done, mut pair_done, mut coloured_done) = (false, false, false);
    // The first case of every effect kind measured with the bank's own model, one clean
    // case, one with AR(1) noise at twice the table's σ, one pair (a pad and a clock
    // offset), the one outside the library.
    let cases: Vec<suite::Case> = suite::cases()
        .into_iter()
        .filter(|c| match &c.hidden {
            Hidden::Effect(e) if !c.finer => {
                let k = std::mem::discriminant(e);
                let first = !seen_kinds.contains(&k);
                seen_kinds.push(k);
                first
            }
            Hidden::Effect(_) => false,
            // The pair of a sleeper effect and a clock offset (the full suite's other pairs, and
            // their misses, are in docs/performance.md#diagnosis-round-two).
            Hidden::Pair(..) => {
                c.name.starts_with("pad 16") && !std::mem::replace(&mut pair_done, true)
            }
            Hidden::Clean if c.noise.ar1 > 0.0 => !std::mem::replace(&mut coloured_done, true),
            Hidden::Clean => !c.finer && !std::mem::replace(&mut clean_done, true),
            Hidden::NotInLibrary(_) => true,
        })
        .collect();
    assert_eq!(
        cases.len(),
        15,
        "eleven kinds, one clean, one coloured noise, one pair, one outside the library"
    );
    let tmp = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("diagnose-suite-local");
    let mut outcomes = Vec::new();
    for (i, case) in cases.iter().enumerate() {
        let (o, _) = suite::run_case(&id, &cal, case, &tmp.join(i.to_string()), 400).unwrap();
        println!(
            "{:<40} {} gap {:.3} → {:?} kN, outside {} → {:?}: {}",
            o.case,
            if o.pass { "PASS" } else { "FAIL" },
            o.gap_before_kn,
            o.gap_after_kn,
            o.outside_before,
            o.outside_after,
            o.verdict
        );
        outcomes.push(o);
    }
    let hidden: Vec<_> = outcomes
        .iter()
        .filter(|o| matches!(o.hidden, Hidden::Effect(_) | Hidden::Pair(..)))
        .collect();
    // The second flat: named, its true L0 inside the range reported for it.
    let second = outcomes
        .iter()
        .find_map(|o| o.second_flat_l0_mm)
        .expect("the subset holds a second flat");
    match second {
        (truth, Some([lo, hi])) => assert!(lo <= truth && truth <= hi, "{truth} vs [{lo}, {hi}]"),
        (truth, None) => panic!("no L0 range for the second flat (true {truth} mm)"),
    }
    // Every hidden effect named right (in the subset and in the full suite of
    // docs/performance.md#diagnosis-round-two, 25 of 25 singles since the restart of
    // diagnose::restart; order 9 and speed −7 % were misses before it).
    for o in &hidden {
        assert!(o.pass, "{}: named {:?} — {}", o.case, o.named, o.verdict);
    }
    // No false alarm on clean data; the effect outside the library is not named.
    for o in outcomes
        .iter()
        .filter(|o| !matches!(o.hidden, Hidden::Effect(_) | Hidden::Pair(..)))
    {
        assert!(o.named.is_empty(), "{}: named {:?}", o.case, o.named);
    }
    // Every effect named and added shrinks the gap at least 3×.
    for o in hidden.iter().filter(|o| o.pass) {
        let after = o.gap_after_kn.expect("a named effect is added");
        assert!(
            after * 3.0 <= o.gap_before_kn,
            "{}: gap {} → {after}",
            o.case,
            o.gap_before_kn
        );
    }
}

#[test]
fn the_goodness_of_fit_z_is_standard_normal_for_chi2_at_its_quantiles() {
    use wheelflat::diagnose::name::chi2_z;
    // Quantiles computed with mpmath (regularised incomplete gamma, bisection to 1e-20):
    // χ² with 3000 dof has median 2999.333 (z = 0) and 0.999 quantile 3245.079 (z = 3.090).
    assert!(
        chi2_z(2999.333, 3000.0).abs() < 0.005,
        "{}",
        chi2_z(2999.333, 3000.0)
    );
    assert!(
        (chi2_z(3245.079, 3000.0) - 3.090).abs() < 0.01,
        "{}",
        chi2_z(3245.079, 3000.0)
    );
    // Small dof, where the approximation is worst: the 0.999 quantile at 10 dof is 29.588.
    assert!((chi2_z(29.588, 10.0) - 3.09).abs() < 0.05);
}

#[test]
fn the_noise_model_follows_the_uncertainty_table() {
    use wheelflat::diagnose::fit::NoiseModel;
    let cal = narrow_calibration();
    let n = NoiseModel::from_settings(&cal.identification);
    // Absolute sources: ±1 kN noise and ±50 N resolution: σ² = 2²/12 + 0.1²/12.
    let sigma = ((4.0 + 0.01) / 12.0f64).sqrt();
    assert!((n.sigma_kn - sigma).abs() < 1e-12, "{}", n.sigma_kn);
    // Sensor factor: (1 − mean model error)(1 + mean measurement error); model means −5 %,
    // −1.5 %, 0, 0, 0 → 1.065; measurement means 0.
    assert!((n.gain_mean - 1.065).abs() < 1e-12, "{}", n.gain_mean);
    // Variance: Σ w²/12 over the relative sources.
    let widths: [f64; 7] = [0.20, 0.13, 0.06, 0.02, 0.10, 0.10, 0.04];
    let sd = (widths.iter().map(|w| w * w / 12.0).sum::<f64>()).sqrt();
    assert!((n.gain_sd - sd).abs() < 1e-12, "{}", n.gain_sd);
}

#[test]
fn the_flat_fit_by_resimulation_recovers_a_known_flat() {
    use wheelflat::diagnose::fit::{self, levenberg_marquardt, NoiseModel, Observed, Problem};
    let cal = narrow_calibration();
    let noise = NoiseModel::from_settings(&cal.identification);
    // The "measurement": the model's own prediction of a known flat on all sensors, times the
    // prior sensor factor, no noise.
    let windows: Vec<Observed> = (0..cal.sensors.pad.len())
        .map(|i| Observed {
            sensor: cal.sensors.pad[i].name.clone(),
            first_sample: cal.window_start_sample(i),
            values_kn: vec![0.0; cal.output.window_samples],
        })
        .collect();
    let wheel = cal.vehicle.flat_wheel;
    let probe = Problem::new(cal.document().clone(), &windows, noise, wheel);
    let truth = fit::flat_vector(58.0, 0.47, 0.04, 12.41);
    let g = probe.simulate(&truth, &[]).unwrap();
    let observed: Vec<Observed> = windows
        .iter()
        .zip(&g)
        .map(|(w, g)| Observed {
            values_kn: g.iter().map(|v| v * noise.gain_mean).collect(),
            ..w.clone()
        })
        .collect();
    let problem = Problem::new(cal.document().clone(), &observed, noise, wheel);
    let params = fit::flat_params(&cal.population);
    let eval = |x: &[f64]| problem.evaluate(&[x[0], x[1], x[2], x[3]], &[]);
    // Start 3 mm longer, 0.02 mm deeper and 2 mm later than the truth.
    let start = fit::flat_vector(61.0, 0.49, 0.04, 12.412);
    let r = levenberg_marquardt(&params, &start, &eval, 40).unwrap();
    println!(
        "fit {:?} (truth {truth:?}), χ² {:.3} after {} Jacobians, {} simulations",
        r.x,
        r.eval.chi2,
        r.iterations,
        problem.simulations()
    );
    // Tolerances: a hundredth of the bank's resolution or less along each parameter (the
    // 2,000-instance bank's cells are ~6 mm in L, ~0.05 mm in d, ~30 mm in X_p); noise-free
    // data, so the fit must land on the truth.
    assert!((r.x[0] - truth[0]).abs() < 0.05, "L {}", r.x[0]);
    assert!((r.x[1] - truth[1]).abs() < 0.0005, "d {}", r.x[1]);
    assert!((r.x[3] - truth[3]).abs() < 0.00005, "X_p {}", r.x[3]);
    // Left: a χ² far below one sample's worth of noise per sensor.
    assert!(r.eval.chi2 < 1.0, "χ² {}", r.eval.chi2);
}

#[test]
fn the_diagnose_command_reports_clean_data_and_names_a_missing_file() {
    let (dir, cal) = small_bank();
    let tmp = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("diagnose-cli");
    std::fs::create_dir_all(&tmp).unwrap();
    let flat = Flat::from_mm(58.0, 0.47, 0.04, 12.41).unwrap();
    let syn = synth::synthesize(&cal, &flat, 25, true).unwrap();
    let csv = tmp.join("clean.csv");
    std::fs::write(&csv, &syn.csv).unwrap();
    let diagnose = |measured: &Path, out: &Path| {
        let _ = std::fs::remove_dir_all(out);
        std::process::Command::new(wheelflat_path())
            .args(["diagnose", "--bank"])
            .arg(&dir)
            .arg("--measured")
            .arg(measured)
            .arg("--out")
            .arg(out)
            .output()
            .unwrap()
    };
    let out = tmp.join("report");
    let run = diagnose(&csv, &out);
    let stdout = String::from_utf8_lossy(&run.stdout);
    println!("{stdout}{}", String::from_utf8_lossy(&run.stderr));
    assert!(run.status.success());
    assert!(stdout.contains("no missing effect found"), "{stdout}");
    for f in ["diagnosis.json", "diagnosis.html", "diagnosis-gap.png"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    assert!(!out.join("calibration-with-effect.toml").exists());
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("diagnosis.json")).unwrap())
            .unwrap();
    assert_eq!(json["before_stage"]["samples_outside"], 0);
    // A measurement that is not there: the error names it, nothing is written.
    let missing = tmp.join("no-such.csv");
    let out2 = tmp.join("report-2");
    let run = diagnose(&missing, &out2);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success());
    assert!(stderr.contains("no-such.csv"), "{stderr}");
    assert!(!out2.exists());
}

#[test]
#[ignore = "acceptance: a speed line beyond the bank diagnosed, ~1.5 min on 2 cores"]
fn a_speed_line_beyond_the_bank_is_diagnosed_from_the_record_and_identify_still_refuses_it() {
    // The train ran 10 % faster than the 50 km/h bank and the file says so (55 km/h):
    // `identify` refuses (no bank covers 55 km/h); `diagnose` takes the record as it is and
    // names the speed from the data, saying what its line said.
    let (dir, cal) = small_bank();
    let tmp = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("diagnose-speed-line");
    let _ = std::fs::remove_dir_all(&tmp);
    std::fs::create_dir_all(&tmp).unwrap();
    let mut doc = cal.document().clone();
    doc.effects = vec![Effect::SpeedDeviation { fraction: 0.10 }];
    let hidden = doc.check().unwrap();
    let flat = Flat::from_mm(66.0, 0.52, 0.06, 12.37).unwrap();
    let syn = synth::synthesize(&hidden, &flat, 48, true).unwrap();
    let csv_text = syn
        .csv
        .replace("# speed_km_per_h = 50\n", "# speed_km_per_h = 55\n");
    assert_ne!(csv_text, syn.csv, "the speed line was rewritten");
    let csv = tmp.join("fast.csv");
    std::fs::write(&csv, &csv_text).unwrap();
    let run = |command: &str| {
        let mut c = std::process::Command::new(wheelflat_path());
        c.args([command, "--bank"])
            .arg(&dir)
            .arg("--measured")
            .arg(&csv);
        c.arg("--out").arg(tmp.join(command));
        if command == "diagnose" {
            c.arg("--no-local-bank");
        }
        c.output().unwrap()
    };
    let refused = run("identify");
    assert!(!refused.status.success());
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(stderr.contains("55"), "{stderr}");
    let diagnosed = run("diagnose");
    let stdout = String::from_utf8_lossy(&diagnosed.stdout);
    println!("{stdout}{}", String::from_utf8_lossy(&diagnosed.stderr));
    assert!(diagnosed.status.success());
    assert!(stdout.contains("the speed line says 55 km/h"), "{stdout}");
    assert!(
        stdout.contains("missing effect: speed_deviation"),
        "{stdout}"
    );
    // The record's speed within 0.5 km/h (1 %) of the 55 km/h it ran at.
    let line = stdout
        .lines()
        .find(|l| l.starts_with("the record's speed: "))
        .expect("the record's speed is printed");
    let v: f64 = line["the record's speed: ".len()..]
        .split_whitespace()
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!((v - 55.0).abs() < 0.5, "{line}");
    // The noise estimated from the record is in the text, the JSON and the HTML report.
    assert!(stdout.contains("noise from the record: σ "), "{stdout}");
    let out = tmp.join("diagnose");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("diagnosis.json")).unwrap())
            .unwrap();
    let used = json["noise"]["sigma_used_kn"].as_f64().unwrap();
    assert!(
        used >= json["noise"]["sigma_table_kn"].as_f64().unwrap(),
        "{used}"
    );
    let html = std::fs::read_to_string(out.join("diagnosis.html")).unwrap();
    assert!(html.contains("Noise from the record"));
}

/// Issue 32: ten clean passes of the converged reference whose field noise is coloured and
/// 1.6–2× the table's (AR(1), ρ 0.7–0.85): the diagnosis names *noise above the uncertainty
/// table*, with σ and ρ near the truth and the table entry to change, in at least 9 of 10
/// (and names no effect there).
/// (Before, it answered "no effect in the library explains the disagreement".)
#[test]
#[ignore = "acceptance: ten diagnoses, 4–5 min on 2 cores"]
fn noise_above_the_table_is_named_with_its_sigma_and_rho() {
    let (dir, cal) = small_bank();
    let id = Identifier::new(Bank::open(&dir).unwrap(), cal.identification.clone()).unwrap();
    let converged = wheelflat_testkit::coverage::converged_model(&cal);
    let sigma_table = diagnose::fit::NoiseModel::from_settings(&cal.identification).sigma_kn;
    let passes = [
        (60.0, 0.45, 0.05, 12.35, 1.6, 0.7),
        (45.0, 0.35, 0.10, 12.45, 1.8, 0.8),
        (75.0, 0.55, 0.05, 12.40, 2.0, 0.85),
        (50.0, 0.50, 0.00, 12.32, 1.7, 0.75),
        (65.0, 0.30, 0.10, 12.48, 1.9, 0.7),
        (42.0, 0.58, 0.05, 12.38, 1.6, 0.85),
        (70.0, 0.40, 0.00, 12.43, 2.0, 0.8),
        (55.0, 0.33, 0.10, 12.36, 1.8, 0.7),
        (78.0, 0.48, 0.05, 12.46, 1.7, 0.85),
        (48.0, 0.42, 0.00, 12.41, 1.9, 0.75),
    ];
    let mut named = 0;
    for (k, &(l, d, c, xp, scale, rho)) in passes.iter().enumerate() {
        let flat = Flat::from_mm(l, d, c, xp).unwrap();
        let noise = synth::FieldNoise { scale, ar1: rho };
        let syn =
            synth::synthesize_with_noise(&converged, &flat, 50 + k as u64, true, noise).unwrap();
        let m = Measurement::from_csv(Path::new("noisy.csv"), &syn.csv, 2500.0).unwrap();
        let ident = id.identify(&m, None, Extras::AS_RECORDED).unwrap();
        let opts = diagnose::Options::default();
        let out =
            diagnose::diagnose(&id, &m, None, &ident, &opts, &wheelflat::bank::Quiet).unwrap();
        let found = out.noise_above_table.as_ref();
        println!(
            "pass {k}: σ {:.2} kN ρ {rho} → {:?}: {}",
            scale * sigma_table,
            found.map(|f| (f.sigma_kn, f.rho)),
            out.verdict
        );
        if let Some(f) = found {
            assert!(out.verdict.starts_with("noise above the uncertainty table"));
            assert!(out.verdict.contains(&f.entry) && f.suggested_kn[1] > f.bounds_kn[1]);
            // σ̂ and ρ̂ as the finding states them: above the table, ρ̂ near the truth (σ̂ can
            // carry the flat fit's own misfit on this small bank: +36 % once).
            let s = f.sigma_kn;
            assert!(
                s >= 1.25 * sigma_table && s <= 1.5 * scale * sigma_table,
                "σ {s}"
            );
            assert!((f.rho - rho).abs() <= 0.15, "ρ {}", f.rho);
            named += 1;
        }
    }
    assert!(named >= 9, "noise named in {named} of 10");
}

/// Issue 32: a site whose noise is above the table measures it from its passes (a good
/// wheel and a flat, noise 2× the table's, ρ 0.8), and the calibration written carries the
/// widened entry; with it the good wheel is "no flat detected" (with the table's noise the
/// detection step sees the noise itself as departures).
#[test]
fn the_site_noise_is_measured_from_passes_into_a_calibration() {
    let (dir, cal) = small_bank();
    let tmp = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("site-noise");
    std::fs::create_dir_all(&tmp).unwrap();
    let noise = synth::FieldNoise {
        scale: 2.0,
        ar1: 0.8,
    };
    let flat = Flat::from_mm(58.0, 0.47, 0.04, 12.41).unwrap();
    let good = synth::synthesize_pass(&cal, None, 31, true, noise).unwrap();
    let with_flat = synth::synthesize_pass(&cal, Some(&flat), 32, true, noise).unwrap();
    let (a, b) = (tmp.join("good.csv"), tmp.join("flat.csv"));
    std::fs::write(&a, &good.csv).unwrap();
    std::fs::write(&b, &with_flat.csv).unwrap();
    let out = tmp.join("site.toml");
    let _ = std::fs::remove_file(&out);
    let run = std::process::Command::new(wheelflat_path())
        .args(["calibration", "--noise-from"])
        .arg(&a)
        .arg(&b)
        .arg("--bank")
        .arg(&dir)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    assert!(stderr.contains("widened"), "{stderr}");
    let site =
        wheelflat::model::Calibration::from_toml_str(&std::fs::read_to_string(&out).unwrap())
            .unwrap()
            .check()
            .unwrap();
    // The entry bounds ±4σ̂, σ̂ within 20 % of the truth (2× the table's σ).
    let table = diagnose::fit::NoiseModel::from_settings(&cal.identification).sigma_kn;
    let entry = site
        .identification
        .uncertainty
        .iter()
        .find(|u| u.name == "environment noise")
        .unwrap();
    let sigma = entry.max / diagnose::noise::BOUND_SD;
    assert!(
        (sigma / (2.0 * table) - 1.0).abs() < 0.2,
        "{sigma} vs {table}"
    );
    let id = Identifier::new(Bank::open(&dir).unwrap(), site.identification.clone()).unwrap();
    let m = Measurement::from_csv(&a, &good.csv, 2500.0).unwrap();
    let r = id.identify(&m, None, Extras::AS_RECORDED).unwrap();
    assert!(!r.detection.unwrap().flat_detected, "{}", r.summary);
}
