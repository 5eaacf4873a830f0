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
use crate::identify::synth::{draw_sources, resolution_step_kn};
use crate::identify::{
    Extras, FlatFreeCheck, Identification, Identifier, IdentifyError, Measurement, Severity,
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
    let sim = Simulator::new(cal)?;
    let v = cal.speed_m_per_s();
    let rate = cal.output.sample_rate_hz;
    // Sample offset of each bogie: its centre's distance behind the first one.
    let mut offsets = Vec::with_capacity(spec.bogies);
    let mut distance = 0.0;
    for b in 0..spec.bogies {
        offsets.push((distance / v * rate).round() as usize);
        distance += spec.spacing_m[b % 2];
    }
    let flat_of = |b: usize| {
        spec.flats
            .iter()
            .find(|f| f.bogie == b + 1)
            .map(|f| f.flat.on_wheel(f.wheel))
    };
    let good = sim.run(None, Record::default())?;
    let flats: Vec<Option<crate::model::Response>> = (0..spec.bogies)
        .into_par_iter()
        .map(|b| {
            flat_of(b)
                .map(|f| sim.run(Some(&f), Record::default()))
                .transpose()
        })
        .collect::<Result<_, _>>()?;
    let n_sensors = cal.sensors.pad.len();
    let first = good.first_sample;
    let len = offsets.last().copied().unwrap_or(0) + good.len();
    let id = &cal.identification;
    let mut state = spec.seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0x7EA1;
    let mut sum = vec![vec![0.0f64; len]; n_sensors];
    for (b, &off) in offsets.iter().enumerate() {
        let resp = flats[b].as_ref().unwrap_or(&good);
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
    let mut csv = format!(
        "# wheelflat synthetic train: {} bogies (see the truth JSON)\n# speed_km_per_h = {}\ntime_s",
        spec.bogies, cal.run.speed_km_per_h
    );
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
    // Triggers on the recording clock: sample 0 is the bank's global sample `first` of bogie 1.
    let t_lead = (cal.sensors.laser_trigger_m - cal.run.leading_wheel_start_m) / v;
    let gap = 2.0 * cal.vehicle.half_wheelbase_m / v;
    let leading: Vec<f64> = offsets
        .iter()
        .map(|&off| t_lead + (off as f64 - first as f64) / rate)
        .collect();
    let mut triggers_csv = String::from("time_s\n");
    for &t in &leading {
        triggers_csv += &format!("{t:.6}\n{:.6}\n", t + gap);
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

/// Pairs the triggers into bogies (leading, trailing wheel) and checks each pair against the
/// bank's wheelbase and speed (2 %).
pub fn bogies_from_triggers(
    cal: &CheckedCalibration,
    path: &Path,
    times: &[f64],
) -> Result<Vec<[f64; 2]>, IdentifyError> {
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
    let expected = 2.0 * cal.vehicle.half_wheelbase_m / cal.speed_m_per_s();
    times
        .chunks(2)
        .enumerate()
        .map(|(b, p)| {
            let gap = p[1] - p[0];
            if (gap / expected - 1.0).abs() > 0.02 {
                return Err(IdentifyError::Measurement {
                    path: path.to_path_buf(),
                    line: 2 * b + 2,
                    message: format!(
                        "bogie {}: its wheels passed {gap:.4} s apart, which is {:.1} km/h over the {:.2} m wheelbase; the bank is for {} km/h (±2 %)",
                        b + 1,
                        2.0 * cal.vehicle.half_wheelbase_m / gap * 3.6,
                        2.0 * cal.vehicle.half_wheelbase_m,
                        cal.run.speed_km_per_h
                    ),
                });
            }
            Ok([p[0], p[1]])
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
        "bank {} does not cover a train: its population has the flat on the {} wheel{} and X_p over {span:.2} m of the {revolution:.2} m wheel revolution. A flat can be on either wheel and strike anywhere along a revolution: build a train-profile bank (`wheelflat calibration --profile train --out train.toml`, then `wheelflat bank generate --calibration train.toml --out train-bank`)",
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
    /// `no`, `yes`, or `unknown` (the model class is refuted for this bogie).
    pub flat: String,
    /// L0 range of the flat (mm), when there is one.
    pub l0_mm: Option<[f64; 2]>,
    /// Surviving instances with the flat on this wheel.
    pub cms_count: usize,
    /// Severity class (rule in [`Severity::of_wheel`]).
    pub severity: Severity,
}

/// One bogie's outcome.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BogieResult {
    /// Bogie, 1-based.
    pub bogie: usize,
    /// Leading and trailing trigger times (s, recording clock).
    pub triggers_s: [f64; 2],
    /// The good-wheel check.
    pub flat_free: FlatFreeCheck,
    /// The identification, when the good-wheel check failed.
    pub identification: Option<Identification>,
    /// Milliseconds spent on the bogie.
    pub ms: f64,
}

/// The whole train.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrainResult {
    /// The recording.
    pub recording: String,
    /// The bank.
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

/// Identifies every bogie of a train recording.
pub fn identify_train(
    identifier: &Identifier,
    recording: &Measurement,
    bogies: &[[f64; 2]],
) -> Result<TrainResult, IdentifyError> {
    let clock = Instant::now();
    let s = identifier.settings();
    let mut results = Vec::with_capacity(bogies.len());
    let mut rows = Vec::with_capacity(2 * bogies.len());
    // Bogies closer than the windows reach: a neighbour's load inside the windows.
    let meta = identifier.bank().metadata();
    let first = meta.sensors.iter().map(|a| a.t0_s).fold(f64::MAX, f64::min);
    let last = meta
        .sensors
        .iter()
        .map(|a| a.t0_s + a.samples as f64 / a.sample_rate_hz)
        .fold(f64::MIN, f64::max);
    let reach_s = last - first;
    let v = meta.calibration.run.speed_km_per_h / 3.6;
    let warnings: Vec<String> = bogies
        .windows(2)
        .enumerate()
        .filter(|(_, p)| p[1][0] - p[0][0] < reach_s)
        .map(|(b, p)| {
            format!(
                "bogies {} and {} are {:.1} m apart, closer than the {:.1} m the bank's windows reach: the neighbour's load inside the windows is not modelled",
                b + 1,
                b + 2,
                (p[1][0] - p[0][0]) * v,
                reach_s * v
            )
        })
        .collect();
    // A false "flat" on any good bogie of the train is kept below 1 − φ: Šídák over bogies.
    let phi_bogie = s.phi.powf(1.0 / bogies.len().max(1) as f64);
    let mut m = recording.clone();
    for (b, &triggers) in bogies.iter().enumerate() {
        let started = Instant::now();
        m.laser_trigger_s = Some(triggers[0]);
        let check = identifier.check_flat_free(&m, None, phi_bogie)?;
        let identification = if check.passes {
            None
        } else {
            Some(identifier.identify(&m, None, Extras::NONE)?)
        };
        for wheel in [WheelPosition::Leading, WheelPosition::Trailing] {
            let (flat, l0, count) = match &identification {
                None => ("no", None, 0),
                Some(id) if id.cms.is_empty() => ("unknown", None, 0),
                Some(id) => match id.wheel_ranges.iter().find(|w| w.wheel == wheel) {
                    Some(w) => ("yes", Some(w.ranges.l0_mm), w.cms_count),
                    None => ("no", None, 0),
                },
            };
            rows.push(WheelRow {
                car: b / 2 + 1,
                bogie: b + 1,
                wheel,
                flat: flat.into(),
                l0_mm: l0,
                cms_count: count,
                severity: Severity::of_wheel(flat, l0, s.urgent_l0_mm, s.inspect_l0_mm),
            });
        }
        results.push(BogieResult {
            bogie: b + 1,
            triggers_s: triggers,
            flat_free: check,
            identification,
            ms: started.elapsed().as_secs_f64() * 1e3,
        });
    }
    Ok(TrainResult {
        recording: recording.path.display().to_string(),
        bank_id: identifier.bank().metadata().bank_id.clone(),
        wheels: rows,
        bogies: results,
        severity_rule: Severity::train_rule(phi_bogie, s),
        warnings,
        total_ms: clock.elapsed().as_secs_f64() * 1e3,
    })
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
        assert_eq!(
            bogies_from_triggers(&cal, p, &[1.0, 1.0 + gap]).unwrap(),
            vec![[1.0, 1.0 + gap]]
        );
        let e = bogies_from_triggers(&cal, p, &[1.0, 1.0 + 1.1 * gap])
            .unwrap_err()
            .to_string();
        assert!(e.contains("bogie 1: its wheels passed"), "{e}");
        let e = bogies_from_triggers(&cal, p, &[1.0])
            .unwrap_err()
            .to_string();
        assert!(e.contains("count must be even"), "{e}");
    }
}
