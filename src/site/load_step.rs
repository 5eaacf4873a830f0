//! The load step a site's family needs (docs/calibration.md "The family's load step"): how
//! far the good wheel at the fitted track departs from linear in load between a family's
//! members, measured by simulation over the band a family covers, and the coarsest step
//! whose interpolation stays within [`TOLERANCE_KN`].
//!
//! Identification reads a pass between two members with their own shapes, interpolated
//! linearly in load, and allows each sensor what that interpolation may miss
//! ([`crate::identify::detect`]); a coarser family is cheaper to build but that allowance,
//! and so the detection limit, grows with the step where a sleeper hangs.

use super::fit::TrackFit;
use super::SiteError;
use crate::model::calibration::VehicleParams;
use serde::{Deserialize, Serialize};

/// The band of car-body factors a site's family covers (`bank generate --loads auto`).
pub const BAND: [f64; 2] = [0.6, 1.4];

/// The steps tried, coarsest first (each divides the band).
pub const STEPS: [f64; 4] = [0.4, 0.2, 0.1, 0.05];

/// The response is simulated every half of the finest step, so that every step has loads off
/// its grid to be measured at.
const REFERENCE_STEP: f64 = 0.025;

/// What `calibrate` measured of the site's response in load.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LoadStep {
    /// The step written (`population.family_load_step`): the coarsest of [`STEPS`] within
    /// the tolerance, the finest when none is.
    pub step: f64,
    /// Per step tried: `[step, largest interpolation error over the sensors and loads (kN)]`.
    pub errors_kn: Vec<[f64; 2]>,
    /// The tolerance the step was chosen by (kN): the table's absolute bound (noise and
    /// resolution), so that what identification allows each sensor for the interpolation at
    /// most doubles that part of its detection bound.
    pub tolerance_kn: f64,
}

impl LoadStep {
    /// One line for `calibrate`'s report.
    pub fn words(&self) -> String {
        let tried: Vec<String> = self
            .errors_kn
            .iter()
            .map(|[s, e]| format!("{s:.2}: {e:.2} kN"))
            .collect();
        format!(
            "the family's load step: {:.2} × the car body (`bank generate --loads auto` builds {:.1}–{:.1} at it); linear interpolation between members misses the good wheel by at most {} (tolerance {:.2} kN)",
            self.step,
            BAND[0],
            BAND[1],
            tried.join(", "),
            self.tolerance_kn
        )
    }
}

/// Measures the step on `track` at parameters `p` (`vehicle`: the calibration's) against
/// `tolerance_kn`: the good wheel simulated every [`REFERENCE_STEP`] over [`BAND`] (33
/// simulations, in parallel), then for each step of [`STEPS`] the largest difference between
/// the response at the loads off its grid and the linear interpolation (in wheel load)
/// between the grid's neighbours.
pub fn measure(
    track: &TrackFit,
    p: &[f64],
    vehicle: &VehicleParams,
    tolerance_kn: f64,
) -> Result<LoadStep, SiteError> {
    use rayon::prelude::*;
    let finest = STEPS[STEPS.len() - 1];
    let n = ((BAND[1] - BAND[0]) / REFERENCE_STEP).round() as usize;
    let factors: Vec<f64> = (0..=n)
        .map(|k| BAND[0] + REFERENCE_STEP * k as f64)
        .collect();
    // The relative wheel load of a car-body factor, over the base's.
    let relative = |f: f64| {
        let mut v = vehicle.clone();
        v.car_body_mass_kg *= f;
        v.static_wheel_load_n() / track.wheel_load_n()
    };
    let loads: Vec<f64> = factors.iter().map(|&f| relative(f)).collect();
    let responses = loads
        .par_iter()
        .map(|&l| track.template(p, l))
        .collect::<Result<Vec<_>, _>>()?;
    let errors_kn: Vec<[f64; 2]> = STEPS
        .iter()
        .map(|&step| {
            let every = (step / REFERENCE_STEP).round() as usize;
            [step, interpolation_error(&loads, &responses, every)]
        })
        .collect();
    let step = errors_kn
        .iter()
        .find(|e| e[1] <= tolerance_kn)
        .map_or(finest, |e| e[0]);
    Ok(LoadStep {
        step,
        errors_kn,
        tolerance_kn,
    })
}

/// The largest difference between `responses[k]` (per axis, per sample) and the linear
/// interpolation in `loads` between the grid points every `every` around it, over the
/// loads off the grid.
fn interpolation_error(loads: &[f64], responses: &[Vec<Vec<f64>>], every: usize) -> f64 {
    let mut worst = 0.0f64;
    for k in 0..loads.len() {
        if k % every == 0 {
            continue;
        }
        let (a, b) = (k - k % every, (k - k % every + every).min(loads.len() - 1));
        let w = (loads[k] - loads[a]) / (loads[b] - loads[a]);
        for (axis, g) in responses[k].iter().enumerate() {
            let (ga, gb) = (&responses[a][axis], &responses[b][axis]);
            for (i, &x) in g.iter().enumerate() {
                worst = worst.max((x - (ga[i] + w * (gb[i] - ga[i]))).abs());
            }
        }
    }
    worst
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_interpolation_error_is_zero_for_a_linear_response_and_grows_with_the_step_on_a_kink() {
        let loads: Vec<f64> = (0..=16).map(|k| 0.6 + 0.05 * k as f64).collect();
        let linear: Vec<Vec<Vec<f64>>> = loads.iter().map(|&l| vec![vec![10.0 * l]]).collect();
        for every in [1, 2, 4, 8] {
            assert!(interpolation_error(&loads, &linear, every) < 1e-12);
        }
        // A gap closing at 0.925: 20 kN per unit of load above it.
        let kink: Vec<Vec<Vec<f64>>> = loads
            .iter()
            .map(|&l| vec![vec![20.0 * (l - 0.925f64).max(0.0)]])
            .collect();
        let e: Vec<f64> = [8, 4, 2, 1]
            .iter()
            .map(|&every| interpolation_error(&loads, &kink, every))
            .collect();
        assert!(e[3] < 1e-12, "{e:?}");
        assert!(e[0] > e[1] && e[1] > e[2] && e[2] > 0.0, "{e:?}");
        // Step 0.1 (every 2): the kink at 0.925 between 0.9 and 1.0; the point 0.95 is 0.5 kN
        // above 0 and the chord gives 0.75 kN there: 0.25 kN.
        assert!((e[2] - 0.25).abs() < 1e-9, "{e:?}");
    }
}
