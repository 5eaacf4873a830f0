//! Wheel and rail running surfaces (docs/model.md §5b): measured or synthetic traces of a
//! wheel's radius and of the rail head, the contact filter that turns them into the drop of
//! each wheel's centre, and the table the integrator reads that drop from.
//!
//! A surface is a *deviation* `e` (m, positive = material present, as a roughness trolley
//! reports it: negative where material is missing). Under wheel `w` at rail position `x` the
//! wheel and rail deviations meet along the rolling direction as one combined profile
//!
//! `c_w(ξ) = e_wheel((ξ − x_touch) mod C) + e_rail(ξ)`,
//!
//! `C = 2πR_w`, `x_touch` the rail position where the trace's `s = 0` touches the rail (the
//! wheel's circumferential coordinate advances with the rail position, one revolution per
//! `C`). The **contact filter** turns `c_w` into the wheel centre's rise:
//!
//! 1. the **contact patch** averages the profile over the Hertz contact length, weighted as
//!    the Hertz pressure `p(u) ∝ √(1 − (u/a)²)` for `|u| ≤ a`, with the semi-length
//!    `a = √(R_w·δ₀)` and `δ₀ = (W/C_H)^(2/3)` the static Hertz compression (5.3 mm for the
//!    default wheel; a wheel cannot follow wavelengths shorter than its contact patch);
//! 2. the **rolling circle**: a rigid wheel of radius `R_w` rests on the highest points of the
//!    averaged profile, `h(x) = max_u [c̄_w(x + u) − u²/(2R_w)]` (it bridges a pit narrower than
//!    its own curvature allows, as over a flat: a chord of depth `d` spans `√(8·d·R_w)`).
//!
//! The drop of the wheel centre is `z(x) = −h(x)`, added to the flat's trajectory (§5). Which
//! of these steps the independent converged implementation's passes support is measured in
//! docs/model.md §5b.
//!
//! The table is computed once per [`super::Simulator::with_surfaces`] on a 0.25 mm grid over
//! each wheel's travel and read by linear interpolation at every step: the integrator does no
//! surface work in its loop.

pub mod spec;
pub mod spectrum;
pub(crate) mod trace;

pub use spec::{SurfaceNote, SurfaceSpec};
pub use spectrum::{out_of_round, rail_roughness, wheel_roughness, Harmonic, RoughnessClass};
pub use trace::{parse_trace, TraceError, TraceFile};

use super::wheel::WheelPosition;
use thiserror::Error;

/// Largest deviation a surface may carry (m): 5 mm, beyond any roughness, out-of-roundness or
/// flat the model is meant for.
pub const MAX_DEVIATION_M: f64 = 5e-3;

/// Largest sample spacing of a trace (m): 10 mm (roughness standards sample at 1 mm or finer).
pub const MAX_SPACING_M: f64 = 1e-2;

/// Most samples a trace may hold: 10 million (a 10 km rail at 1 mm).
pub const MAX_SAMPLES: usize = 10_000_000;

/// Spacing of the drop table (m).
const TABLE_DX_M: f64 = 2.5e-4;

/// Errors in surface data.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SurfaceError {
    /// A trace value is not finite or out of its range.
    #[error("surface trace `{what}`: {reason}")]
    Invalid {
        /// Which trace (the wheel, the rail, a synthetic surface).
        what: String,
        /// Why it is refused.
        reason: String,
    },
    /// A wheel trace is not one revolution of the model's wheel.
    #[error("wheel trace `{what}` spans {span_mm:.1} mm, but the model's wheel is {circumference_mm:.1} mm round (2πR_w): a trace must cover one revolution, within 10 %")]
    NotOneRevolution {
        /// Which trace.
        what: String,
        /// The trace's period (mm).
        span_mm: f64,
        /// The model wheel's circumference (mm).
        circumference_mm: f64,
    },
    /// Two surfaces were given for the same wheel.
    #[error("two surfaces for the {0} wheel: give one trace per wheel")]
    Duplicate(&'static str),
}

/// Deviation samples at a uniform spacing (SI units).
#[derive(Debug, Clone, PartialEq)]
pub struct Trace {
    spacing_m: f64,
    deviation_m: Vec<f64>,
}

impl Trace {
    /// A trace of `deviation_m` at `spacing_m`, checked: at least 2 and at most
    /// [`MAX_SAMPLES`] samples, finite, `|e| ≤` [`MAX_DEVIATION_M`], spacing in
    /// `(0, MAX_SPACING_M]`.
    pub fn new(what: &str, spacing_m: f64, deviation_m: Vec<f64>) -> Result<Trace, SurfaceError> {
        let bad = |reason: String| SurfaceError::Invalid {
            what: what.to_string(),
            reason,
        };
        if !(spacing_m.is_finite() && spacing_m > 0.0 && spacing_m <= MAX_SPACING_M) {
            return Err(bad(format!(
                "sample spacing {:.4} mm must lie in (0, {}] mm",
                spacing_m * 1e3,
                MAX_SPACING_M * 1e3
            )));
        }
        if deviation_m.len() < 2 || deviation_m.len() > MAX_SAMPLES {
            return Err(bad(format!(
                "{} samples: a trace holds 2 to {MAX_SAMPLES}",
                deviation_m.len()
            )));
        }
        if let Some((i, e)) = deviation_m
            .iter()
            .enumerate()
            .find(|(_, e)| !(e.is_finite() && e.abs() <= MAX_DEVIATION_M))
        {
            return Err(bad(format!(
                "sample {i} is {:.1} µm: deviations must be finite and within ±{} µm",
                e * 1e6,
                MAX_DEVIATION_M * 1e6
            )));
        }
        Ok(Trace {
            spacing_m,
            deviation_m,
        })
    }

    /// Sample spacing (m).
    pub fn spacing_m(&self) -> f64 {
        self.spacing_m
    }

    /// The samples (m).
    pub fn deviation_m(&self) -> &[f64] {
        &self.deviation_m
    }

    /// Length covered, `n·spacing` (m): a closed wheel trace's period.
    pub fn period_m(&self) -> f64 {
        self.deviation_m.len() as f64 * self.spacing_m
    }

    /// Root mean square about the mean (m).
    pub fn rms_m(&self) -> f64 {
        let n = self.deviation_m.len() as f64;
        let mean = self.deviation_m.iter().sum::<f64>() / n;
        (self
            .deviation_m
            .iter()
            .map(|e| (e - mean) * (e - mean))
            .sum::<f64>()
            / n)
            .sqrt()
    }

    /// The value at `s` (m) of the trace closed on itself over `period_m` (linear
    /// interpolation). A trace whose `n·spacing` is within one spacing of the period is one
    /// revolution at its own spacing: its samples stay at `i·spacing` and the last interval
    /// closes onto the first sample. Any other trace (another wheel's, of another
    /// circumference) is stretched onto the period: samples at `i·period/n`.
    pub(crate) fn periodic_at(&self, s: f64, period_m: f64) -> f64 {
        let n = self.deviation_m.len();
        let s = s.rem_euclid(period_m);
        let step = if (self.period_m() - period_m).abs() <= self.spacing_m {
            self.spacing_m
        } else {
            period_m / n as f64
        };
        let pos = s / step;
        let i = (pos.floor() as usize).min(n - 1);
        let (a, b) = (self.deviation_m[i], self.deviation_m[(i + 1) % n]);
        // The closing interval runs from the last sample to the period's end.
        let width = if i + 1 == n {
            (period_m - (n - 1) as f64 * step).max(f64::MIN_POSITIVE)
        } else {
            step
        };
        let f = ((s - i as f64 * step) / width).clamp(0.0, 1.0);
        a + f * (b - a)
    }

    /// The value at `s` (m) from the first sample, 0 beyond either end.
    pub(crate) fn open_at(&self, s: f64) -> f64 {
        let pos = s / self.spacing_m;
        let n = self.deviation_m.len();
        if !(pos >= 0.0 && pos <= (n - 1) as f64) {
            return 0.0;
        }
        let i = (pos.floor() as usize).min(n - 2);
        let f = pos - i as f64;
        self.deviation_m[i] + f * (self.deviation_m[i + 1] - self.deviation_m[i])
    }
}

/// One wheel's tread: a trace over one revolution and where it touches the rail.
#[derive(Debug, Clone, PartialEq)]
pub struct WheelSurface {
    /// The wheel.
    pub wheel: WheelPosition,
    /// Radius deviation over one revolution, from `s = 0` on (closed: the last sample is one
    /// spacing before the first again). It is stretched onto the model wheel's circumference.
    pub trace: Trace,
    /// Rail position where `s = 0` touches the rail (m); again every `2πR_w`.
    pub touch_x_m: f64,
}

/// The rail head's deviation from `start_x_m` on (0 elsewhere: a smooth rail).
#[derive(Debug, Clone, PartialEq)]
pub struct RailSurface {
    /// Rail position of the first sample (m).
    pub start_x_m: f64,
    /// The deviation along the rail.
    pub trace: Trace,
}

/// Which steps of the contact filter apply (docs/model.md §5b). The product uses
/// [`ContactFilter::DEFAULT`]; the others are the variants it was measured against.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ContactFilter {
    /// Average over the Hertz contact patch.
    pub patch: bool,
    /// Rest on the highest points (rolling circle of radius `R_w`).
    pub rolling_circle: bool,
}

impl ContactFilter {
    /// Both steps: the patch average, then the rolling circle.
    pub const DEFAULT: ContactFilter = ContactFilter {
        patch: true,
        rolling_circle: true,
    };
}

/// The surfaces of one run: any wheel's tread and the rail.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Surfaces {
    /// At most one per wheel.
    pub wheels: Vec<WheelSurface>,
    /// The rail, if rough.
    pub rail: Option<RailSurface>,
}

impl Surfaces {
    /// No surface: round wheels on a smooth rail.
    pub fn is_empty(&self) -> bool {
        self.wheels.is_empty() && self.rail.is_none()
    }

    /// The surface of wheel `w`, if any.
    pub fn wheel(&self, w: WheelPosition) -> Option<&WheelSurface> {
        self.wheels.iter().find(|s| s.wheel == w)
    }

    /// Checks the surfaces against a wheel of radius `wheel_radius_m`: one trace per wheel, each
    /// one revolution long within 10 %.
    pub fn check(&self, wheel_radius_m: f64) -> Result<(), SurfaceError> {
        let circumference = std::f64::consts::TAU * wheel_radius_m;
        for (i, s) in self.wheels.iter().enumerate() {
            if self.wheels[..i].iter().any(|o| o.wheel == s.wheel) {
                return Err(SurfaceError::Duplicate(s.wheel.name()));
            }
            let span = s.trace.period_m();
            if (span / circumference - 1.0).abs() > 0.1 {
                return Err(SurfaceError::NotOneRevolution {
                    what: format!("{} wheel", s.wheel.name()),
                    span_mm: span * 1e3,
                    circumference_mm: circumference * 1e3,
                });
            }
            if !s.touch_x_m.is_finite() {
                return Err(SurfaceError::Invalid {
                    what: format!("{} wheel", s.wheel.name()),
                    reason: format!("touch position {} m is not finite", s.touch_x_m),
                });
            }
        }
        if let Some(r) = &self.rail {
            if !r.start_x_m.is_finite() {
                return Err(SurfaceError::Invalid {
                    what: "rail".into(),
                    reason: format!("start position {} m is not finite", r.start_x_m),
                });
            }
        }
        Ok(())
    }

    /// The combined deviation under wheel `w` at rail position `x` (m), before the contact
    /// filter: `e_wheel((x − x_touch) mod C) + e_rail(x)`.
    pub fn combined_m(&self, w: WheelPosition, x: f64, wheel_radius_m: f64) -> f64 {
        let circumference = std::f64::consts::TAU * wheel_radius_m;
        let wheel = self
            .wheel(w)
            .map_or(0.0, |s| s.trace.periodic_at(x - s.touch_x_m, circumference));
        let rail = self
            .rail
            .as_ref()
            .map_or(0.0, |r| r.trace.open_at(x - r.start_x_m));
        wheel + rail
    }
}

/// Each wheel's centre drop from the surfaces on a uniform grid over its travel: what the
/// integrator reads at every step.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct SurfaceDrops {
    /// First grid position of each wheel (m).
    x0_m: [f64; 2],
    /// Grid spacing (m).
    dx_m: f64,
    /// Drop `z = −h` at each grid position (m, downwards positive), per wheel.
    z_m: [Vec<f64>; 2],
}

/// The semi-length of the Hertz contact in the rolling direction, `a = √(R_w·δ₀)` with
/// `δ₀ = (W/C_H)^(2/3)` (m).
pub fn contact_semi_length_m(wheel_radius_m: f64, wheel_load_n: f64, c_h: f64) -> f64 {
    (wheel_radius_m * (wheel_load_n / c_h).powf(2.0 / 3.0)).sqrt()
}

impl SurfaceDrops {
    /// The drop tables over `spans[w]` (rail positions each wheel travels, m) for wheels of
    /// radius `wheel_radius_m`, filtered with contact semi-length `a_m`.
    pub(crate) fn new(
        surfaces: &Surfaces,
        spans: [(f64, f64); 2],
        wheel_radius_m: f64,
        a_m: f64,
        filter: ContactFilter,
    ) -> SurfaceDrops {
        let dx = TABLE_DX_M;
        let r = wheel_radius_m;
        let wheels = [WheelPosition::Leading, WheelPosition::Trailing];
        let mut x0 = [0.0; 2];
        let z = std::array::from_fn(|w| {
            let (lo, hi) = spans[w];
            let half_patch = if filter.patch {
                (a_m / dx).ceil() as usize
            } else {
                0
            };
            // The rolling circle reaches at most this far (bounded below by the patch).
            let reach_cells = 400usize; // 100 mm on the 0.25 mm grid
            let pad = half_patch + reach_cells + 2;
            let n = ((hi - lo) / dx).ceil() as usize + 1;
            x0[w] = lo;
            let start = lo - pad as f64 * dx;
            let raw: Vec<f64> = (0..n + 2 * pad)
                .map(|i| surfaces.combined_m(wheels[w], start + i as f64 * dx, r))
                .collect();
            let averaged = if filter.patch {
                patch_average(&raw, half_patch, a_m / dx)
            } else {
                raw
            };
            let risen: Vec<f64> = if filter.rolling_circle {
                rolling_circle(&averaged, dx, r, pad, n, reach_cells)
            } else {
                averaged[pad..pad + n].to_vec()
            };
            risen.into_iter().map(|h| -h).collect()
        });
        SurfaceDrops {
            x0_m: x0,
            dx_m: dx,
            z_m: z,
        }
    }

    /// The drop of wheel `w` at rail position `x` (m): linear interpolation, 0 off the table.
    #[inline]
    pub(crate) fn drop_m(&self, w: usize, x: f64) -> f64 {
        let z = &self.z_m[w];
        let pos = (x - self.x0_m[w]) / self.dx_m;
        if !(pos >= 0.0 && pos < (z.len() - 1) as f64) {
            return 0.0;
        }
        let i = pos as usize;
        let f = pos - i as f64;
        f.mul_add(z[i + 1] - z[i], z[i])
    }

    /// Rail positions of wheel `w` where its drop exceeds `depth_m` (m): the spans where a deep
    /// pit (a flat in a measured tread) strikes, `(from, to)`.
    pub(crate) fn deep_spans(&self, w: usize, depth_m: f64) -> Vec<(f64, f64)> {
        let mut spans = Vec::new();
        let mut open: Option<usize> = None;
        for (i, &z) in self.z_m[w].iter().enumerate() {
            match (z > depth_m, open) {
                (true, None) => open = Some(i),
                (false, Some(a)) => {
                    spans.push((a, i));
                    open = None;
                }
                _ => {}
            }
        }
        if let Some(a) = open {
            spans.push((a, self.z_m[w].len()));
        }
        spans
            .into_iter()
            .map(|(a, b)| {
                (
                    self.x0_m[w] + a as f64 * self.dx_m,
                    self.x0_m[w] + b as f64 * self.dx_m,
                )
            })
            .collect()
    }
}

/// The Hertz-weighted average of `raw` over `±half` cells, weights `√(1 − (j/a_cells)²)`.
fn patch_average(raw: &[f64], half: usize, a_cells: f64) -> Vec<f64> {
    let weights: Vec<f64> = (0..=2 * half)
        .map(|k| {
            let u = (k as f64 - half as f64) / a_cells;
            (1.0 - u * u).max(0.0).sqrt()
        })
        .collect();
    let total: f64 = weights.iter().sum();
    let mut out = raw.to_vec();
    for (i, o) in out.iter_mut().enumerate().take(raw.len() - half).skip(half) {
        *o = weights
            .iter()
            .enumerate()
            .map(|(k, w)| w * raw[i + k - half])
            .sum::<f64>()
            / total;
    }
    out
}

/// The rise of a rigid circle of radius `r` resting on `profile` (spacing `dx`) at the `n`
/// cells from `first`: `h_i = max_{|j| ≤ reach} [p_{i+j} − (j·dx)²/(2r)]`. The search stops
/// once the parabola has fallen below the highest point of the whole profile's reach.
fn rolling_circle(
    profile: &[f64],
    dx: f64,
    r: f64,
    first: usize,
    n: usize,
    reach: usize,
) -> Vec<f64> {
    let top = profile.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    (first..first + n)
        .map(|i| {
            let mut h = profile[i];
            for j in 1..=reach {
                let fall = (j as f64 * dx).powi(2) / (2.0 * r);
                if top - fall <= h {
                    break;
                }
                let ahead = profile[i + j] - fall;
                let behind = profile[i - j] - fall;
                h = h.max(ahead).max(behind);
            }
            h
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wheel(trace: Trace) -> Surfaces {
        Surfaces {
            wheels: vec![WheelSurface {
                wheel: WheelPosition::Trailing,
                trace,
                touch_x_m: 10.0,
            }],
            rail: None,
        }
    }

    #[test]
    fn a_trace_refuses_what_no_surface_is() {
        assert!(Trace::new("t", 1e-3, vec![0.0; 10]).is_ok());
        let e = Trace::new("t", 1e-3, vec![0.0, 1.0])
            .unwrap_err()
            .to_string();
        assert!(e.contains("sample 1") && e.contains("1000000.0 µm"), "{e}");
        assert!(Trace::new("t", 0.0, vec![0.0; 10]).is_err());
        assert!(Trace::new("t", 0.02, vec![0.0; 10]).is_err());
        assert!(Trace::new("t", 1e-3, vec![f64::NAN, 0.0]).is_err());
        assert!(Trace::new("t", 1e-3, vec![0.0]).is_err());
    }

    #[test]
    fn a_wheel_trace_must_be_one_revolution() {
        let c = std::f64::consts::TAU * 0.4;
        let n = (c / 1e-3).round() as usize;
        let ok = wheel(Trace::new("w", 1e-3, vec![0.0; n]).unwrap());
        assert!(ok.check(0.4).is_ok());
        let short = wheel(Trace::new("w", 1e-3, vec![0.0; n / 2]).unwrap());
        let e = short.check(0.4).unwrap_err().to_string();
        assert!(e.contains("1256.0 mm") && e.contains("2513.3 mm"), "{e}");
    }

    #[test]
    fn the_wheel_trace_turns_with_the_wheel_and_the_rail_stays_put() {
        // e_wheel(s) = s (a ramp, µm per mm) over one revolution from x_touch = 10 m.
        let r = 0.4;
        let c = std::f64::consts::TAU * r;
        let n = 2513;
        let spacing = c / n as f64;
        let ramp: Vec<f64> = (0..n).map(|i| i as f64 * 1e-9).collect();
        let mut s = wheel(Trace::new("w", spacing, ramp).unwrap());
        let at = |s: &Surfaces, x: f64| s.combined_m(WheelPosition::Trailing, x, r);
        assert!(at(&s, 10.0).abs() < 1e-15);
        assert!((at(&s, 10.0 + 100.0 * spacing) - 100e-9).abs() < 1e-15);
        // One revolution later, the same point of the tread.
        assert!((at(&s, 10.0 + c + 100.0 * spacing) - 100e-9).abs() < 1e-14);
        assert!(s.combined_m(WheelPosition::Leading, 10.1, r).abs() < 1e-18);
        s.rail = Some(RailSurface {
            start_x_m: 11.0,
            trace: Trace::new("r", 1e-3, vec![2e-6; 1001]).unwrap(),
        });
        // The rail adds under both wheels, only over its own span.
        assert!((s.combined_m(WheelPosition::Leading, 11.5, r) - 2e-6).abs() < 1e-15);
        assert!(s.combined_m(WheelPosition::Leading, 12.5, r).abs() < 1e-18);
    }

    #[test]
    fn the_patch_averages_out_wavelengths_shorter_than_the_contact() {
        // A sinusoid of wavelength λ averaged over the Hertz pressure of semi-length a keeps
        // the fraction 2·J1(ka)/(ka) of its amplitude (k = 2π/λ): at ka = 3.8317 (J1's first
        // zero) nothing; at λ = 20a (ka = π/10), 0.988 (the series 1 − (ka)²/8 + (ka)⁴/192).
        let dx: f64 = 1e-5;
        let a: f64 = 5e-3;
        let half = (a / dx).ceil() as usize;
        for (ka, expected) in [(3.8317f64, 0.0f64), (std::f64::consts::TAU / 20.0, 0.988)] {
            let k = ka / a;
            let raw: Vec<f64> = (0..6000).map(|i| (k * i as f64 * dx).sin()).collect();
            let avg = patch_average(&raw, half, a / dx);
            let amp = avg[2000..4000].iter().fold(0.0f64, |m, v| m.max(v.abs()));
            assert!(
                (amp - expected).abs() < 0.01,
                "ka {ka}: {amp} vs {expected}"
            );
        }
    }

    #[test]
    fn the_rolling_circle_bridges_a_chord_flat_to_its_fresh_depth() {
        // A sharp pit of depth 0.5 mm and width 10 mm (narrower than the chord a wheel of
        // R_w = 0.4 m spans at that depth, √(8dR) = 40 mm): the circle resting on the edges
        // drops only (w/2)²/(2R) = 31 µm at the middle; a smooth profile is followed exactly.
        let dx = TABLE_DX_M;
        let r = 0.4;
        let n = 2000;
        let profile: Vec<f64> = (0..n)
            .map(|i| {
                let x = (i as f64 - 1000.0) * dx;
                if x.abs() < 5e-3 {
                    -0.5e-3
                } else {
                    0.0
                }
            })
            .collect();
        let h = rolling_circle(&profile, dx, r, 500, 1000, 400);
        let mid = h[500];
        let expected = -(5e-3f64).powi(2) / (2.0 * r);
        assert!((mid - expected).abs() < 1e-6, "{mid} vs {expected}");
        let smooth: Vec<f64> = (0..n)
            .map(|i| 1e-5 * (i as f64 * dx * 10.0).sin())
            .collect();
        let h = rolling_circle(&smooth, dx, r, 500, 1000, 400);
        for (k, v) in h.iter().enumerate() {
            assert!((v - smooth[500 + k]).abs() < 1e-12);
        }
    }
}
