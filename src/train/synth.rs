//! Synthetic trains: a recording of many bogies, flats hidden on chosen wheels, with its
//! trigger file and truth (`wheelflat synth --train`).

use crate::identify::domain::uncertainty::{draw_sources, resolution_step_kn};
use crate::identify::synth::MARGIN_SAMPLES;
use crate::model::calibration::{UncertaintyGroup, UncertaintyKind};
use crate::model::surface::{SurfaceNote, SurfaceSpec};
use crate::model::{CheckedCalibration, Flat, Record, SimError, Simulator, WheelPosition};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

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
    /// Rough treads and rail: each bogie's wheels drawn from the class with a seed of their
    /// own (the spec's seed × 1000 + bogie), the rail drawn once for the whole train.
    pub surfaces: Option<SurfaceSpec>,
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
    /// than a bogie's windows reach (8 m with the default sensors), see [`super::identify_bogies`].
    pub fn twelve_bogies(flats: Vec<TrainFlat>, seed: u64) -> TrainSpec {
        TrainSpec {
            bogies: 12,
            flats,
            spacing_m: [12.5, 9.0],
            seed,
            speeds_km_per_h: Vec::new(),
            loads: Vec::new(),
            surfaces: None,
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
    /// The surfaces each bogie was simulated with (bogie, what).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub surfaces: Vec<(usize, SurfaceNote)>,
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
    // With surfaces every bogie is its own run (its wheels drawn anew, the rail the train's).
    let bogie_surfaces = |b: usize| -> Result<
        Option<(
            crate::model::Surfaces,
            Vec<SurfaceNote>,
            crate::model::ContactFilter,
        )>,
        SimError,
    > {
        let Some(s) = &spec.surfaces else {
            return Ok(None);
        };
        let mut own = s.clone();
        own.wheel_roughness = s
            .wheel_roughness
            .map(|(c, seed)| (c, seed.wrapping_mul(1000).wrapping_add(b as u64 + 1)));
        let (surfaces, notes) = own.build(cal.vehicle.wheel_radius_m, cal.rail_length_m())?;
        Ok(Some((surfaces, notes, s.filter)))
    };
    let runs: Vec<(Option<crate::model::Response>, Vec<SurfaceNote>)> = (0..spec.bogies)
        .into_par_iter()
        .map(|b| {
            let surfaces = bogie_surfaces(b)?;
            let flat = flat_of(b);
            match surfaces {
                None => Ok((
                    flat.map(|f| sim_of(b).1.run(Some(&f), Record::default()))
                        .transpose()?,
                    Vec::new(),
                )),
                Some((s, notes, filter)) => {
                    let sim = sim_of(b).1.clone().with_surfaces(&s, filter)?;
                    Ok((Some(sim.run(flat.as_ref(), Record::default())?), notes))
                }
            }
        })
        .collect::<Result<_, SimError>>()?;
    let (flats, notes): (Vec<Option<crate::model::Response>>, Vec<Vec<SurfaceNote>>) =
        runs.into_iter().unzip();
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
            surfaces: notes
                .into_iter()
                .enumerate()
                .flat_map(|(b, n)| n.into_iter().map(move |x| (b + 1, x)))
                .collect(),
        },
    })
}
