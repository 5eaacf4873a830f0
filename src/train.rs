//! Whole-train identification: one recording of all sensors while a train of many bogies
//! passes, with the laser trigger time of every wheel. Each bogie is identified on its own:
//! its leading wheel's trigger aligns the recording to the bank's time axis (the bank's
//! windows then cut the bogie's part out of the recording). A good-wheel check comes first:
//! the bank's flat-free prediction against the measurement at every PIP. When it passes, no
//! flat can be told from the measurement and the bogie's wheels are reported without one;
//! only a bogie that fails it is identified. The check spreads φ over the train's bogies
//! (Šídák, `φ^(1/bogies)` per bogie), so that a false flat anywhere on a train of good wheels
//! has probability ≤ 1 − φ; at φ per bogie a 12-bogie train of good wheels would raise one in
//! about 46 % of passes.
//!
//! The bank simulates one isolated half bogie. Its windows cover the time from the first
//! window's start to the last one's end (8 m of travel with the default five sensors); a
//! neighbouring bogie closer than that puts its load inside them, which the bank does not
//! model, and `train` says so for every such pair. The synthetic train keeps its bogies
//! 12.5 m apart within a car and 9 m between cars.

use crate::bank::Bank;
use crate::identify::refine::{bank_simulator, refine, RefineSettings};
use crate::identify::synth::{draw_sources, resolution_step_kn, MARGIN_SAMPLES};
use crate::identify::{
    Detection, Extras, Identification, Identifier, IdentifyError, Measurement, Severity,
};
use crate::model::calibration::{UncertaintyGroup, UncertaintyKind};
use crate::model::{CheckedCalibration, Flat, Record, SimError, Simulator, WheelPosition};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::time::Instant;

/// A flat hidden on one wheel of a synthetic train.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainFlat {
    /// Bogie number, 1-based in running order.
    pub bogie: usize,
    /// The wheel of the (half) bogie.
    pub wheel: WheelPosition,
    /// The flat.
    pub flat: Flat,
}

/// A synthetic train.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainSpec {
    /// Bogies, in running order (two per car).
    pub bogies: usize,
    /// Flats; every other wheel is good.
    pub flats: Vec<TrainFlat>,
    /// Bogie-centre spacing within a car and between cars (m).
    pub spacing_m: [f64; 2],
    /// Seed of the perturbation.
    pub seed: u64,
    /// Each bogie's speed over the site (km/h), e.g. a train accelerating through it; empty:
    /// every bogie at the calibration's speed.
    pub speeds_km_per_h: Vec<f64>,
    /// Each bogie's car-body mass as a factor of the calibration's (cars empty or laden);
    /// empty: every bogie at the calibration's.
    pub loads: Vec<f64>,
}

/// The default train's flats: bogie 2 leading (60 × 0.5 mm), bogie 7 trailing (45 × 0.3 mm),
/// bogie 11 leading (90 × 0.8 mm), at impact positions spread over the revolution.
pub fn default_flats() -> Vec<TrainFlat> {
    let flat = |l, d, c, x| Flat::from_mm(l, d, c, x).expect("valid default flat");
    vec![
        TrainFlat {
            bogie: 2,
            wheel: WheelPosition::Leading,
            flat: flat(60.0, 0.5, 0.1, 12.4),
        },
        TrainFlat {
            bogie: 7,
            wheel: WheelPosition::Trailing,
            flat: flat(45.0, 0.3, 0.05, 13.5),
        },
        TrainFlat {
            bogie: 11,
            wheel: WheelPosition::Leading,
            flat: flat(90.0, 0.8, 0.2, 14.0),
        },
    ]
}

impl TrainSpec {
    /// 12 bogies (6 cars), 12.5 m bogie centres within a car, 9 m between cars: farther apart
    /// than a bogie's windows reach (8 m with the default sensors), see [`identify_train`].
    pub fn twelve_bogies(flats: Vec<TrainFlat>, seed: u64) -> TrainSpec {
        TrainSpec {
            bogies: 12,
            flats,
            spacing_m: [12.5, 9.0],
            seed,
            speeds_km_per_h: Vec::new(),
            loads: Vec::new(),
        }
    }
}

/// What a synthetic train hides.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrainTruth {
    /// Bogies in the train.
    pub bogies: usize,
    /// (bogie, wheel, L mm, d mm, c mm, X_p m, L0 mm) of every flat.
    pub flats: Vec<(usize, WheelPosition, f64, f64, f64, f64, f64)>,
    /// Leading-wheel trigger time of every bogie (recording clock, s).
    pub leading_triggers_s: Vec<f64>,
    /// Seed of the perturbation.
    pub seed: u64,
}

/// A synthetic train recording.
#[derive(Debug, Clone, PartialEq)]
pub struct SyntheticTrain {
    /// The recording (measurement CSV format).
    pub csv: String,
    /// The trigger times, one per wheel (`time_s` column).
    pub triggers_csv: String,
    /// The truth.
    pub truth: TrainTruth,
}

/// Simulates every bogie (the good ones once), places them on one clock and perturbs the sum
/// as `synth` does: per bogie and sensor a systematic model error, per sensor a gain error,
/// noise per sample, quantisation.
pub fn synthesize_train(
    cal: &CheckedCalibration,
    spec: &TrainSpec,
) -> Result<SyntheticTrain, SimError> {
    let rate = cal.output.sample_rate_hz;
    let speed_of = |b: usize| {
        spec.speeds_km_per_h
            .get(b)
            .copied()
            .unwrap_or(cal.run.speed_km_per_h)
    };
    let load_of = |b: usize| spec.loads.get(b).copied().unwrap_or(1.0);
    // One simulator (and one good-wheel response) per distinct speed and load.
    let mut speeds: Vec<(f64, f64)> = (0..spec.bogies)
        .map(|b| (speed_of(b), load_of(b)))
        .collect();
    speeds.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    speeds.dedup();
    let sims: Vec<((f64, f64), Simulator, crate::model::Response)> = speeds
        .iter()
        .map(|&(kmh, load)| {
            let mut doc = cal.document().clone();
            doc.run.speed_km_per_h = kmh;
            doc.vehicle.car_body_mass_kg *= load;
            // A margin around the windows, as `synth` records: a bogie at another speed than
            // its bank's is read a little before and after them.
            doc.output.window_samples += 2 * MARGIN_SAMPLES;
            let c = doc.check().map_err(|e| SimError::Setup(e.to_string()))?;
            let sim = Simulator::new(&c)?;
            let good = sim.run(None, Record::default())?;
            Ok(((kmh, load), sim, good))
        })
        .collect::<Result<_, SimError>>()?;
    let sim_of = |b: usize| {
        sims.iter()
            .find(|((kmh, load), ..)| {
                kmh.to_bits() == speed_of(b).to_bits() && load.to_bits() == load_of(b).to_bits()
            })
            .expect("every bogie's speed has a simulator")
    };
    // Where each bogie's record starts on the recording clock (s): its centre's distance
    // behind the first one at the speed of the bogie ahead, and its window's start.
    let mut starts_s = Vec::with_capacity(spec.bogies);
    let mut t = 0.0;
    for b in 0..spec.bogies {
        starts_s.push(t);
        t += spec.spacing_m[b % 2] / (speed_of(b) / 3.6);
    }
    let offsets: Vec<usize> = starts_s
        .iter()
        .map(|t| (t * rate).round() as usize)
        .collect();
    let flat_of = |b: usize| {
        spec.flats
            .iter()
            .find(|f| f.bogie == b + 1)
            .map(|f| f.flat.on_wheel(f.wheel))
    };
    let flats: Vec<Option<crate::model::Response>> = (0..spec.bogies)
        .into_par_iter()
        .map(|b| {
            flat_of(b)
                .map(|f| sim_of(b).1.run(Some(&f), Record::default()))
                .transpose()
        })
        .collect::<Result<_, _>>()?;
    let n_sensors = cal.sensors.pad.len();
    let len = (0..spec.bogies)
        .map(|b| offsets[b] + sim_of(b).2.len())
        .max()
        .unwrap_or(0);
    let id = &cal.identification;
    let mut state = spec.seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0x7EA1;
    let mut sum = vec![vec![0.0f64; len]; n_sensors];
    for (b, &off) in offsets.iter().enumerate() {
        let resp = flats[b].as_ref().unwrap_or(&sim_of(b).2);
        for (s, series) in resp.pad_force_n.iter().enumerate() {
            let e = draw_sources(
                id,
                UncertaintyGroup::Model,
                UncertaintyKind::Relative,
                false,
                &mut state,
            );
            for (j, &g) in series.iter().enumerate() {
                sum[s][off + j] += g / 1e3 * (1.0 - e);
            }
        }
    }
    let gain: Vec<f64> = (0..n_sensors)
        .map(|_| {
            draw_sources(
                id,
                UncertaintyGroup::Measurement,
                UncertaintyKind::Relative,
                false,
                &mut state,
            )
        })
        .collect();
    let step = resolution_step_kn(id);
    let names: Vec<&str> = cal.sensors.pad.iter().map(|p| p.name.as_str()).collect();
    // The speed line only when every bogie ran at one speed (each bogie's own speed is in
    // the triggers).
    let mut csv = format!(
        "# wheelflat synthetic train: {} bogies (see the truth JSON)\n",
        spec.bogies
    );
    if speeds
        .iter()
        .all(|v| v.0.to_bits() == speeds[0].0.to_bits())
    {
        csv += &format!("# speed_km_per_h = {}\n", speeds[0].0);
    }
    csv += "time_s";
    for n in &names {
        csv += &format!(",{n}_kn");
    }
    csv.push('\n');
    for j in 0..len {
        csv += &format!("{:.6}", j as f64 / rate);
        for (series, g) in sum.iter().zip(&gain) {
            let noise = draw_sources(
                id,
                UncertaintyGroup::Measurement,
                UncertaintyKind::AbsoluteKn,
                true,
                &mut state,
            );
            let mut y = series[j] * (1.0 + g) + noise;
            if step > 0.0 {
                y = (y / step).round() * step;
            }
            csv += &format!(",{y:.4}");
        }
        csv.push('\n');
    }
    // Triggers on the recording clock: bogie b's record starts at its offset, which holds
    // its simulation's global sample `first_sample`.
    let mut leading = Vec::with_capacity(spec.bogies);
    let mut triggers_csv = String::from("time_s\n");
    for (b, &off) in offsets.iter().enumerate() {
        let v = speed_of(b) / 3.6;
        let t_lead = (cal.sensors.laser_trigger_m - cal.run.leading_wheel_start_m) / v;
        let first = sim_of(b).2.first_sample;
        let t = t_lead + (off as f64 - first as f64) / rate;
        let gap = 2.0 * cal.vehicle.half_wheelbase_m / v;
        triggers_csv += &format!("{t:.6}\n{:.6}\n", t + gap);
        leading.push(t);
    }
    let radius = cal.vehicle.wheel_radius_m;
    Ok(SyntheticTrain {
        csv,
        triggers_csv,
        truth: TrainTruth {
            bogies: spec.bogies,
            flats: spec
                .flats
                .iter()
                .map(|f| {
                    (
                        f.bogie,
                        f.wheel,
                        f.flat.length_m() * 1e3,
                        f.flat.depth_m() * 1e3,
                        f.flat.curvature_m() * 1e3,
                        f.flat.impact_position_m(),
                        f.flat.fresh_length_m(radius) * 1e3,
                    )
                })
                .collect(),
            leading_triggers_s: leading,
            seed: spec.seed,
        },
    })
}

/// Reads a trigger file: one time per wheel passing the laser (s, recording clock), an
/// optional `time_s` header, `#` comments. Errors name the file, line and value.
pub fn read_triggers(path: &Path, text: &str) -> Result<Vec<f64>, IdentifyError> {
    let bad = |line: usize, message: String| IdentifyError::Measurement {
        path: path.to_path_buf(),
        line,
        message,
    };
    let mut times: Vec<f64> = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') || (i == 0 && line == "time_s") {
            continue;
        }
        let t: f64 = line
            .parse()
            .map_err(|_| bad(i + 1, format!("`{line}` is not a time in seconds")))?;
        if !t.is_finite() {
            return Err(bad(i + 1, format!("`{line}` is not a finite time")));
        }
        if let Some(&prev) = times.last() {
            if t <= prev {
                return Err(bad(
                    i + 1,
                    format!("trigger time {t} s does not increase (previous {prev} s)"),
                ));
            }
        }
        times.push(t);
    }
    if times.is_empty() {
        return Err(bad(1, "no trigger times".into()));
    }
    Ok(times)
}

/// One bogie of a recording: its wheels' trigger times and the speed they give.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Bogie {
    /// Leading and trailing wheel's trigger times (s, recording clock).
    pub triggers_s: [f64; 2],
    /// The bogie's speed over the laser (km/h): wheelbase / time between its wheels.
    pub speed_km_per_h: f64,
}

/// Pairs the triggers into bogies (leading, trailing wheel), each with the speed its pair
/// gives over the calibration's wheelbase (a train may accelerate through the site, so every
/// bogie has its own); a speed outside 1–500 km/h is an error naming the line.
pub fn bogies_from_triggers(
    cal: &CheckedCalibration,
    path: &Path,
    times: &[f64],
) -> Result<Vec<Bogie>, IdentifyError> {
    if !times.len().is_multiple_of(2) {
        return Err(IdentifyError::Measurement {
            path: path.to_path_buf(),
            line: 1,
            message: format!(
                "{} trigger times: a half bogie has two wheels, so the count must be even",
                times.len()
            ),
        });
    }
    let wheelbase = 2.0 * cal.vehicle.half_wheelbase_m;
    times
        .chunks(2)
        .enumerate()
        .map(|(b, p)| {
            let gap = p[1] - p[0];
            let speed = wheelbase / gap * 3.6;
            if !(1.0..=500.0).contains(&speed) {
                return Err(IdentifyError::Measurement {
                    path: path.to_path_buf(),
                    line: 2 * b + 2,
                    message: format!(
                        "bogie {}: its wheels passed {gap:.4} s apart, which is {speed:.1} km/h over the {wheelbase:.2} m wheelbase: not a train speed (1 to 500 km/h)",
                        b + 1,
                    ),
                });
            }
            Ok(Bogie {
                triggers_s: [p[0], p[1]],
                speed_km_per_h: speed,
            })
        })
        .collect()
}

/// Whether a bank's population covers a train: both wheels, X_p over a whole revolution.
pub fn check_coverage(bank: &Bank, dir: &Path) -> Result<(), IdentifyError> {
    let cal = &bank.metadata().calibration;
    let p = &cal.population;
    let wheels = p
        .flat_wheels
        .clone()
        .unwrap_or_else(|| vec![cal.vehicle.flat_wheel]);
    let revolution = std::f64::consts::TAU * cal.vehicle.wheel_radius_m;
    let span = p.impact_position_m[1] - p.impact_position_m[0];
    let both =
        wheels.contains(&WheelPosition::Leading) && wheels.contains(&WheelPosition::Trailing);
    if both && span >= revolution - 1e-3 {
        return Ok(());
    }
    Err(IdentifyError::Invalid(format!(
        "bank {} does not cover a train: its population has the flat on the {} wheel{} and X_p over {span:.2} m of the {revolution:.2} m wheel revolution. A flat can be on either wheel and strike anywhere along a revolution: build a bank of the site profile, the default (`wheelflat bank generate --out train-bank`; or `wheelflat calibration --out site.toml` to start a calibration from)",
        dir.display(),
        wheels
            .iter()
            .map(|w| w.name())
            .collect::<Vec<_>>()
            .join(" and "),
        if wheels.len() > 1 { "s" } else { "" },
    )))
}

/// One wheel's line of the train table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WheelRow {
    /// Car, 1-based (two bogies per car).
    pub car: usize,
    /// Bogie, 1-based in running order.
    pub bogie: usize,
    /// Leading or trailing wheel of the (half) bogie.
    pub wheel: WheelPosition,
    /// `no`, `yes`, `unknown` (the model class is refuted for this bogie) or `not seen` (no
    /// flat detected, but these sensors cannot see this wheel's flats at this pass).
    pub flat: String,
    /// L0 range of the flat (mm), when there is one.
    pub l0_mm: Option<[f64; 2]>,
    /// Surviving instances with the flat on this wheel.
    pub cms_count: usize,
    /// Severity class (rule in [`Severity::of_wheel`]; from the refined range when there is
    /// one).
    pub severity: Severity,
    /// The refined L0 range (mm), with `train --refine` ([`refine_wheels`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refined_l0_mm: Option<[f64; 2]>,
}

/// One bogie's outcome.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BogieResult {
    /// Bogie, 1-based.
    pub bogie: usize,
    /// Leading and trailing trigger times (s, recording clock).
    pub triggers_s: [f64; 2],
    /// The bogie's speed from its triggers (km/h).
    #[serde(default)]
    pub speed_km_per_h: f64,
    /// The speed of the bank (family member) it was compared with (km/h).
    #[serde(default)]
    pub bank_speed_km_per_h: f64,
    /// The detection step (`identify::detect`), with the detection limit when no flat is
    /// detected.
    pub detection: Detection,
    /// The identification, when a flat was detected.
    pub identification: Option<Identification>,
    /// The wheel load its part of the record shows, and the bank's it was compared at.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub load: Option<crate::identify::load::LoadEstimate>,
    /// Milliseconds spent on the bogie.
    pub ms: f64,
}

/// The whole train.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrainResult {
    /// The recording.
    pub recording: String,
    /// The bank, or the family members' banks in the order first used.
    pub bank_id: String,
    /// One line per wheel.
    pub wheels: Vec<WheelRow>,
    /// Per bogie.
    pub bogies: Vec<BogieResult>,
    /// The severity rule, in words.
    pub severity_rule: String,
    /// What the result may suffer from (bogies closer than the bank's windows reach).
    pub warnings: Vec<String>,
    /// Wall time (ms).
    pub total_ms: f64,
}

/// Identifies every bogie of a train recording, bogie `b` against `identifiers[b]` (the bank,
/// or the family member at the bogie's speed; the recording is put on its time axis at the
/// bogie's speed).
pub fn identify_train(
    identifiers: &[&Identifier],
    recording: &Measurement,
    bogies: &[Bogie],
) -> Result<TrainResult, IdentifyError> {
    if identifiers.len() != bogies.len() || bogies.is_empty() {
        return Err(IdentifyError::Invalid(format!(
            "{} bogies and {} banks for them",
            bogies.len(),
            identifiers.len()
        )));
    }
    let identifier = identifiers[0];
    let clock = Instant::now();
    let s = identifier.settings();
    let mut results = Vec::with_capacity(bogies.len());
    let mut rows = Vec::with_capacity(2 * bogies.len());
    // Bogies closer than the windows reach: a neighbour's load inside the windows.
    let reach_m = |id: &Identifier| {
        let meta = id.bank().metadata();
        let first = meta.sensors.iter().map(|a| a.t0_s).fold(f64::MAX, f64::min);
        let last = meta
            .sensors
            .iter()
            .map(|a| a.t0_s + a.samples as f64 / a.sample_rate_hz)
            .fold(f64::MIN, f64::max);
        (last - first) * meta.calibration.run.speed_km_per_h / 3.6
    };
    let warnings: Vec<String> = bogies
        .windows(2)
        .enumerate()
        .filter_map(|(b, p)| {
            let apart_m = (p[1].triggers_s[0] - p[0].triggers_s[0]) * p[0].speed_km_per_h / 3.6;
            let reach = reach_m(identifiers[b]);
            (apart_m < reach).then(|| format!(
                "bogies {} and {} are {apart_m:.1} m apart, closer than the {reach:.1} m the bank's windows reach: the neighbour's load inside the windows is not modelled",
                b + 1,
                b + 2,
            ))
        })
        .collect();
    let mut m = recording.clone();
    let mut bank_ids: Vec<&str> = Vec::new();
    for (b, bogie) in bogies.iter().enumerate() {
        let started = Instant::now();
        let identifier = identifiers[b];
        let id_of_bank = identifier.bank().metadata().bank_id.as_str();
        if !bank_ids.contains(&id_of_bank) {
            bank_ids.push(id_of_bank);
        }
        m.laser_trigger_s = Some(bogie.triggers_s[0]);
        m.speed_km_per_h = Some(bogie.speed_km_per_h);
        // Detection first, in the identification itself: the same step as `identify` and
        // `watch`.
        let mut id = identifier.identify(&m, None, Extras::NONE)?;
        let load = id.load.clone();
        let detection = id
            .detection
            .take()
            .expect("identify runs the detection step");
        let identification = detection.flat_detected.then(|| {
            id.detection = Some(detection.clone());
            id
        });
        for wheel in [WheelPosition::Leading, WheelPosition::Trailing] {
            // (verdict, L0 range, CMS count, the settings' rule on the wheel's ranges)
            // A wheel whose flats the pass cannot see is not a good wheel: no verdict.
            let unseen = detection.limit.as_ref().is_some_and(|l| {
                l.l0_mm.is_none()
                    || l.wheels
                        .iter()
                        .any(|w| w.wheel == wheel && w.l0_mm.is_none())
            });
            let (flat, l0, count, by_rule) = match &identification {
                None if unseen => ("not seen", None, 0, None),
                None => ("no", None, 0, None),
                // Smaller than the population: on a wheel the population puts flats on.
                Some(id) if id.below_population => {
                    match id.population.flat_wheels.contains(&wheel) {
                        true => ("yes", Some([0.0, id.population.l0_mm[0]]), 0, None),
                        false => ("no", None, 0, None),
                    }
                }
                Some(id) if id.cms.is_empty() => ("unknown", None, 0, None),
                Some(id) => match id.wheel_ranges.iter().find(|w| w.wheel == wheel) {
                    Some(w) => (
                        "yes",
                        Some(w.ranges.l0_mm),
                        w.cms_count,
                        Some(Severity::of_ranges(&w.ranges, s)),
                    ),
                    None => ("no", None, 0, None),
                },
            };
            rows.push(WheelRow {
                car: b / 2 + 1,
                bogie: b + 1,
                wheel,
                flat: flat.into(),
                l0_mm: l0,
                cms_count: count,
                severity: match (flat, by_rule) {
                    ("yes", Some(rule)) => rule,
                    _ => Severity::of_wheel(flat, l0, s.urgent_l0_mm, s.inspect_l0_mm),
                },
                refined_l0_mm: None,
            });
        }
        results.push(BogieResult {
            bogie: b + 1,
            triggers_s: bogie.triggers_s,
            speed_km_per_h: bogie.speed_km_per_h,
            bank_speed_km_per_h: identifier.bank().metadata().calibration.run.speed_km_per_h,
            detection,
            load,
            identification,
            ms: started.elapsed().as_secs_f64() * 1e3,
        });
    }
    Ok(TrainResult {
        recording: recording.path.display().to_string(),
        bank_id: bank_ids.join(", "),
        wheels: rows,
        bogies: results,
        severity_rule: Severity::train_rule(s),
        warnings,
        total_ms: clock.elapsed().as_secs_f64() * 1e3,
    })
}

/// Refines every wheel with a flat (`train --refine`, [`crate::identify::refine`]): the
/// bogie's identification restricted to the instances with the flat on that wheel is refined
/// with its bank's calibration, the row gets the refined L0 range beside the bank-only one and
/// its severity from the refined upper bound. `identifiers[b]` is bogie b's bank, as given to
/// [`identify_train`].
pub fn refine_wheels(
    result: &mut TrainResult,
    identifiers: &[&Identifier],
    settings: RefineSettings,
) -> Result<(), IdentifyError> {
    settings.check()?;
    let started = Instant::now();
    let mut sims: Vec<(String, Simulator)> = Vec::new();
    for (b, bogie) in result.bogies.iter().enumerate() {
        let (Some(id), Some(identifier)) = (&bogie.identification, identifiers.get(b)) else {
            continue;
        };
        let bank_id = identifier.bank().metadata().bank_id.clone();
        if !sims.iter().any(|(k, _)| *k == bank_id) {
            sims.push((bank_id.clone(), bank_simulator(identifier)?));
        }
        let sim = &sims
            .iter()
            .find(|(k, _)| *k == bank_id)
            .expect("added above")
            .1;
        let s = identifier.settings();
        for row in result
            .wheels
            .iter_mut()
            .filter(|w| w.bogie == bogie.bogie && w.flat == "yes")
        {
            let mut one = id.clone();
            one.cms.retain(|c| c.flat_wheel == row.wheel);
            if let Some(r) = refine(identifier, sim, &one, settings)?.ranges {
                row.refined_l0_mm = Some(r.l0_mm);
                row.severity =
                    Severity::of_wheel("yes", Some(r.l0_mm), s.urgent_l0_mm, s.inspect_l0_mm);
            }
        }
    }
    result.severity_rule += "; with --refine, by the upper bound of the wheel's refined L0 range";
    result.total_ms += started.elapsed().as_secs_f64() * 1e3;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Calibration;

    #[test]
    fn triggers_are_read_and_paired_with_errors_naming_line_and_value() {
        let p = Path::new("t.csv");
        assert_eq!(
            read_triggers(p, "time_s\n1.0\n1.5\n").unwrap(),
            vec![1.0, 1.5]
        );
        let e = read_triggers(p, "time_s\n1.0\nx\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("t.csv, line 3: `x` is not a time"), "{e}");
        let e = read_triggers(p, "2.0\n1.0\n").unwrap_err().to_string();
        assert!(
            e.contains("line 2: trigger time 1 s does not increase"),
            "{e}"
        );
        let cal = Calibration::default().check().unwrap();
        let gap = 2.0 * cal.vehicle.half_wheelbase_m / cal.speed_m_per_s();
        // Each bogie's speed from its own pair: 50 km/h, then 10 % slower (a gap 1/0.9 as long).
        let b = bogies_from_triggers(&cal, p, &[1.0, 1.0 + gap, 2.0, 2.0 + gap / 0.9]).unwrap();
        assert_eq!(
            b[0].triggers_s.map(f64::to_bits),
            [1.0, 1.0 + gap].map(f64::to_bits)
        );
        assert!((b[0].speed_km_per_h - 50.0).abs() < 1e-9, "{b:?}");
        assert!((b[1].speed_km_per_h - 45.0).abs() < 1e-9, "{b:?}");
        let e = bogies_from_triggers(&cal, p, &[1.0, 1.0 + 100.0 * gap])
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 2: bogie 1: its wheels passed"), "{e}");
        assert!(e.contains("0.5 km/h"), "{e}");
        let e = bogies_from_triggers(&cal, p, &[1.0])
            .unwrap_err()
            .to_string();
        assert!(e.contains("count must be even"), "{e}");
    }
}
