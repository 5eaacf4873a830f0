//! The good-wheel side of identification: the detection step run before sizing
//! ([`super::detect`]), its detection limit from the bank's departures table, and the answer of
//! a pass in which no flat is detected. `identify`, `watch` and `train` all come through here.

use super::compare::Comparison;
use super::detect::{self, Detection, DetectionLimit, WheelLimit};
use super::ranges::population_ranges;
use super::result::{Alignment, MeasuredSeries, SpeedUse};
use super::{Identification, Identifier, IdentifyError, Measurement};
use crate::bank::departures::{self, Departures};
use crate::model::WheelPosition;
use std::sync::Arc;

impl Identifier {
    /// The detection step over a pass's series on the bank's windows (`axes[i]` is series i's
    /// bank axis), the series as comparison `c` sees them: milliseconds, no bank column is
    /// read.
    pub(super) fn detect(
        &self,
        axes: &[usize],
        series: &[MeasuredSeries],
        bounds: detect::TableBounds,
        c: Comparison,
    ) -> Detection {
        let templates: Vec<&[f32]> = axes.iter().map(|&a| self.flat_free(a, c)).collect();
        detect::detect(series, &templates, bounds)
    }

    /// How detection compares a pass: through the average, or sample by sample where the
    /// settings state round wheels on a smooth rail (as every pass was before roughness was
    /// allowed for).
    pub(super) fn detection_comparison(&self) -> Comparison {
        if self.settings.round_wheels_stated() {
            Comparison::Samples
        } else {
            Comparison::Binomial5
        }
    }

    /// The bank's departures table of comparison `c` (read from its file, or computed and
    /// stored on first use; kept for the next pass).
    pub fn departures(&self, c: Comparison) -> Result<Arc<Departures>, IdentifyError> {
        let slot = &self.departures[usize::from(c == Comparison::Binomial5)];
        let mut slot = slot.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(d) = slot.as_ref() {
            return Ok(Arc::clone(d));
        }
        let d = Arc::new(departures::load_or_compute(&self.bank, c.weights())?);
        *slot = Some(Arc::clone(&d));
        Ok(d)
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
    pub(super) fn departure_rule(
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
    pub(super) fn speed_use(&self, m: &Measurement) -> SpeedUse {
        SpeedUse {
            pass_km_per_h: m.speed_km_per_h,
            bank_km_per_h: self.bank.metadata().calibration.run.speed_km_per_h,
        }
    }

    /// The answer for a pass in which no flat is detected: no sizing, the detection limit
    /// instead of a size, severity none.
    pub(super) fn no_flat(
        &self,
        m: &Measurement,
        (alignment, series): (Alignment, Vec<MeasuredSeries>),
        (mut detection, roughness): (Detection, super::RoughnessUse),
        load: Option<super::load::LoadEstimate>,
        axes: &[usize],
        mut timings_ms: Vec<(String, f64)>,
    ) -> Result<Identification, IdentifyError> {
        let started = std::time::Instant::now();
        let limit = self.detection_limit(axes, &detection.bounds)?;
        let s = &self.settings;
        let meta = self.bank.metadata();
        let worst = detection.worst();
        let closest = worst.map_or(String::new(), |w| {
            format!(
                " (closest: {:.2} kN inside, {} at {:.4} s)",
                -w.excess_kn, w.sensor, w.at_time_s
            )
        });
        let limit_words = match (limit.l0_mm, limit.at_population_floor) {
            (Some(l0), true) => format!(
                "every flat of the bank's population (L0 from {l0:.0} mm) would have been detected at this speed and load; smaller ones may be too"
            ),
            (Some(l0), false) => format!(
                "flats with L0 of {l0:.0} mm and more would have been detected at this speed and load ({:.1} % of the bank's population); smaller ones may pass unseen",
                100.0 * limit.share_detected
            ),
            (None, _) => "no size of flat in the bank's population is surely detected by these sensors at this speed (its strikes fall where they cannot see them): this pass says nothing about a flat".into(),
        };
        // A wheel whose flats this pass does not see gets no verdict, whatever the other's.
        let unseen: Vec<&str> = limit
            .wheels
            .iter()
            .filter(|w| w.l0_mm.is_none())
            .map(|w| w.wheel.name())
            .collect();
        let unseen_words = match (limit.l0_mm, unseen.as_slice()) {
            (Some(_), [w]) => format!(
                " Flat not seen on the {w} wheel: no size of flat on it is surely detected by these sensors at this speed (its strikes can fall where they cannot see them); no verdict for that wheel."
            ),
            _ => String::new(),
        };
        let summary = match &detection.out_of_round {
            Some(fit) => format!(
                "No flat detected; {}. Detection limit: {limit_words}.{unseen_words}",
                fit.words()
            ),
            None => format!(
                "No flat detected: every one of the {} samples of {} sensor(s) lies within the good wheel's bounds{closest}. Detection limit: {limit_words}.{unseen_words}",
                detection.samples,
                detection.sensors.len(),
            ),
        };
        let hint = match (limit.l0_mm, unseen.as_slice()) {
            (Some(_), []) => match &detection.out_of_round {
                Some(f) => format!(
                    "No flat-spot action. The {} wheel is out of round (order {}, {:.0} µm): check it against the out-of-roundness limit for reprofiling.",
                    f.wheel.name(),
                    f.order,
                    f.amplitude_um
                ),
                None => "No action: no flat detected at this pass.".to_string(),
            },
            (Some(_), [w]) => format!(
                "No action on the other wheel; no verdict on the {w} wheel: these sensors cannot see its flats — do not count this pass as a good {w} wheel."
            ),
            _ => "No verdict: the sensors used cannot see this wheel's flats; do not count this pass as a good wheel.".to_string(),
        };
        // A good wheel is `none`; a pass that cannot see a wheel gives no class.
        let severity = (limit.l0_mm.is_some() && unseen.is_empty())
            .then_some(super::SeverityRange::single(super::Severity::None));
        detection.limit = Some(limit);
        timings_ms.push((
            "detection limit".into(),
            started.elapsed().as_secs_f64() * 1e3,
        ));
        Ok(Identification {
            measurement: m.path.display().to_string(),
            speed: self.speed_use(m),
            load,
            bank_id: meta.bank_id.clone(),
            bank_instances: self.bank.instances(),
            population: population_ranges(&meta.calibration),
            alignment,
            series,
            pip_distance: s.pip_distance,
            pips_per_series: s.pips_per_series,
            candidates: Vec::new(),
            eip: Vec::new(),
            eip_joint_entropy_bits: Vec::new(),
            envelope: Vec::new(),
            alpha_bits: 0.0,
            entropy_curves: Vec::new(),
            phi: s.phi,
            per_point_probability: 1.0,
            cms: Vec::new(),
            falsifications: Vec::new(),
            wheel_ranges: Vec::new(),
            residual_minimisation: None,
            random_subsets: None,
            model_class_refuted: false,
            below_population: false,
            detection: Some(detection),
            comparison: roughness.comparison(),
            roughness: Some(roughness),
            summary,
            maintenance_hint: hint,
            severity,
            timings_ms,
            refinement: None,
        })
    }
}
