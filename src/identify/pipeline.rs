//! One pass through identification ([`Identifier::identify`]): the measurement prepared, its
//! load read, detection; for a pass with a flat detected, the sizing stages
//! ([`super::stages`]); else the answer without sizing ([`super::answer::no_flat`]).

use crate::identify::answer::identification::Identification;
use crate::identify::detect::spike::SpikeTest;
use crate::identify::error::IdentifyError;
use crate::identify::extras::Extras;
use crate::identify::identifier::Identifier;
use crate::identify::input::compare::Comparison;
use crate::identify::input::measurement::Measurement;
use crate::identify::prepare::Prepared;
use crate::identify::stages;
use crate::stopwatch::Stopwatch;

impl Identifier {
    /// Identifies the flat behind one measurement, stage by stage ([`stages`]): the
    /// measurement prepared (sensors, alignment, series on the bank's windows, PIPs); its load
    /// read and the record put on the bank's load; detection ([`crate::identify::detect`]) — when no flat is
    /// detected, that answer with the pass's detection limit and no sizing; else the bank's
    /// predictions read, the comparison points selected by joint entropy, the envelope points,
    /// falsification and the departure rule, and the result assembled. `sensors` restricts
    /// the sensors used.
    pub fn identify(
        &self,
        m: &Measurement,
        sensors: Option<&[String]>,
        extras: Extras,
    ) -> Result<Identification, IdentifyError> {
        let mut laps = Stopwatch::start_ms();
        let Prepared {
            used,
            alignment,
            mut series,
            cands,
            hf_kn,
            hf_peaks,
        } = self.prepare(m, sensors)?;
        let axes: Vec<usize> = used.iter().map(|&(_, bi)| bi).collect();
        // The roughness the pass is judged with, the bounds it gives, and how it is compared.
        let roughness = self.roughness_use(hf_kn)?;
        let bounds = roughness.bounds(self.bounds);
        let comparison = roughness.comparison();
        // The load the record shows, and the record put on the bank's load (input::load::at_bank_load).
        let recorded = self.detect(&axes, &series, self.bounds, Comparison::Samples, None);
        let load = self.load_of(&axes, &series, &recorded);
        if let Some(l) = load.as_ref().filter(|_| !extras.as_recorded) {
            self.at_bank_load(&axes, &mut series, l);
        }
        let shape = load.as_ref().and_then(|l| self.shape_change(&axes, l));
        let shape = shape.as_deref();
        // Detection compares through the average, with the strike test on the record as taken;
        // wheels stated round, sample by sample as every pass did before roughness was
        // allowed for.
        let averaged = Comparison::Binomial5.series(&series);
        let detected_by = self.detection_comparison();
        let stated_round = detected_by == Comparison::Samples;
        let detection = if stated_round {
            self.detect(&axes, &series, bounds, Comparison::Samples, shape)
        } else {
            let mut d = self.detect(&axes, &averaged, bounds, Comparison::Binomial5, shape);
            let names: Vec<String> = series.iter().map(|s| s.sensor.clone()).collect();
            let level = hf_kn.max(roughness.noise_hf_kn);
            let spike = SpikeTest::of(&names, &hf_peaks, level);
            d.flat_detected |= spike.flat_detected;
            d.spike = Some(spike);
            d
        };
        laps.lap("detection");
        // A departure with no sharp strike may be an out-of-round wheel: named, not sized.
        let mut detection = detection;
        let strike = detection.spike.as_ref().is_some_and(|t| t.flat_detected);
        if detection.flat_detected && !strike {
            let compared = if stated_round { &series } else { &averaged };
            if let Some((fit, mut d)) =
                self.explain_out_of_round(&axes, compared, &detection, bounds, detected_by)?
            {
                d.spike = detection.spike.take();
                d.out_of_round = Some(fit);
                detection = d;
            }
            laps.lap("out of round");
        }
        if !detection.flat_detected {
            return self.no_flat(
                m,
                (alignment, series),
                (detection, roughness),
                load,
                &axes,
                laps.laps,
            );
        }
        // Sizing compares as the roughness says: the departure rule with that comparison's test.
        let (series, cands, rule) = match comparison {
            Comparison::Binomial5 => {
                let cands = self.candidates(&averaged);
                (averaged, cands, detection.clone())
            }
            Comparison::Samples if stated_round => {
                let rule = detection.clone();
                (series, cands, rule)
            }
            Comparison::Samples => {
                let rule = self.detect(&axes, &series, bounds, Comparison::Samples, shape);
                (series, cands, rule)
            }
        };
        let parts = stages::Prepared {
            alignment,
            series,
            load,
            detection,
            rule,
        };
        let z = stages::SizingInput {
            m,
            extras,
            used: &used,
            cands: &cands,
            roughness: &roughness,
            comparison,
        };
        let mut buffer = self.buffers.lock().unwrap_or_else(|e| e.into_inner());
        let read = self.read_predictions(&z, &parts.series, &mut buffer, &mut laps)?;
        let mut bin_buffer = self.bin_buffers.lock().unwrap_or_else(|e| e.into_inner());
        let selected = self.select_points(&z, &read, &mut bin_buffer, &mut laps)?;
        let judged = self.judge(
            &z,
            &parts.series,
            &read,
            &selected,
            &axes,
            &parts.rule,
            &mut laps,
        )?;
        self.assemble(&z, &read, selected, judged, parts, laps)
    }
}
