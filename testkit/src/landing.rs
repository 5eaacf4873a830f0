//! Where a landing is judged: the samples of each sensor window near a flat's strikes, from 1 ms
//! before a strike to 5 ms after the flat has passed — the landing impact and its ringing. The
//! landing test (`tests/it/landing.rs`) and the landing study (`studies/src/bin/landing_study`)
//! measure a mesh's error there against the converged reference.

use wheelflat::bank::schema::sensor_axes;
use wheelflat::model::{CheckedCalibration, Flat, Response};

/// Before a strike (s).
pub const BEFORE_STRIKE_S: f64 = 1e-3;
/// After the flat has passed (s).
pub const AFTER_FLAT_S: f64 = 5e-3;

/// Per sensor window of `cal`, per sample: whether it lies near a strike of run `r` of `flat`.
pub fn near_strikes(cal: &CheckedCalibration, r: &Response, flat: &Flat) -> Vec<Vec<bool>> {
    let (rate, speed) = (cal.output.sample_rate_hz, cal.speed_m_per_s());
    let zones: Vec<(f64, f64)> = r
        .strike_times_s
        .iter()
        .map(|&t| {
            (
                t - BEFORE_STRIKE_S,
                t + flat.length_m() / speed + AFTER_FLAT_S,
            )
        })
        .collect();
    sensor_axes(cal)
        .iter()
        .map(|a| {
            (0..a.samples)
                .map(|j| {
                    let t = (a.first_sample + j) as f64 / rate;
                    zones.iter().any(|&(lo, hi)| lo <= t && t <= hi)
                })
                .collect()
        })
        .collect()
}
