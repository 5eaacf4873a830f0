//! The answer of a pass in which no flat is detected: no sizing, the pass's detection limit
//! instead of a size, severity none.

use crate::identify::answer::identification::Identification;
use crate::identify::answer::ranges::population_ranges;
use crate::identify::answer::result::{Alignment, MeasuredSeries};
use crate::identify::detect::Detection;
use crate::identify::error::IdentifyError;
use crate::identify::identifier::Identifier;
use crate::identify::input::measurement::Measurement;

impl Identifier {
    /// The answer for a pass in which no flat is detected: no sizing, the detection limit
    /// instead of a size, severity none.
    pub(in crate::identify) fn no_flat(
        &self,
        m: &Measurement,
        (alignment, series): (Alignment, Vec<MeasuredSeries>),
        (mut detection, roughness): (Detection, crate::identify::detect::roughness::RoughnessUse),
        load: Option<crate::identify::detect::load::LoadEstimate>,
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
        let severity = (limit.l0_mm.is_some() && unseen.is_empty()).then_some(
            crate::identify::answer::severity::SeverityRange::single(
                crate::identify::answer::severity::Severity::None,
            ),
        );
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
            phi: s.phi,
            sizing: None,
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
