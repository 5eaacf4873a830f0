//! The bank mesh's discretisation error as an uncertainty source (docs/identification.md,
//! "Discretisation error").
//!
//! Against the converged reference, the bank's mesh lands a flat that loses contact a fraction
//! of a sample early or late: the error at a sample follows the prediction's step between
//! adjacent samples there, not its departure from the good wheel. Each instance that lands
//! (its peak wheel–rail force at least `discretisation_dynamic_ratio` times the static wheel
//! load) may be off by `discretisation_fraction` of its own step at each comparison point
//! ([`crate::identify::domain::falsify::Discretisation`]): one more bounded source added to the interval.

use crate::bank::{Bank, Parameters};
use crate::identify::domain::falsify;
use crate::identify::input::measurement::MeasuredSeries;
use crate::identify::input::pip::Candidate;
use crate::identify::{Identifier, IdentifyError};
use crate::model::calibration::IdentificationParams;

/// Per-point steps of every instance: at the EIP points, then at the envelope windows.
pub(in crate::identify) type Steps = (Vec<Vec<f32>>, Vec<Vec<f32>>);

impl Identifier {
    /// The discretisation share of a flat whose wheel's peak wheel–rail force is `peak_kn`
    /// (a refinement's simulated flats; [`Identifier::discretisation`]).
    pub fn discretisation_share(&self, peak_kn: f64) -> f32 {
        share(&self.settings, static_load_kn(&self.bank), peak_kn)
    }

    /// Every instance's steps at the EIP points `order` (indices into the candidates `cands`,
    /// whose predictions are `predictions`) — from the samples either side, two more columns a
    /// point — and at the envelope windows (their `2·hw + 1` columns each, `env_columns`).
    #[allow(clippy::too_many_arguments)]
    pub(in crate::identify) fn allowance_steps(
        &self,
        used: &[(usize, usize)],
        series: &[MeasuredSeries],
        cands: &[Candidate],
        order: &[usize],
        predictions: &[&[f32]],
        env_columns: &[&[f32]],
        hw: usize,
    ) -> Result<Steps, IdentifyError> {
        let sides: Vec<usize> = order
            .iter()
            .flat_map(|&i| {
                let Candidate {
                    series: si,
                    sample: k,
                    ..
                } = cands[i];
                let (b, last) = (used[si].1, series[si].values_kn.len() - 1);
                [
                    self.bank.sample_index(b, k.saturating_sub(1)),
                    self.bank.sample_index(b, (k + 1).min(last)),
                ]
            })
            .collect();
        let side = self.bank.read_columns(&sides)?;
        let eip: Vec<Vec<f32>> = order
            .iter()
            .enumerate()
            .map(|(j, &i)| falsify::steps(&[&side[2 * j], predictions[i], &side[2 * j + 1]]))
            .collect();
        let env: Vec<Vec<f32>> = env_columns.chunks(2 * hw + 1).map(falsify::steps).collect();
        Ok((eip, env))
    }
}

/// [`Identifier::discretisation`]'s shares, one per instance (empty when none are allowed or
/// no instance lands).
pub(in crate::identify) fn shares(
    s: &IdentificationParams,
    params: &Parameters,
    bank: &Bank,
) -> Vec<f32> {
    if s.discretisation_fraction <= 0.0 {
        return Vec::new();
    }
    let load_kn = static_load_kn(bank);
    let shares: Vec<f32> = params
        .peak_contact_kn
        .iter()
        .map(|&peak| share(s, load_kn, peak))
        .collect();
    // A bank none of whose flats lands needs no allowance (nor its columns read).
    if shares.iter().all(|&x| x == 0.0) {
        return Vec::new();
    }
    shares
}

/// The static wheel load of the bank's vehicle (kN).
fn static_load_kn(bank: &Bank) -> f64 {
    bank.metadata().calibration.vehicle.static_wheel_load_n() / 1e3
}

/// The discretisation share of a flat with peak wheel–rail force `peak_kn` on a wheel whose
/// static load is `load_kn`.
fn share(s: &IdentificationParams, load_kn: f64, peak_kn: f64) -> f32 {
    if peak_kn >= s.discretisation_dynamic_ratio * load_kn {
        s.discretisation_fraction as f32
    } else {
        0.0
    }
}
