//! The calibration file: every parameter of the train–track model (MODEL.md §1–6)
//! plus the integration settings and the population ranges of the bank.
//!
//! [`Calibration`] is the editable document (what `wheelflat calibration` prints and
//! what a TOML file deserialises into). [`Calibration::check`] turns it into a
//! [`CheckedCalibration`], the only form the physics accepts: every value is finite,
//! every mass and stiffness positive, every sensor on the rail, every output window
//! inside the simulated span.

use serde::{Deserialize, Serialize};
use std::ops::Deref;
use thiserror::Error;

/// Errors raised while reading or checking a calibration.
#[derive(Debug, Error)]
pub enum CalibrationError {
    /// The TOML text does not parse or has unknown / missing keys (the message has line and column).
    #[error("{0}")]
    Parse(#[from] toml::de::Error),
    /// A value parses but is physically or logically invalid.
    #[error("invalid calibration value `{key}` = {value}: {reason}")]
    Invalid {
        /// Dotted key, e.g. `track.pad_stiffness_n_per_m`.
        key: String,
        /// The offending value as written.
        value: String,
        /// Why it is rejected.
        reason: String,
    },
}

/// Rail, pads, sleepers and ballast (MODEL.md §2). Per rail seat: one rail, half a sleeper.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrackParams {
    /// Number of sleeper bays; the rail is `bays · sleeper_spacing_m` long, clamped at both ends.
    pub bays: usize,
    /// Sleeper spacing (m).
    pub sleeper_spacing_m: f64,
    /// Young's modulus of the rail (Pa).
    pub youngs_modulus_pa: f64,
    /// Shear modulus of the rail (Pa).
    pub shear_modulus_pa: f64,
    /// Rail cross-section area (m²).
    pub rail_area_m2: f64,
    /// Rail second moment of area (m⁴).
    pub rail_second_moment_m4: f64,
    /// Timoshenko shear coefficient κ.
    pub shear_coefficient: f64,
    /// Rail density (kg/m³).
    pub rail_density_kg_per_m3: f64,
    /// Rail-pad stiffness K_p (N/m).
    pub pad_stiffness_n_per_m: f64,
    /// Rail-pad damping C_p (N·s/m).
    pub pad_damping_ns_per_m: f64,
    /// Half-sleeper mass M_s (kg).
    pub sleeper_mass_kg: f64,
    /// Ballast stiffness K_b (N/m).
    pub ballast_stiffness_n_per_m: f64,
    /// Ballast damping C_b (N·s/m).
    pub ballast_damping_ns_per_m: f64,
}

/// Which wheel of the half bogie carries the flat.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum WheelPosition {
    /// The wheel ahead in the direction of travel.
    Leading,
    /// The wheel behind (the paper's and MODEL.md's default).
    Trailing,
}

impl WheelPosition {
    /// Index of the wheel in the vehicle's wheel arrays (0 = leading, 1 = trailing).
    pub fn index(self) -> usize {
        match self {
            WheelPosition::Leading => 0,
            WheelPosition::Trailing => 1,
        }
    }

    /// The wheel of a stored code (the bank's `flat_wheel` column): 0 leading, else trailing.
    pub fn from_code(code: u8) -> WheelPosition {
        if code == 0 {
            WheelPosition::Leading
        } else {
            WheelPosition::Trailing
        }
    }

    /// The name people and files use: `leading` or `trailing`.
    pub fn name(self) -> &'static str {
        match self {
            WheelPosition::Leading => "leading",
            WheelPosition::Trailing => "trailing",
        }
    }
}

/// Pitch-plane half bogie (MODEL.md §3).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VehicleParams {
    /// Bogie frame mass M_b, half (kg).
    pub bogie_mass_kg: f64,
    /// Bogie pitch inertia J_b, half (kg·m²).
    pub bogie_pitch_inertia_kg_m2: f64,
    /// Unsprung mass per wheel M_w, half wheelset (kg).
    pub wheel_mass_kg: f64,
    /// Primary suspension stiffness K_1 per wheel (N/m).
    pub primary_stiffness_n_per_m: f64,
    /// Primary suspension damping C_1 per wheel (N·s/m).
    pub primary_damping_ns_per_m: f64,
    /// Half wheelbase l_b (m).
    pub half_wheelbase_m: f64,
    /// Quarter car body mass M_c, applied as the constant load M_c·g at the bogie centre (kg).
    pub car_body_mass_kg: f64,
    /// Wheel rolling radius R_w (m).
    pub wheel_radius_m: f64,
    /// Gravitational acceleration (m/s²).
    pub gravity_m_per_s2: f64,
    /// Which wheel carries the flat.
    pub flat_wheel: WheelPosition,
}

/// Wheel–rail contact (MODEL.md §4).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContactParams {
    /// Hertz constant C_H in `F = C_H·δ^1.5` (N/m^1.5). When omitted it follows from the
    /// wheel radius: `C_H = G^-1.5`, `G = 4.57·R_w^-0.149 × 10^-8 m/N^(2/3)`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hertz_constant_n_per_m1_5: Option<f64>,
}

/// Train speed and where the run starts (MODEL.md §1).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunParams {
    /// Constant train speed (km/h).
    pub speed_km_per_h: f64,
    /// Position of the leading wheel at t = 0 (m from the left rail end).
    pub leading_wheel_start_m: f64,
}

/// One rail-pad force sensor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PadSensor {
    /// Short name used in column headers and on the command line, e.g. `rps2`.
    pub name: String,
    /// Index k of the sleeper it sits on (sleeper k is at `k · sleeper_spacing_m`).
    pub sleeper: usize,
}

/// Sensor layout (MODEL.md §1).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorParams {
    /// Position of the laser trigger that records each wheel's passing time (m).
    pub laser_trigger_m: f64,
    /// The rail-pad sensors.
    pub pad: Vec<PadSensor>,
}

/// Output sampling (MODEL.md §6).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputParams {
    /// Output sample rate (Hz).
    pub sample_rate_hz: f64,
    /// Samples in each sensor's window. The window is centred on the instant the bogie
    /// centre passes over the sensor, so both wheels' passages are inside it.
    pub window_samples: usize,
}

/// Time integration and mesh (chosen by the convergence study in the README).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IntegrationParams {
    /// Timoshenko beam elements per sleeper bay.
    pub elements_per_bay: usize,
    /// Coarse (flat-free) Newmark steps per output sample: `dt_coarse = 1/(rate·this)`.
    pub coarse_steps_per_sample: usize,
    /// Fine steps per coarse step around each flat strike: `dt_fine = dt_coarse/this`.
    pub fine_steps_per_coarse: usize,
    /// Fine stepping starts this long before the flat starts to strike (s).
    pub fine_before_strike_s: f64,
    /// Fine stepping continues this long after the flat has passed (s), covering the
    /// landing impact after a loss of contact and the P1 ringing.
    pub fine_after_strike_s: f64,
}

/// Parameter ranges of the model population (MODEL.md §5, paper Table 1).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PopulationParams {
    /// Flat length L range (mm).
    pub length_mm: [f64; 2],
    /// Flat depth d range (mm).
    pub depth_mm: [f64; 2],
    /// Curvature parameter c range (mm); each instance also honours c < d/2.
    pub curvature_mm: [f64; 2],
    /// Impact position X_p range (m).
    pub impact_position_m: [f64; 2],
    /// The wheels that may carry the flat, spread over the instances (a fifth low-discrepancy
    /// coordinate picks one per instance). Absent: `vehicle.flat_wheel` only, the paper's
    /// profile. The train profile (`wheelflat calibration --profile train`) has both, with
    /// X_p over one wheel revolution.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flat_wheels: Option<Vec<WheelPosition>>,
}

/// A physical effect beyond the base model (issue #5's effect library), switched on by
/// listing it under `[[effects]]` in the calibration. Each changes the simulation as its
/// documentation says; the README lists the equations.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Effect {
    /// A voided (hanging) sleeper: a gap g opens between sleeper k and its ballast, which
    /// pushes back only once the sleeper has come down through the gap:
    /// `F_b = K_b·(z_s − g) + C_b·ż_s` for `z_s > g`, else 0 (z downwards).
    VoidedSleeper {
        /// Sleeper index k.
        sleeper: usize,
        /// Gap g (mm, ≥ 0).
        gap_mm: f64,
    },
    /// The rail pad at one sleeper is stiffer or softer: `K_p → factor·K_p` there (a worn or
    /// missing pad, a frozen one). The pad force there is `factor·K_p·(w − z_s) + C_p·(ẇ − ż_s)`.
    PadStiffness {
        /// Sleeper index k.
        sleeper: usize,
        /// Multiplier of the pad stiffness (> 0).
        factor: f64,
    },
    /// The ballast under one sleeper is stiffer or softer: `K_b → factor·K_b` there.
    BallastStiffness {
        /// Sleeper index k.
        sleeper: usize,
        /// Multiplier of the ballast stiffness (> 0).
        factor: f64,
    },
    /// A local dip of the rail head (dipped weld): both wheels see the extra drop
    /// `z(x) = a/2·(1 + cos(2π(x − x_d)/ℓ))` for `|x − x_d| ≤ ℓ/2`, else 0.
    RailDip {
        /// Centre x_d (m).
        position_m: f64,
        /// Length ℓ (m).
        length_m: f64,
        /// Depth a (mm).
        depth_mm: f64,
    },
    /// A periodic rail-head irregularity under both wheels: `z(x) = A·sin(2πx/λ + φ)`.
    RailIrregularity {
        /// Wavelength λ (m).
        wavelength_m: f64,
        /// Amplitude A (mm).
        amplitude_mm: f64,
        /// Phase φ at x = 0 (degrees; 0 when left out).
        #[serde(default)]
        phase_deg: f64,
    },
    /// An out-of-round wheel (polygonal wear): its radius is `R_w + A·cos(n·θ + φ)`, θ = x/R_w
    /// the rolling angle, so its centre drops by `z = −A·cos(n·x/R_w + φ)`.
    WheelOutOfRound {
        /// The wheel.
        wheel: WheelPosition,
        /// Polygon order n (≥ 1).
        order: u32,
        /// Radius amplitude A (mm).
        amplitude_mm: f64,
        /// Phase φ at x = 0 (degrees; 0 when left out).
        #[serde(default)]
        phase_deg: f64,
    },
    /// A sensor reads `factor` times the pad force (a calibration error of one sensor).
    SensorGain {
        /// Sensor name.
        sensor: String,
        /// Multiplier (> 0).
        factor: f64,
    },
    /// The recording's clock is off: every sensor reads `F(t − τ)` (a late laser trigger, a
    /// data-logger delay).
    TimeOffset {
        /// τ (ms), positive: the signals arrive late.
        offset_ms: f64,
    },
    /// The car body bounces on its secondary suspension instead of resting as a constant load:
    /// the load on the bogie centre is `M_c·g·(1 + a·sin(2πf·t + φ))`. Over the second or so
    /// that the windows span, the bounce, driven by the track long before the sensors, is
    /// taken as this steady oscillation.
    CarBodyBounce {
        /// Relative amplitude a of the load (0 ≤ a < 1).
        amplitude: f64,
        /// Bounce frequency f (Hz).
        frequency_hz: f64,
        /// Phase φ at t = 0 (degrees).
        phase_deg: f64,
    },
    /// The train runs at `(1 + fraction)·v`. The recording stays aligned on the leading
    /// wheel's laser trigger, so the output is also delayed by `(x_laser − x_0)·(1/v − 1/v')`.
    SpeedDeviation {
        /// Relative speed change, |fraction| < 0.5.
        fraction: f64,
    },
}

/// Whether an uncertainty source scales with the force or is a fixed amount.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum UncertaintyKind {
    /// A fraction of the force (`min`, `max` as fractions, e.g. -0.15).
    Relative,
    /// A fixed amount in kN.
    AbsoluteKn,
}

/// Whether a source belongs to the model or to the measurement (paper Table 2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum UncertaintyGroup {
    /// Model error: prediction minus truth.
    Model,
    /// Measurement error: measurement minus truth.
    Measurement,
}

/// One uniform uncertainty source (MODEL.md §7).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UncertaintySource {
    /// Model or measurement.
    pub group: UncertaintyGroup,
    /// What it is, e.g. "train system".
    pub name: String,
    /// Relative or absolute.
    pub kind: UncertaintyKind,
    /// Lower bound of the uniform distribution.
    pub min: f64,
    /// Upper bound.
    pub max: f64,
}

/// Identification settings (paper §2–3, MODEL.md §7–8). Not part of a bank's identity.
/// Keys left out take their defaults.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IdentificationParams {
    /// Target identification probability φ (Šídák: each point gets `φ^(1/m)`).
    pub phi: f64,
    /// Perceptually important points per series (paper: 30).
    pub pips_per_series: usize,
    /// PIP distance: "vertical", "perpendicular" or "euclidean".
    pub pip_distance: String,
    /// Greedy joint-entropy selection stops when the gain is below `alpha_fraction·log2(N)`.
    pub alpha_fraction: f64,
    /// Monte Carlo samples of the combined uncertainty.
    pub monte_carlo_samples: usize,
    /// Random subsets for the baseline (paper: 2,000).
    pub random_subsets: usize,
    /// Seed of the Monte Carlo draw and of the random subsets.
    pub seed: u64,
    /// Bank resolution κ: every instance is judged for the cell of parameter space it stands
    /// for, its thresholds widened by κ × the largest prediction difference to its 8 nearest
    /// neighbours (see `identify::cells`; 0.5 is half-way to the farthest neighbour), and the
    /// candidate ranges are the union of the surviving cells. 0: the paper's thresholds alone,
    /// as if the truth were one of the instances.
    pub bank_resolution: f64,
    /// Maintenance rule: upper bound of the fresh-flat length L0 (mm) from which the wheelset
    /// is to be removed from service within 24 hours.
    pub urgent_l0_mm: f64,
    /// Maintenance rule: upper L0 bound (mm) from which the wheel is to be inspected.
    pub inspect_l0_mm: f64,
    /// The uncertainty table (paper Table 2).
    pub uncertainty: Vec<UncertaintySource>,
}

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
            pip_distance: "vertical".into(),
            alpha_fraction: 0.01,
            monte_carlo_samples: 20_000,
            random_subsets: 2000,
            seed: 1,
            bank_resolution: 0.5,
            urgent_l0_mm: 40.0,
            inspect_l0_mm: 25.0,
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

/// The calibration document. Units are in the key names; see MODEL.md for the meaning.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Calibration {
    /// Rail, pads, sleepers, ballast.
    pub track: TrackParams,
    /// Half bogie.
    pub vehicle: VehicleParams,
    /// Wheel–rail contact.
    pub contact: ContactParams,
    /// Speed and start position.
    pub run: RunParams,
    /// Sensor layout.
    pub sensors: SensorParams,
    /// Output sampling.
    pub output: OutputParams,
    /// Mesh and time step.
    pub integration: IntegrationParams,
    /// Population ranges for the bank.
    pub population: PopulationParams,
    /// Effects beyond the base model (none by default).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub effects: Vec<Effect>,
    /// Identification settings and the uncertainty table (not part of a bank's identity).
    #[serde(default)]
    pub identification: IdentificationParams,
}

impl Default for Calibration {
    /// The MODEL.md defaults (metro vehicle, ballasted track with timber sleepers).
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
            },
            population: PopulationParams {
                length_mm: [10.0, 200.0],
                depth_mm: [0.1, 1.0],
                curvature_mm: [0.0, 0.5],
                impact_position_m: [12.0, 13.0],
                flat_wheels: None,
            },
            effects: Vec::new(),
            identification: IdentificationParams::default(),
        }
    }
}

/// A calibration that passed [`Calibration::check`]; the physics only takes this type.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckedCalibration(Calibration);

impl Deref for CheckedCalibration {
    type Target = Calibration;
    fn deref(&self) -> &Calibration {
        &self.0
    }
}

impl CheckedCalibration {
    /// The underlying document (for printing or storing in bank metadata).
    pub fn document(&self) -> &Calibration {
        &self.0
    }

    /// Train speed (m/s).
    pub fn speed_m_per_s(&self) -> f64 {
        self.run.speed_km_per_h / 3.6
    }

    /// Rail length (m).
    pub fn rail_length_m(&self) -> f64 {
        self.track.bays as f64 * self.track.sleeper_spacing_m
    }

    /// Hertz constant C_H (N/m^1.5): the file's value, or `G^-1.5` with
    /// `G = 4.57·R_w^-0.149 × 10^-8` (MODEL.md §4).
    pub fn hertz_constant(&self) -> f64 {
        self.contact.hertz_constant_n_per_m1_5.unwrap_or_else(|| {
            let g = 4.57e-8 * self.vehicle.wheel_radius_m.powf(-0.149);
            g.powf(-1.5)
        })
    }

    /// Static load on each wheel (N): `(M_c + M_b + 2·M_w)·g / 2`.
    pub fn static_wheel_load_n(&self) -> f64 {
        let v = &self.vehicle;
        (v.car_body_mass_kg + v.bogie_mass_kg + 2.0 * v.wheel_mass_kg) * v.gravity_m_per_s2 / 2.0
    }

    /// Coarse time step (s).
    pub fn dt_coarse_s(&self) -> f64 {
        1.0 / (self.output.sample_rate_hz * self.integration.coarse_steps_per_sample as f64)
    }

    /// Fine time step (s).
    pub fn dt_fine_s(&self) -> f64 {
        self.dt_coarse_s() / self.integration.fine_steps_per_coarse as f64
    }

    /// Position of sensor `i` along the rail (m).
    pub fn sensor_position_m(&self, i: usize) -> f64 {
        self.sensors.pad[i].sleeper as f64 * self.track.sleeper_spacing_m
    }

    /// Index of the sensor called `name`, if any.
    pub fn sensor_index(&self, name: &str) -> Option<usize> {
        self.sensors.pad.iter().position(|s| s.name == name)
    }

    /// First output sample index (global, `t = k / rate`) of sensor `i`'s window: the window
    /// is centred on the instant the bogie centre passes over the sensor.
    pub fn window_start_sample(&self, i: usize) -> usize {
        let centre_start_m = self.run.leading_wheel_start_m - self.vehicle.half_wheelbase_m;
        let t_centre = (self.sensor_position_m(i) - centre_start_m) / self.speed_m_per_s();
        let k_centre = (t_centre * self.output.sample_rate_hz).round() as i64;
        let start = k_centre - (self.output.window_samples / 2) as i64;
        // check() guarantees start >= 0.
        start.max(0) as usize
    }

    /// One past the last global output sample index that any window needs.
    pub fn end_sample(&self) -> usize {
        (0..self.sensors.pad.len())
            .map(|i| self.window_start_sample(i) + self.output.window_samples)
            .max()
            .unwrap_or(0)
    }
}

impl Calibration {
    /// The CI-sized profile of the tests and the diagnosis suite: narrower flat ranges, so
    /// that 2,000 instances cover them about as densely as 50,000 cover the paper's, and
    /// 600-sample windows.
    pub fn narrow_profile() -> Calibration {
        let mut c = Calibration::default();
        c.output.window_samples = 600;
        c.population.length_mm = [40.0, 80.0];
        c.population.depth_mm = [0.3, 0.6];
        c.population.curvature_mm = [0.0, 0.1];
        c.population.impact_position_m = [12.3, 12.5];
        c
    }

    /// The train profile: the defaults with a population for whole-train monitoring, where a
    /// flat may be on either wheel of a bogie and strike anywhere along a revolution: both
    /// wheels, X_p over one circumference `2πR_w` from 12 m.
    pub fn train_profile() -> Calibration {
        let mut c = Calibration::default();
        let start = c.population.impact_position_m[0];
        c.population.impact_position_m = [
            start,
            start + std::f64::consts::TAU * c.vehicle.wheel_radius_m,
        ];
        c.population.flat_wheels = Some(vec![WheelPosition::Leading, WheelPosition::Trailing]);
        c
    }

    /// Parses a TOML document (no checking beyond syntax and key names).
    pub fn from_toml_str(text: &str) -> Result<Calibration, CalibrationError> {
        Ok(toml::from_str(text)?)
    }

    /// The model part of the document (everything but `[identification]`) as canonical TOML:
    /// what determines simulated values, and so a bank's identity.
    pub fn model_toml_string(&self) -> String {
        // The `[identification]` table is left out altogether, so that neither its values nor
        // its defaults (which change between versions) enter a bank's identity.
        let mut model = toml::Table::try_from(self).expect("calibration always serialises");
        model.remove("identification");
        toml::to_string_pretty(&model).expect("a TOML table always serialises")
    }

    /// The document as TOML, with a header comment.
    pub fn to_toml_string(&self) -> String {
        let body = toml::to_string_pretty(self).expect("calibration always serialises");
        format!(
            "# wheelflat calibration: train-track model, sensors, sampling, integration and\n\
             # population ranges. Units are in the key names (SI, except speed in km/h and\n\
             # flat sizes in mm). Defaults follow MODEL.md; see the README for each key.\n\
             # contact.hertz_constant_n_per_m1_5, when absent, is computed from the wheel radius.\n\n{body}"
        )
    }

    /// Checks every value once and returns the validated form.
    pub fn check(self) -> Result<CheckedCalibration, CalibrationError> {
        let t = &self.track;
        positive("track.bays", t.bays as f64)?;
        positive("track.sleeper_spacing_m", t.sleeper_spacing_m)?;
        positive("track.youngs_modulus_pa", t.youngs_modulus_pa)?;
        positive("track.shear_modulus_pa", t.shear_modulus_pa)?;
        positive("track.rail_area_m2", t.rail_area_m2)?;
        positive("track.rail_second_moment_m4", t.rail_second_moment_m4)?;
        positive("track.shear_coefficient", t.shear_coefficient)?;
        at_most("track.shear_coefficient", t.shear_coefficient, 1.0)?;
        positive("track.rail_density_kg_per_m3", t.rail_density_kg_per_m3)?;
        positive("track.pad_stiffness_n_per_m", t.pad_stiffness_n_per_m)?;
        non_negative("track.pad_damping_ns_per_m", t.pad_damping_ns_per_m)?;
        positive("track.sleeper_mass_kg", t.sleeper_mass_kg)?;
        positive(
            "track.ballast_stiffness_n_per_m",
            t.ballast_stiffness_n_per_m,
        )?;
        non_negative("track.ballast_damping_ns_per_m", t.ballast_damping_ns_per_m)?;
        if t.bays < 2 {
            return Err(invalid("track.bays", t.bays, "at least 2 bays are needed"));
        }

        let v = &self.vehicle;
        positive("vehicle.bogie_mass_kg", v.bogie_mass_kg)?;
        positive(
            "vehicle.bogie_pitch_inertia_kg_m2",
            v.bogie_pitch_inertia_kg_m2,
        )?;
        positive("vehicle.wheel_mass_kg", v.wheel_mass_kg)?;
        positive(
            "vehicle.primary_stiffness_n_per_m",
            v.primary_stiffness_n_per_m,
        )?;
        non_negative(
            "vehicle.primary_damping_ns_per_m",
            v.primary_damping_ns_per_m,
        )?;
        positive("vehicle.half_wheelbase_m", v.half_wheelbase_m)?;
        non_negative("vehicle.car_body_mass_kg", v.car_body_mass_kg)?;
        positive("vehicle.wheel_radius_m", v.wheel_radius_m)?;
        positive("vehicle.gravity_m_per_s2", v.gravity_m_per_s2)?;
        if let Some(ch) = self.contact.hertz_constant_n_per_m1_5 {
            positive("contact.hertz_constant_n_per_m1_5", ch)?;
        }

        positive("run.speed_km_per_h", self.run.speed_km_per_h)?;
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
        positive("output.window_samples", self.output.window_samples as f64)?;

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

        let p = &self.population;
        range("population.length_mm", p.length_mm, 0.0)?;
        range("population.depth_mm", p.depth_mm, 0.0)?;
        range("population.curvature_mm", p.curvature_mm, -1.0)?;
        non_negative("population.curvature_mm[0]", p.curvature_mm[0])?;
        range("population.impact_position_m", p.impact_position_m, -1.0)?;
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
        if id.pips_per_series < 3 {
            return Err(invalid(
                "identification.pips_per_series",
                id.pips_per_series,
                "at least 3",
            ));
        }
        if !["vertical", "perpendicular", "euclidean"].contains(&id.pip_distance.as_str()) {
            return Err(invalid(
                "identification.pip_distance",
                format!("{:?}", id.pip_distance),
                "one of \"vertical\", \"perpendicular\", \"euclidean\"",
            ));
        }
        non_negative("identification.alpha_fraction", id.alpha_fraction)?;
        non_negative("identification.bank_resolution", id.bank_resolution)?;

        if id.monte_carlo_samples < 1000 {
            return Err(invalid(
                "identification.monte_carlo_samples",
                id.monte_carlo_samples,
                "at least 1000",
            ));
        }
        non_negative("identification.urgent_l0_mm", id.urgent_l0_mm)?;
        non_negative("identification.inspect_l0_mm", id.inspect_l0_mm)?;
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

fn invalid(key: &str, value: impl std::fmt::Display, reason: &str) -> CalibrationError {
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

fn positive(key: &str, v: f64) -> Result<(), CalibrationError> {
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
    fn defaults_pass_and_round_trip_through_toml() {
        let c = Calibration::default();
        let text = c.to_toml_string();
        let back = Calibration::from_toml_str(&text).unwrap();
        assert_eq!(back, c);
        back.check().unwrap();
    }

    #[test]
    fn default_static_wheel_load_is_about_49_5_kn() {
        let c = Calibration::default().check().unwrap();
        assert!((c.static_wheel_load_n() - 49_540.5).abs() < 1.0);
        // MODEL.md §4: C_H ≈ 8.3e10 N/m^1.5 for R_w = 0.4 m.
        assert!(
            (c.hertz_constant() / 8.3e10 - 1.0).abs() < 0.01,
            "{}",
            c.hertz_constant()
        );
    }

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
    fn unknown_key_is_a_parse_error_with_its_position() {
        let text = Calibration::default()
            .to_toml_string()
            .replace("bays = 34", "bayz = 34");
        let msg = Calibration::from_toml_str(&text).unwrap_err().to_string();
        assert!(msg.contains("bayz") && msg.contains("line"), "{msg}");
    }

    #[test]
    fn window_past_the_rail_end_is_rejected() {
        let mut c = Calibration::default();
        c.output.window_samples = 20_000;
        assert!(c
            .check()
            .unwrap_err()
            .to_string()
            .contains("output.window_samples"));
    }
}
