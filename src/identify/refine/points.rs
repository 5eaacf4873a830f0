//! The comparison points a refinement judges flats at, and the simulation that gives every
//! flat's values there.

use crate::bank::schema::SensorAxis;
use crate::identify::answer::identification::Identification;
use crate::identify::answer::sizing::Sizing;
use crate::identify::domain::falsify::{largest_step, Discretisation, Point};
use crate::identify::domain::uncertainty::ThresholdCurve;
use crate::identify::error::IdentifyError;
use crate::identify::identifier::Identifier;
use crate::model::{batch_key, Flat, Record, Simulator, WheelPosition, LANES};
use rayon::prelude::*;

/// How a comparison point reads a series over its samples `a..=b`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Read {
    /// The sample (`a == b`).
    Sample,
    /// The window's maximum.
    Max,
    /// The window's minimum.
    Min,
}

/// A comparison point: (bank axis, first sample, last sample, how it reads them).
pub(super) type At = (usize, usize, usize, Read);

/// The comparison points of an identification: each is a sample (EIP) or a window's extreme
/// (envelope point) of one bank axis, with its measurement, thresholds and threshold curve.
pub(super) struct Comparison {
    /// The bank's sensor axes.
    pub(super) axes: Vec<SensorAxis>,
    pub(super) at: Vec<At>,
    pub(super) measured: Vec<f64>,
    pub(super) thresholds: Vec<(f64, f64)>,
    pub(super) curves: Vec<ThresholdCurve>,
    /// The average the identification compared through (`[1.0]`: the samples), which the new
    /// flats' series go through too.
    pub(super) average: &'static [f64],
    /// The points falsification judges (`at[..method]`: EIP, then envelope points); after
    /// them every PIP candidate, which the shared-gain stage reads too (none without it).
    pub(super) method: usize,
    /// Where the envelope points start.
    pub(super) envelope_from: usize,
    /// Each point's flat-free prediction (kN): the sample's, a window's peak.
    pub(super) flat_free: Vec<f64>,
}

impl Comparison {
    /// The comparison points of identification `id`, sized as `sizing`.
    pub(super) fn of(identifier: &Identifier, id: &Identification, sizing: &Sizing) -> Comparison {
        let axes = &identifier.bank().metadata().sensors;
        let axis_of = |series: usize| {
            axes.iter()
                .position(|a| a.name == id.series[series].sensor)
                .expect("identified sensors are the bank's")
        };
        let p = sizing.per_point_probability;
        let rough = id
            .roughness
            .clone()
            .unwrap_or_else(|| crate::identify::detect::roughness::RoughnessUse::none(0.0, 0.0));
        let mut c = Comparison {
            axes: axes.clone(),
            at: Vec::new(),
            measured: Vec::new(),
            thresholds: Vec::new(),
            curves: Vec::new(),
            average: id.comparison.weights(),
            method: 0,
            envelope_from: sizing.eip.len(),
            flat_free: Vec::new(),
        };
        let signed =
            |axis: usize, k: usize| f64::from(identifier.flat_free(axis, id.comparison)[k]);
        for &e in &sizing.eip {
            let cand = &sizing.candidates[e];
            c.at.push((axis_of(cand.series), cand.sample, cand.sample, Read::Sample));
            c.measured.push(cand.measured_kn);
            c.thresholds
                .push((cand.threshold_low_kn, cand.threshold_high_kn));
            let ff = identifier.flat_free_peak_kn(
                axis_of(cand.series),
                cand.sample,
                cand.sample,
                id.comparison,
            );
            c.curves
                .push(identifier.point_curve(&rough, cand.measured_kn, ff, p));
            c.flat_free.push(signed(axis_of(cand.series), cand.sample));
        }
        for x in &sizing.envelope {
            c.at.push((
                axis_of(x.series),
                x.sample - x.half_width,
                x.sample + x.half_width,
                if x.kind == crate::identify::select::envelope::Extreme::Max {
                    Read::Max
                } else {
                    Read::Min
                },
            ));
            c.measured.push(x.measured_kn);
            c.thresholds.push((x.threshold_low_kn, x.threshold_high_kn));
            let ff = identifier.flat_free_peak_kn(
                axis_of(x.series),
                x.sample - x.half_width,
                x.sample + x.half_width,
                id.comparison,
            );
            c.curves
                .push(identifier.point_curve(&rough, x.measured_kn, ff, p));
            c.flat_free.push(ff);
        }
        c.method = c.at.len();
        if identifier.settings().shared_gains {
            for cand in &sizing.candidates {
                let axis = axis_of(cand.series);
                c.at.push((axis, cand.sample, cand.sample, Read::Sample));
                c.measured.push(cand.measured_kn);
                c.flat_free.push(signed(axis, cand.sample));
            }
        }
        c
    }

    /// The points the shared-gain stage judges (every point but the EIP, which are among the
    /// candidates) over `columns` (one per point), with the members' allowances.
    pub(super) fn shared_points<'a>(
        &'a self,
        columns: &'a [Vec<f32>],
        steps: &'a [Vec<f32>],
        shares: Option<&'a [f32]>,
        bounds: &crate::identify::domain::table_bounds::TableBounds,
    ) -> Vec<crate::identify::domain::shared_gain::SharedPoint<'a>> {
        (self.envelope_from..self.at.len())
            .map(|p| {
                let ff = self.flat_free[p];
                crate::identify::domain::shared_gain::SharedPoint {
                    sensor: self.at[p].0,
                    predictions: &columns[p],
                    measured_kn: self.measured[p],
                    flat_free_kn: ff,
                    bound_kn: crate::identify::domain::shared_gain::measurement_bound_kn(
                        bounds, ff,
                    ),
                    allowance: shares.map(|sh| (sh, steps[p].as_slice())),
                }
            })
            .collect()
    }

    /// The falsification points `range` of the comparison over `columns` (one per point).
    /// `steps` and `shares` give each member's discretisation allowance at each point
    /// ([`Discretisation`]; `shares` None: none).
    pub(super) fn points<'a>(
        &'a self,
        columns: &'a [Vec<f32>],
        range: std::ops::Range<usize>,
        steps: &'a [Vec<f32>],
        shares: Option<&'a [f32]>,
    ) -> Vec<Point<'a>> {
        range
            .map(|p| Point {
                predictions: &columns[p],
                measured_kn: self.measured[p],
                low_kn: self.thresholds[p].0,
                high_kn: self.thresholds[p].1,
                curve: Some(&self.curves[p]),
                discretisation: Discretisation::of(shares, steps, p),
            })
            .collect()
    }

    /// The samples `(first, last)` a point's discretisation step spans on a series whose last
    /// sample is `last`: a sample point's reaches one sample either side, a window's stays
    /// inside it (as identification reads the bank, [`crate::identify::domain::falsify::steps`]).
    pub(super) fn step_span(at: At, last: usize) -> (usize, usize) {
        match at.3 {
            Read::Sample => (at.1.saturating_sub(1), (at.2 + 1).min(last)),
            _ => (at.1, at.2),
        }
    }

    /// A window's value: the sample, the extreme over the window, or the smoothed sample.
    pub(super) fn value(at: At, series: impl Fn(usize) -> f32) -> f32 {
        let (_, a, b, kind) = at;
        match kind {
            Read::Sample => series(a),
            Read::Max => (a..=b).map(series).fold(f32::MIN, f32::max),
            Read::Min => (a..=b).map(series).fold(f32::MAX, f32::min),
        }
    }
}

/// One simulated flat at the comparison points: values, steps ([`Comparison::step_span`]) and the
/// peak wheel–rail force of its wheel (kN).
pub(super) type AtPoints = (Vec<f32>, Vec<f32>, f64);

/// Simulates `flats` (in lockstep batches sorted by their first strike, on the rayon pool)
/// and returns each one's values at the comparison points, in the order given.
pub(super) fn simulate_at(
    sim: &Simulator,
    cmp: &Comparison,
    flats: &[(Flat, [f64; 4], WheelPosition)],
) -> Result<Vec<AtPoints>, IdentifyError> {
    let mut order: Vec<usize> = (0..flats.len()).collect();
    let keys: Vec<f64> = flats.iter().map(|f| batch_key(sim, Some(&f.0))).collect();
    order.sort_by(|&a, &b| keys[a].total_cmp(&keys[b]).then(a.cmp(&b)));
    let done: Vec<Vec<(usize, AtPoints)>> = order
        .par_chunks(LANES)
        .map_init(
            || sim.lane_workspace::<LANES>(),
            |ws, batch| {
                let members: Vec<Option<&Flat>> =
                    batch.iter().map(|&k| Some(&flats[k].0)).collect();
                let (results, _) = sim.run_batch(&members, Record::default(), ws);
                batch
                    .iter()
                    .zip(results)
                    .map(|(&k, r)| {
                        let resp = r.map_err(IdentifyError::Simulation)?;
                        let mut g = Vec::with_capacity(cmp.at.len());
                        let mut steps = Vec::with_capacity(cmp.at.len());
                        // Each axis' window as the identification compared it.
                        let windows: Vec<Vec<f64>> = cmp
                            .axes
                            .iter()
                            .enumerate()
                            .map(|(i, a)| {
                                let w = resp.window(i, a.first_sample, a.samples);
                                crate::model::average::centred_average(w, cmp.average)
                            })
                            .collect();
                        for &at in &cmp.at {
                            let a = &cmp.axes[at.0];
                            let w = &windows[at.0];
                            let read = |j: usize| (w[j] / 1e3) as f32;
                            g.push(Comparison::value(at, read));
                            let (lo, hi) = Comparison::step_span(at, a.samples - 1);
                            steps.push(largest_step((lo..=hi).map(read)));
                        }
                        let peak_kn = resp.peak_contact_force_n[flats[k].2.index()] / 1e3;
                        Ok((k, (g, steps, peak_kn)))
                    })
                    .collect::<Result<Vec<_>, IdentifyError>>()
            },
        )
        .collect::<Result<_, _>>()?;
    let mut out = vec![(Vec::new(), Vec::new(), 0.0); flats.len()];
    for (k, g) in done.into_iter().flatten() {
        out[k] = g;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_window_value_is_the_sample_or_the_window_extreme() {
        let series = [1.0f32, 4.0, -2.0, 3.0];
        let at = |kind| (0, 0, 3, kind);
        let v = |at| Comparison::value(at, |j| series[j]).to_bits();
        assert_eq!(v((0, 2, 2, Read::Sample)), (-2.0f32).to_bits());
        assert_eq!(v(at(Read::Max)), 4.0f32.to_bits());
        assert_eq!(v(at(Read::Min)), (-2.0f32).to_bits());
    }
}
