//! How a pass is compared with the bank: sample by sample, or — for a pass judged as rough —
//! through the 5-sample binomial average `B₅` ([`crate::model::average`]), the measurement and
//! every prediction alike (docs/detection.md, "Rough wheels").
//!
//! A rough tread or rail moves the pad forces most at high frequency, where the average takes
//! it out; it costs the sharpest part of an impact, so a pass with round wheels on a smooth
//! rail keeps the samples as they are (and the discretisation allowance those need). The
//! bank stores the samples; an averaged prediction at sample `k` of a window is the weighted
//! sum of the stored columns `k − 2 … k + 2` of that window (renormalised at its ends, as the
//! measurement's), read in blocks. Detection always compares through the average: the
//! classes a record cannot tell apart from round wheels (disc and composite treads, whose
//! high-frequency level lies within the table's noise) leave the good wheel's bounds sample by
//! sample, not through the average (measured, docs/detection.md).

use crate::identify::input::measurement::MeasuredSeries;
use crate::model::average::{centred_average, BINOMIAL5};
use serde::{Deserialize, Serialize};

/// How a pass's series meet the bank's predictions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Comparison {
    /// Sample by sample (round wheels on a smooth rail).
    #[default]
    Samples,
    /// Through the 5-sample binomial average (a pass judged as rough).
    Binomial5,
}

impl Comparison {
    /// The average's weights (`[1.0]`: samples as they are).
    pub fn weights(self) -> &'static [f64] {
        match self {
            Comparison::Samples => &[1.0],
            Comparison::Binomial5 => &BINOMIAL5,
        }
    }

    /// `series` as this comparison sees them.
    pub fn series(self, series: &[MeasuredSeries]) -> Vec<MeasuredSeries> {
        series
            .iter()
            .map(|s| MeasuredSeries {
                values_kn: centred_average(&s.values_kn, self.weights()),
                ..s.clone()
            })
            .collect()
    }
}

/// The bank's flat-free predictions through the average, one per axis (kN).
pub(crate) fn averaged_templates(templates: &[Vec<f32>]) -> Vec<Vec<f32>> {
    templates
        .iter()
        .map(|t| {
            let x: Vec<f64> = t.iter().map(|&g| f64::from(g)).collect();
            centred_average(&x, &BINOMIAL5)
                .into_iter()
                .map(|g| g as f32)
                .collect()
        })
        .collect()
}
