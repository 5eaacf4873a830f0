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
use crate::identify::{
    Detection, Extras, FlatVerdict, Identification, Identifier, Measurement, Severity,
    SeverityRange,
};
use crate::model::{Simulator, WheelPosition};
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::time::Instant;

mod error;
mod synth;
mod triggers;

pub use error::TrainError;

pub use synth::{
    default_flats, synthesize_train, SyntheticTrain, TrainFlat, TrainSpec, TrainTruth,
};
pub use triggers::{bogies_from_triggers, read_triggers, Bogie};

/// Whether a bank's population covers a train: both wheels, X_p over a whole revolution.
pub fn check_coverage(bank: &Bank, dir: &Path) -> Result<(), TrainError> {
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
    Err(TrainError::NotCovering {
        dir: dir.to_path_buf(),
        wheels: wheels
            .iter()
            .map(|w| w.name())
            .collect::<Vec<_>>()
            .join(" and "),
        span_m: span,
        revolution_m: revolution,
    })
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
    /// The flat verdict: `no`, `yes`, `unknown` (the model class is refuted for this bogie)
    /// or `not seen` (no flat detected, but these sensors cannot see this wheel's flats at
    /// this pass).
    pub flat: FlatVerdict,
    /// L0 range of the flat (mm), when there is one.
    pub l0_mm: Option<[f64; 2]>,
    /// Surviving instances with the flat on this wheel.
    pub cms_count: usize,
    /// Severity class (rule in [`Severity::of_wheel`]; from the refined range when there is
    /// one).
    pub severity: Severity,
    /// The classes the wheel's answer spans (`severity` is their highest, the one acted on);
    /// absent for a wheel the pass cannot see.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub classes: Option<SeverityRange>,
    /// The wheel's id, `<bogie_id>/leading` or `…/trailing`, when the recording's consist
    /// names its bogies.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wheel_id: Option<String>,
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
    pub load: Option<crate::identify::detect::load::LoadEstimate>,
    /// Milliseconds spent on the bogie.
    pub ms: f64,
    /// The bogie's id from the consist, when given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bogie_id: Option<String>,
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
/// bogie's speed). A whole train pass from its files (the members picked, the table written,
/// the bogies stored) is [`crate::pass::train::identify_train`].
pub fn identify_bogies(
    identifiers: &[&Identifier],
    recording: &Measurement,
    bogies: &[Bogie],
) -> Result<TrainResult, TrainError> {
    if identifiers.len() != bogies.len() || bogies.is_empty() {
        return Err(TrainError::BanksPerBogie {
            bogies: bogies.len(),
            banks: identifiers.len(),
        });
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
            let sized = identification
                .as_ref()
                .and_then(|id| id.sizing.as_ref().map(|z| (id, z)));
            let (flat, l0, count, by_rule) = match sized {
                None if unseen => (FlatVerdict::NotSeen, None, 0, None),
                None => (FlatVerdict::No, None, 0, None),
                // Smaller than the population: on a wheel the population puts flats on.
                Some((id, z)) if z.below_population => {
                    match id.population.flat_wheels.contains(&wheel) {
                        true => (
                            FlatVerdict::Yes,
                            Some([0.0, id.population.l0_mm[0]]),
                            0,
                            None,
                        ),
                        false => (FlatVerdict::No, None, 0, None),
                    }
                }
                Some((_, z)) if z.cms.is_empty() => (FlatVerdict::Unknown, None, 0, None),
                Some((_, z)) => match z.wheel_ranges.iter().find(|w| w.wheel == wheel) {
                    Some(w) => (
                        FlatVerdict::Yes,
                        Some(w.ranges.l0_mm),
                        w.cms_count,
                        Some(SeverityRange::of_ranges(&w.ranges, s)),
                    ),
                    None => (FlatVerdict::No, None, 0, None),
                },
            };
            let classes = match (flat, by_rule, l0) {
                (FlatVerdict::Yes, Some(rule), _) => Some(rule),
                (FlatVerdict::Yes, None, Some(l0)) => {
                    Some(SeverityRange::of_l0(l0, s.urgent_l0_mm, s.inspect_l0_mm))
                }
                (FlatVerdict::NotSeen, ..) => None,
                _ => Some(SeverityRange::single(Severity::of_wheel(
                    flat,
                    l0,
                    s.urgent_l0_mm,
                    s.inspect_l0_mm,
                ))),
            };
            rows.push(WheelRow {
                car: b / 2 + 1,
                bogie: b + 1,
                wheel,
                flat,
                l0_mm: l0,
                cms_count: count,
                severity: classes.map_or_else(
                    || Severity::of_wheel(flat, l0, s.urgent_l0_mm, s.inspect_l0_mm),
                    SeverityRange::acted_on,
                ),
                classes,
                wheel_id: None,
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
            bogie_id: None,
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
/// [`identify_bogies`].
pub fn refine_wheels(
    result: &mut TrainResult,
    identifiers: &[&Identifier],
    settings: RefineSettings,
) -> Result<(), TrainError> {
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
            .filter(|w| w.bogie == bogie.bogie && w.flat == FlatVerdict::Yes)
        {
            let mut one = id.clone();
            if let Some(z) = one.sizing.as_mut() {
                z.cms.retain(|c| c.flat_wheel == row.wheel);
            }
            if let Some(r) = refine(identifier, sim, &one, settings)?.ranges {
                row.refined_l0_mm = Some(r.l0_mm);
                let classes = SeverityRange::of_l0(r.l0_mm, s.urgent_l0_mm, s.inspect_l0_mm);
                row.severity = classes.acted_on();
                row.classes = Some(classes);
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
