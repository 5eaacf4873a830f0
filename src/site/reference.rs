//! Absolute sensor gains from passes of known load (docs/calibration.md, "Absolute gains").
//! Good wheels alone fix the sensors' gains relative to each other: a pass's load and its
//! sensors' common level are one unknown. A pass whose wheel load is known from elsewhere (its
//! `# reference_wheel_load_kn` line: a weighbridge, or the vehicle named in the consist)
//! separates them: its sensors' amplitudes over the good wheel simulated at that load, each
//! over its relative gain (which every good wheel measured), give the common level; over the
//! level the calibrated table gives on average, it turns the relative gains absolute — the
//! sensors' own gain and the model's force level at this site together, which is what the load
//! read from a record needs.

use super::fit::TrackFit;
use super::passes::SitePass;
use super::residual::amplitudes;
use super::SiteError;
use super::{table, Gain, Interval, GAIN_ALLOWANCE};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// The fewest passes of known load that give absolute gains.
pub const MIN_REFERENCE_PASSES: usize = 5;

/// The absolute gains read from the passes of known load.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Reference {
    /// Passes of known load used.
    pub passes: usize,
    /// The calibrated table's mean level factor `(1 − E_model)·(1 + γ)` the common level is
    /// divided by: the load read from a record divides by the same.
    pub table_level: f64,
    /// The sensors' common level over their relative gains at the known loads, over
    /// `table_level`, with its interval.
    pub common: Interval,
    /// Per sensor (the calibration's order), the absolute gain over the calibration's: the
    /// relative gain times `common`; the prior (not pinned) where the relative gain is not
    /// pinned either.
    pub gains: Vec<Interval>,
}

/// The absolute gains from `passes` (each with its known wheel load, kN) on the track fitted
/// as `params`, from the relative gains `relative`; `table_level`: the calibrated table's mean
/// level factor. The common level's interval: bootstrap over the passes (`draws`, seeded) plus
/// [`GAIN_ALLOWANCE`]; an absolute gain's: its relative interval times the common one.
pub(super) fn absolute_gains(
    track: &TrackFit,
    params: &[f64],
    passes: &[(&SitePass, f64)],
    relative: &[Gain],
    table_level: f64,
    (draws, seed): (usize, u64),
) -> Result<Reference, SiteError> {
    // Per pass, the mean over the pinned sensors of the log amplitude over the good wheel at
    // the pass's own load, less the log relative gain.
    let logs: Vec<f64> = passes
        .par_iter()
        .map(|(p, load_kn)| {
            let t = track.template(params, load_kn * 1e3 / track.wheel_load_n())?;
            let (sum, k) = amplitudes(&p.series_kn, &t)
                .iter()
                .zip(relative)
                .filter(|(_, g)| g.factor.pinned)
                .fold((0.0, 0usize), |(s, k), (a, g)| {
                    (s + (a.max(1e-9) / g.factor.value).ln(), k + 1)
                });
            Ok(sum / k.max(1) as f64)
        })
        .collect::<Result<_, SiteError>>()?;
    let n = logs.len();
    let level = |idx: &mut dyn Iterator<Item = usize>| -> f64 {
        let (sum, k) = idx.fold((0.0, 0usize), |(s, k), i| (s + logs[i], k + 1));
        (sum / k.max(1) as f64).exp() / table_level
    };
    let value = level(&mut (0..n));
    let mut state = seed ^ 0xAB5_01D;
    let mut boot: Vec<f64> = (0..draws)
        .map(|_| level(&mut (0..n).map(|_| crate::model::random::index(&mut state, n))))
        .collect();
    let [low, high] = table::quantiles(&mut boot);
    let common = Interval::pinned(
        value,
        low.min(value) - GAIN_ALLOWANCE,
        high.max(value) + GAIN_ALLOWANCE,
    );
    let gains = relative
        .iter()
        .map(|g| {
            let f = g.factor;
            if f.pinned {
                Interval::pinned(
                    f.value * common.value,
                    f.low * common.low,
                    f.high * common.high,
                )
            } else {
                Interval::prior(1.0, 0.0, f64::INFINITY)
            }
        })
        .collect();
    Ok(Reference {
        passes: n,
        table_level,
        common,
        gains,
    })
}
