//! The good-wheel side of identification: the detection step run before sizing
//! ([`crate::identify::detect`]) and its detection limit from the bank's departures table
//! (the answer of a pass in which no flat is detected is written by the answer stage).
//! `identify`, `watch` and `train` all come through here.

use crate::identify::detect::{self, Detection, DetectionLimit, WheelLimit};
use crate::identify::error::IdentifyError;
use crate::identify::identifier::Identifier;
use crate::identify::input::alignment::SpeedUse;
use crate::identify::input::compare::Comparison;
use crate::identify::input::measurement::MeasuredSeries;
use crate::identify::input::measurement::Measurement;
use crate::model::WheelPosition;

impl Identifier {
    /// The detection step over a pass's series on the bank's windows (`axes[i]` is series i's
    /// bank axis), the series as comparison `c` sees them: milliseconds, no bank column is
    /// read.
    pub(in crate::identify) fn detect(
        &self,
        axes: &[usize],
        series: &[MeasuredSeries],
        bounds: detect::TableBounds,
        c: Comparison,
        shape_kn: Option<&[Vec<f64>]>,
    ) -> Detection {
        let templates: Vec<&[f32]> = axes.iter().map(|&a| self.flat_free(a, c)).collect();
        // On a family over loads, each sample's bound holds what the prediction at the pass's
        // load may miss there between members (0 on a linear track).
        let mut extra: Vec<Vec<f64>> = match &self.load_shapes {
            Some(s) => axes
                .iter()
                .map(|&a| s.interpolation_error_kn(a).to_vec())
                .collect(),
            None => Vec::new(),
        };
        if let Some(shape) = shape_kn {
            for (e, x) in extra.iter_mut().zip(shape) {
                e.iter_mut().zip(x).for_each(|(e, x)| *e += x);
            }
        }
        let extra: Vec<&[f64]> = extra.iter().map(Vec::as_slice).collect();
        detect::detect_with(series, &templates, bounds, &extra)
    }

    /// How detection compares a pass: through the average, or sample by sample where the
    /// settings state round wheels on a smooth rail (as every pass was before roughness was
    /// allowed for).
    pub(in crate::identify) fn detection_comparison(&self) -> Comparison {
        if self.settings.round_wheels_stated() {
            Comparison::Samples
        } else {
            Comparison::Binomial5
        }
    }

    /// The detection limit of a pass through the bank axes `axes` judged with `bounds` (the
    /// table's and the pass's roughness; [`DetectionLimit`]), detection comparing through the
    /// average as it does.
    pub fn detection_limit(
        &self,
        axes: &[usize],
        bounds: &detect::TableBounds,
    ) -> Result<DetectionLimit, IdentifyError> {
        let d = self.departures(self.detection_comparison())?;
        let detected = detect::detected(&d, axes, bounds);
        let mut limit = detect::limit_of(&self.params.l0_mm, &detected, |_| true);
        let codes = &self.params.flat_wheel;
        if codes.iter().any(|&c| c != codes[0]) {
            limit.wheels = [WheelPosition::Leading, WheelPosition::Trailing]
                .into_iter()
                .map(|wheel| WheelLimit {
                    wheel,
                    l0_mm: detect::limit_of(&self.params.l0_mm, &detected, |i| {
                        codes[i] as usize == wheel.index()
                    })
                    .l0_mm,
                })
                .collect();
        }
        Ok(limit)
    }

    /// Sizing's departure rule ([`detect::falsified_by_departure`]) over the candidate model
    /// set `cms` of a pass whose detection is `detection` (series on the bank axes `axes`).
    /// Returns the survivors, and whether the pass is below the population: every instance of
    /// the bank predicts a larger departure than measured (only looked at when none survives).
    pub(in crate::identify) fn departure_rule(
        &self,
        cms: Vec<u32>,
        axes: &[usize],
        (detection, c): (&Detection, Comparison),
    ) -> Result<(Vec<u32>, bool), IdentifyError> {
        let s = &self.settings;
        if !s.falsify_at_departures {
            return Ok((cms, false));
        }
        let d = self.departures(c)?;
        let sensors: Vec<(usize, &detect::SensorTest)> =
            axes.iter().copied().zip(&detection.sensors).collect();
        let resolution = self.resolution();
        let ruled_out = |i: usize| {
            let cell = resolution.map_or(&[][..], |r| r.cells.neighbours(i));
            detect::falsified_by_departure(
                &d,
                i,
                cell,
                &sensors,
                &detection.bounds,
                s.departure_model_form_fraction,
            )
        };
        let kept: Vec<u32> = cms
            .into_iter()
            .filter(|&i| !ruled_out(i as usize))
            .collect();
        let below = kept.is_empty() && {
            use rayon::prelude::*;
            (0..self.bank.instances()).into_par_iter().all(ruled_out)
        };
        Ok((kept, below))
    }

    /// The pass's speed and the bank's it was compared with.
    pub(in crate::identify) fn speed_use(&self, m: &Measurement) -> SpeedUse {
        SpeedUse {
            pass_km_per_h: m.speed_km_per_h,
            bank_km_per_h: self.bank.metadata().calibration.run.speed_km_per_h,
        }
    }
}
