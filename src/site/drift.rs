//! A night's calibration against the bank's (docs/calibration.md, "Drift and the nightly
//! rebuild"): the fit starts from the bank's calibration, so every factor is 1, every gain 1
//! and every void its stated gap when nothing moved. A value has drifted when it moved by
//! more than its tolerance and its interval, widened by its own half-width either side (about
//! four standard errors), leaves the bank's value out: a 95 % interval alone leaves a true
//! value out one night in twenty per value, and a rebuild is not a coin toss.

use super::SiteCalibration;
use serde::{Deserialize, Serialize};

/// The least change that counts as drift: stiffness factors, sensor gains (relative), voids
/// (mm).
pub const TOLERANCE: [f64; 3] = [0.05, 0.01, 0.1];

/// One value that drifted.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Drifted {
    /// What.
    pub what: String,
    /// The bank's value.
    pub was: f64,
    /// Tonight's, with its interval.
    pub now: [f64; 3],
}

/// Every value of `c` that drifted from the calibration it started from (`start_gaps`: the
/// voids that calibration states, per candidate sleeper of `c.voids`).
pub fn drifted(c: &SiteCalibration, start_gaps: &[f64]) -> Vec<Drifted> {
    let mut out = Vec::new();
    let mut check = |what: String, was: f64, i: &super::Interval, tol: f64| {
        let half = 0.5 * (i.high - i.low);
        let wide = (i.low - half)..=(i.high + half);
        if i.pinned && !wide.contains(&was) && (i.value - was).abs() > tol {
            out.push(Drifted {
                what,
                was,
                now: [i.value, i.low, i.high],
            });
        }
    };
    check(
        "support stiffness factor".into(),
        1.0,
        &c.support_factor,
        TOLERANCE[0],
    );
    for g in &c.gains {
        check(
            format!("gain of {}", g.sensor),
            1.0,
            &g.factor,
            TOLERANCE[1],
        );
    }
    for (v, &was) in c.voids.iter().zip(start_gaps) {
        check(
            format!("void at sleeper {} (mm)", v.sleeper),
            was,
            &v.gap_mm,
            TOLERANCE[2],
        );
    }
    out
}
