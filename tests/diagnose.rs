//! Diagnosis (issue #5), the *locate* step: on a CI-sized bank, a measurement with a hidden
//! effect shows its disagreement where the effect acts; clean data stays near the chance level.

mod common;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use wheelflat::bank::Bank;
use wheelflat::diagnose;
use wheelflat::identify::{synth, Extras, Identifier, Measurement};
use wheelflat::model::{CheckedCalibration, Effect, Flat};

/// A CI-sized bank (the identification tests' calibration), built once per test binary:
/// the tests run in parallel and must not generate it side by side.
fn small_bank() -> (PathBuf, CheckedCalibration) {
    static BANK: OnceLock<(PathBuf, CheckedCalibration)> = OnceLock::new();
    BANK.get_or_init(|| {
        let cal = common::narrow_calibration();
        let dir = common::build_bank(&cal, "diagnose-bank", 2000, 1000);
        (dir, cal)
    })
    .clone()
}

fn locate(id: &Identifier, cal: &CheckedCalibration, effects: Vec<Effect>) -> diagnose::Located {
    let mut doc = cal.document().clone();
    doc.effects = effects;
    let hidden = doc.check().unwrap();
    let flat = Flat::from_mm(58.0, 0.47, 0.04, 12.41).unwrap();
    let syn = synth::synthesize(&hidden, &flat, 5, true).unwrap();
    let m = Measurement::from_csv(Path::new("m.csv"), &syn.csv, 2500.0).unwrap();
    let ident = id
        .identify(
            &m,
            None,
            Extras {
                baselines: false,
                curves: false,
            },
        )
        .unwrap();
    diagnose::locate(id, &ident).unwrap()
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
