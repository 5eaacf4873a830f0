//! Folded populations: X_p stored over one sleeper bay, the rest of a wheel revolution stood
//! in for by whole-bay shifts (`population.fold_to_one_bay`, docs/bank.md "Folded banks").
//!
//! The track repeats every sleeper bay, so a flat striking at `X_p + k·bay` gives at the sensor
//! on sleeper `s` what a flat striking at `X_p` gives at sleeper `s − k`, at the same place in
//! that sensor's window (windows are centred on the bogie passing their sensor). Only the
//! rail's clamped ends break the symmetry; docs/bank.md measures how little.

use super::{Calibration, CalibrationError, CheckedCalibration, PadSensor, PopulationParams};
use crate::model::Effect;

/// Tolerance on "a whole number of output samples per sleeper bay" (samples).
const WHOLE_SAMPLES: f64 = 1e-6;

impl Calibration {
    /// One wheel revolution, `2πR_w` (m).
    pub fn circumference_m(&self) -> f64 {
        std::f64::consts::TAU * self.vehicle.wheel_radius_m
    }

    /// The whole-bay shifts a folded bank stands in for, beyond the stored bay: 0 unless
    /// `population.fold_to_one_bay`, else `⌈revolution / bay⌉ − 1` (3 with the defaults).
    pub fn fold_shifts(&self) -> usize {
        if !self.population.fold_to_one_bay {
            return 0;
        }
        let bays = self.circumference_m() / self.track.sleeper_spacing_m;
        (bays - 1e-9).ceil() as usize - 1
    }

    /// The population the bank stores: X_p over the range's first sleeper bay when folded.
    pub fn stored_population(&self) -> PopulationParams {
        let mut p = self.population.clone();
        if p.fold_to_one_bay {
            let x0 = p.impact_position_m[0];
            p.impact_position_m = [x0, x0 + self.track.sleeper_spacing_m];
            p.fold_to_one_bay = false;
        }
        p
    }

    /// The pads a folded bank stores: the calibration's own, then the sleepers the shifts reach
    /// that carry none of them (named `pad<sleeper>`), nearest first.
    pub fn stored_pads(&self) -> Vec<PadSensor> {
        let mut pads = self.sensors.pad.clone();
        for k in 1..=self.fold_shifts() {
            for p in &self.sensors.pad {
                let Some(sleeper) = p.sleeper.checked_sub(k) else {
                    continue;
                };
                if !pads.iter().any(|q| q.sleeper == sleeper) {
                    pads.push(PadSensor {
                        name: format!("pad{sleeper}"),
                        sleeper,
                    });
                }
            }
        }
        pads
    }

    /// The calibration a folded bank is simulated with: its stored pads and population, not
    /// folded (itself when not folded).
    pub fn stored(&self) -> Calibration {
        let mut c = self.clone();
        c.sensors.pad = self.stored_pads();
        c.population = self.stored_population();
        c
    }

    /// This calibration for simulating passes rather than storing a bank: not folded (how a
    /// bank stores its population does not apply), so it runs at any speed.
    pub fn unfolded(&self) -> Calibration {
        let mut c = self.clone();
        c.population.fold_to_one_bay = false;
        c
    }

    /// Output samples per sleeper bay at the run's speed.
    pub fn samples_per_bay(&self) -> f64 {
        self.track.sleeper_spacing_m / (self.run.speed_km_per_h / 3.6) * self.output.sample_rate_hz
    }

    /// Instances as read per stored instance: [`Calibration::fold_shifts`] + 1 (1 unfolded).
    pub fn fold_factor(&self) -> usize {
        self.fold_shifts() + 1
    }

    /// Where a folded bank's instance stored at `stored_m` strikes when shifted by `k` whole
    /// bays: `X_p + k·bay` brought back onto the revolution `impact_position_m` (a strike one
    /// revolution on is the same flat).
    pub fn folded_position_m(&self, stored_m: f64, k: usize) -> f64 {
        let x = stored_m + k as f64 * self.track.sleeper_spacing_m;
        let [x0, _] = self.population.impact_position_m;
        let rev = self.circumference_m();
        if x >= x0 + rev {
            x - rev
        } else {
            x
        }
    }

    /// Whether a sleeper bay takes a whole number of output samples at the run's speed (a fold
    /// needs one).
    pub fn bay_is_whole_samples(&self) -> bool {
        let per_bay = self.samples_per_bay();
        (per_bay - per_bay.round()).abs() <= WHOLE_SAMPLES
    }

    /// The checks a folded population adds before a bank stores it (`bank::generate`): a
    /// revolution of X_p, a whole number of samples per bay, the stored pads on the rail and
    /// their windows in the run. Simulating passes does not need them.
    pub fn check_fold(&self) -> Result<(), CalibrationError> {
        if !self.population.fold_to_one_bay {
            return Ok(());
        }
        // Folding reads a strike k bays on from the pads k sleepers before each sensor: the
        // track must be the same at every sleeper, and every pad read alike. An effect tied to
        // one place or one sensor breaks that.
        if let Some(e) = self.effects.iter().find(|e| {
            matches!(
                e,
                Effect::VoidedSleeper { .. }
                    | Effect::PadStiffness { .. }
                    | Effect::BallastStiffness { .. }
                    | Effect::RailDip { .. }
                    | Effect::SensorGain { .. }
            )
        }) {
            return Err(super::check::invalid(
                "population.fold_to_one_bay",
                true,
                &format!(
                    "a folded bank reads a strike a few bays on from the pads before each sensor, so the track must be the same at every sleeper and every pad read alike; the effect {} is tied to one place or sensor: set fold_to_one_bay = false (four times the simulations)",
                    serde_json::to_string(e).unwrap_or_default()
                ),
            ));
        }
        let [x0, x1] = self.population.impact_position_m;
        let rev = self.circumference_m();
        if ((x1 - x0) - rev).abs() > 1e-6 {
            return Err(super::check::invalid(
                "population.impact_position_m",
                format!("[{x0}, {x1}]"),
                &format!(
                    "a folded population covers one wheel revolution: [{x0}, {:.6}] (2πR_w = {rev:.6} m)",
                    x0 + rev
                ),
            ));
        }
        // A shift must be a whole number of samples: an impact spike lasts a few samples, and a
        // window a fraction of a sample off differs from the shifted strike by most of its
        // peak (60 kN for a 20 mm × 1 mm flat at 47.5 km/h, `studies/src/bin/fold_error.rs`).
        let per_bay = self.samples_per_bay();
        if !self.bay_is_whole_samples() {
            let at = |n: f64| self.track.sleeper_spacing_m * self.output.sample_rate_hz / n * 3.6;
            return Err(super::check::invalid(
                "population.fold_to_one_bay",
                true,
                &format!(
                    "a sleeper bay takes {per_bay:.3} output samples at {} km/h; folding needs a whole number: run at {:.4} or {:.4} km/h, or set fold_to_one_bay = false",
                    self.run.speed_km_per_h,
                    at(per_bay.ceil()),
                    at(per_bay.floor())
                ),
            ));
        }
        for p in &self.sensors.pad {
            if p.sleeper <= self.fold_shifts() {
                return Err(super::check::invalid(
                    &format!("sensors.pad `{}`", p.name),
                    p.sleeper,
                    &format!(
                        "a folded bank stores the sleepers up to {} before each sensor; put the sensors further from the rail end",
                        self.fold_shifts()
                    ),
                ));
            }
        }
        for p in self.stored_pads().iter().skip(self.sensors.pad.len()) {
            if self.sensors.pad.iter().any(|q| q.name == p.name) {
                return Err(super::check::invalid(
                    "sensors.pad",
                    &p.name,
                    "is the name a folded bank gives a stored sleeper; rename the sensor",
                ));
            }
        }
        // The stored pads' windows must fit the run like the sensors' own.
        self.stored().check().map(|_| ())
    }
}

impl CheckedCalibration {
    /// [`Calibration::stored`], checked with this calibration.
    pub fn stored(&self) -> CheckedCalibration {
        CheckedCalibration(self.document().stored())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_site_default_folds_a_revolution_into_one_bay_and_three_shifts() {
        let c = Calibration::default();
        assert!(c.population.fold_to_one_bay);
        assert_eq!(c.fold_shifts(), 3);
        assert!((c.samples_per_bay() - 126.0).abs() < 1e-9);
        let pads: Vec<usize> = c.stored_pads().iter().map(|p| p.sleeper).collect();
        assert_eq!(pads, vec![19, 18, 17, 16, 15, 14, 13, 12]);
        let checked = c.clone().check().unwrap();
        // X_b + 3 bays past the revolution's end comes back one revolution earlier.
        let x = checked.folded_position_m(12.6, 3);
        assert!((x - (12.6 + 2.1 - c.circumference_m())).abs() < 1e-12);
        assert!((checked.folded_position_m(12.1, 2) - 13.5).abs() < 1e-12);
    }

    #[test]
    fn a_fold_at_a_speed_without_whole_samples_per_bay_is_refused_with_the_speeds_that_fit() {
        let mut c = Calibration::default();
        c.run.speed_km_per_h = 55.0;
        // A pass at that speed simulates; a bank of it cannot fold.
        c.clone().check().unwrap();
        let msg = c.check_fold().unwrap_err().to_string();
        assert!(
            msg.contains("114.545") && msg.contains("54.7826") && msg.contains("55.2632"),
            "{msg}"
        );
        let mut c = Calibration::default();
        c.population.impact_position_m = [12.0, 13.0];
        let msg = c.check_fold().unwrap_err().to_string();
        assert!(msg.contains("one wheel revolution"), "{msg}");
    }
}
