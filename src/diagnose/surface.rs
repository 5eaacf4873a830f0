//! Where a rough pass's departure lives (docs/diagnosis.md, "Wheel or rail"): a wheel's tread
//! roughness or out-of-roundness travels with its wheel, a rail's roughness or defect stays at
//! its place on the rail. Each sensor is passed by the leading wheel and, a wheelbase later, by
//! the trailing wheel over the same rail: the departure from the good wheel that the two leave
//! at the same sensor is the same where the rail makes it, and unrelated where the wheels do.
//!
//! The departure at sensor `j` is `r_jk = y_jk − a_j·g_jk` (`g` the good wheel's series, `a_j`
//! its least-squares gain), averaged over 5 samples (binomial: white noise to 27 % of its
//! power) and high-passed (its centred moving average over [`SMOOTHING_SAMPLES`] taken off:
//! what the gain leaves of the quasi-static shape is common to both wheels and is not a
//! surface). Within half a sleeper bay of the sensor, the leading wheel's samples are paired
//! with the trailing wheel's a wheelbase later. The record's noise power `N` is read where
//! both wheels are at least a bay from the sensor; the correlation of what is above it,
//! `ρ = Σ r_L r_T / n / √((P_L − N)(P_T − N))` over every sensor, decides: the rail at
//! `ρ ≥` [`RAIL_CORRELATION`], else the wheels — one of them when it leaves at least
//! [`ONE_WHEEL_POWER_RATIO`] times the other's power above `N`. A departure whose power is
//! within [`NOISE_FACTOR`] of `N` names nothing.

use crate::identify::input::compare::Comparison;
use crate::identify::{Identification, Identifier, Measurement};
use crate::model::average::{centred_average, BINOMIAL5};
use crate::model::WheelPosition;
use serde::{Deserialize, Serialize};

/// Samples of the centred moving average taken off the departure (0.35 m, half a bay, at
/// 50 km/h and 2.5 kHz: shorter than the quasi-static shape, as long as a 6-sided wheel's
/// wave; measured against 27 and 95 samples in docs/diagnosis.md, "Wheel or rail").
pub const SMOOTHING_SAMPLES: usize = 63;

/// The least correlation read as the rail (docs/diagnosis.md, "Wheel or rail": measured).
pub const RAIL_CORRELATION: f64 = 0.5;

/// The least ratio of one wheel's power above the noise to the other's to name that wheel.
pub const ONE_WHEEL_POWER_RATIO: f64 = 4.0;

/// A departure whose power is within this factor of the noise's names nothing.
pub const NOISE_FACTOR: f64 = 1.5;

/// Which surface the departure is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Origin {
    /// The same under both wheels: the rail (roughness or a defect).
    Rail,
    /// Different under the two wheels: both treads.
    BothWheels,
    /// Under one wheel only.
    Wheel(WheelPosition),
    /// Nothing above the record's noise.
    Noise,
}

/// What the departure under the two wheels says.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SurfaceOrigin {
    /// The finding.
    pub origin: Origin,
    /// Correlation of the departures above the noise under the two wheels at the same
    /// sensors; `None` where either wheel leaves nothing above the noise (a tenth of it).
    pub correlation: Option<f64>,
    /// RMS departure under the leading and the trailing wheel (kN).
    pub rms_kn: [f64; 2],
    /// RMS of the record's noise in the departure (kN).
    pub noise_rms_kn: f64,
    /// Sample pairs compared.
    pub pairs: usize,
}

impl SurfaceOrigin {
    /// The finding in words.
    pub fn words(&self) -> String {
        let what = match self.origin {
            Origin::Rail => "the rail: the same departure under both wheels at the same place (rail roughness or a rail defect)".to_string(),
            Origin::BothWheels => "the wheels' treads: the departures under the two wheels differ (tread roughness travels with its wheel)".to_string(),
            Origin::Wheel(w) => format!("the {} wheel's tread: the departure is under that wheel only (roughness or out-of-roundness of that wheel)", w.name()),
            Origin::Noise => "nothing above the record's noise".to_string(),
        };
        format!(
            "{what}; correlation {} over {} pairs, rms {:.2} kN under the leading wheel, {:.2} kN under the trailing, noise {:.2} kN",
            self.correlation.map_or("none (one wheel leaves nothing above the noise)".to_string(), |c| format!("{c:.2}")),
            self.pairs, self.rms_kn[0], self.rms_kn[1], self.noise_rms_kn
        )
    }
}

/// The surface origin of the departure of measurement `m` (identified as `id`) from the good
/// wheel, or `None` when no sensor's window holds both wheels' passages and samples away
/// from both.
pub fn origin(
    identifier: &Identifier,
    m: &Measurement,
    id: &Identification,
) -> Result<Option<SurfaceOrigin>, crate::identify::IdentifyError> {
    let meta = identifier.bank().metadata();
    let cal = &meta.calibration;
    let speed = cal.run.speed_km_per_h / 3.6;
    let bay = cal.track.sleeper_spacing_m;
    let wheelbase_m = 2.0 * cal.vehicle.half_wheelbase_m;
    let series = identifier.series_as_recorded(m, id)?;
    let mut sums = Sums::default();
    for s in &series {
        let Some(axis) = meta.sensors.iter().position(|a| a.name == s.sensor) else {
            continue;
        };
        let a = &meta.sensors[axis];
        let g = identifier.flat_free(axis, Comparison::Samples);
        if g.len() != s.values_kn.len() {
            continue;
        }
        let r = filtered(&departure(&s.values_kn, g));
        // Where the leading wheel is, relative to the sensor, at sample k.
        let lead_from_sensor = |k: usize| {
            let t = (a.first_sample + k) as f64 / a.sample_rate_hz;
            cal.run.leading_wheel_start_m + speed * t - a.position_m
        };
        let shift = (wheelbase_m / speed * a.sample_rate_hz).round() as usize;
        for (k, &x) in r.iter().enumerate() {
            let d = lead_from_sensor(k);
            if d.abs().min((d - wheelbase_m).abs()) >= bay {
                sums.noise += x * x;
                sums.noise_n += 1;
            }
            if d.abs() <= 0.5 * bay {
                if let Some(&y) = r.get(k + shift) {
                    sums.lt += x * y;
                    sums.ll += x * x;
                    sums.tt += y * y;
                    sums.pairs += 1;
                }
            }
        }
    }
    Ok(sums.finding())
}

/// The sums over every sensor.
#[derive(Default)]
struct Sums {
    lt: f64,
    ll: f64,
    tt: f64,
    pairs: usize,
    noise: f64,
    noise_n: usize,
}

impl Sums {
    fn finding(&self) -> Option<SurfaceOrigin> {
        if self.pairs == 0 || self.noise_n == 0 {
            return None;
        }
        let n = self.pairs as f64;
        let noise_power = self.noise / self.noise_n as f64;
        let power = [self.ll / n, self.tt / n];
        // The noise is in both wheels' sums and not in their product: the correlation of what
        // is above it.
        let above = [
            (power[0] - noise_power).max(0.0),
            (power[1] - noise_power).max(0.0),
        ];
        // Undefined where either wheel leaves nothing above the noise (a tenth of it).
        let correlation = (above[0].min(above[1]) > 0.1 * noise_power)
            .then(|| (self.lt / n / (above[0] * above[1]).sqrt()).clamp(-1.0, 1.0));
        Some(SurfaceOrigin {
            origin: classify(correlation, power, noise_power),
            correlation,
            rms_kn: [power[0].sqrt(), power[1].sqrt()],
            noise_rms_kn: noise_power.sqrt(),
            pairs: self.pairs,
        })
    }
}

/// The finding from the correlation, the powers under the two wheels and the noise's power.
fn classify(correlation: Option<f64>, power: [f64; 2], noise_power: f64) -> Origin {
    if power[0].max(power[1]) <= NOISE_FACTOR * noise_power {
        return Origin::Noise;
    }
    if correlation.is_some_and(|c| c >= RAIL_CORRELATION) {
        return Origin::Rail;
    }
    let above = [
        (power[0] - noise_power).max(0.0),
        (power[1] - noise_power).max(0.0),
    ];
    if above[0] >= ONE_WHEEL_POWER_RATIO * above[1] {
        Origin::Wheel(WheelPosition::Leading)
    } else if above[1] >= ONE_WHEEL_POWER_RATIO * above[0] {
        Origin::Wheel(WheelPosition::Trailing)
    } else {
        Origin::BothWheels
    }
}

/// The departure as compared: the 5-sample binomial average (white noise to 27 % of its
/// power; a surface's departure, smooth at the sample rate, kept), then high-passed.
fn filtered(r: &[f64]) -> Vec<f64> {
    high_passed(&centred_average(r, &BINOMIAL5))
}

/// `y − a·g` with `a` the least-squares gain.
fn departure(y: &[f64], g: &[f32]) -> Vec<f64> {
    let (yg, gg) = y.iter().zip(g).fold((0.0, 0.0), |(yg, gg), (&y, &g)| {
        let g = f64::from(g);
        (yg + y * g, gg + g * g)
    });
    let a = if gg > 0.0 { yg / gg } else { 0.0 };
    y.iter()
        .zip(g)
        .map(|(&y, &g)| y - a * f64::from(g))
        .collect()
}

/// `r` less its centred moving average over [`SMOOTHING_SAMPLES`] (shortened at the ends).
fn high_passed(r: &[f64]) -> Vec<f64> {
    let h = SMOOTHING_SAMPLES / 2;
    let mut prefix = Vec::with_capacity(r.len() + 1);
    prefix.push(0.0);
    for &x in r {
        prefix.push(prefix.last().copied().unwrap_or(0.0) + x);
    }
    (0..r.len())
        .map(|k| {
            let (a, b) = (k.saturating_sub(h), (k + h + 1).min(r.len()));
            r[k] - (prefix[b] - prefix[a]) / (b - a) as f64
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_same_departure_under_both_wheels_is_the_rail_and_one_wheels_is_that_wheel() {
        assert_eq!(classify(Some(0.9), [4.0, 4.0], 0.1), Origin::Rail);
        assert_eq!(classify(Some(0.1), [4.0, 4.0], 0.1), Origin::BothWheels);
        assert_eq!(
            classify(None, [0.2, 4.0], 0.1),
            Origin::Wheel(WheelPosition::Trailing)
        );
        assert_eq!(classify(Some(0.9), [0.12, 0.1], 0.1), Origin::Noise);
    }

    #[test]
    fn the_high_pass_takes_a_constant_and_a_line_off_and_keeps_a_short_wave() {
        let h = SMOOTHING_SAMPLES / 2;
        let line: Vec<f64> = (0..200).map(|k| 3.0 + 0.01 * k as f64).collect();
        let hp = high_passed(&line);
        // Away from the ends the centred average of a line is the line itself.
        assert!(hp[h..200 - h].iter().all(|x| x.abs() < 1e-9));
        // A wave of 4 samples (shorter than the window) passes nearly whole.
        let wave: Vec<f64> = (0..200)
            .map(|k| (std::f64::consts::FRAC_PI_2 * k as f64).sin())
            .collect();
        let hp = high_passed(&wave);
        let kept: f64 = hp[h..200 - h].iter().map(|x| x * x).sum::<f64>()
            / wave[h..200 - h].iter().map(|x| x * x).sum::<f64>();
        assert!((kept - 1.0).abs() < 0.1, "kept {kept}");
    }
}
