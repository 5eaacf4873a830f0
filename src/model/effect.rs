//! The effect library: physical effects beyond the base model, switched on by
//! listing them under `[[effects]]` in the calibration, and the terms each adds to the
//! simulation. The track reads the sleeper effects when it is assembled
//! ([`pad_stiffness_factor`], [`ballast_stiffness_factor`], [`void_gap_m`]); the integrator
//! reads the rest at every step ([`Effect::wheel_drop_m`], [`Effect::body_load_n`]) or once
//! per run ([`sensor_gain`], [`clock`], [`Effect::dip_span_m`]).
//!
//! Every term is a closed form, stated above the function that implements it.

use super::flat::Flat;
use super::wheel::WheelPosition;
use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;

/// A physical effect beyond the base model (the effect library), switched on by
/// listing it under `[[effects]]` in the calibration. Each changes the simulation as its
/// documentation says; docs/diagnosis.md ("The effect library") gives the equations.
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
    /// A second flat: a flat of its own on `wheel` (the other wheel, or the flat
    /// wheel at another angle), with the profile of paper Eq. 9 striking once per revolution
    /// from `impact_position_m`: `z = d/2·(1 − cos(2πs/L)) − c/4·(1 − cos(4πs/L))`,
    /// `0 ≤ s ≤ L`, added to that wheel's drop. The integrator takes fine steps around its
    /// strikes as around the main flat's.
    SecondFlat {
        /// The wheel carrying it.
        wheel: WheelPosition,
        /// Length L (mm).
        length_mm: f64,
        /// Depth d (mm).
        depth_mm: f64,
        /// Curvature c (mm), `0 ≤ c < d/2`.
        #[serde(default)]
        curvature_mm: f64,
        /// Where it first strikes X_p (m).
        impact_position_m: f64,
    },
    /// The train runs at `(1 + fraction)·v`. The recording stays aligned on the leading
    /// wheel's laser trigger, so the output is also delayed by `(x_laser − x_0)·(1/v − 1/v')`.
    SpeedDeviation {
        /// Relative speed change, |fraction| < 0.5.
        fraction: f64,
    },
}

impl Effect {
    /// The drop of wheel `wheel`'s centre (index 0 leading, 1 trailing) at position `x_m` due
    /// to this effect (m, downwards positive); 0 for effects that move no wheel:
    ///
    /// - rail dip: `z(x) = a/2·(1 + cos(2π(x − x_d)/ℓ))` for `|x − x_d| ≤ ℓ/2`, else 0;
    /// - rail irregularity: `z(x) = A·sin(2πx/λ + φ)`;
    /// - out-of-round wheel, on its wheel only: `z(x) = −A·cos(n·x/R_w + φ)`;
    /// - second flat, on its wheel only: the flat's trajectory (paper Eq. 9, once a revolution).
    ///
    /// Rail effects act under both wheels.
    #[inline]
    pub fn wheel_drop_m(&self, wheel: usize, x_m: f64, wheel_radius_m: f64) -> f64 {
        let x = x_m;
        match self {
            Effect::RailDip {
                position_m,
                length_m,
                depth_mm,
            } => {
                let s = x - position_m;
                if s.abs() <= length_m / 2.0 {
                    depth_mm * 1e-3 / 2.0 * (1.0 + (TAU * s / length_m).cos())
                } else {
                    0.0
                }
            }
            Effect::RailIrregularity {
                wavelength_m,
                amplitude_mm,
                phase_deg,
            } => amplitude_mm * 1e-3 * (TAU * x / wavelength_m + phase_deg.to_radians()).sin(),
            Effect::WheelOutOfRound {
                wheel: on,
                order,
                amplitude_mm,
                phase_deg,
            } if on.index() == wheel => {
                -amplitude_mm
                    * 1e-3
                    * (f64::from(*order) * x / wheel_radius_m + phase_deg.to_radians()).cos()
            }
            Effect::SecondFlat { wheel: on, .. } if on.index() == wheel => self
                .second_flat()
                .map_or(0.0, |f| f.trajectory(x, wheel_radius_m)),
            _ => 0.0,
        }
    }

    /// The flat of a second-flat effect, on its wheel (None for other effects, and for
    /// numbers that make no flat, which the calibration check refuses).
    pub fn second_flat(&self) -> Option<Flat> {
        match self {
            Effect::SecondFlat {
                wheel,
                length_mm,
                depth_mm,
                curvature_mm,
                impact_position_m,
            } => Flat::from_mm(*length_mm, *depth_mm, *curvature_mm, *impact_position_m)
                .ok()
                .map(|f| f.on_wheel(*wheel)),
            _ => None,
        }
    }

    /// The car body's load on the bogie centre beyond its weight `W = M_c·g`, at time `t_s`
    /// (N, downwards): `W·a·sin(2πf·t + φ)` for a car-body bounce, else 0.
    #[inline]
    pub fn body_load_n(&self, car_body_weight_n: f64, t_s: f64) -> f64 {
        match self {
            Effect::CarBodyBounce {
                amplitude,
                frequency_hz,
                phase_deg,
            } => {
                car_body_weight_n
                    * amplitude
                    * (TAU * frequency_hz * t_s + phase_deg.to_radians()).sin()
            }
            _ => 0.0,
        }
    }

    /// The stretch of rail `[x_d − ℓ/2, x_d + ℓ/2]` (m) of a rail dip with some depth, where
    /// the wheels need fine steps; `None` for every other effect and for a dip of no depth
    /// (which changes nothing).
    pub fn dip_span_m(&self) -> Option<(f64, f64)> {
        match self {
            Effect::RailDip {
                position_m,
                length_m,
                depth_mm,
            } if depth_mm.abs() != 0.0 => {
                Some((position_m - length_m / 2.0, position_m + length_m / 2.0))
            }
            _ => None,
        }
    }
}

/// The product of the `factor`s that `pick` finds for sleeper `sleeper` (1 when none does).
fn sleeper_factor(
    effects: &[Effect],
    sleeper: usize,
    pick: fn(&Effect) -> Option<(usize, f64)>,
) -> f64 {
    effects
        .iter()
        .filter_map(pick)
        .filter(|&(k, _)| k == sleeper)
        .map(|(_, f)| f)
        .product::<f64>()
}

/// Multiplier of the pad stiffness at sleeper `sleeper`: `K_p → factor·K_p`, the product of
/// its `pad_stiffness` effects (1 without one).
pub(crate) fn pad_stiffness_factor(effects: &[Effect], sleeper: usize) -> f64 {
    sleeper_factor(effects, sleeper, |e| match e {
        Effect::PadStiffness { sleeper, factor } => Some((*sleeper, *factor)),
        _ => None,
    })
}

/// Multiplier of the ballast stiffness under sleeper `sleeper`: `K_b → factor·K_b`, the
/// product of its `ballast_stiffness` effects (1 without one).
pub(crate) fn ballast_stiffness_factor(effects: &[Effect], sleeper: usize) -> f64 {
    sleeper_factor(effects, sleeper, |e| match e {
        Effect::BallastStiffness { sleeper, factor } => Some((*sleeper, *factor)),
        _ => None,
    })
}

/// The gap g (m) between sleeper `sleeper` and its ballast when the first `voided_sleeper`
/// effect on it says so; `None` for a sleeper resting on its ballast.
pub(crate) fn void_gap_m(effects: &[Effect], sleeper: usize) -> Option<f64> {
    effects.iter().find_map(|e| match e {
        Effect::VoidedSleeper { sleeper: k, gap_mm } if *k == sleeper => Some(gap_mm * 1e-3),
        _ => None,
    })
}

/// The gain of sensor `name`'s reading: the product of its `sensor_gain` factors (1 without
/// one).
pub(crate) fn sensor_gain(effects: &[Effect], name: &str) -> f64 {
    effects
        .iter()
        .filter_map(|e| match e {
            Effect::SensorGain { sensor, factor } if sensor == name => Some(*factor),
            _ => None,
        })
        .product()
}

/// The clock effects: the speed the train actually runs at (m/s) and the output delay τ (s)
/// by which every series reads `F(t − τ)`.
///
/// A time offset adds `τ` itself. A speed deviation runs the train at `v' = (1 + fraction)·v`
/// while the recording stays aligned on the leading wheel's laser trigger, `trigger_ahead_m`
/// ahead of the leading wheel's start, which delays the output by
/// `trigger_ahead_m·(1/v − 1/v')`.
pub(crate) fn clock(
    effects: &[Effect],
    nominal_speed_m_per_s: f64,
    trigger_ahead_m: f64,
) -> (f64, f64) {
    let nominal = nominal_speed_m_per_s;
    let mut speed = nominal;
    let mut output_delay_s = 0.0;
    for e in effects {
        match e {
            Effect::TimeOffset { offset_ms } => output_delay_s += offset_ms * 1e-3,
            Effect::SpeedDeviation { fraction } => {
                let actual = nominal * (1.0 + fraction);
                output_delay_s += trigger_ahead_m * (1.0 / nominal - 1.0 / actual);
                speed = actual;
            }
            _ => {}
        }
    }
    (speed, output_delay_s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// Tolerance on a drop (m): far below a nanometre, only rounding.
    const DROP_TOL_M: f64 = 1e-15;

    #[test]
    fn a_periodic_irregularity_has_its_value_phase_and_period_under_both_wheels() {
        // A = 0.3 mm, λ = 2 m, φ = 30°: z(0) = A·sin 30° = A/2; the crest is where
        // 2πx/λ + φ = π/2, at x = λ/6; z repeats every λ.
        let e = Effect::RailIrregularity {
            wavelength_m: 2.0,
            amplitude_mm: 0.3,
            phase_deg: 30.0,
        };
        for w in 0..2 {
            assert!((e.wheel_drop_m(w, 0.0, 0.4) - 0.15e-3).abs() < DROP_TOL_M);
            assert!((e.wheel_drop_m(w, 2.0 / 6.0, 0.4) - 0.3e-3).abs() < DROP_TOL_M);
            for i in 0..50 {
                let x = 11.0 + 0.037 * i as f64;
                let (z, z_next) = (e.wheel_drop_m(w, x, 0.4), e.wheel_drop_m(w, x + 2.0, 0.4));
                assert!((z - z_next).abs() < DROP_TOL_M, "x = {x}: {z} vs {z_next}");
                assert!(z.abs() <= 0.3e-3 + DROP_TOL_M);
            }
        }
    }

    #[test]
    fn a_dip_is_a_raised_cosine_of_its_depth_and_zero_beyond_its_ends() {
        // a = 0.5 mm, ℓ = 0.4 m at x_d = 10 m: z(x_d) = a, z(x_d ± ℓ/4) = a/2,
        // z(x_d ± ℓ/2) = 0, and nothing outside.
        let e = Effect::RailDip {
            position_m: 10.0,
            length_m: 0.4,
            depth_mm: 0.5,
        };
        let z = |x: f64| e.wheel_drop_m(0, x, 0.4);
        assert!((z(10.0) - 0.5e-3).abs() < DROP_TOL_M);
        assert!((z(10.1) - 0.25e-3).abs() < DROP_TOL_M);
        assert!((z(9.9) - 0.25e-3).abs() < DROP_TOL_M);
        assert!(z(9.8).abs() < DROP_TOL_M && z(10.2).abs() < DROP_TOL_M);
        assert_eq!(z(9.79).to_bits(), 0.0f64.to_bits());
        assert_eq!(z(10.21).to_bits(), 0.0f64.to_bits());
        for i in 0..20 {
            let s = 0.01 * i as f64;
            assert!(
                (z(10.0 + s) - z(10.0 - s)).abs() < DROP_TOL_M,
                "symmetric at ±{s}"
            );
        }
        // Both wheels meet it; its span is where fine steps are taken.
        assert_eq!(z(10.05).to_bits(), e.wheel_drop_m(1, 10.05, 0.4).to_bits());
        let (lo, hi) = e.dip_span_m().unwrap();
        assert!((lo - 9.8).abs() < 1e-12 && (hi - 10.2).abs() < 1e-12);
        let flat_dip = Effect::RailDip {
            position_m: 10.0,
            length_m: 0.4,
            depth_mm: 0.0,
        };
        assert_eq!(flat_dip.dip_span_m(), None);
    }

    #[test]
    fn an_out_of_round_wheel_repeats_its_order_times_per_revolution_on_its_wheel_only() {
        // R_w = 0.4 m, n = 3, A = 0.2 mm, φ = 0: z(0) = −A; z repeats every 2πR_w/n and
        // changes sign 2n times over one revolution.
        let radius = 0.4;
        let e = Effect::WheelOutOfRound {
            wheel: WheelPosition::Trailing,
            order: 3,
            amplitude_mm: 0.2,
            phase_deg: 0.0,
        };
        let z = |x: f64| e.wheel_drop_m(1, x, radius);
        assert!((z(0.0) + 0.2e-3).abs() < DROP_TOL_M);
        let revolution = 2.0 * PI * radius;
        for i in 0..40 {
            let x = 12.0 + 0.031 * i as f64;
            assert!((z(x) - z(x + revolution / 3.0)).abs() < 1e-14);
            assert_eq!(e.wheel_drop_m(0, x, radius).to_bits(), 0.0f64.to_bits());
        }
        let samples = 10_000;
        let signs: Vec<bool> = (0..=samples)
            .map(|i| z(0.001 + revolution * i as f64 / samples as f64) > 0.0)
            .collect();
        let changes = signs.windows(2).filter(|w| w[0] != w[1]).count();
        assert_eq!(changes, 6);
    }

    #[test]
    fn a_car_body_bounce_adds_its_share_of_the_weight_and_nothing_else_does() {
        // W = 73,575 N, a = 0.1, f = 2 Hz, φ = 90°: W·a at t = 0, zero a quarter period later.
        let e = Effect::CarBodyBounce {
            amplitude: 0.1,
            frequency_hz: 2.0,
            phase_deg: 90.0,
        };
        let weight_n = 7500.0 * 9.81;
        assert!((e.body_load_n(weight_n, 0.0) - 7357.5).abs() < 1e-9);
        assert!(e.body_load_n(weight_n, 0.125).abs() < 1e-9);
        assert!((e.body_load_n(weight_n, 0.25) + 7357.5).abs() < 1e-9);
        let other = Effect::TimeOffset { offset_ms: 1.0 };
        assert_eq!(other.body_load_n(weight_n, 0.0).to_bits(), 0.0f64.to_bits());
        assert_eq!(other.wheel_drop_m(0, 12.0, 0.4).to_bits(), 0.0f64.to_bits());
    }

    #[test]
    fn sleeper_effects_multiply_per_sleeper_and_the_first_void_counts() {
        // The factors are binary fractions, so their products are exact.
        let effects = [
            Effect::PadStiffness {
                sleeper: 5,
                factor: 2.0,
            },
            Effect::PadStiffness {
                sleeper: 5,
                factor: 0.25,
            },
            Effect::PadStiffness {
                sleeper: 6,
                factor: 3.0,
            },
            Effect::BallastStiffness {
                sleeper: 6,
                factor: 0.5,
            },
            Effect::VoidedSleeper {
                sleeper: 7,
                gap_mm: 1.5,
            },
            Effect::VoidedSleeper {
                sleeper: 7,
                gap_mm: 2.0,
            },
        ];
        assert_eq!(
            pad_stiffness_factor(&effects, 5).to_bits(),
            0.5f64.to_bits()
        );
        assert_eq!(
            pad_stiffness_factor(&effects, 6).to_bits(),
            3.0f64.to_bits()
        );
        assert_eq!(
            pad_stiffness_factor(&effects, 7).to_bits(),
            1.0f64.to_bits()
        );
        assert_eq!(
            ballast_stiffness_factor(&effects, 5).to_bits(),
            1.0f64.to_bits()
        );
        assert_eq!(
            ballast_stiffness_factor(&effects, 6).to_bits(),
            0.5f64.to_bits()
        );
        assert_eq!(void_gap_m(&effects, 7), Some(1.5e-3));
        assert_eq!(void_gap_m(&effects, 6), None);
    }

    #[test]
    fn sensor_gains_multiply_and_the_clock_adds_its_delays() {
        let effects = [
            Effect::SensorGain {
                sensor: "rps2".into(),
                factor: 1.1,
            },
            Effect::SensorGain {
                sensor: "rps2".into(),
                factor: 2.0,
            },
            Effect::TimeOffset { offset_ms: 2.0 },
            Effect::SpeedDeviation { fraction: 0.1 },
        ];
        assert!((sensor_gain(&effects, "rps2") - 2.2).abs() < 1e-15);
        assert_eq!(sensor_gain(&effects, "rps1").to_bits(), 1.0f64.to_bits());
        // v = 50 km/h, the trigger 8.2 m ahead: v' = 1.1·v, τ = 2 ms + 8.2·(1/v − 1/v').
        let v = 50.0 / 3.6;
        let (speed, delay_s) = clock(&effects, v, 8.2);
        assert!((speed - 1.1 * v).abs() < 1e-12);
        let expected = 2e-3 + 8.2 / v * (1.0 - 1.0 / 1.1);
        assert!(
            (delay_s - expected).abs() < 1e-15,
            "{delay_s} vs {expected}"
        );
        assert_eq!(clock(&[], v, 8.2), (v, 0.0));
    }
}
