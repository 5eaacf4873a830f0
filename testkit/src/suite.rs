//! The diagnosis acceptance suite: measurements with one effect hidden (every kind of the
//! library at two places or amplitudes, sleeper effects and dips away from the sensors too),
//! a second flat, two effects at once, clean ones (some with AR(1) noise at twice the table's
//! σ), one with an effect the library does not hold, and one whose speed line disagrees with
//! the bank; each is identified on a bank built without effects and diagnosed. A third of the
//! measurements are simulated with a finer model than the bank's (twice the elements per bay,
//! half the steps: model-form error present). Shared by the tests (a CI-sized subset) and
//! `studies/src/bin/diagnose_suite.rs` (all of it).

use serde::{Deserialize, Serialize};
use std::path::Path;
use wheelflat::bank::Quiet;
use wheelflat::diagnose::{diagnose, DiagnoseError, Diagnosis, Options};
use wheelflat::identify::synth::FieldNoise;
use wheelflat::identify::{synth, Extras, Identifier, Measurement};
use wheelflat::model::{Calibration, CheckedCalibration, Effect, Flat, WheelPosition};

/// What a case hides.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Hidden {
    /// Nothing: must come out as "no missing effect found".
    Clean,
    /// An effect of the library: must be named, kind and place.
    Effect(Effect),
    /// Two effects of the library at once: both must be named.
    Pair(Effect, Effect),
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
    /// Measurement simulated with the finer model (model-form error present).
    pub finer: bool,
    /// The measurement's noise.
    pub noise: FieldNoise,
    /// A speed line (km/h) written instead of the bank's, when the case says the train ran at
    /// another speed than the bank's.
    pub speed_line_km_per_h: Option<f64>,
}

/// Every case of the suite.
pub fn cases() -> Vec<Case> {
    use Effect::*;
    let case = |name: &str, hidden: Hidden, flat: [f64; 4], seed: u64| Case {
        name: name.to_string(),
        hidden,
        flat,
        seed,
        finer: false,
        noise: FieldNoise::TABLE,
        speed_line_km_per_h: None,
    };
    let hide = |name: &str, e: Effect, flat: [f64; 4], seed: u64| {
        case(name, Hidden::Effect(e), flat, seed)
    };
    let f1 = [58.0, 0.47, 0.04, 12.41];
    let f2 = [66.0, 0.52, 0.06, 12.37];
    let f3 = [50.0, 0.40, 0.02, 12.45];
    let mut out = vec![
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
        case("clean A", Hidden::Clean, f1, 25),
        case("clean B", Hidden::Clean, f2, 26),
        case("clean C", Hidden::Clean, f3, 27),
        case(
            "unsprung mass +40 % (not in the library)",
            Hidden::NotInLibrary("wheel_mass_kg × 1.4".into()),
            f1,
            28,
        ),
    ];
    out.extend(round_two(&case));
    // A third of the cases, spread over the kinds, measured with the finer model.
    let finer = [
        "pad 16 ×0.15",
        "ballast 18 ×0.2",
        "dip at 12.95 m, 0.4 m, 1 mm",
        "irregularity 0.8 m, 0.6 mm",
        "leading wheel order 5, 0.4 mm",
        "rps4 gain ×0.55",
        "clock −15 ms",
        "speed +5 %",
        "bounce 25 % at 3 Hz",
        "clean C",
        "voided sleeper 13, 0.8 mm",
        "second flat, leading wheel, L 60 mm",
        "ballast 18 ×0.3 + speed +5 %",
        "clean D, finer model",
        "clean E, finer model",
    ];
    for c in &mut out {
        c.finer |= finer.contains(&c.name.as_str());
    }
    out
}

/// Issue 15's cases: away from the sensors, second flats, pairs, field noise, a speed line.
/// A case from its name, what it hides, its flat and seed.
type MakeCase<'a> = &'a dyn Fn(&str, Hidden, [f64; 4], u64) -> Case;

fn round_two(case: MakeCase) -> Vec<Case> {
    use Effect::*;
    let f1 = [58.0, 0.47, 0.04, 12.41];
    let f2 = [66.0, 0.52, 0.06, 12.37];
    let f3 = [50.0, 0.40, 0.02, 12.45];
    let one = |name: &str, e: Effect, flat, seed| case(name, Hidden::Effect(e), flat, seed);
    let two =
        |name: &str, a: Effect, b: Effect, flat, seed| case(name, Hidden::Pair(a, b), flat, seed);
    let second = |wheel, l: f64, d: f64, xp: f64| SecondFlat {
        wheel,
        length_mm: l,
        depth_mm: d,
        curvature_mm: 0.0,
        impact_position_m: xp,
    };
    let ar1 = |name: &str, flat, seed, rho| Case {
        noise: FieldNoise {
            scale: 2.0,
            ar1: rho,
        },
        ..case(name, Hidden::Clean, flat, seed)
    };
    vec![
        one(
            "voided sleeper 13, 0.8 mm",
            VoidedSleeper {
                sleeper: 13,
                gap_mm: 0.8,
            },
            f1,
            31,
        ),
        one(
            "voided sleeper 21, 1.0 mm",
            VoidedSleeper {
                sleeper: 21,
                gap_mm: 1.0,
            },
            f2,
            32,
        ),
        one(
            "dip at 9.9 m, 0.3 m, 0.6 mm (outside the sensors)",
            RailDip {
                position_m: 9.9,
                length_m: 0.3,
                depth_mm: 0.6,
            },
            f3,
            33,
        ),
        one(
            "dip at 14.1 m, 0.3 m, 0.8 mm (outside the sensors)",
            RailDip {
                position_m: 14.1,
                length_m: 0.3,
                depth_mm: 0.8,
            },
            f1,
            34,
        ),
        one(
            "second flat, leading wheel, L 45 mm",
            second(WheelPosition::Leading, 45.0, 0.2, 12.9),
            f1,
            35,
        ),
        one(
            "second flat, trailing wheel, another angle",
            second(WheelPosition::Trailing, 40.0, 0.25, 11.6),
            f2,
            36,
        ),
        one(
            "second flat, leading wheel, L 60 mm",
            second(WheelPosition::Leading, 60.0, 0.35, 12.1),
            f3,
            37,
        ),
        two(
            "voided sleeper 17 + rps4 gain ×0.6",
            VoidedSleeper {
                sleeper: 17,
                gap_mm: 0.5,
            },
            SensorGain {
                sensor: "rps4".into(),
                factor: 0.6,
            },
            f1,
            38,
        ),
        two(
            "pad 16 ×0.2 + clock +8 ms",
            PadStiffness {
                sleeper: 16,
                factor: 0.2,
            },
            TimeOffset { offset_ms: 8.0 },
            f2,
            39,
        ),
        two(
            "dip at 12.95 m + bounce 25 % at 2 Hz",
            RailDip {
                position_m: 12.95,
                length_m: 0.4,
                depth_mm: 1.0,
            },
            CarBodyBounce {
                amplitude: 0.25,
                frequency_hz: 2.0,
                phase_deg: 60.0,
            },
            f3,
            40,
        ),
        two(
            "ballast 18 ×0.3 + speed +5 %",
            BallastStiffness {
                sleeper: 18,
                factor: 0.3,
            },
            SpeedDeviation { fraction: 0.05 },
            f1,
            41,
        ),
        two(
            "irregularity 0.5 m + voided sleeper 15",
            RailIrregularity {
                wavelength_m: 0.5,
                amplitude_mm: 0.5,
                phase_deg: 30.0,
            },
            VoidedSleeper {
                sleeper: 15,
                gap_mm: 0.6,
            },
            f2,
            42,
        ),
        ar1("clean, AR(1) ρ 0.5 at 2σ", f1, 43, 0.5),
        ar1("clean, AR(1) ρ 0.7 at 2σ", f2, 44, 0.7),
        ar1("clean, AR(1) ρ 0.3 at 2σ", f3, 45, 0.3),
        case("clean D, finer model", Hidden::Clean, f2, 46),
        case("clean E, finer model", Hidden::Clean, f3, 47),
        Case {
            speed_line_km_per_h: Some(55.0),
            ..one(
                "speed +10 %, the line says 55 km/h",
                SpeedDeviation { fraction: 0.10 },
                f2,
                48,
            )
        },
    ]
}

/// Whether `named` is `truth`'s kind in `truth`'s place (issue 15: a sleeper effect within
/// one sleeper, a dip within 0.2 m, the same sensor or wheel; a second flat on its wheel
/// striking within 0.2 m of the truth, modulo a revolution of `circumference_m`).
pub fn same_kind_and_place(named: &Effect, truth: &Effect, circumference_m: f64) -> bool {
    use Effect::*;
    match (named, truth) {
        (VoidedSleeper { sleeper: a, .. }, VoidedSleeper { sleeper: b, .. })
        | (PadStiffness { sleeper: a, .. }, PadStiffness { sleeper: b, .. })
        | (BallastStiffness { sleeper: a, .. }, BallastStiffness { sleeper: b, .. }) => {
            a.abs_diff(*b) <= 1
        }
        (RailDip { position_m: a, .. }, RailDip { position_m: b, .. }) => (a - b).abs() <= 0.2,
        (
            SecondFlat {
                wheel: a,
                impact_position_m: x,
                ..
            },
            SecondFlat {
                wheel: b,
                impact_position_m: y,
                ..
            },
        ) => {
            let off = (x - y).rem_euclid(circumference_m);
            a == b && off.min(circumference_m - off) <= 0.2
        }
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
    /// The effects named (none, one, or a pair).
    pub named: Vec<Effect>,
    /// Measured with the finer model.
    pub finer: bool,
    /// The noise estimated from the record.
    pub noise: Option<wheelflat::diagnose::noise::NoiseEstimate>,
    /// A hidden second flat's true L0 and the range reported for it (mm).
    pub second_flat_l0_mm: Option<(f64, Option<[f64; 2]>)>,
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

/// Why a suite case could not be run.
#[derive(Debug, thiserror::Error)]
pub enum SuiteError {
    /// Its measurement could not be made (the hidden calibration, flat or simulation refused:
    /// their own words).
    #[error("making the case's measurement: {0}")]
    Case(String),
    /// Identification refused its measurement.
    #[error(transparent)]
    Identify(#[from] wheelflat::identify::IdentifyError),
    /// The diagnosis refused it.
    #[error(transparent)]
    Diagnose(#[from] DiagnoseError),
}

/// Synthesises the case's measurement on `cal` (the bank's calibration, effects added; the
/// finer model when the case says so).
pub fn measurement(cal: &CheckedCalibration, case: &Case) -> Result<(Measurement, f64), String> {
    let mut doc: Calibration = cal.document().clone();
    match &case.hidden {
        Hidden::Clean => {}
        Hidden::Effect(e) => doc.effects.push(e.clone()),
        Hidden::Pair(a, b) => doc.effects.extend([a.clone(), b.clone()]),
        Hidden::NotInLibrary(_) => doc.vehicle.wheel_mass_kg *= 1.4,
    }
    let hidden = doc.check().map_err(|e| e.to_string())?;
    let hidden = crate::coverage::measurement_model(&hidden, case.finer);
    let [l, d, c, xp] = case.flat;
    let flat = Flat::from_mm(l, d, c, xp).map_err(|e| e.to_string())?;
    let syn = synth::synthesize_with_noise(&hidden, &flat, case.seed, true, case.noise)
        .map_err(|e| e.to_string())?;
    let csv = match case.speed_line_km_per_h {
        Some(v) => syn.csv.replace(
            &format!("# speed_km_per_h = {}\n", cal.run.speed_km_per_h),
            &format!("# speed_km_per_h = {v}\n"),
        ),
        None => syn.csv,
    };
    let m = Measurement::from_csv(Path::new(&case.name), &csv, cal.output.sample_rate_hz)
        .map_err(|e| e.to_string())?;
    Ok((m, syn.truth.l0_mm))
}

/// Whether the effects named are the hidden ones (a pair in either order).
fn named_right(hidden: &Hidden, named: &[Effect], circumference_m: f64) -> bool {
    let same = |a: &Effect, b: &Effect| same_kind_and_place(a, b, circumference_m);
    match (hidden, named) {
        (Hidden::Effect(t), [n]) => same(n, t),
        (Hidden::Pair(a, b), [x, y]) => (same(x, a) && same(y, b)) || (same(x, b) && same(y, a)),
        (Hidden::Clean | Hidden::NotInLibrary(_), []) => true,
        _ => false,
    }
}

/// Runs one case: identify on `identifier`'s bank, diagnose, regenerate a local bank of
/// `local_instances` in `local_dir` when an effect is named.
pub fn run_case(
    identifier: &Identifier,
    cal: &CheckedCalibration,
    case: &Case,
    local_dir: &Path,
    local_instances: usize,
) -> Result<(Outcome, Diagnosis), SuiteError> {
    run_case_with(
        identifier,
        cal,
        case,
        &Options {
            local_instances,
            local_bank_dir: Some(local_dir.to_path_buf()),
            ..Options::default()
        },
    )
}

/// [`run_case`] with diagnosis options `opts`.
pub fn run_case_with(
    identifier: &Identifier,
    cal: &CheckedCalibration,
    case: &Case,
    opts: &Options,
) -> Result<(Outcome, Diagnosis), SuiteError> {
    let t = std::time::Instant::now();
    let (m, l0) = measurement(cal, case).map_err(SuiteError::Case)?;
    let (m, _note) = wheelflat::diagnose::on_bank_speed(&m, cal.run.speed_km_per_h)?;
    let id = identifier.identify(&m, None, Extras::AS_RECORDED)?;
    let d = diagnose(identifier, &m, None, &id, opts, &Quiet)?;
    let named = d
        .naming
        .as_ref()
        .map(|n| n.named_effects())
        .unwrap_or_default();
    let circumference = std::f64::consts::TAU * cal.vehicle.wheel_radius_m;
    let pass = named_right(&case.hidden, &named, circumference);
    let hidden_second = match &case.hidden {
        Hidden::Effect(e) => e.second_flat(),
        Hidden::Pair(a, b) => a.second_flat().or_else(|| b.second_flat()),
        _ => None,
    };
    let second_flat_l0_mm = hidden_second.map(|f| {
        (
            f.fresh_length_m(cal.vehicle.wheel_radius_m) * 1e3,
            d.naming.as_ref().and_then(|n| n.second_flat_l0_mm),
        )
    });
    let after = d.added.as_ref().map(|a| &a.after_stage);
    let outcome = Outcome {
        case: case.name.clone(),
        hidden: case.hidden.clone(),
        named,
        finer: case.finer,
        noise: d.noise,
        second_flat_l0_mm,
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
