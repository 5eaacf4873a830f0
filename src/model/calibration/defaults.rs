//! The default calibration (the model's reference vehicle and track, the paper's population
//! and uncertainty table) and the named profiles built from it.

use super::{
    Calibration, ContactParams, IdentificationParams, IntegrationParams, MaintenanceRule,
    OutputParams, PadSensor, PopulationParams, RunParams, SensorParams, TrackParams,
    UncertaintyGroup, UncertaintyKind, UncertaintySource, VehicleParams, WheelPosition,
};

impl Default for IdentificationParams {
    fn default() -> Self {
        use UncertaintyGroup::{Measurement, Model};
        use UncertaintyKind::{AbsoluteKn, Relative};
        let src = |group, name: &str, kind, min, max| UncertaintySource {
            group,
            name: name.to_string(),
            kind,
            min,
            max,
        };
        IdentificationParams {
            phi: 0.95,
            pips_per_series: 30,
            pip_distance: super::PipDistance::Vertical,
            alpha_fraction: 0.01,
            monte_carlo_samples: 20_000,
            random_subsets: 2000,
            seed: 1,
            bank_resolution: 0.5,
            envelope_windows_per_sensor: 3,
            envelope_half_width_samples: 2,
            urgent_l0_mm: 40.0,
            inspect_l0_mm: 25.0,
            maintenance_rule: MaintenanceRule::L0,
            urgent_dynamic_ratio: 3.0,
            inspect_dynamic_ratio: 2.0,
            detection_allowance_kn: 0.25,
            detection_allowance_fraction: 0.01,
            falsify_at_departures: true,
            departure_model_form_fraction: 0.25,
            discretisation_fraction: DISCRETISATION_FRACTION,
            discretisation_dynamic_ratio: super::DISCRETISATION_DYNAMIC_RATIO,
            shared_gains: true,
            shared_model_form: super::SHARED_MODEL_FORM,
            refine_landings: 0,
            refine_resolution: REFINE_RESOLUTION,
            wheel_roughness: super::WheelRoughness::Auto,
            rail_roughness: super::RailRoughness::Smooth,
            uncertainty: vec![
                src(Model, "train system", Relative, -0.15, 0.05),
                src(Model, "finite element model", Relative, -0.08, 0.05),
                src(Model, "mesh refinement", Relative, -0.03, 0.03),
                src(Model, "additional", Relative, -0.01, 0.01),
                src(Model, "track calibration", Relative, -0.05, 0.05),
                src(Measurement, "sensor accuracy", Relative, -0.05, 0.05),
                src(Measurement, "environment noise", AbsoluteKn, -1.0, 1.0),
                src(Measurement, "sensor resolution", AbsoluteKn, -0.05, 0.05),
                src(Measurement, "additional", Relative, -0.02, 0.02),
            ],
        }
    }
}

impl Default for Calibration {
    /// The docs/model.md defaults (metro vehicle, ballasted track with timber sleepers).
    fn default() -> Self {
        let pad = [
            ("rps1", 19),
            ("rps2", 18),
            ("rps3", 17),
            ("rps4", 16),
            ("rps5", 15),
        ]
        .into_iter()
        .map(|(name, sleeper)| PadSensor {
            name: name.to_string(),
            sleeper,
        })
        .collect();
        Calibration {
            track: TrackParams {
                bays: 34,
                sleeper_spacing_m: 0.7,
                youngs_modulus_pa: 210e9,
                shear_modulus_pa: 81e9,
                rail_area_m2: 6.977e-3,
                rail_second_moment_m4: 2.346e-5,
                shear_coefficient: 0.40,
                rail_density_kg_per_m3: 7850.0,
                pad_stiffness_n_per_m: 150e6,
                pad_damping_ns_per_m: 30e3,
                sleeper_mass_kg: 45.0,
                ballast_stiffness_n_per_m: 60e6,
                ballast_damping_ns_per_m: 50e3,
            },
            vehicle: VehicleParams {
                bogie_mass_kg: 1300.0,
                bogie_pitch_inertia_kg_m2: 800.0,
                wheel_mass_kg: 650.0,
                primary_stiffness_n_per_m: 1.2e6,
                primary_damping_ns_per_m: 12e3,
                half_wheelbase_m: 1.25,
                car_body_mass_kg: 7500.0,
                wheel_radius_m: 0.400,
                gravity_m_per_s2: 9.81,
                flat_wheel: WheelPosition::Trailing,
            },
            contact: ContactParams {
                hertz_constant_n_per_m1_5: None,
            },
            run: RunParams {
                speed_km_per_h: 50.0,
                leading_wheel_start_m: 6.0,
            },
            sensors: SensorParams {
                laser_trigger_m: 14.2,
                pad,
            },
            output: OutputParams {
                sample_rate_hz: 2500.0,
                window_samples: 1000,
            },
            integration: IntegrationParams {
                elements_per_bay: 4,
                coarse_steps_per_sample: 1,
                fine_steps_per_coarse: 10,
                fine_before_strike_s: 0.001,
                fine_after_strike_s: 0.010,
                refine: Vec::new(),
            },
            // The site population: either wheel, X_p over one revolution from 12 m, folded
            // into one sleeper bay (docs/bank.md "Folded banks").
            population: PopulationParams {
                length_mm: [10.0, 200.0],
                depth_mm: [0.1, 1.0],
                curvature_mm: [0.0, 0.5],
                impact_position_m: [12.0, 12.0 + std::f64::consts::TAU * 0.400],
                flat_wheels: Some(vec![WheelPosition::Leading, WheelPosition::Trailing]),
                fold_to_one_bay: true,
                family_load_step: None,
            },
            effects: Vec::new(),
            identification: IdentificationParams::default(),
            maintenance: None,
        }
    }
}

impl Calibration {
    /// The paper's case study (`wheelflat calibration --profile paper`): the flat on the
    /// trailing wheel, X_p in [12, 13] m, stored as simulated (not folded) — for reproducing
    /// the paper's numbers.
    pub fn paper_profile() -> Calibration {
        let mut c = Calibration::default();
        c.population.impact_position_m = [12.0, 13.0];
        c.population.flat_wheels = None;
        c.population.fold_to_one_bay = false;
        c
    }

    /// The CI-sized profile of the tests and the diagnosis suite: the paper's profile with
    /// narrower flat ranges, so that 2,000 instances cover them about as densely as 50,000
    /// cover the paper's, and 600-sample windows.
    pub fn narrow_profile() -> Calibration {
        let mut c = Calibration::paper_profile();
        c.output.window_samples = 600;
        c.population.length_mm = [40.0, 80.0];
        c.population.depth_mm = [0.3, 0.6];
        c.population.curvature_mm = [0.0, 0.1];
        c.population.impact_position_m = [12.3, 12.5];
        // Its passes are synthetic: round wheels on a smooth rail, judged sample by sample.
        c.identification.wheel_roughness = super::WheelRoughness::Round;
        c
    }

    /// This calibration with the mesh and time step of a converged reference: 40 rail elements
    /// per sleeper bay (the default: 4) and 20 coarse steps per output sample (Δt = 2·10⁻⁵ s at
    /// 2.5 kHz; 2·10⁻⁶ s in the fine zones): a good wheel's pad forces at the default mesh
    /// and at an independent converged implementation against it are measured in
    /// docs/detection.md, "Measured". Used to make
    /// measurements that carry the bank's discretisation error, as a field record does.
    /// Its fine steps are 10 a coarse one whatever this calibration's (a calibration with
    /// [`Calibration::with_converged_landings`]' 100 would take 0.2 µs steps for nothing).
    pub fn converged_reference(&self) -> Calibration {
        let mut c = self.clone();
        c.integration.elements_per_bay = 40;
        c.integration.coarse_steps_per_sample = 20;
        c.integration.fine_steps_per_coarse = 10;
        c
    }

    /// This calibration with landings near the converged reference where the sensors see them
    /// (docs/identification.md, "Landings"): the rail meshed at [`LANDING_ELEMENTS_PER_BAY`]
    /// elements from [`LANDING_MARGIN_BAYS`] bays before the first sensor's sleeper to as
    /// many after the last (`[[integration.refine]]`), [`LANDING_FINE_STEPS`] fine steps a
    /// coarse one (4 µs at 2.5 kHz) in the fine zones, and no discretisation allowance. It
    /// lands a flat within 4.4 % of the peak of the converged reference at the 99th percentile
    /// (the bank's mesh: 10 %) at about 13× the bank's cost — a bank for the cluster's
    /// nightly build.
    pub fn with_converged_landings(&self) -> Calibration {
        let mut c = self.clone();
        let spacing = c.track.sleeper_spacing_m;
        let sleepers = c.sensors.pad.iter().map(|p| p.sleeper);
        if let (Some(lo), Some(hi)) = (sleepers.clone().min(), sleepers.max()) {
            let last = c.track.bays;
            c.integration.refine = vec![super::RefinedSpan {
                from_m: lo.saturating_sub(LANDING_MARGIN_BAYS) as f64 * spacing,
                to_m: (hi + LANDING_MARGIN_BAYS).min(last) as f64 * spacing,
                elements_per_bay: LANDING_ELEMENTS_PER_BAY.max(c.integration.elements_per_bay),
            }];
        }
        c.integration.fine_steps_per_coarse =
            LANDING_FINE_STEPS.max(c.integration.fine_steps_per_coarse);
        c.identification.discretisation_fraction = 0.0;
        c
    }

    /// The train profile: the site population of the defaults (both wheels, X_p over one
    /// revolution, folded). Kept under its earlier name; `--profile train` is `--profile site`.
    pub fn train_profile() -> Calibration {
        Calibration::default()
    }
}

/// [`Calibration::with_converged_landings`]: rail elements a bay around the sensors (the
/// converged reference's count; 20 held the landing to 2.95 %, docs/identification.md).
pub(super) const LANDING_ELEMENTS_PER_BAY: usize = 40;
/// Bays refined beyond the outermost sensors (over 60 flats ±1 bay 6.5 %, ±3 2.3 %; ±3 over
/// 600: 4.4 %).
pub(super) const LANDING_MARGIN_BAYS: usize = 3;
/// Fine steps a coarse one in the fine zones (the bank's: 10).
pub(super) const LANDING_FINE_STEPS: usize = 100;

/// [`super::IdentificationParams::discretisation_fraction`]'s default (a calibration written before
/// it existed reads it).
pub(super) fn default_discretisation_fraction() -> f64 {
    DISCRETISATION_FRACTION
}

/// [`super::IdentificationParams::refine_resolution`]'s default.
pub(super) fn default_refine_resolution() -> f64 {
    REFINE_RESOLUTION
}

/// [`super::IdentificationParams::discretisation_dynamic_ratio`]'s default.
pub(super) fn default_discretisation_dynamic_ratio() -> f64 {
    DISCRETISATION_DYNAMIC_RATIO
}

/// [`super::IdentificationParams::shared_gains`]' default.
pub(super) fn default_shared_gains() -> bool {
    true
}

/// [`super::IdentificationParams::shared_model_form`]'s default.
pub(super) fn default_shared_model_form() -> [f64; 3] {
    SHARED_MODEL_FORM
}

/// The default of [`super::IdentificationParams::shared_model_form`]: 2 % of the prediction, 10 % of
/// its departure from the good wheel and 2 kN hold every sample of 48 physics-varied flats
/// (Table 3's vehicle, contact ±10 %, pad damping ±30 %, sleeper mass ±10 %; converged
/// reference against the bank's mesh, the landing allowance beside; largest use 1.96 kN of
/// the 2; `physics_gap 48 5`, 2026-11-28).
pub const SHARED_MODEL_FORM: [f64; 3] = [0.02, 0.1, 2.0];

/// The default of [`super::IdentificationParams::discretisation_dynamic_ratio`]: 95 % of the flats
/// that lose contact reach 1.92 times the static wheel load on the bank's mesh (600 flats).
pub const DISCRETISATION_DYNAMIC_RATIO: f64 = 1.9;

/// The default of [`super::IdentificationParams::discretisation_fraction`]: the 90th percentile of
/// |bank − converged| over the bank's step at the samples of flats that lose contact
/// (0.46 over 600 flats, `studies/src/bin/discretisation.rs`), rounded up.
pub const DISCRETISATION_FRACTION: f64 = 0.5;

/// The default of [`super::IdentificationParams::refine_resolution`] (docs/identification.md,
/// "Bounds settled", where every value tried is measured).
pub const REFINE_RESOLUTION: f64 = 0.25;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_landings_calibration_refines_around_the_sensors_and_is_another_bank() {
        let c = Calibration::default();
        let l = c.with_converged_landings();
        // The sensors sit on sleepers 15–19: the stretch from sleeper 12 to 22, 40 elements.
        let s = c.track.sleeper_spacing_m;
        let span = &l.integration.refine[0];
        assert_eq!(span.elements_per_bay, LANDING_ELEMENTS_PER_BAY);
        assert!((span.from_m - 12.0 * s).abs() < 1e-12 && (span.to_m - 22.0 * s).abs() < 1e-12);
        assert_eq!(l.integration.fine_steps_per_coarse, LANDING_FINE_STEPS);
        assert!(l.identification.discretisation_fraction.abs() < 1e-12);
        // Its model part differs, so a bank built from it has its own identity (never mixed
        // with the default's); the identification settings alone would not change it.
        assert_ne!(l.model_toml_string(), c.model_toml_string());
        l.clone().check().unwrap();
        // The converged reference from it keeps 2 µs fine steps, not 0.2 µs.
        let r = l.converged_reference();
        assert_eq!(r.integration.fine_steps_per_coarse, 10);
        assert_eq!(r.integration.elements_per_bay, 40);
    }

    #[test]
    fn defaults_pass_and_round_trip_through_toml() {
        let c = Calibration::default();
        let text = c.to_toml_string();
        let back = Calibration::from_toml_str(&text).unwrap();
        assert_eq!(back, c);
        back.check().unwrap();
    }
}
