//! The calibration file: every parameter of the train–track model (docs/model.md §1–6)
//! plus the integration settings and the population ranges of the bank.
//!
//! [`Calibration`] is the editable document (what `wheelflat calibration` prints and
//! what a TOML file deserialises into). [`Calibration::check`] turns it into a
//! [`CheckedCalibration`], the only form the physics accepts: every value is finite,
//! every mass and stiffness positive, every sensor on the rail, every output window
//! inside the simulated span.

mod check;
mod defaults;
mod family_step;
mod fold;
mod maintenance;
mod mesh;
mod roughness;
mod text;

pub use super::effect::Effect;
pub use super::wheel::WheelPosition;
pub use defaults::{
    DISCRETISATION_DYNAMIC_RATIO, DISCRETISATION_FRACTION, REFINE_RESOLUTION, SHARED_MODEL_FORM,
};
pub use maintenance::MaintenanceParams;
pub use mesh::RefinedSpan;
pub use roughness::{RailRoughness, WheelRoughness};

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

/// Rail, pads, sleepers and ballast (docs/model.md §2). Per rail seat: one rail, half a sleeper.
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

/// Pitch-plane half bogie (docs/model.md §3).
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

/// Wheel–rail contact (docs/model.md §4).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContactParams {
    /// Hertz constant C_H in `F = C_H·δ^1.5` (N/m^1.5). When omitted it follows from the
    /// wheel radius: `C_H = G^-1.5`, `G = 4.57·R_w^-0.149 × 10^-8 m/N^(2/3)`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hertz_constant_n_per_m1_5: Option<f64>,
}

/// Train speed and where the run starts (docs/model.md §1).
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

/// Sensor layout (docs/model.md §1).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorParams {
    /// Position of the laser trigger that records each wheel's passing time (m).
    pub laser_trigger_m: f64,
    /// The rail-pad sensors.
    pub pad: Vec<PadSensor>,
}

/// Output sampling (docs/model.md §6).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputParams {
    /// Output sample rate (Hz).
    pub sample_rate_hz: f64,
    /// Samples in each sensor's window. The window is centred on the instant the bogie
    /// centre passes over the sensor, so both wheels' passages are inside it.
    pub window_samples: usize,
}

/// Time integration and mesh (chosen by the convergence study: docs/performance.md,
/// "Simulator convergence").
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
    /// Stretches of rail meshed finer than `elements_per_bay` (every bay they overlap gets
    /// their element count): where landings need a finer rail (docs/identification.md,
    /// "Landings"). None by default.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub refine: Vec<RefinedSpan>,
}

/// Parameter ranges of the model population (docs/model.md §5, paper Table 1).
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
    /// The wheels that may carry the flat (a fifth low-discrepancy coordinate picks one per
    /// instance). Absent: `vehicle.flat_wheel` only (the paper's); the site profile has both.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flat_wheels: Option<Vec<WheelPosition>>,
    /// Store X_p over the first sleeper bay only, the rest of the range (one wheel revolution)
    /// stood in for by whole-bay shifts of the periodic track ([`Calibration::fold_shifts`],
    /// docs/bank.md "Folded banks").
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub fold_to_one_bay: bool,
    /// The car-body step a site's family over loads needs (written by `calibrate`; read by
    /// `bank generate --loads auto`; [`family_step`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub family_load_step: Option<f64>,
}

/// Whether an uncertainty source scales with the force or is a fixed amount.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum UncertaintyKind {
    /// A fraction of the force (`min`, `max` as fractions, e.g. -0.15).
    Relative,
    /// A fixed amount in kN.
    AbsoluteKn,
    /// A fraction of the good wheel's (flat-free) predicted force at the point, bounded: a
    /// rough tread or rail moves a pad's force most while a wheel is over it. It widens each
    /// point's thresholds by `[min, max]·|g_ff|` (model group; the measurement group mirrors)
    /// and the detection bound by the larger of `|min|`, `|max|` times the flat-free force
    /// (docs/detection.md, "Rough wheels").
    GoodWheelRelative,
    /// A bounded amount in kN at every point, not drawn per sample as noise is: it widens each
    /// point's thresholds by `[min, max]` and the detection bound by the larger of `|min|`,
    /// `|max|` (the floor of a rough tread's or rail's departure where no wheel is near).
    BoundKn,
}

impl UncertaintyKind {
    /// Whether the source is drawn (by the Monte Carlo of the thresholds, and by synthetic
    /// errors): the relative and absolute sources. The bounded sources (a rough tread or
    /// rail) are applied per point instead, and synthetic passes simulate what they stand for.
    pub fn is_drawn(self) -> bool {
        matches!(
            self,
            UncertaintyKind::Relative | UncertaintyKind::AbsoluteKn
        )
    }
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

/// One uniform uncertainty source (docs/model.md §7).
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

impl UncertaintySource {
    /// Variance of the uniform distribution on `[min, max]`.
    pub fn variance(&self) -> f64 {
        (self.max - self.min).powi(2) / 12.0
    }

    /// Its mean, `(min + max) / 2`.
    pub fn mean(&self) -> f64 {
        0.5 * (self.max + self.min)
    }
}

/// What the maintenance rule acts on (`identification.maintenance_rule`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MaintenanceRule {
    /// The upper bound of the fresh-flat length L0 over the candidates (the paper's rule).
    #[default]
    L0,
    /// The upper bound of the candidates' dynamic ratio: the peak wheel–rail force at this
    /// pass's speed and load over the static wheel load, as wayside impact detectors act.
    Impact,
}

/// How "far from the line" a perceptually important point is (paper §3.1). Written as
/// `vertical`, `perpendicular` or `euclidean`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PipDistance {
    /// Vertical distance `|y − ŷ(x)|` (the paper's choice for the second step).
    Vertical,
    /// Perpendicular distance to the line, with time and force each scaled to [0, 1] over the
    /// series (the distance is otherwise unit-dependent).
    Perpendicular,
    /// Sum of the Euclidean distances to the two neighbouring PIPs, same scaling.
    Euclidean,
}

impl PipDistance {
    /// The name calibrations and results use.
    pub fn as_str(self) -> &'static str {
        match self {
            PipDistance::Vertical => "vertical",
            PipDistance::Perpendicular => "perpendicular",
            PipDistance::Euclidean => "euclidean",
        }
    }
}

impl std::fmt::Display for PipDistance {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.pad(self.as_str())
    }
}

/// Identification settings (paper §2–3, docs/model.md §7–8). Not part of a bank's identity.
/// Keys left out take their defaults.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IdentificationParams {
    /// Target identification probability φ (Šídák: each point gets `φ^(1/m)`).
    pub phi: f64,
    /// Perceptually important points per series (paper: 30).
    pub pips_per_series: usize,
    /// PIP distance: `vertical`, `perpendicular` or `euclidean`.
    pub pip_distance: PipDistance,
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
    /// Envelope windows per sensor: after the EIP, the maximum and the minimum of the series
    /// over a short window at each of the samples where the measurement departs most from the
    /// flat-free signature (the impact spikes) are compared too (`identify::envelope`).
    /// 0: the EIP alone.
    pub envelope_windows_per_sensor: usize,
    /// Half-width of an envelope window (output samples; 2 = ±0.8 ms at 2.5 kHz).
    pub envelope_half_width_samples: usize,
    /// Maintenance rule: upper bound of the fresh-flat length L0 (mm) from which the wheelset
    /// is to be removed from service within 24 hours.
    pub urgent_l0_mm: f64,
    /// Maintenance rule: upper L0 bound (mm) from which the wheel is to be inspected.
    pub inspect_l0_mm: f64,
    /// What the maintenance rule acts on: `"l0"` (the limits above) or `"impact"` (the two
    /// dynamic-ratio limits below). Every answer reports both quantities.
    pub maintenance_rule: MaintenanceRule,
    /// Impact rule: upper bound of the dynamic ratio (peak wheel–rail force over the static
    /// wheel load) from which the wheelset is removed within 24 hours.
    pub urgent_dynamic_ratio: f64,
    /// Impact rule: upper dynamic-ratio bound from which the wheel is inspected.
    pub inspect_dynamic_ratio: f64,
    /// Detection before sizing (`identify::detect`): the flat-free model's own form error
    /// allowed besides the table's absolute sources, absolute part (kN). The default mesh's
    /// good-wheel prediction's distance to a converged one: docs/detection.md, "The test".
    pub detection_allowance_kn: f64,
    /// ... and its part proportional to the flat-free force (fraction).
    pub detection_allowance_fraction: f64,
    /// Sizing also falsifies at each instance's own strikes (`identify::detect`): an instance
    /// whose cell departs from the good wheel by more than the measurement does, at any sensor,
    /// is ruled out. `false`: the EIP and envelope points alone (as before detection came first).
    pub falsify_at_departures: bool,
    /// The share of an instance's largest departure its truth may fall short by (the bank
    /// mesh's error at impact peaks against a converged one, and the sampling phase of a short
    /// spike), in the departure rule.
    pub departure_model_form_fraction: f64,
    /// The bank mesh's discretisation error around a landing impact, as a share of the
    /// prediction's largest step between adjacent samples at a comparison point, added to
    /// that point's thresholds for that prediction (0.5: the landing may fall half a sample
    /// from the bank's; measured against the converged reference: docs/identification.md,
    /// "Discretisation error"). Absent from a calibration file: the default.
    #[serde(default = "defaults::default_discretisation_fraction")]
    pub discretisation_fraction: f64,
    /// ... for the instances whose peak wheel–rail force reaches this many times the static
    /// wheel load (flats that lose contact and land; the others keep the table's mesh term).
    #[serde(default = "defaults::default_discretisation_dynamic_ratio")]
    pub discretisation_dynamic_ratio: f64,
    /// One gain per sensor solved per instance at every point read (docs/model.md, "Shared
    /// gains"); `false`: the per-point thresholds alone. Absent: `true`.
    #[serde(default = "defaults::default_shared_gains")]
    pub shared_gains: bool,
    /// The model form a pass leaves after its gain, `[fraction of |g|, of |g − g_ff|, kN]`
    /// (`studies/src/bin/physics_gap.rs`). Absent: the default.
    #[serde(default = "defaults::default_shared_model_form")]
    pub shared_model_form: [f64; 3],
    /// A refinement's simulations on the landings calibration at the L0 bounds
    /// (docs/identification.md, "Landings resolved"; 0–256). Absent: 0, none.
    #[serde(default)]
    pub refine_landings: usize,
    /// κ of a refinement's local cells when it settles the L0 bounds (docs/identification.md,
    /// "Bounds settled"): every simulated flat is judged for its own prediction widened by κ ×
    /// the spread to its nearest simulated neighbours, and the answer is the union of the
    /// surviving cells. Absent: the default.
    #[serde(default = "defaults::default_refine_resolution")]
    pub refine_resolution: f64,
    /// The wheels' roughness class (docs/detection.md, "Rough wheels"): `auto` (read from each
    /// pass's record, by its high-frequency level), `round`, or a class (`disc`, `composite`,
    /// `cast-iron`, `cast-iron-rough`). Its bound, simulated per bank, widens detection and the
    /// thresholds. Absent from a calibration file: `auto`.
    #[serde(default)]
    pub wheel_roughness: WheelRoughness,
    /// The site's rail: `smooth` (the model's) or `iso3095` (at the EN ISO 3095 limit
    /// spectrum); a pass cannot tell it from its record, the site states it. Absent: `smooth`.
    #[serde(default)]
    pub rail_roughness: RailRoughness,
    /// The uncertainty table (paper Table 2).
    pub uncertainty: Vec<UncertaintySource>,
}

impl VehicleParams {
    /// The static load of one wheel on the rail (N): half the car body and bogie the half bogie
    /// carries, plus the wheel, `((m_c + m_b)/2 + m_w)·g` (docs/model.md §3).
    pub fn static_wheel_load_n(&self) -> f64 {
        (0.5 * (self.car_body_mass_kg + self.bogie_mass_kg) + self.wheel_mass_kg)
            * self.gravity_m_per_s2
    }
}

/// The calibration document. Units are in the key names; see docs/model.md for the meaning.
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
    /// The maintenance rule's class limits (`[maintenance]`, an operator's rulebook): when
    /// given they replace the same keys of `[identification]` (not part of a bank's identity).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub maintenance: Option<MaintenanceParams>,
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
    /// `G = 4.57·R_w^-0.149 × 10^-8` (docs/model.md §4).
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_static_wheel_load_is_about_49_5_kn() {
        let c = Calibration::default().check().unwrap();
        assert!((c.static_wheel_load_n() - 49_540.5).abs() < 1.0);
        // docs/model.md §4: C_H ≈ 8.3e10 N/m^1.5 for R_w = 0.4 m.
        assert!(
            (c.hertz_constant() / 8.3e10 - 1.0).abs() < 0.01,
            "{}",
            c.hertz_constant()
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
}
