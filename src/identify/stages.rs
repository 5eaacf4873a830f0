//! The sizing stages of [`Identifier::identify`], for a pass with a flat detected, each one
//! lap of `timings_ms`:
//! 1. [`Identifier::read_predictions`]: the bank's predictions at the PIP candidates and the
//!    envelope windows (the hot read, one memory-mapped pass);
//! 2. [`Identifier::select_points`]: the comparison points (EIP) by greedy joint entropy, at
//!    bin widths of the thresholds widened by the bank's resolution — once with one point's
//!    Šídák probability, again with the number of points found;
//! 3. [`Identifier::judge`]: the envelope points, the thresholds at the Šídák probability of
//!    every point, falsification (with the discretisation allowance) and the departure rule;
//! 4. [`Identifier::assemble`]: the candidate model set, its ranges per wheel, the baselines
//!    and entropy curves when asked for, the summary and severity.

use super::answer::ranges::{instance, population_ranges};
use super::answer::result::{
    Alignment, CandidatePoint, EntropyCurve, Falsification, InstanceParams, MeasuredSeries, Method,
    WheelRanges,
};
use super::answer::severity::{below_population_words, summarise, SeverityRange};
use super::domain::falsify::{self, falsify, residual_minimisation, Point};
use super::select::entropy::{
    self, bin_into, binned_columns, greedy_joint_entropy, Binned, Selection,
};
use super::select::envelope::{self, EnvelopePoint};
use super::shared_stage::{Allowance, SharedInput};
use crate::identify::answer::identification::Identification;
use crate::identify::answer::sizing::Sizing;
use crate::identify::detect::Detection;
use crate::identify::domain::uncertainty::ThresholdCurve;
use crate::identify::error::IdentifyError;
use crate::identify::extras::Extras;
use crate::identify::identifier::Identifier;
use crate::identify::input::buffer::HugeBuffer;
use crate::identify::input::measurement::Measurement;
use crate::identify::input::pip::Candidate;
use crate::model::WheelPosition;
use crate::stopwatch::Stopwatch;

/// What the sizing stages read of the prepared measurement.
pub(super) struct SizingInput<'a> {
    /// The measurement.
    pub(super) m: &'a Measurement,
    /// The optional parts asked for.
    pub(super) extras: Extras,
    /// (measurement sensor index, bank axis index) of the sensors used.
    pub(super) used: &'a [(usize, usize)],
    /// The PIP candidates: (series, sample, PIP order).
    pub(super) cands: &'a [Candidate],
    /// The roughness the pass is judged with.
    pub(super) roughness: &'a crate::identify::detect::roughness::RoughnessUse,
    /// How its series meet the bank's predictions.
    pub(super) comparison: crate::identify::input::compare::Comparison,
}

/// Stage 1's outcome: the predictions read, and the envelope windows they include.
pub(super) struct Read<'b> {
    /// Every instance's prediction at each candidate (one column a candidate).
    pub(super) predictions: Vec<&'b [f32]>,
    /// The envelope windows' columns, window after window, sample after sample.
    pub(super) env_columns: Vec<&'b [f32]>,
    /// The envelope windows' centres (series, sample).
    pub(super) centres: Vec<(usize, usize)>,
    /// The measured force at each candidate (kN).
    pub(super) measured: Vec<f64>,
    /// The bank's flat-free prediction at each candidate (kN): what the bounded sources
    /// scale with.
    pub(super) flat_free: Vec<f64>,
}

/// Stage 2's outcome: the EIP and what the selection binned.
pub(super) struct Selected<'c> {
    /// Each candidate's thresholds' widening by the bank's resolution (kN).
    pub(super) widening: Vec<f64>,
    /// Each candidate's predictions binned at the final widths.
    pub(super) binned: Vec<Binned<&'c [u16]>>,
    /// The EIP in order, with the joint entropy after each.
    pub(super) selection: Selection,
    /// The selection's stopping gain (bits).
    pub(super) alpha_bits: f64,
}

/// Stage 3's outcome: the envelope points, the thresholds, the points judged and what
/// survives them.
pub(super) struct Judged {
    /// The Šídák probability of each point.
    pub(super) p_final: f64,
    /// The envelope points, as reported.
    pub(super) envelope: Vec<EnvelopePoint>,
    /// Thresholds at each candidate's measured force (kN).
    pub(super) thresholds: Vec<(f64, f64)>,
    /// Threshold curves where a prediction may exceed the measurement (the EIP; every
    /// candidate with the baselines).
    pub(super) curves: Vec<Option<ThresholdCurve>>,
    /// The instance of least squared residual at the EIP (the residual-minimisation baseline).
    pub(super) residual_best: usize,
    /// Every point the method judged (EIP and envelope).
    pub(super) method_points: usize,
    /// The candidate model set (instances).
    pub(super) cms: Vec<u32>,
    /// The measurement is smaller than the population's smallest flat.
    pub(super) below_population: bool,
    /// The shared-gain stage explained no survivor, and the per-point answer stands.
    pub(super) shared_fallback: bool,
}

/// The parts of the result the stages before sizing made.
pub(super) struct Prepared {
    /// How the measurement was put on the bank's time axis.
    pub(super) alignment: Alignment,
    /// The series on the bank's windows.
    pub(super) series: Vec<MeasuredSeries>,
    /// The load the record shows.
    pub(super) load: Option<super::detect::load::LoadEstimate>,
    /// Detection's answer.
    pub(super) detection: Detection,
    /// The detection test of the sizing's comparison, which the departure rule judges with.
    pub(super) rule: Detection,
}

impl Identifier {
    /// Stage 1: the bank's predictions at the candidates, then at the envelope windows at the
    /// impact spikes (they depend on the measurement only, so they are read together).
    pub(super) fn read_predictions<'b>(
        &self,
        z: &SizingInput<'_>,
        series: &[MeasuredSeries],
        buffer: &'b mut HugeBuffer,
        laps: &mut Stopwatch,
    ) -> Result<Read<'b>, IdentifyError> {
        let hw = self.settings.envelope_half_width_samples;
        let template: Vec<&[f32]> = z
            .used
            .iter()
            .map(|&(_, bi)| self.flat_free(bi, z.comparison))
            .collect();
        let centres = envelope::windows(
            series,
            &template,
            self.settings.envelope_windows_per_sensor,
            hw,
        );
        laps.lap("align and pip");
        let cols: Vec<(usize, usize)> = z
            .cands
            .iter()
            .map(|c| (z.used[c.series].1, c.sample))
            .chain(
                centres
                    .iter()
                    .flat_map(|&(si, k)| (k - hw..=k + hw).map(move |j| (si, j)))
                    .map(|(si, j)| (z.used[si].1, j)),
            )
            .collect();
        let n = self.bank.instances();
        let flat = buffer
            .values(cols.len() * n)
            .map_err(|source| IdentifyError::Memory {
                what: "the bank's predictions",
                mb: (cols.len() * n * 4) >> 20,
                source,
            })?;
        self.read_compared(&cols, z.comparison, flat)?;
        let (flat, env_flat) = flat.split_at(z.cands.len() * n);
        let predictions: Vec<&[f32]> = flat.chunks(n.max(1)).collect();
        let env_columns: Vec<&[f32]> = env_flat.chunks(n.max(1)).collect();
        laps.lap("read columns");
        let measured: Vec<f64> = z
            .cands
            .iter()
            .map(|c| series[c.series].values_kn[c.sample])
            .collect();
        let flat_free: Vec<f64> = z
            .cands
            .iter()
            .map(|c| f64::from(template[c.series][c.sample]))
            .collect();
        Ok(Read {
            predictions,
            env_columns,
            centres,
            measured,
            flat_free,
        })
    }

    /// Stage 2: the comparison points. Entropy bins at the Šídák width for m points; m comes
    /// from the selection itself, so select with m = 1, then again with the m found (the
    /// widths, and so the choice, change). Bin width: the thresholds widened by the bank's
    /// typical resolution at the point, so points the bank cannot resolve (moving impact
    /// edges) are not taken as informative.
    pub(super) fn select_points<'c>(
        &self,
        z: &SizingInput<'_>,
        read: &Read<'_>,
        bin_buffer: &'c mut HugeBuffer,
        laps: &mut Stopwatch,
    ) -> Result<Selected<'c>, IdentifyError> {
        use rayon::prelude::*;
        let s = &self.settings;
        let n = self.bank.instances();
        let (predictions, measured) = (&read.predictions, &read.measured);
        let alpha_bits = s.alpha_fraction * (n as f64).log2();
        let all: Vec<usize> = (0..measured.len()).collect();
        let widening: Vec<f64> = predictions
            .par_iter()
            .map(|g| self.typical_widening(g))
            .collect();
        let bounds = |i: usize, p: f64| {
            let (lo, hi) = self.point_thresholds(z.roughness, measured[i], read.flat_free[i], p);
            (lo - widening[i], hi + widening[i])
        };
        let bins: &mut [u16] =
            bin_buffer
                .values(measured.len() * n)
                .map_err(|source| IdentifyError::Memory {
                    what: "the predictions' bins",
                    mb: (measured.len() * n * 2) >> 20,
                    source,
                })?;
        // Bins every candidate's predictions at the widths for p into `bins` (one column a
        // candidate); returns each column's number of bins, entropy and instances outside its
        // most populated bin.
        let bin_all = |p: f64, bins: &mut [u16]| -> Vec<entropy::Histogram> {
            bins.par_chunks_mut(n.max(1))
                .enumerate()
                .map(|(i, b)| {
                    let (lo, hi) = bounds(i, p);
                    bin_into(predictions[i], hi - lo, b)
                })
                .collect()
        };
        laps.lap("resolution");
        let hists = bin_all(s.phi, bins);
        let first = {
            let binned = binned_columns(bins, n, hists);
            laps.lap("binning 1");
            greedy_joint_entropy(&binned, &all, alpha_bits, measured.len())
        };
        let m1 = first.order.len().max(1);
        let p = s.phi.powf(1.0 / m1 as f64);
        laps.lap("greedy 1");
        let hists = bin_all(p, bins);
        let binned = binned_columns(bins, n, hists);
        laps.lap("binning 2");
        let selection = greedy_joint_entropy(&binned, &all, alpha_bits, m1);
        laps.lap("greedy 2");
        Ok(Selected {
            widening,
            binned,
            selection,
            alpha_bits,
        })
    }

    /// Stage 3: the envelope points (Šídák over every point), the thresholds, falsification
    /// at the EIP and envelope points, then the departure rule.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn judge(
        &self,
        z: &SizingInput<'_>,
        series: &[MeasuredSeries],
        read: &Read<'_>,
        selected: &Selected<'_>,
        axes: &[usize],
        detection: &Detection,
        laps: &mut Stopwatch,
    ) -> Result<Judged, IdentifyError> {
        let s = &self.settings;
        let hw = s.envelope_half_width_samples;
        let order = &selected.selection.order;
        let m_final = order.len().max(1);
        let p_final = s.phi.powf(1.0 / (m_final + 2 * read.centres.len()) as f64);
        let env_flat_free: Vec<f64> = read
            .centres
            .iter()
            .map(|&(si, k)| {
                self.flat_free_peak_kn(axes[si], k.saturating_sub(hw), k + hw, z.comparison)
            })
            .collect();
        let judge_at = |y: f64, ff: f64| {
            (
                self.point_thresholds(z.roughness, y, ff, p_final),
                self.point_curve(z.roughness, y, ff, p_final),
            )
        };
        let (env_reported, env_features, env_curves) = envelope::points(
            series,
            &read.centres,
            hw,
            (&judge_at, &env_flat_free),
            &read.env_columns,
        );
        laps.lap("envelope");

        let measured = &read.measured;
        let thresholds: Vec<(f64, f64)> = (0..measured.len())
            .map(|i| self.point_thresholds(z.roughness, measured[i], read.flat_free[i], p_final))
            .collect();
        // The thresholds at a prediction's own force where it exceeds the measurement: for the
        // EIP, and for every candidate when the baselines draw from them.
        let curves: Vec<Option<ThresholdCurve>> = (0..measured.len())
            .map(|i| {
                (z.extras.baselines || order.contains(&i))
                    .then(|| self.point_curve(z.roughness, measured[i], read.flat_free[i], p_final))
            })
            .collect();
        // The discretisation allowance's steps (identify::discretisation), for the samples
        // compared one by one (the average takes in a landing's neighbours).
        let shares = self
            .discretisation()
            .filter(|_| z.comparison == crate::identify::input::compare::Comparison::Samples);
        // The steps at the EIP for every instance (falsification judges them all); the shared
        // stage's at every candidate are read below for the survivors alone.
        let shared = s.shared_gains;
        let cand = |&i: &usize| &z.cands[i];
        let at_of = |points: &[usize]| -> Vec<(usize, usize)> {
            points
                .iter()
                .map(|i| (z.used[cand(i).series].1, cand(i).sample))
                .collect()
        };
        let (eip_steps, env_steps) = match shares {
            Some(_) => {
                let g: Vec<&[f32]> = order.iter().map(|&i| read.predictions[i]).collect();
                self.allowance_steps(&at_of(order), &g, &read.env_columns, hw, None)?
            }
            None => (Vec::new(), Vec::new()),
        };
        let point = |i: usize| Point {
            predictions: read.predictions[i],
            measured_kn: measured[i],
            low_kn: thresholds[i].0,
            high_kn: thresholds[i].1,
            curve: curves[i].as_ref(),
            discretisation: None,
        };
        let eip_points: Vec<Point> = order
            .iter()
            .enumerate()
            .map(|(j, &i)| Point {
                discretisation: falsify::Discretisation::of(shares, &eip_steps, j),
                ..point(i)
            })
            .collect();
        let mut method_points = eip_points.clone();
        method_points.extend(
            envelope::as_points(&env_reported, &env_features, &env_curves)
                .into_iter()
                .enumerate()
                .map(|(j, p)| Point {
                    discretisation: falsify::Discretisation::of(shares, &env_steps, j / 2),
                    ..p
                }),
        );
        let cms_idx = falsify(&method_points, self.resolution());
        laps.lap("falsify");
        let cms_idx = if shared {
            let all: Vec<usize> = (0..measured.len()).collect();
            let cand_steps = match shares {
                Some(_) => {
                    let (steps, _) = self.allowance_steps(
                        &at_of(&all),
                        &read.predictions,
                        &[],
                        hw,
                        Some(&cms_idx),
                    )?;
                    steps
                }
                None => Vec::new(),
            };
            let input = SharedInput {
                sensors: z.cands.iter().map(|c| c.series).collect(),
                predictions: &read.predictions,
                measured,
                flat_free: &read.flat_free,
                envelope: (&env_reported, &env_features),
                env_flat_free: &env_flat_free,
                allowance: shares.map(|shares| Allowance {
                    shares,
                    candidates: &cand_steps,
                    windows: &env_steps,
                }),
                bounds: z.roughness.bounds(self.bounds),
            };
            let kept = self.shared_gains(&input, cms_idx.clone());
            laps.lap("shared gains");
            // No survivor explained with one gain per sensor: the pass carries what the
            // structure leaves out (an out-of-round tread, an effect the bank lacks), and the
            // per-point answer stands, said so, rather than a refuted class.
            if kept.is_empty() && !cms_idx.is_empty() {
                (cms_idx, true)
            } else {
                (kept, false)
            }
        } else {
            (cms_idx, false)
        };
        let (cms_idx, shared_fallback) = cms_idx;
        let (cms, below_population) =
            self.departure_rule(cms_idx, axes, (detection, z.comparison))?;
        laps.lap("departures");
        let residual_best = residual_minimisation(&eip_points);
        let method_points = method_points.len();
        Ok(Judged {
            p_final,
            envelope: env_reported,
            thresholds,
            curves,
            residual_best,
            method_points,
            cms,
            below_population,
            shared_fallback,
        })
    }

    /// Stage 4: the result. The candidate model set and its ranges (all, and per wheel), the
    /// method's falsification, the baselines (residual minimisation, random subsets,
    /// equidistant points) and the entropy curves per sensor set when asked for, the summary,
    /// maintenance hint and severity classes.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn assemble(
        &self,
        z: &SizingInput<'_>,
        read: &Read<'_>,
        selected: Selected<'_>,
        judged: Judged,
        prepared: Prepared,
        mut laps: Stopwatch,
    ) -> Result<Identification, IdentifyError> {
        let s = &self.settings;
        let meta = self.bank.metadata();
        let n = self.bank.instances();
        let (cands, measured, thresholds) = (z.cands, &read.measured, &judged.thresholds);
        let series = &prepared.series;
        let m_final = selected.selection.order.len().max(1);
        let candidates: Vec<CandidatePoint> = cands
            .iter()
            .enumerate()
            .map(|(i, c)| CandidatePoint {
                series: c.series,
                sample: c.sample,
                time_s: series[c.series].t0_s + c.sample as f64 / series[c.series].sample_rate_hz,
                measured_kn: measured[i],
                pip_order: c.order,
                entropy_bits: selected.binned[i].entropy_bits,
                threshold_low_kn: thresholds[i].0,
                threshold_high_kn: thresholds[i].1,
                resolution_kn: selected.widening[i],
            })
            .collect();
        let cms: Vec<InstanceParams> = judged
            .cms
            .iter()
            .map(|&k| instance(&self.params, k as usize))
            .collect();
        let cms_ranges = self.ranges(judged.cms.iter().map(|&k| k as usize));
        let wheel_ranges: Vec<WheelRanges> = [WheelPosition::Leading, WheelPosition::Trailing]
            .into_iter()
            .filter_map(|wheel| {
                let members: Vec<usize> = judged
                    .cms
                    .iter()
                    .map(|&k| k as usize)
                    .filter(|&k| WheelPosition::from_code(self.params.flat_wheel[k]) == wheel)
                    .collect();
                Some(WheelRanges {
                    wheel,
                    cms_count: members.len(),
                    ranges: self.ranges(members.into_iter())?,
                })
            })
            .collect();
        let mut falsifications = vec![Falsification {
            method: Method::Eip {
                envelope: !judged.envelope.is_empty(),
                departures: s.falsify_at_departures,
            },
            points: judged.method_points,
            cms_count: cms.len(),
            ranges: cms_ranges.clone(),
        }];

        let mut random_subsets = None;
        if z.extras.baselines {
            let all_points: Vec<Point> = (0..cands.len())
                .map(|i| Point {
                    predictions: read.predictions[i],
                    measured_kn: measured[i],
                    low_kn: thresholds[i].0,
                    high_kn: thresholds[i].1,
                    curve: judged.curves[i].as_ref(),
                    discretisation: None,
                })
                .collect();
            let (subsets, random) = self.random_subsets(&all_points, m_final);
            random_subsets = Some(subsets);
            falsifications.push(random);
            falsifications.push(self.equidistant(
                series,
                z.used,
                m_final,
                (judged.p_final, z.roughness),
            )?);
            laps.lap("baselines");
        }

        let mut entropy_curves = Vec::new();
        if z.extras.curves {
            let mut sets: Vec<(String, Vec<usize>)> = series
                .iter()
                .enumerate()
                .map(|(si, ser)| {
                    (
                        ser.sensor.clone(),
                        (0..cands.len())
                            .filter(|&i| cands[i].series == si)
                            .collect(),
                    )
                })
                .collect();
            if series.len() > 1 {
                let label = series
                    .iter()
                    .map(|s| s.sensor.as_str())
                    .collect::<Vec<_>>()
                    .join("+");
                sets.push((label, (0..cands.len()).collect()));
            }
            for (label, allowed) in sets {
                let sel = greedy_joint_entropy(&selected.binned, &allowed, 0.0, allowed.len());
                entropy_curves.push(EntropyCurve {
                    label,
                    joint_entropy_bits: sel.joint_bits,
                });
            }
            laps.lap("entropy curves");
        }

        let population = population_ranges(&meta.calibration);
        let below_population = judged.below_population;
        let refuted = cms.is_empty() && !below_population;
        let (mut summary, hint) = if below_population {
            below_population_words(&population, s)
        } else {
            summarise(&cms_ranges, cms.len(), n, judged.method_points, s)
        };
        if judged.shared_fallback {
            summary += " One gain per sensor explains none of them at every point read (an effect the bank does not model, such as an out-of-round tread): the per-point answer stands.";
        }
        let severity = SeverityRange::of_answer(
            true,
            cms_ranges.as_ref(),
            below_population.then_some(population.l0_mm[0]),
            s,
        );
        Ok(Identification {
            measurement: z.m.path.display().to_string(),
            speed: self.speed_use(z.m),
            load: prepared.load,
            bank_id: meta.bank_id.clone(),
            bank_instances: n,
            population,
            alignment: prepared.alignment,
            series: prepared.series,
            pip_distance: s.pip_distance,
            pips_per_series: s.pips_per_series,
            phi: s.phi,
            sizing: Some(Sizing {
                candidates,
                eip: selected.selection.order,
                eip_joint_entropy_bits: selected.selection.joint_bits,
                envelope: judged.envelope,
                alpha_bits: selected.alpha_bits,
                entropy_curves,
                per_point_probability: judged.p_final,
                cms,
                falsifications,
                wheel_ranges,
                residual_minimisation: Some(instance(&self.params, judged.residual_best)),
                random_subsets,
                model_class_refuted: refuted,
                below_population,
                shared_gains_fallback: judged.shared_fallback,
            }),
            detection: Some(prepared.detection),
            roughness: Some(z.roughness.clone()),
            comparison: z.comparison,
            summary,
            maintenance_hint: hint,
            severity: Some(severity),
            timings_ms: laps.laps,
            refinement: None,
        })
    }
}
