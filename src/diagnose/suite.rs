//! The diagnosis acceptance suite: measurements with one effect hidden (every kind of the
//! library at two places or amplitudes), clean ones, and one with an effect the library does
//! not hold; each is identified on a bank built without effects and diagnosed. Shared by the
//! tests (a CI-sized subset) and `examples/diagnose_suite.rs` (all of it).

use super::{diagnose, DiagnoseError, Diagnosis, Options};
use crate::bank::Quiet;
use crate::identify::{synth, Extras, Identifier, Measurement};
use crate::model::{Calibration, CheckedCalibration, Effect, Flat, WheelPosition};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// What a case hides.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Hidden {
    /// Nothing: must come out as "no missing effect found".
    Clean,
    /// An effect of the library: must be named, kind and place.
    Effect(Effect),
    /// Something outside the library (described): must not be named.
    NotInLibrary(String),
}

/// One case of the suite.
#[derive(Debug, Clone, PartialEq)]
pub struct Case {
    /// Short name.
    pub name: String,
    /// What is hidden.
    pub hidden: Hidden,
    /// The true flat `[L (mm), d (mm), c (mm), X_p (m)]`.
    pub flat: [f64; 4],
    /// Perturbation seed.
    pub seed: u64,
}

/// Every case of the suite.
pub fn cases() -> Vec<Case> {
    use Effect::*;
    let hide = |name: &str, e: Effect, flat: [f64; 4], seed: u64| Case {
        name: name.to_string(),
        hidden: Hidden::Effect(e),
        flat,
        seed,
    };
    let f1 = [58.0, 0.47, 0.04, 12.41];
    let f2 = [66.0, 0.52, 0.06, 12.37];
    let f3 = [50.0, 0.40, 0.02, 12.45];
    vec![
        hide(
            "voided sleeper 17, 0.3 mm",
            VoidedSleeper {
                sleeper: 17,
                gap_mm: 0.3,
            },
            f1,
            5,
        ),
        hide(
            "voided sleeper 18, 1.0 mm",
            VoidedSleeper {
                sleeper: 18,
                gap_mm: 1.0,
            },
            f2,
            6,
        ),
        hide(
            "pad 17 ×0.3",
            PadStiffness {
                sleeper: 17,
                factor: 0.3,
            },
            f3,
            7,
        ),
        hide(
            "pad 16 ×0.15",
            PadStiffness {
                sleeper: 16,
                factor: 0.15,
            },
            f1,
            8,
        ),
        hide(
            "ballast 18 ×0.2",
            BallastStiffness {
                sleeper: 18,
                factor: 0.2,
            },
            f2,
            9,
        ),
        hide(
            "ballast 16 ×0.3",
            BallastStiffness {
                sleeper: 16,
                factor: 0.3,
            },
            f3,
            10,
        ),
        hide(
            "dip at 11.9 m, 0.5 m, 1.5 mm",
            RailDip {
                position_m: 11.9,
                length_m: 0.5,
                depth_mm: 1.5,
            },
            f1,
            11,
        ),
        hide(
            "dip at 12.95 m, 0.4 m, 1 mm",
            RailDip {
                position_m: 12.95,
                length_m: 0.4,
                depth_mm: 1.0,
            },
            f2,
            12,
        ),
        hide(
            "irregularity 0.5 m, 0.5 mm",
            RailIrregularity {
                wavelength_m: 0.5,
                amplitude_mm: 0.5,
                phase_deg: 30.0,
            },
            f3,
            13,
        ),
        hide(
            "irregularity 0.8 m, 0.6 mm",
            RailIrregularity {
                wavelength_m: 0.8,
                amplitude_mm: 0.6,
                phase_deg: 120.0,
            },
            f1,
            14,
        ),
        hide(
            "leading wheel order 5, 0.4 mm",
            WheelOutOfRound {
                wheel: WheelPosition::Leading,
                order: 5,
                amplitude_mm: 0.4,
                phase_deg: 0.0,
            },
            f2,
            15,
        ),
        hide(
            "trailing wheel order 9, 0.1 mm",
            WheelOutOfRound {
                wheel: WheelPosition::Trailing,
                order: 9,
                amplitude_mm: 0.1,
                phase_deg: 60.0,
            },
            f3,
            16,
        ),
        hide(
            "rps2 gain ×1.6",
            SensorGain {
                sensor: "rps2".into(),
                factor: 1.6,
            },
            f1,
            17,
        ),
        hide(
            "rps4 gain ×0.55",
            SensorGain {
                sensor: "rps4".into(),
                factor: 0.55,
            },
            f2,
            18,
        ),
        hide("clock +10 ms", TimeOffset { offset_ms: 10.0 }, f3, 19),
        hide("clock −15 ms", TimeOffset { offset_ms: -15.0 }, f1, 20),
        hide("speed +5 %", SpeedDeviation { fraction: 0.05 }, f2, 21),
        hide("speed −7 %", SpeedDeviation { fraction: -0.07 }, f3, 22),
        hide(
            "bounce 30 % at 1.2 Hz",
            CarBodyBounce {
                amplitude: 0.3,
                frequency_hz: 1.2,
                phase_deg: 40.0,
            },
            f1,
            23,
        ),
        hide(
            "bounce 25 % at 3 Hz",
            CarBodyBounce {
                amplitude: 0.25,
                frequency_hz: 3.0,
                phase_deg: 200.0,
            },
            f2,
            24,
        ),
        Case {
            name: "clean A".into(),
            hidden: Hidden::Clean,
            flat: f1,
            seed: 25,
        },
        Case {
            name: "clean B".into(),
            hidden: Hidden::Clean,
            flat: f2,
            seed: 26,
        },
        Case {
            name: "clean C".into(),
            hidden: Hidden::Clean,
            flat: f3,
            seed: 27,
        },
        Case {
            name: "unsprung mass +40 % (not in the library)".into(),
            hidden: Hidden::NotInLibrary("wheel_mass_kg × 1.4".into()),
            flat: f1,
            seed: 28,
        },
    ]
}

/// Whether `named` is `truth`'s kind in `truth`'s place (same sleeper, sensor or wheel; a dip
/// within half a sleeper bay).
pub fn same_kind_and_place(named: &Effect, truth: &Effect) -> bool {
    use Effect::*;
    match (named, truth) {
        (VoidedSleeper { sleeper: a, .. }, VoidedSleeper { sleeper: b, .. })
        | (PadStiffness { sleeper: a, .. }, PadStiffness { sleeper: b, .. })
        | (BallastStiffness { sleeper: a, .. }, BallastStiffness { sleeper: b, .. }) => a == b,
        (RailDip { position_m: a, .. }, RailDip { position_m: b, .. }) => (a - b).abs() < 0.35,
        (WheelOutOfRound { wheel: a, .. }, WheelOutOfRound { wheel: b, .. }) => a == b,
        (SensorGain { sensor: a, .. }, SensorGain { sensor: b, .. }) => a == b,
        _ => std::mem::discriminant(named) == std::mem::discriminant(truth),
    }
}

/// A case's outcome.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Outcome {
    /// Case name.
    pub case: String,
    /// What was hidden.
    pub hidden: Hidden,
    /// The effect named, if any.
    pub named: Option<Effect>,
    /// The verdict.
    pub verdict: String,
    /// Passed: hidden effect named in its place; clean and out-of-library: nothing named.
    pub pass: bool,
    /// Gap RMS before (kN).
    pub gap_before_kn: f64,
    /// Gap RMS after adding the named effect (kN), when one was added.
    pub gap_after_kn: Option<f64>,
    /// Samples outside before.
    pub outside_before: usize,
    /// Samples outside after.
    pub outside_after: Option<usize>,
    /// Residual RMS before / after (kN).
    pub rms_before_kn: f64,
    /// After.
    pub rms_after_kn: Option<f64>,
    /// CMS before / after.
    pub cms_before: usize,
    /// After.
    pub cms_after: Option<usize>,
    /// L0 range before / after (mm).
    pub l0_before_mm: Option<[f64; 2]>,
    /// After.
    pub l0_after_mm: Option<[f64; 2]>,
    /// True L0 (mm).
    pub l0_true_mm: f64,
    /// Simulations of the naming.
    pub simulations: usize,
    /// Wall-clock (s).
    pub seconds: f64,
}

/// Synthesises the case's measurement on `cal` (the bank's calibration, effects added).
pub fn measurement(cal: &CheckedCalibration, case: &Case) -> Result<(Measurement, f64), String> {
    let mut doc: Calibration = cal.document().clone();
    match &case.hidden {
        Hidden::Clean => {}
        Hidden::Effect(e) => doc.effects.push(e.clone()),
        Hidden::NotInLibrary(_) => doc.vehicle.wheel_mass_kg *= 1.4,
    }
    let hidden = doc.check().map_err(|e| e.to_string())?;
    let [l, d, c, xp] = case.flat;
    let flat = Flat::from_mm(l, d, c, xp).map_err(|e| e.to_string())?;
    let syn = synth::synthesize(&hidden, &flat, case.seed, true).map_err(|e| e.to_string())?;
    let m = Measurement::from_csv(Path::new(&case.name), &syn.csv, cal.output.sample_rate_hz)
        .map_err(|e| e.to_string())?;
    Ok((m, syn.truth.l0_mm))
}

/// Runs one case: identify on `identifier`'s bank, diagnose, regenerate a local bank of
/// `local_instances` in `local_dir` when an effect is named.
pub fn run_case(
    identifier: &Identifier,
    cal: &CheckedCalibration,
    case: &Case,
    local_dir: &Path,
    local_instances: usize,
) -> Result<(Outcome, Diagnosis), DiagnoseError> {
    let t = std::time::Instant::now();
    let (m, l0) = measurement(cal, case).map_err(DiagnoseError::Other)?;
    let id = identifier.identify(&m, None, Extras::NONE)?;
    let opts = Options {
        local_instances,
        local_bank_dir: Some(local_dir.to_path_buf()),
        ..Options::default()
    };
    let d = diagnose(identifier, &m, None, &id, &opts, &Quiet)?;
    let named = d
        .naming
        .as_ref()
        .and_then(|n| n.named.map(|i| n.ranking[i].effect.clone()))
        .flatten();
    let pass = match (&case.hidden, &named) {
        (Hidden::Effect(t), Some(n)) => same_kind_and_place(n, t),
        (Hidden::Effect(_), None) => false,
        (_, named) => named.is_none(),
    };
    let after = d.added.as_ref().map(|a| &a.after_stage);
    let outcome = Outcome {
        case: case.name.clone(),
        hidden: case.hidden.clone(),
        named,
        verdict: d.verdict.clone(),
        pass,
        gap_before_kn: d.before_stage.gap_rms_kn,
        gap_after_kn: after.map(|a| a.gap_rms_kn),
        outside_before: d.before_stage.samples_outside,
        outside_after: after.map(|a| a.samples_outside),
        rms_before_kn: d.before_stage.rms_residual_kn,
        rms_after_kn: after.map(|a| a.rms_residual_kn),
        cms_before: d.before_stage.cms,
        cms_after: after.map(|a| a.cms),
        l0_before_mm: d.before_stage.l0_mm,
        l0_after_mm: after.and_then(|a| a.l0_mm),
        l0_true_mm: l0,
        simulations: d.naming.as_ref().map_or(0, |n| n.simulations),
        seconds: t.elapsed().as_secs_f64(),
    };
    Ok((outcome, d))
}
