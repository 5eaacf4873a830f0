//! Refinement (issue 11, opt-in `identify --refine`): simulate new flats inside the surviving
//! cells with the bank's calibration and falsify them at the same comparison points, so the
//! answer is resolved where the measurement is informative instead of at the bank's spacing.
//!
//! Why: with direct simulation and no cell widening, the flats a measurement cannot rule out
//! span a few millimetres of L0 (`examples/oracle_study`), while the bank's cells are ~14 mm of
//! L and ~0.13 mm of d wide (docs/identification.md). The bank-only answer is the union of its
//! surviving cells; refinement samples those cells more densely, in rounds:
//!
//! 1. the seeds are the bank's survivors, each with its cell (half-way to its farthest
//!    neighbour in the stretched metric, [`super::cells`]);
//! 2. each round simulates its share of the budget uniformly inside the seeds' cells (the
//!    flat on the seed's wheel; L, d, c, X_p clamped to the population, c < d/2);
//! 3. the new flats and the seeds form a local population: neighbours in the same stretched
//!    metric (sensitivities per mm × the local box), cells as in the bank, the same
//!    falsification at the same points and thresholds (EIP and envelope points, per-point
//!    probability of the bank-only answer, thresholds at the prediction's force) with the same
//!    κ;
//! 4. its survivors are the next round's seeds; the answer is the union of the last round's
//!    surviving cells. A round with no survivor ends the refinement and the previous round's
//!    answer stands (said in the result).
//!
//! The budget is a number of simulations (deterministic: same inputs, same answer on any
//! thread count), not a time; 640 simulations take about 1.2 s on 2 cores.
//!
//! [`RefineMode::Witnesses`] is a measuring instrument, not offered by the CLI: it searches
//! every bank cell for flats that pass every point with *no* widening (κ = 0). Those are
//! flats the measurement cannot rule out at these points, so the largest L0 among them is a
//! floor under the upper bound of any answer that keeps every such flat (docs/performance.md,
//! "Refinement"). As an answer it narrows most but loses the truth too often (coverage 0.78–0.83
//! on 100 cases).

use super::cells::{Cells, NEIGHBOURS};
use super::falsify::{falsify, Point, Resolution};
use super::result::{Identification, ParamRanges};
use super::uncertainty::uniform;
use super::{Identifier, IdentifyError, ThresholdCurve};
use crate::bank::neighbours::{nearest_weighted, SENSITIVITY_PER_MM};
use crate::bank::schema::SensorAxis;
use crate::model::calibration::PopulationParams;
use crate::model::{batch_key, Flat, Record, Simulator, WheelPosition, LANES};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// The most simulations one refinement may ask for (a resource bound: 20,000 take about
/// 40 s on 2 cores).
pub const MAX_SIMULATIONS: usize = 20_000;

/// How much refinement to do.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefineSettings {
    /// Simulations in all, split evenly over the rounds (1–[`MAX_SIMULATIONS`]).
    pub simulations: usize,
    /// Rounds (1–8).
    pub rounds: usize,
    /// Seed of the sampling inside the cells.
    pub seed: u64,
    /// κ of the local cells (`None`: the identification's `bank_resolution`).
    pub kappa: Option<f64>,
    /// How the refined answer is formed.
    pub mode: RefineMode,
}

/// How the refined answer is formed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RefineMode {
    /// Cells of the local population, falsified with κ as the bank's (round after round).
    Cells,
    /// Witnesses: flats that pass every point with no widening (κ = 0), sampled around the
    /// bank's survivors and then around the witnesses found; the answer is the hull of the
    /// witnesses, widened by `margin` × their local cells.
    Witnesses {
        /// Share of each witness's local cell added around it (0: the hull of the witnesses).
        margin: f64,
    },
}

impl Default for RefineSettings {
    fn default() -> Self {
        RefineSettings {
            simulations: 640,
            rounds: 2,
            seed: 1,
            kappa: None,
            mode: RefineMode::Cells,
        }
    }
}

impl RefineSettings {
    /// Checks the ranges: a refusal names the setting and its value.
    pub fn check(&self) -> Result<(), IdentifyError> {
        if !(1..=MAX_SIMULATIONS).contains(&self.simulations) {
            return Err(IdentifyError::Invalid(format!(
                "refine simulations = {}: must be 1–{MAX_SIMULATIONS}",
                self.simulations
            )));
        }
        if let Some(k) = self
            .kappa
            .filter(|k| !(k.is_finite() && (0.0..=10.0).contains(k)))
        {
            return Err(IdentifyError::Invalid(format!(
                "refine kappa = {k}: must be 0–10"
            )));
        }
        if let RefineMode::Witnesses { margin } = self.mode {
            if !(margin.is_finite() && (0.0..=10.0).contains(&margin)) {
                return Err(IdentifyError::Invalid(format!(
                    "refine witness margin = {margin}: must be 0–10"
                )));
            }
        }
        if !(1..=8).contains(&self.rounds) {
            return Err(IdentifyError::Invalid(format!(
                "refine rounds = {}: must be 1–8",
                self.rounds
            )));
        }
        Ok(())
    }
}

/// One round of a refinement.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RefineRound {
    /// Flats simulated in the round.
    pub simulated: usize,
    /// Seeds plus new flats that survive.
    pub survivors: usize,
    /// The round's answer (None when nothing survived).
    pub ranges: Option<ParamRanges>,
}

/// The refined answer, reported beside the bank-only one.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Refinement {
    /// The union of the last surviving round's cells.
    pub ranges: Option<ParamRanges>,
    /// Flats that stand for it (the last surviving round's survivors).
    pub survivors: usize,
    /// Simulations run.
    pub simulations: usize,
    /// Every round.
    pub rounds: Vec<RefineRound>,
    /// True when a round kept nothing and an earlier answer stands.
    pub stopped_early: bool,
    /// Wall time (ms).
    pub time_ms: f64,
    /// The refined answer in words.
    pub summary: String,
    /// The maintenance hint from the refined upper L0 bound (rule stated), or why the bank-only
    /// answer's stands.
    pub maintenance_hint: String,
}

/// A flat of the local population with its predictions at the comparison points.
#[derive(Debug, Clone)]
struct Member {
    /// L (mm), d (mm), c (mm), X_p (m).
    x: [f64; 4],
    wheel: WheelPosition,
    /// Half-extent of its cell (same units), set once the population's cells are known.
    half: [f64; 4],
    /// Predictions at the comparison points, in the order of [`Comparison::points`].
    g: Vec<f32>,
}

/// The comparison points of an identification: each is a sample (EIP) or a window's extreme
/// (envelope point) of one bank axis, with its measurement, thresholds and threshold curve.
struct Comparison {
    /// The bank's sensor axes.
    axes: Vec<SensorAxis>,
    /// (bank axis, first sample, last sample, window maximum / minimum / the sample).
    at: Vec<(usize, usize, usize, Option<bool>)>,
    measured: Vec<f64>,
    thresholds: Vec<(f64, f64)>,
    curves: Vec<ThresholdCurve>,
}

impl Comparison {
    fn of(identifier: &Identifier, id: &Identification) -> Comparison {
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
            c.at.push((axis_of(cand.series), cand.sample, cand.sample, None));
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
                Some(x.kind == "max"),
            ));
            c.measured.push(x.measured_kn);
            c.thresholds.push((x.threshold_low_kn, x.threshold_high_kn));
            c.curves.push(identifier.threshold_curve(x.measured_kn, p));
        }
        c
    }

    /// A window's value: the sample, or the extreme over the window.
    fn value(at: (usize, usize, usize, Option<bool>), series: impl Fn(usize) -> f32) -> f32 {
        let (_, a, b, kind) = at;
        match kind {
            None => series(a),
            Some(true) => (a..=b).map(series).fold(f32::MIN, f32::max),
            Some(false) => (a..=b).map(series).fold(f32::MAX, f32::min),
        }
    }
}

/// Refines an identification made by `identifier` (see the module docs). `sim` must be the
/// bank calibration's simulator. An identification with no survivor is returned as it is
/// (nothing to refine).
pub fn refine(
    identifier: &Identifier,
    sim: &Simulator,
    id: &Identification,
    settings: RefineSettings,
) -> Result<Refinement, IdentifyError> {
    settings.check()?;
    let t0 = std::time::Instant::now();
    let bank = identifier.bank();
    let cal = &bank.metadata().calibration;
    let pop = &cal.population;
    let radius = cal.vehicle.wheel_radius_m;
    let kappa = settings
        .kappa
        .unwrap_or(identifier.settings().bank_resolution);
    let cmp = Comparison::of(identifier, id);

    // Seeds: the bank's survivors with their cells and their stored predictions.
    let mut columns: Vec<usize> = Vec::new();
    let mut spans: Vec<(usize, usize)> = Vec::new(); // (first column, count) per point
    for &(axis, a, b, _) in &cmp.at {
        spans.push((columns.len(), b - a + 1));
        columns.extend((a..=b).map(|k| bank.sample_index(axis, k)));
    }
    let stored = bank.read_columns(&columns)?;
    let mut seeds: Vec<Member> = id
        .cms
        .iter()
        .map(|s| {
            let k = s.instance as usize;
            let half = identifier
                .resolution()
                .map_or([0.0; 4], |r| r.cells.half_extent(k));
            let g = cmp
                .at
                .iter()
                .zip(&spans)
                .map(|(&at, &(first, _))| Comparison::value(at, |j| stored[first + j - at.1][k]))
                .collect();
            Member {
                x: [s.length_mm, s.depth_mm, s.curvature_mm, s.impact_position_m],
                wheel: s.flat_wheel,
                half,
                g,
            }
        })
        .collect();

    let mut out = Refinement {
        ranges: ranges_of(&seeds, pop, radius),
        survivors: seeds.len(),
        simulations: 0,
        rounds: Vec::new(),
        stopped_early: false,
        time_ms: 0.0,
        summary: String::new(),
        maintenance_hint: String::new(),
    };
    if seeds.is_empty() {
        return Ok(finish(out, t0, identifier));
    }
    let mut state = settings.seed ^ 0x5DEE_CE66_D1CE_4E5B;
    if let RefineMode::Witnesses { margin } = settings.mode {
        witnesses(
            sim, &cmp, seeds, settings, margin, &mut state, &mut out, pop, radius,
        )?;
        return Ok(finish(out, t0, identifier));
    }
    for round in 0..settings.rounds {
        let budget = settings.simulations / settings.rounds
            + usize::from(round < settings.simulations % settings.rounds);
        let flats = sample_in_cells(&seeds, budget, pop, &mut state);
        let predictions = simulate_at(sim, &cmp, &flats)?;
        out.simulations += flats.len();
        let mut members: Vec<Member> = std::mem::take(&mut seeds);
        members.extend(
            flats
                .into_iter()
                .zip(predictions)
                .map(|((_, x, wheel), g)| Member {
                    x,
                    wheel,
                    half: [0.0; 4],
                    g,
                }),
        );
        let cells = local_cells(&members);
        for (i, m) in members.iter_mut().enumerate() {
            m.half = cells.half_extent(i);
        }
        let columns: Vec<Vec<f32>> = (0..cmp.at.len())
            .map(|p| members.iter().map(|m| m.g[p]).collect())
            .collect();
        let points: Vec<Point> = (0..cmp.at.len())
            .map(|p| Point {
                predictions: &columns[p],
                measured_kn: cmp.measured[p],
                low_kn: cmp.thresholds[p].0,
                high_kn: cmp.thresholds[p].1,
                curve: Some(&cmp.curves[p]),
            })
            .collect();
        let alive = falsify(
            &points,
            (kappa > 0.0).then_some(Resolution {
                cells: &cells,
                kappa,
            }),
        );
        let kept: Vec<Member> = alive.iter().map(|&k| members[k as usize].clone()).collect();
        let ranges = ranges_of(&kept, pop, radius);
        out.rounds.push(RefineRound {
            simulated: budget,
            survivors: kept.len(),
            ranges: ranges.clone(),
        });
        if kept.is_empty() {
            out.stopped_early = true;
            break;
        }
        out.ranges = ranges;
        out.survivors = kept.len();
        seeds = kept;
    }
    Ok(finish(out, t0, identifier))
}

/// Stamps the time and writes the summary and the maintenance hint.
fn finish(mut out: Refinement, t0: std::time::Instant, identifier: &Identifier) -> Refinement {
    out.time_ms = t0.elapsed().as_secs_f64() * 1e3;
    let s = identifier.settings();
    let rounds = out.rounds.len();
    out.summary = match (&out.ranges, out.rounds.is_empty()) {
        (_, true) => "refinement: nothing to refine (no instance of the bank survives)".into(),
        (None, false) => "refinement: no flat survives".into(),
        (Some(r), false) => {
            let early = if out.stopped_early {
                format!(
                    " (round {rounds} kept none: round {}'s answer stands)",
                    rounds - 1
                )
            } else {
                String::new()
            };
            format!(
                "refined: {} flats survive after {} simulations in {rounds} rounds ({:.1} s){early}: L in [{:.0}, {:.0}] mm, d in [{:.2}, {:.2}] mm, L0 in [{:.0}, {:.0}] mm, X_p in [{:.3}, {:.3}] m.",
                out.survivors, out.simulations, out.time_ms / 1e3,
                r.length_mm[0], r.length_mm[1], r.depth_mm[0], r.depth_mm[1],
                r.l0_mm[0], r.l0_mm[1], r.impact_position_m[0], r.impact_position_m[1]
            )
        }
    };
    out.maintenance_hint = match &out.ranges {
        Some(r) if !out.rounds.is_empty() => format!(
            "refined verdict: {}",
            super::Severity::maintenance_hint(Some(r.l0_mm[1]), s)
        ),
        _ => "refined verdict: none; the bank-only verdict stands.".into(),
    };
    out
}

/// Simulates `flats` (in lockstep batches sorted by their first strike, on the rayon pool)
/// and returns each one's values at the comparison points, in the order given.
fn simulate_at(
    sim: &Simulator,
    cmp: &Comparison,
    flats: &[(Flat, [f64; 4], WheelPosition)],
) -> Result<Vec<Vec<f32>>, IdentifyError> {
    let mut order: Vec<usize> = (0..flats.len()).collect();
    let keys: Vec<f64> = flats.iter().map(|f| batch_key(sim, Some(&f.0))).collect();
    order.sort_by(|&a, &b| keys[a].total_cmp(&keys[b]).then(a.cmp(&b)));
    let done: Vec<Vec<(usize, Vec<f32>)>> = order
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
                        let g = cmp
                            .at
                            .iter()
                            .map(|&at| {
                                let a = &cmp.axes[at.0];
                                let w = resp.window(at.0, a.first_sample, a.samples);
                                Comparison::value(at, |j| (w[j] / 1e3) as f32)
                            })
                            .collect();
                        Ok((k, g))
                    })
                    .collect::<Result<Vec<_>, IdentifyError>>()
            },
        )
        .collect::<Result<_, _>>()?;
    let mut out = vec![Vec::new(); flats.len()];
    for (k, g) in done.into_iter().flatten() {
        out[k] = g;
    }
    Ok(out)
}

/// `budget` new flats, an even share uniform in every seed's cell (the rest to the first
/// seeds), on the seed's wheel, clamped to the population with c < d/2.
fn sample_in_cells(
    seeds: &[Member],
    budget: usize,
    pop: &PopulationParams,
    state: &mut u64,
) -> Vec<(Flat, [f64; 4], WheelPosition)> {
    (0..budget)
        .map(|j| {
            let s = &seeds[j % seeds.len()];
            loop {
                let mut u = |t: usize, r: [f64; 2]| {
                    let v = s.x[t] + s.half[t] * (2.0 * uniform(state) - 1.0);
                    v.clamp(r[0], r[1])
                };
                let l = u(0, pop.length_mm);
                let d = u(1, pop.depth_mm);
                let c = u(2, [pop.curvature_mm[0], pop.curvature_mm[1].min(0.499 * d)]);
                let xp = u(3, pop.impact_position_m);
                if let Ok(f) = Flat::from_mm(l, d, c, xp) {
                    break (f.on_wheel(s.wheel), [l, d, c, xp], s.wheel);
                }
            }
        })
        .collect()
}

/// How far each member lies outside its band at the worst comparison point, in half-widths
/// of the measured force's thresholds there (≤ 0: it passes every point with no widening,
/// κ = 0, judged as falsification judges: the prediction's own thresholds where it is the
/// larger force).
fn misfit(cmp: &Comparison, members: &[Member]) -> Vec<f64> {
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

/// The witness refinement ([`RefineMode::Witnesses`]): a search in every bank cell for the
/// flats closest to passing (each round samples around the cell's best flat so far in a box
/// half as wide as the round before), then a last round around the witnesses at the ends of
/// L and d, where the answer's bounds are decided.
#[allow(clippy::too_many_arguments)]
fn witnesses(
    sim: &Simulator,
    cmp: &Comparison,
    bank_seeds: Vec<Member>,
    settings: RefineSettings,
    margin: f64,
    state: &mut u64,
    out: &mut Refinement,
    pop: &PopulationParams,
    radius: f64,
) -> Result<(), IdentifyError> {
    let cells_n = bank_seeds.len();
    let mut all: Vec<Member> = bank_seeds.clone();
    let mut score = misfit(cmp, &all);
    // Per bank cell: the best flat so far (index into `all`) and the search box.
    let mut best: Vec<usize> = (0..cells_n).collect();
    let mut boxes: Vec<[f64; 4]> = bank_seeds.iter().map(|m| m.half).collect();
    let mut found: Vec<Member> = Vec::new();
    for round in 0..settings.rounds {
        let budget = settings.simulations / settings.rounds
            + usize::from(round < settings.simulations % settings.rounds);
        let last = round + 1 == settings.rounds && round > 0;
        // Seeds and the bank cell each stands for (None: an end witness).
        let (seeds, owner): (Vec<Member>, Vec<Option<usize>>) = if last && !found.is_empty() {
            let mut s = Vec::new();
            for t in [0, 1] {
                let mut by: Vec<&Member> = found.iter().collect();
                by.sort_by(|a, b| a.x[t].total_cmp(&b.x[t]));
                let q = (found.len() / 10).max(1);
                s.extend(
                    by[..q]
                        .iter()
                        .chain(by[by.len() - q..].iter())
                        .map(|m| (*m).clone()),
                );
            }
            let n = s.len();
            (s, vec![None; n])
        } else {
            (0..cells_n)
                .map(|j| {
                    (
                        Member {
                            half: boxes[j],
                            ..all[best[j]].clone()
                        },
                        Some(j),
                    )
                })
                .unzip()
        };
        let flats = sample_in_cells(&seeds, budget, pop, state);
        let predictions = simulate_at(sim, cmp, &flats)?;
        out.simulations += flats.len();
        let first = all.len();
        for ((_, x, wheel), g) in flats.into_iter().zip(predictions) {
            all.push(Member {
                x,
                wheel,
                half: [0.0; 4],
                g,
            });
        }
        score.extend(misfit(cmp, &all[first..]));
        for (j, k) in (first..all.len()).enumerate() {
            if let Some(c) = owner[j % owner.len()] {
                if score[k] < score[best[c]] {
                    best[c] = k;
                }
            }
        }
        for b in &mut boxes {
            *b = b.map(|h| 0.5 * h);
        }
        let cells = local_cells(&all);
        found = (0..all.len())
            .filter(|&i| score[i] <= 0.0)
            .map(|i| Member {
                half: cells.half_extent(i).map(|h| h * margin),
                ..all[i].clone()
            })
            .collect();
        out.rounds.push(RefineRound {
            simulated: budget,
            survivors: found.len(),
            ranges: ranges_of(&found, pop, radius),
        });
    }
    if found.is_empty() {
        out.stopped_early = true;
        return Ok(());
    }
    out.survivors = found.len();
    out.ranges = ranges_of(&found, pop, radius);
    Ok(())
}

/// The cells of a local population: its [`NEIGHBOURS`] nearest members on the same wheel, in
/// the stretched metric of [`crate::bank::neighbours::cell_weights`] over the population's
/// own box (sensitivity per mm × the box's span along each axis).
fn local_cells(members: &[Member]) -> Cells {
    let coords: Vec<[f64; 4]> = members.iter().map(|m| m.x).collect();
    let mut neighbours = vec![0u32; members.len() * NEIGHBOURS];
    for wheel in [WheelPosition::Leading, WheelPosition::Trailing] {
        let idx: Vec<usize> = (0..members.len())
            .filter(|&i| members[i].wheel == wheel)
            .collect();
        if idx.is_empty() {
            continue;
        }
        let lo: [f64; 4] =
            std::array::from_fn(|t| idx.iter().map(|&i| coords[i][t]).fold(f64::MAX, f64::min));
        let hi: [f64; 4] =
            std::array::from_fn(|t| idx.iter().map(|&i| coords[i][t]).fold(f64::MIN, f64::max));
        // X_p is in metres, the sensitivities per millimetre.
        let mm = [1.0, 1.0, 1.0, 1e3];
        let weights: [f64; 4] =
            std::array::from_fn(|t| (SENSITIVITY_PER_MM[t] * (hi[t] - lo[t]) * mm[t]).max(1e-6));
        let unit: Vec<[f64; 4]> = idx
            .iter()
            .map(|&i| {
                std::array::from_fn(|t| {
                    if hi[t] > lo[t] {
                        (coords[i][t] - lo[t]) / (hi[t] - lo[t])
                    } else {
                        0.0
                    }
                })
            })
            .collect();
        let graph = nearest_weighted(&unit, weights, NEIGHBOURS);
        for (a, &i) in idx.iter().enumerate() {
            for t in 0..NEIGHBOURS {
                neighbours[i * NEIGHBOURS + t] = idx[graph[a * NEIGHBOURS + t] as usize] as u32;
            }
        }
    }
    Cells::from_neighbours(neighbours, coords)
}

/// The union of the members' cells, clamped to the population, L0 from the depth bounds.
fn ranges_of(members: &[Member], pop: &PopulationParams, radius_m: f64) -> Option<ParamRanges> {
    if members.is_empty() {
        return None;
    }
    let span = |t: usize, clamp: [f64; 2]| {
        let [lo, hi] = members.iter().fold([f64::MAX, f64::MIN], |[lo, hi], m| {
            [lo.min(m.x[t] - m.half[t]), hi.max(m.x[t] + m.half[t])]
        });
        [lo.max(clamp[0]), hi.min(clamp[1])]
    };
    let depth_mm = span(1, pop.depth_mm);
    let mut wheels: Vec<WheelPosition> = Vec::new();
    for w in [WheelPosition::Leading, WheelPosition::Trailing] {
        if members.iter().any(|m| m.wheel == w) {
            wheels.push(w);
        }
    }
    Some(ParamRanges {
        length_mm: span(0, pop.length_mm),
        depth_mm,
        curvature_mm: span(2, pop.curvature_mm),
        impact_position_m: span(3, pop.impact_position_m),
        l0_mm: [
            Flat::fresh_length_mm(depth_mm[0], radius_m),
            Flat::fresh_length_mm(depth_mm[1], radius_m),
        ],
        flat_wheels: wheels,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::uncertainty::CombinedUncertainty;

    /// The witness test (`misfit ≤ 0`) is falsification at κ = 0: the same flats pass, on
    /// predictions spread across the band's edges, above and below the measurement.
    #[test]
    fn a_witness_is_what_falsification_keeps_with_no_widening() {
        let u = CombinedUncertainty::new(&crate::model::Calibration::default().identification);
        let p = 0.995;
        let measured = vec![20.0, 35.0, 5.0];
        let cmp = Comparison {
            axes: Vec::new(),
            at: vec![(0, 0, 0, None); 3],
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
            })
            .collect();
        let score = misfit(&cmp, &members);
        let columns: Vec<Vec<f32>> = (0..3)
            .map(|q| members.iter().map(|m| m.g[q]).collect())
            .collect();
        let points: Vec<Point> = (0..3)
            .map(|q| Point {
                predictions: &columns[q],
                measured_kn: cmp.measured[q],
                low_kn: cmp.thresholds[q].0,
                high_kn: cmp.thresholds[q].1,
                curve: Some(&cmp.curves[q]),
            })
            .collect();
        let kept = falsify(&points, None);
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
    fn a_window_value_is_the_sample_or_the_window_extreme() {
        let series = [1.0f32, 4.0, -2.0, 3.0];
        let at = |kind| (0, 0, 3, kind);
        assert_eq!(Comparison::value((0, 2, 2, None), |j| series[j]), -2.0);
        assert_eq!(Comparison::value(at(Some(true)), |j| series[j]), 4.0);
        assert_eq!(Comparison::value(at(Some(false)), |j| series[j]), -2.0);
    }
}
