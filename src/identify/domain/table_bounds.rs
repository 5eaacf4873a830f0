//! The hard bounds the uncertainty table (and a pass's roughness) put on a good wheel's record:
//! what detection tests every sample against (docs/detection.md, "The test").

use crate::model::calibration::{IdentificationParams, UncertaintyGroup, UncertaintyKind};
use serde::{Deserialize, Serialize};

/// The hard bounds the uncertainty table puts on a good wheel's record.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TableBounds {
    /// Smallest and largest ratio `measured / predicted` the relative sources allow,
    /// `1/(1+S_max)` and `1/(1+S_min)`.
    pub gain: [f64; 2],
    /// The absolute sources' bound `T_max` (kN).
    pub absolute_kn: f64,
    /// The flat-free model's form allowance: absolute part (kN).
    pub allowance_kn: f64,
    /// ... and relative part (fraction of the flat-free force).
    pub allowance_fraction: f64,
    /// The good-wheel-relative sources' bound (a rough tread or rail): a fraction of the
    /// flat-free force, the larger of their summed `|min|`, `|max|`.
    #[serde(default)]
    pub good_wheel_fraction: f64,
    /// The bounded sources in kN (a rough tread's or rail's departure where no wheel is near).
    #[serde(default)]
    pub bound_kn: f64,
}

impl TableBounds {
    /// The bounds of the settings' table. `S` combines the sources as the thresholds do
    /// (model sources minus measurement sources).
    pub fn of(s: &IdentificationParams) -> TableBounds {
        let (mut s_min, mut s_max, mut t_max) = (0.0, 0.0, 0.0);
        let (mut w_min, mut w_max) = (0.0f64, 0.0f64);
        let mut bound_kn = 0.0;
        for src in &s.uncertainty {
            match (src.kind, src.group) {
                (UncertaintyKind::GoodWheelRelative, UncertaintyGroup::Model) => {
                    w_min += src.min;
                    w_max += src.max;
                }
                (UncertaintyKind::GoodWheelRelative, UncertaintyGroup::Measurement) => {
                    w_min -= src.max;
                    w_max -= src.min;
                }
                (UncertaintyKind::BoundKn, _) => bound_kn += src.min.abs().max(src.max.abs()),
                (UncertaintyKind::Relative, UncertaintyGroup::Model) => {
                    s_min += src.min;
                    s_max += src.max;
                }
                (UncertaintyKind::Relative, UncertaintyGroup::Measurement) => {
                    s_min -= src.max;
                    s_max -= src.min;
                }
                (UncertaintyKind::AbsoluteKn, _) => t_max += src.min.abs().max(src.max.abs()),
            }
        }
        // A table whose relative sources reach −100 % allows any gain up from 1/(1+S_max).
        let high = if 1.0 + s_min > 1e-6 {
            1.0 / (1.0 + s_min)
        } else {
            f64::INFINITY
        };
        TableBounds {
            gain: [1.0 / (1.0 + s_max).max(1e-6), high],
            absolute_kn: t_max,
            allowance_kn: s.detection_allowance_kn,
            allowance_fraction: s.detection_allowance_fraction,
            good_wheel_fraction: w_min.abs().max(w_max.abs()),
            bound_kn,
        }
    }

    /// The relative part of the bound: the form allowance and the good-wheel-relative sources.
    pub fn fraction(&self) -> f64 {
        self.allowance_fraction + self.good_wheel_fraction
    }

    /// The bound on `|y − a·g|` at a sample whose flat-free force is `g_kn`, for gain `a`.
    pub fn bound_kn(&self, gain: f64, g_kn: f64) -> f64 {
        self.absolute_kn + self.bound_kn + self.allowance_kn + self.fraction() * gain * g_kn.abs()
    }
}
