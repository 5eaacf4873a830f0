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
use crate::model::calibration::IdentificationParams;

/// Per-point steps of every instance: at the EIP points, then at the envelope windows.
pub(in crate::identify) type Steps = (Vec<Vec<f32>>, Vec<Vec<f32>>);

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
pub(in crate::identify) fn static_load_kn(bank: &Bank) -> f64 {
    bank.metadata().calibration.vehicle.static_wheel_load_n() / 1e3
}

/// The discretisation share of a flat with peak wheel–rail force `peak_kn` on a wheel whose
/// static load is `load_kn`.
pub(in crate::identify) fn share(s: &IdentificationParams, load_kn: f64, peak_kn: f64) -> f32 {
    if peak_kn >= s.discretisation_dynamic_ratio * load_kn {
        s.discretisation_fraction as f32
    } else {
        0.0
    }
}
