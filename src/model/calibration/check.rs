//! [`Calibration::check`]: every value checked once, naming the key and the value it rejects.

use super::{Calibration, CalibrationError, CheckedCalibration, Effect};

impl Calibration {
    /// Checks every value once and returns the validated form.
    pub fn check(mut self) -> Result<CheckedCalibration, CalibrationError> {
        // `[maintenance]` states the class limits; the rule reads them from the settings.
        if let Some(m) = &self.maintenance {
            m.check()?;
            m.apply(&mut self.identification);
        }
        let t = &self.track;
        // Physical ranges: wide (an order of magnitude or more around real track), so that
        // any real track fits and a slip of units or digits does not.
        within("track.youngs_modulus_pa", t.youngs_modulus_pa, 1e10, 1e12)?;
        // Up to effectively rigid in shear: the Euler–Bernoulli limit of the physics checks.
        within("track.shear_modulus_pa", t.shear_modulus_pa, 1e9, 1e18)?;
        within("track.rail_area_m2", t.rail_area_m2, 1e-4, 1e-1)?;
        within(
            "track.rail_second_moment_m4",
            t.rail_second_moment_m4,
            1e-7,
            1e-3,
        )?;
        positive("track.shear_coefficient", t.shear_coefficient)?;
        at_most("track.shear_coefficient", t.shear_coefficient, 1.0)?;
        within(
            "track.rail_density_kg_per_m3",
            t.rail_density_kg_per_m3,
            1e3,
            2e4,
        )?;
        within(
            "track.pad_stiffness_n_per_m",
            t.pad_stiffness_n_per_m,
            1e5,
            1e11,
        )?;
        within(
            "track.pad_damping_ns_per_m",
            t.pad_damping_ns_per_m,
            0.0,
            1e8,
        )?;
        within("track.sleeper_mass_kg", t.sleeper_mass_kg, 1.0, 2000.0)?;
        within(
            "track.ballast_stiffness_n_per_m",
            t.ballast_stiffness_n_per_m,
            1e5,
            1e11,
        )?;
        within(
            "track.ballast_damping_ns_per_m",
            t.ballast_damping_ns_per_m,
            0.0,
            1e8,
        )?;
        // Physical ranges and resource bounds, checked before anything is allocated.
        within("track.bays", t.bays as f64, 2.0, MAX_BAYS as f64)?;
        within("track.sleeper_spacing_m", t.sleeper_spacing_m, 0.05, 5.0)?;

        let v = &self.vehicle;
        within("vehicle.bogie_mass_kg", v.bogie_mass_kg, 10.0, 1e5)?;
        within(
            "vehicle.bogie_pitch_inertia_kg_m2",
            v.bogie_pitch_inertia_kg_m2,
            1.0,
            1e6,
        )?;
        within("vehicle.wheel_mass_kg", v.wheel_mass_kg, 10.0, 1e4)?;
        within(
            "vehicle.primary_stiffness_n_per_m",
            v.primary_stiffness_n_per_m,
            1e4,
            1e10,
        )?;
        within(
            "vehicle.primary_damping_ns_per_m",
            v.primary_damping_ns_per_m,
            0.0,
            1e8,
        )?;
        within("vehicle.half_wheelbase_m", v.half_wheelbase_m, 0.3, 5.0)?;
        within("vehicle.car_body_mass_kg", v.car_body_mass_kg, 0.0, 1e6)?;
        within("vehicle.wheel_radius_m", v.wheel_radius_m, 0.1, 1.5)?;
        within("vehicle.gravity_m_per_s2", v.gravity_m_per_s2, 1.0, 30.0)?;
        if let Some(ch) = self.contact.hertz_constant_n_per_m1_5 {
            within("contact.hertz_constant_n_per_m1_5", ch, 1e8, 1e13)?;
        }

        positive("run.speed_km_per_h", self.run.speed_km_per_h)?;
        within("run.speed_km_per_h", self.run.speed_km_per_h, 1.0, 500.0)?;
        let rail_m = t.bays as f64 * t.sleeper_spacing_m;
        finite("run.leading_wheel_start_m", self.run.leading_wheel_start_m)?;
        let trailing_start = self.run.leading_wheel_start_m - 2.0 * v.half_wheelbase_m;
        if trailing_start <= 0.0 || self.run.leading_wheel_start_m >= rail_m {
            return Err(invalid(
                "run.leading_wheel_start_m",
                self.run.leading_wheel_start_m,
                &format!(
                    "both wheels must start on the rail (0, {rail_m} m); the trailing wheel would be at {trailing_start} m"
                ),
            ));
        }

        finite("sensors.laser_trigger_m", self.sensors.laser_trigger_m)?;
        if self.sensors.laser_trigger_m <= 0.0 || self.sensors.laser_trigger_m >= rail_m {
            return Err(invalid(
                "sensors.laser_trigger_m",
                self.sensors.laser_trigger_m,
                &format!("must lie on the rail (0, {rail_m} m)"),
            ));
        }
        if self.sensors.pad.is_empty() {
            return Err(invalid(
                "sensors.pad",
                "[]",
                "at least one sensor is needed",
            ));
        }
        for (i, s) in self.sensors.pad.iter().enumerate() {
            let key = format!("sensors.pad[{i}].sleeper");
            if s.sleeper == 0 || s.sleeper >= t.bays {
                return Err(invalid(
                    &key,
                    s.sleeper,
                    &format!(
                        "sensor `{}` must sit on a sleeper 1..={} of the modelled rail",
                        s.name,
                        t.bays - 1
                    ),
                ));
            }
            let name_ok = !s.name.is_empty()
                && s.name
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_');
            if !name_ok {
                return Err(invalid(
                    &format!("sensors.pad[{i}].name"),
                    format!("{:?}", s.name),
                    "names are non-empty and use letters, digits and '_' only",
                ));
            }
            if self.sensors.pad[..i].iter().any(|o| o.name == s.name) {
                return Err(invalid(
                    &format!("sensors.pad[{i}].name"),
                    format!("{:?}", s.name),
                    "duplicate sensor name",
                ));
            }
        }

        positive("output.sample_rate_hz", self.output.sample_rate_hz)?;
        within(
            "output.sample_rate_hz",
            self.output.sample_rate_hz,
            100.0,
            100_000.0,
        )?;
        within(
            "output.window_samples",
            self.output.window_samples as f64,
            1.0,
            100_000.0,
        )?;

        let n = &self.integration;
        positive("integration.elements_per_bay", n.elements_per_bay as f64)?;
        positive(
            "integration.coarse_steps_per_sample",
            n.coarse_steps_per_sample as f64,
        )?;
        positive(
            "integration.fine_steps_per_coarse",
            n.fine_steps_per_coarse as f64,
        )?;
        non_negative("integration.fine_before_strike_s", n.fine_before_strike_s)?;
        non_negative("integration.fine_after_strike_s", n.fine_after_strike_s)?;
        within(
            "integration.elements_per_bay",
            n.elements_per_bay as f64,
            1.0,
            64.0,
        )?;
        within(
            "integration.coarse_steps_per_sample",
            n.coarse_steps_per_sample as f64,
            1.0,
            1000.0,
        )?;
        within(
            "integration.fine_steps_per_coarse",
            n.fine_steps_per_coarse as f64,
            1.0,
            1000.0,
        )?;
        n.check_refine()?;
        // One run's size: rail elements, and time steps if every step were a fine one (the
        // run lasts at most the time to cross the rail).
        let elements: usize = n.bay_elements(t.bays, t.sleeper_spacing_m).iter().sum();
        if elements > MAX_ELEMENTS {
            return Err(invalid(
                "integration.elements_per_bay",
                n.elements_per_bay,
                &format!(
                    "{} bays × {} elements = {elements} rail elements, more than the {MAX_ELEMENTS} a run may have",
                    t.bays, n.elements_per_bay
                ),
            ));
        }
        let crossing_s = rail_m / (self.run.speed_km_per_h / 3.6);
        let steps = crossing_s
            * self.output.sample_rate_hz
            * n.coarse_steps_per_sample as f64
            * n.fine_steps_per_coarse as f64;
        if steps > MAX_STEPS {
            return Err(invalid(
                "integration.fine_steps_per_coarse",
                n.fine_steps_per_coarse,
                &format!(
                    "a run of up to {crossing_s:.1} s at {} Hz × {} × {} steps is {steps:.3e} fine steps, more than the {MAX_STEPS:.0e} a run may take",
                    self.output.sample_rate_hz, n.coarse_steps_per_sample, n.fine_steps_per_coarse
                ),
            ));
        }

        let p = &self.population;
        range("population.length_mm", p.length_mm, 0.0)?;
        range("population.depth_mm", p.depth_mm, 0.0)?;
        range("population.curvature_mm", p.curvature_mm, -1.0)?;
        non_negative("population.curvature_mm[0]", p.curvature_mm[0])?;
        range("population.impact_position_m", p.impact_position_m, -1.0)?;
        super::family_step::check(p.family_load_step)?;
        if let Some(w) = &p.flat_wheels {
            if w.is_empty() || (w.len() == 2 && w[0] == w[1]) || w.len() > 2 {
                return Err(invalid(
                    "population.flat_wheels",
                    format!("{w:?}"),
                    "one or both of \"leading\", \"trailing\", each once",
                ));
            }
        }
        if p.curvature_mm[0] >= p.depth_mm[0] / 2.0 {
            return Err(invalid(
                "population.curvature_mm[0]",
                p.curvature_mm[0],
                &format!(
                    "must be below half the smallest depth ({} mm) so that c < d/2 can hold",
                    p.depth_mm[0] / 2.0
                ),
            ));
        }
        for (i, e) in self.effects.iter().enumerate() {
            let key = |name: &str| format!("effects[{i}].{name}");
            let on_track = |k: usize| {
                if (1..t.bays).contains(&k) {
                    Ok(())
                } else {
                    Err(invalid(
                        &key("sleeper"),
                        k,
                        &format!("a sleeper of the track, 1 to {}", t.bays - 1),
                    ))
                }
            };
            match e {
                Effect::VoidedSleeper { sleeper, gap_mm } => {
                    on_track(*sleeper)?;
                    non_negative(&key("gap_mm"), *gap_mm)?;
                }
                Effect::PadStiffness { sleeper, factor }
                | Effect::BallastStiffness { sleeper, factor } => {
                    on_track(*sleeper)?;
                    positive(&key("factor"), *factor)?;
                }
                Effect::RailDip {
                    position_m,
                    length_m,
                    depth_mm,
                } => {
                    finite(&key("position_m"), *position_m)?;
                    positive(&key("length_m"), *length_m)?;
                    finite(&key("depth_mm"), *depth_mm)?;
                }
                Effect::RailIrregularity {
                    wavelength_m,
                    amplitude_mm,
                    phase_deg,
                } => {
                    positive(&key("wavelength_m"), *wavelength_m)?;
                    finite(&key("amplitude_mm"), *amplitude_mm)?;
                    finite(&key("phase_deg"), *phase_deg)?;
                }
                Effect::WheelOutOfRound {
                    order,
                    amplitude_mm,
                    phase_deg,
                    ..
                } => {
                    positive(&key("order"), *order as f64)?;
                    finite(&key("amplitude_mm"), *amplitude_mm)?;
                    finite(&key("phase_deg"), *phase_deg)?;
                }
                Effect::TimeOffset { offset_ms } => finite(&key("offset_ms"), *offset_ms)?,
                Effect::CarBodyBounce {
                    amplitude,
                    frequency_hz,
                    phase_deg,
                } => {
                    non_negative(&key("amplitude"), *amplitude)?;
                    if *amplitude >= 1.0 {
                        return Err(invalid(&key("amplitude"), amplitude, "below 1"));
                    }
                    positive(&key("frequency_hz"), *frequency_hz)?;
                    finite(&key("phase_deg"), *phase_deg)?;
                }
                Effect::SpeedDeviation { fraction } => {
                    finite(&key("fraction"), *fraction)?;
                    if fraction.abs() >= 0.5 {
                        return Err(invalid(&key("fraction"), fraction, "|fraction| < 0.5"));
                    }
                }
                Effect::SecondFlat {
                    length_mm,
                    depth_mm,
                    curvature_mm,
                    impact_position_m,
                    ..
                } => {
                    let flat = crate::model::Flat::from_mm(
                        *length_mm,
                        *depth_mm,
                        *curvature_mm,
                        *impact_position_m,
                    )
                    .map_err(|e| {
                        invalid(
                            &key("second_flat"),
                            format!("L {length_mm} mm, d {depth_mm} mm, c {curvature_mm} mm"),
                            &e.to_string(),
                        )
                    })?;
                    let circumference_mm = std::f64::consts::TAU * v.wheel_radius_m * 1e3;
                    if flat.length_m() * 1e3 >= circumference_mm {
                        return Err(invalid(
                            &key("length_mm"),
                            length_mm,
                            &format!(
                                "shorter than the wheel's circumference ({circumference_mm:.0} mm)"
                            ),
                        ));
                    }
                }
                Effect::SensorGain { sensor, factor } => {
                    if !self.sensors.pad.iter().any(|p| &p.name == sensor) {
                        return Err(invalid(
                            &key("sensor"),
                            sensor,
                            "one of the calibration's sensors",
                        ));
                    }
                    positive(&key("factor"), *factor)?;
                }
            }
        }
        let id = &self.identification;
        if !(id.phi > 0.0 && id.phi < 1.0) {
            return Err(invalid("identification.phi", id.phi, "must lie in (0, 1)"));
        }
        within(
            "identification.pips_per_series",
            id.pips_per_series as f64,
            3.0,
            1000.0,
        )?;
        non_negative("identification.alpha_fraction", id.alpha_fraction)?;
        non_negative("identification.bank_resolution", id.bank_resolution)?;
        within(
            "identification.envelope_windows_per_sensor",
            id.envelope_windows_per_sensor as f64,
            0.0,
            20.0,
        )?;
        within(
            "identification.envelope_half_width_samples",
            id.envelope_half_width_samples as f64,
            0.0,
            50.0,
        )?;

        within(
            "identification.monte_carlo_samples",
            id.monte_carlo_samples as f64,
            1000.0,
            1_000_000.0,
        )?;
        non_negative("identification.urgent_l0_mm", id.urgent_l0_mm)?;
        non_negative("identification.inspect_l0_mm", id.inspect_l0_mm)?;
        within(
            "identification.detection_allowance_kn",
            id.detection_allowance_kn,
            0.0,
            100.0,
        )?;
        within(
            "identification.urgent_dynamic_ratio",
            id.urgent_dynamic_ratio,
            1.0,
            100.0,
        )?;
        within(
            "identification.inspect_dynamic_ratio",
            id.inspect_dynamic_ratio,
            1.0,
            100.0,
        )?;
        let (f, dr) = (id.shared_model_form, id.discretisation_dynamic_ratio);
        for (key, v, hi) in [
            (
                "detection_allowance_fraction",
                id.detection_allowance_fraction,
                1.0,
            ),
            (
                "departure_model_form_fraction",
                id.departure_model_form_fraction,
                1.0,
            ),
            ("discretisation_fraction", id.discretisation_fraction, 1.0),
            ("discretisation_dynamic_ratio", dr, 1e2),
            ("shared_model_form[0]", f[0], 1.0),
            ("shared_model_form[1]", f[1], 1.0),
            ("shared_model_form[2]", f[2], 1e3),
            ("refine_landings", id.refine_landings as f64, 256.0),
            ("refine_resolution", id.refine_resolution, 10.0),
        ] {
            within(&format!("identification.{key}"), v, 0.0, hi)?;
        }
        for (i, u) in id.uncertainty.iter().enumerate() {
            finite(&format!("identification.uncertainty[{i}].min"), u.min)?;
            finite(&format!("identification.uncertainty[{i}].max"), u.max)?;
            if u.min > u.max {
                return Err(invalid(
                    &format!("identification.uncertainty[{i}]"),
                    format!("[{}, {}]", u.min, u.max),
                    "min exceeds max",
                ));
            }
        }

        let checked = CheckedCalibration(self);
        // Windows: each must start at t >= 0 and end while the leading wheel is still on the rail.
        let rate = checked.output.sample_rate_hz;
        let half = checked.output.window_samples / 2;
        let centre_start_m = checked.run.leading_wheel_start_m - checked.vehicle.half_wheelbase_m;
        for i in 0..checked.sensors.pad.len() {
            let t_centre =
                (checked.sensor_position_m(i) - centre_start_m) / checked.speed_m_per_s();
            if (t_centre * rate).round() < half as f64 {
                return Err(invalid(
                    "output.window_samples",
                    checked.output.window_samples,
                    &format!(
                        "the window of sensor `{}` would start before t = 0; shorten the window or start the train further back",
                        checked.sensors.pad[i].name
                    ),
                ));
            }
        }
        let t_end = checked.end_sample() as f64 / rate;
        let lead_end = checked.run.leading_wheel_start_m + checked.speed_m_per_s() * t_end;
        if lead_end >= rail_m {
            return Err(invalid(
                "output.window_samples",
                checked.output.window_samples,
                &format!(
                    "at the end of the last window (t = {t_end:.3} s) the leading wheel would be at {lead_end:.2} m, past the rail end at {rail_m} m"
                ),
            ));
        }
        Ok(checked)
    }
}

pub(super) fn invalid(key: &str, value: impl std::fmt::Display, reason: &str) -> CalibrationError {
    CalibrationError::Invalid {
        key: key.to_string(),
        value: value.to_string(),
        reason: reason.to_string(),
    }
}

fn finite(key: &str, v: f64) -> Result<(), CalibrationError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(invalid(key, v, "must be a finite number"))
    }
}

/// The most bays a modelled rail may have (the default has 34).
const MAX_BAYS: usize = 2000;
/// The most rail elements of one run (the default has 136; the convergence reference 544).
const MAX_ELEMENTS: usize = 20_000;
/// The most time steps of one run, counted as if every step were fine (the default takes
/// about 43,000; the convergence reference 680,000): a bound against runs that never end.
const MAX_STEPS: f64 = 2e8;

/// A value inside `[lo, hi]`, the range named in the error.
pub(super) fn within(key: &str, v: f64, lo: f64, hi: f64) -> Result<(), CalibrationError> {
    finite(key, v)?;
    if (lo..=hi).contains(&v) {
        Ok(())
    } else {
        Err(invalid(key, v, &format!("must lie in [{lo}, {hi}]")))
    }
}

pub(super) fn positive(key: &str, v: f64) -> Result<(), CalibrationError> {
    finite(key, v)?;
    if v > 0.0 {
        Ok(())
    } else {
        Err(invalid(key, v, "must be positive"))
    }
}

fn non_negative(key: &str, v: f64) -> Result<(), CalibrationError> {
    finite(key, v)?;
    if v >= 0.0 {
        Ok(())
    } else {
        Err(invalid(key, v, "must not be negative"))
    }
}

fn at_most(key: &str, v: f64, max: f64) -> Result<(), CalibrationError> {
    if v <= max {
        Ok(())
    } else {
        Err(invalid(key, v, &format!("must be at most {max}")))
    }
}

/// A `[lo, hi]` range with `lo <= hi` and `lo > floor`.
fn range(key: &str, r: [f64; 2], floor: f64) -> Result<(), CalibrationError> {
    finite(key, r[0])?;
    finite(key, r[1])?;
    if r[0] <= floor {
        return Err(invalid(
            key,
            format!("{:?}", r),
            &format!("the lower bound must exceed {floor}"),
        ));
    }
    if r[0] > r[1] {
        return Err(invalid(
            key,
            format!("{:?}", r),
            "the lower bound exceeds the upper bound",
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn negative_mass_is_rejected_naming_key_and_value() {
        let mut c = Calibration::default();
        c.vehicle.wheel_mass_kg = -650.0;
        let msg = c.check().unwrap_err().to_string();
        assert!(msg.contains("vehicle.wheel_mass_kg"), "{msg}");
        assert!(msg.contains("-650"), "{msg}");
    }

    #[test]
    fn sensor_outside_the_rail_is_rejected() {
        let mut c = Calibration::default();
        c.sensors.pad[0].sleeper = 40;
        let msg = c.check().unwrap_err().to_string();
        assert!(
            msg.contains("sensors.pad[0].sleeper") && msg.contains("40"),
            "{msg}"
        );
    }

    #[test]
    fn window_past_the_rail_end_is_rejected() {
        let mut c = Calibration::default();
        c.output.window_samples = 20_000;
        let msg = c.check().unwrap_err().to_string();
        assert!(msg.contains("output.window_samples"), "{msg}");
    }
}
