//! The harmonic of one wheel's radius that explains a pass detection flagged: what an answer
//! names when a wheel is out of round ([`crate::identify::detect::out_of_round`]).

use crate::model::WheelPosition;
use serde::{Deserialize, Serialize};

/// The harmonic that explains a pass.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OutOfRoundFit {
    /// The wheel.
    pub wheel: WheelPosition,
    /// The order (1: eccentric).
    pub order: u32,
    /// The amplitude of the radius' deviation (µm).
    pub amplitude_um: f64,
    /// The phase (rad) of `A·cos(n·θ + φ)`, `θ = 0` where the basis wheel's trace starts.
    pub phase_rad: f64,
    /// The largest departure from the round wheel's bounds before the fit (kN, positive).
    pub excess_before_kn: f64,
    /// The closest sample to the bounds with the harmonic (kN, negative: inside).
    pub excess_after_kn: f64,
    /// The share of the departure from the round wheel (sum of squares over every sample) the
    /// harmonic explains.
    pub explained_share: f64,
}

impl OutOfRoundFit {
    /// In words, for the answer.
    pub fn words(&self) -> String {
        format!(
            "out of round: the {} wheel, order {}, amplitude {:.0} µm (a harmonic of its radius; with it every sample lies within the good wheel's bounds, {:.2} kN inside at the closest, {:.2} kN outside without it)",
            self.wheel.name(),
            self.order,
            self.amplitude_um,
            -self.excess_after_kn,
            self.excess_before_kn
        )
    }
}
