//! The comparison points a refinement judges flats at, and the simulation that gives every
//! flat's values there.

use super::{Member, WholeRecord};
use crate::bank::schema::SensorAxis;
use crate::identify::falsify::{largest_step, Discretisation, Point};
use crate::identify::result::Identification;
use crate::identify::{Identifier, IdentifyError, ThresholdCurve};
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
    /// The three samples `a, a+1, a+2` weighted ¼, ½, ¼ (a filter that removes the
    /// Nyquist frequency and quarters the rail's ringing near 800 Hz).
    Smoothed,
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
}

impl Comparison {
    pub(super) fn of(identifier: &Identifier, id: &Identification) -> Comparison {
        let axes = &identifier.bank().metadata().sensors;
        let axis_of = |series: usize| {
            axes.iter()
                .position(|a| a.name == id.series[series].sensor)
                .expect("identified sensors are the bank's")
        };
        let p = id.per_point_probability;
        let mut c = Comparison {
            axes: axes.clone(),
            at: Vec::new(),
            measured: Vec::new(),
            thresholds: Vec::new(),
            curves: Vec::new(),
        };
        for &e in &id.eip {
            let cand = &id.candidates[e];
            c.at.push((axis_of(cand.series), cand.sample, cand.sample, Read::Sample));
            c.measured.push(cand.measured_kn);
            c.thresholds
                .push((cand.threshold_low_kn, cand.threshold_high_kn));
            c.curves
                .push(identifier.threshold_curve(cand.measured_kn, p));
        }
        for x in &id.envelope {
            c.at.push((
                axis_of(x.series),
                x.sample - x.half_width,
                x.sample + x.half_width,
                if x.kind == "max" {
                    Read::Max
                } else {
                    Read::Min
                },
            ));
            c.measured.push(x.measured_kn);
            c.thresholds.push((x.threshold_low_kn, x.threshold_high_kn));
            c.curves.push(identifier.threshold_curve(x.measured_kn, p));
        }
        c
    }

    /// Every sample of every sensor window of the identification, read as `whole` says, with
    /// thresholds at `φ^(1/N)` for the N points (Šídák over the whole record). A smoothed
    /// point's thresholds are those of its smoothed measured force: a weighted mean of errors
    /// is no wider than one of them where they are shared, and narrower where independent.
    pub(super) fn whole_record(
        identifier: &Identifier,
        id: &Identification,
        whole: WholeRecord,
    ) -> Comparison {
        let axes = &identifier.bank().metadata().sensors;
        let (half_width, kinds): (usize, &[Read]) = match whole {
            WholeRecord::Samples => (0, &[Read::Sample]),
            WholeRecord::Extremes(w) => (w, &[Read::Max, Read::Min]),
            WholeRecord::Smoothed => (1, &[Read::Smoothed]),
        };
        let total: usize = id
            .series
            .iter()
            .map(|s| s.values_kn.len().saturating_sub(2 * half_width) * kinds.len())
            .sum();
        let p = id.phi.powf(1.0 / total.max(1) as f64);
        let mut c = Comparison {
            axes: axes.clone(),
            at: Vec::with_capacity(total),
            measured: Vec::with_capacity(total),
            thresholds: Vec::with_capacity(total),
            curves: Vec::with_capacity(total),
        };
        for ser in &id.series {
            let axis = axes
                .iter()
                .position(|a| a.name == ser.sensor)
                .expect("identified sensors are the bank's");
            let n = ser.values_kn.len();
            for k in half_width..n.saturating_sub(half_width) {
                for &kind in kinds {
                    let at = (axis, k - half_width, k + half_width, kind);
                    let y = match kind {
                        Read::Sample => ser.values_kn[k],
                        _ => Comparison::value(at, |j| ser.values_kn[j] as f32) as f64,
                    };
                    c.at.push(at);
                    c.measured.push(y);
                    c.thresholds.push(identifier.thresholds(y, p));
                    c.curves.push(identifier.threshold_curve(y, p));
                }
            }
        }
        c
    }

    /// The points of `self` followed by those of `other`.
    pub(super) fn chain(mut self, other: Comparison) -> Comparison {
        self.at.extend(other.at);
        self.measured.extend(other.measured);
        self.thresholds.extend(other.thresholds);
        self.curves.extend(other.curves);
        self
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
    /// inside it (as identification reads the bank, [`crate::identify::falsify::steps`]).
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
            Read::Smoothed => {
                (0.25 * series(a) as f64 + 0.5 * series(a + 1) as f64 + 0.25 * series(a + 2) as f64)
                    as f32
            }
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
                        let resp = r.map_err(|e| {
                            IdentifyError::Invalid(format!(
                                "refinement: simulating a flat failed: {e}"
                            ))
                        })?;
                        let mut g = Vec::with_capacity(cmp.at.len());
                        let mut steps = Vec::with_capacity(cmp.at.len());
                        for &at in &cmp.at {
                            let a = &cmp.axes[at.0];
                            let w = resp.window(at.0, a.first_sample, a.samples);
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

/// How far each member lies outside its band at the worst comparison point, in half-widths
/// of the measured force's thresholds there (≤ 0: it passes every point with no widening,
/// κ = 0, judged as falsification judges: the prediction's own thresholds where it is the
/// larger force).
pub(super) fn misfit(cmp: &Comparison, members: &[Member]) -> Vec<f64> {
    members
        .iter()
        .map(|m| {
            (0..cmp.at.len())
                .map(|p| {
                    let (g, y) = (m.g[p] as f64, cmp.measured[p]);
                    let (lo, hi) = cmp.thresholds[p];
                    let half = 0.5 * (hi - lo).max(1e-9);
                    let outside = |(lo, hi): (f64, f64)| {
                        let r = g - y;
                        if r > hi {
                            r - hi
                        } else if r < lo {
                            lo - r
                        } else {
                            -(r - lo).min(hi - r)
                        }
                    };
                    let mut e = outside((lo, hi));
                    if e > 0.0 && g.abs() > y.abs() {
                        e = e.min(outside(cmp.curves[p].at(g)));
                    }
                    e / half
                })
                .fold(f64::MIN, f64::max)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::falsify::falsify;
    use crate::identify::uncertainty::{uniform, CombinedUncertainty};

    /// The witness test (`misfit ≤ 0`) is falsification at κ = 0: the same flats pass, on
    /// predictions spread across the band's edges, above and below the measurement.
    #[test]
    fn a_witness_is_what_falsification_keeps_with_no_widening() {
        let u = CombinedUncertainty::new(&crate::model::Calibration::default().identification);
        let p = 0.995;
        let measured = vec![20.0, 35.0, 5.0];
        let cmp = Comparison {
            axes: Vec::new(),
            at: vec![(0, 0, 0, Read::Sample); 3],
            thresholds: measured.iter().map(|&y| u.thresholds(y, p)).collect(),
            curves: measured.iter().map(|&y| u.curve(y, p)).collect(),
            measured,
        };
        let mut state = 7u64;
        let members: Vec<Member> = (0..3000)
            .map(|_| Member {
                x: [0.0; 4],
                wheel: WheelPosition::Trailing,
                half: [0.0; 4],
                g: cmp
                    .measured
                    .iter()
                    .map(|&y| (y * (0.6 + 0.8 * uniform(&mut state))) as f32)
                    .collect(),
                steps: Vec::new(),
                share: 0.0,
            })
            .collect();
        let score = misfit(&cmp, &members);
        let columns: Vec<Vec<f32>> = (0..3)
            .map(|q| members.iter().map(|m| m.g[q]).collect())
            .collect();
        let kept = falsify(&cmp.points(&columns, 0..3, &[], None), None);
        let witnesses: Vec<u32> = (0..members.len() as u32)
            .filter(|&k| score[k as usize] <= 0.0)
            .collect();
        assert_eq!(kept, witnesses);
        assert!(
            !kept.is_empty() && kept.len() < members.len(),
            "{}",
            kept.len()
        );
    }

    #[test]
    fn a_window_value_is_the_sample_the_window_extreme_or_the_smoothed_sample() {
        let series = [1.0f32, 4.0, -2.0, 3.0];
        let at = |kind| (0, 0, 3, kind);
        let v = |at| Comparison::value(at, |j| series[j]).to_bits();
        assert_eq!(v((0, 2, 2, Read::Sample)), (-2.0f32).to_bits());
        assert_eq!(v(at(Read::Max)), 4.0f32.to_bits());
        assert_eq!(v(at(Read::Min)), (-2.0f32).to_bits());
        // ¼·4 + ½·(−2) + ¼·3 = 0.75, exact in binary.
        assert_eq!(v((0, 1, 3, Read::Smoothed)), 0.75f32.to_bits());
    }
}
