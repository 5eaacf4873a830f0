//! A pass's surfaces as asked for: roughness drawn from a class, out-of-round harmonics,
//! measured traces, the contact filter — built into [`Surfaces`] for one calibration, with a
//! description of each for the pass's truth.

use super::spectrum::{out_of_round, rail_roughness, wheel_roughness, Harmonic, RoughnessClass};
use super::{ContactFilter, RailSurface, SurfaceError, Surfaces, Trace, WheelSurface};
use crate::model::WheelPosition;
use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;

/// What one simulated surface was: on which wheel (none: the rail), where it came from and
/// its rms.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SurfaceNote {
    /// The wheel (absent: the rail).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wheel: Option<WheelPosition>,
    /// Where it came from: a roughness class and its seed, an out-of-round wheel's order and
    /// amplitude, a trace file.
    pub source: String,
    /// Its rms about the mean (µm).
    pub rms_um: f64,
}

/// The surfaces of a pass, as asked for.
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceSpec {
    /// Both wheels' treads drawn from a wheel class, seeded (each wheel its own draw).
    pub wheel_roughness: Option<(RoughnessClass, u64)>,
    /// The rail drawn from a rail class, seeded.
    pub rail_roughness: Option<(RoughnessClass, u64)>,
    /// Out-of-round harmonics, each on its wheel.
    pub out_of_round: Vec<(WheelPosition, Harmonic)>,
    /// Measured wheel traces (a file's, with its wheel and where it touches the rail).
    pub wheel_traces: Vec<(WheelSurface, String)>,
    /// A measured rail trace and its name.
    pub rail_trace: Option<(RailSurface, String)>,
    /// The contact filter.
    pub filter: ContactFilter,
}

impl Default for SurfaceSpec {
    fn default() -> Self {
        SurfaceSpec {
            wheel_roughness: None,
            rail_roughness: None,
            out_of_round: Vec::new(),
            wheel_traces: Vec::new(),
            rail_trace: None,
            filter: ContactFilter::DEFAULT,
        }
    }
}

/// Where a drawn wheel's tread starts touching the rail (m): a fixed place per wheel, so that
/// a seed gives the same pass.
const DRAWN_TOUCH_M: [f64; 2] = [3.1, 1.9];

impl SurfaceSpec {
    /// Nothing asked for.
    pub fn is_empty(&self) -> bool {
        self.wheel_roughness.is_none()
            && self.rail_roughness.is_none()
            && self.out_of_round.is_empty()
            && self.wheel_traces.is_empty()
            && self.rail_trace.is_none()
    }

    /// The surfaces for a wheel of radius `wheel_radius_m` on a rail of `rail_length_m`, and
    /// what each is. A wheel's drawn roughness, its out-of-round harmonics and a measured
    /// trace add up (on the drawn spacing); so do the rail's.
    pub fn build(
        &self,
        wheel_radius_m: f64,
        rail_length_m: f64,
    ) -> Result<(Surfaces, Vec<SurfaceNote>), SurfaceError> {
        let mut notes = Vec::new();
        let c = TAU * wheel_radius_m;
        let mut wheels = Vec::new();
        for (i, w) in [WheelPosition::Leading, WheelPosition::Trailing]
            .into_iter()
            .enumerate()
        {
            let mut parts: Vec<(Trace, f64)> = Vec::new(); // (trace, its touch position)
            if let Some((class, seed)) = self.wheel_roughness {
                let s = seed.wrapping_mul(2).wrapping_add(i as u64);
                let t = wheel_roughness(class, wheel_radius_m, s)?;
                notes.push(SurfaceNote {
                    wheel: Some(w),
                    source: format!("{} roughness, seed {s}", class.name()),
                    rms_um: t.rms_m() * 1e6,
                });
                parts.push((t, DRAWN_TOUCH_M[i]));
            }
            let harmonics: Vec<Harmonic> = self
                .out_of_round
                .iter()
                .filter(|(on, _)| *on == w)
                .map(|&(_, h)| h)
                .collect();
            if !harmonics.is_empty() {
                let t = out_of_round(&harmonics, wheel_radius_m)?;
                notes.push(SurfaceNote {
                    wheel: Some(w),
                    source: format!(
                        "out of round: {}",
                        harmonics
                            .iter()
                            .map(|h| format!(
                                "order {} at {:.1} µm, phase {:.0}°",
                                h.order,
                                h.amplitude_m * 1e6,
                                h.phase_rad.to_degrees()
                            ))
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                    rms_um: t.rms_m() * 1e6,
                });
                parts.push((t, DRAWN_TOUCH_M[i]));
            }
            for (s, name) in self.wheel_traces.iter().filter(|(s, _)| s.wheel == w) {
                notes.push(SurfaceNote {
                    wheel: Some(w),
                    source: format!("trace {name}"),
                    rms_um: s.trace.rms_m() * 1e6,
                });
                parts.push((s.trace.clone(), s.touch_x_m));
            }
            match parts.len() {
                0 => {}
                1 => {
                    let (trace, touch_x_m) = parts.pop().expect("one part");
                    wheels.push(WheelSurface {
                        wheel: w,
                        trace,
                        touch_x_m,
                    });
                }
                _ => {
                    // On one grid from the first part's touch position, each part read at its
                    // own phase.
                    let touch = parts[0].1;
                    let n = (c / super::spectrum::DRAWN_SPACING_M).round() as usize;
                    let values = (0..n)
                        .map(|k| {
                            let x = touch + k as f64 * c / n as f64;
                            parts.iter().map(|(t, at)| t.periodic_at(x - at, c)).sum()
                        })
                        .collect();
                    wheels.push(WheelSurface {
                        wheel: w,
                        trace: Trace::new(&format!("{} wheel", w.name()), c / n as f64, values)?,
                        touch_x_m: touch,
                    });
                }
            }
        }
        let mut rail_parts: Vec<RailSurface> = Vec::new();
        if let Some((class, seed)) = self.rail_roughness {
            let t = rail_roughness(class, rail_length_m, seed)?;
            notes.push(SurfaceNote {
                wheel: None,
                source: format!("{} roughness, seed {seed}", class.name()),
                rms_um: t.rms_m() * 1e6,
            });
            rail_parts.push(RailSurface {
                start_x_m: 0.0,
                trace: t,
            });
        }
        if let Some((r, name)) = &self.rail_trace {
            notes.push(SurfaceNote {
                wheel: None,
                source: format!("trace {name}"),
                rms_um: r.trace.rms_m() * 1e6,
            });
            rail_parts.push(r.clone());
        }
        let rail = match rail_parts.len() {
            0 => None,
            1 => rail_parts.pop(),
            _ => {
                let dx = super::spectrum::DRAWN_SPACING_M;
                let n = (rail_length_m / dx).ceil() as usize + 1;
                let values = (0..n)
                    .map(|k| {
                        rail_parts
                            .iter()
                            .map(|r| r.trace.open_at(k as f64 * dx - r.start_x_m))
                            .sum()
                    })
                    .collect();
                Some(RailSurface {
                    start_x_m: 0.0,
                    trace: Trace::new("rail", dx, values)?,
                })
            }
        };
        let surfaces = Surfaces { wheels, rail };
        surfaces.check(wheel_radius_m)?;
        Ok((surfaces, notes))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parts_on_one_wheel_add_up_and_each_is_described() {
        let r = 0.4;
        let spec = SurfaceSpec {
            wheel_roughness: Some((RoughnessClass::CastIron, 3)),
            out_of_round: vec![(
                WheelPosition::Trailing,
                Harmonic {
                    order: 8,
                    amplitude_m: 20e-6,
                    phase_rad: 0.0,
                },
            )],
            ..SurfaceSpec::default()
        };
        let (s, notes) = spec.build(r, 23.8).unwrap();
        assert_eq!(s.wheels.len(), 2);
        assert_eq!(notes.len(), 3);
        // The trailing wheel is its roughness plus the polygon: at its touch position the sum.
        let rough = wheel_roughness(RoughnessClass::CastIron, r, 7).unwrap();
        let at = DRAWN_TOUCH_M[1];
        let trailing = s.wheel(WheelPosition::Trailing).unwrap();
        let expected = rough.deviation_m()[0] + 20e-6;
        let got = s.combined_m(WheelPosition::Trailing, at, r);
        assert!((got - expected).abs() < 1e-9, "{got} vs {expected}");
        assert!((trailing.touch_x_m - at).abs() < 1e-12);
        assert!(SurfaceSpec::default().is_empty());
    }
}
