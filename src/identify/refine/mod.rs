//! Refinement (opt-in `identify --refine`): simulate new flats inside the surviving
//! cells with the bank's calibration and falsify them at the same comparison points, so the
//! answer is resolved where the measurement is informative instead of at the bank's spacing.
//!
//! Why: with direct simulation and no cell widening, the flats a measurement cannot rule out
//! span a few millimetres of L0 (`studies/src/bin/oracle_study`), while the bank's cells are ~14 mm of
//! L and ~0.13 mm of d wide (docs/identification.md). The bank-only answer is the union of its
//! surviving cells; refinement samples those cells more densely, in rounds:
//!
//! 1. the seeds are the bank's survivors, each with its cell (half-way to its farthest
//!    neighbour in the stretched metric, [`super::domain::cells`]);
//! 2. each round simulates its share of the budget uniformly inside the seeds' cells (the
//!    flat on the seed's wheel; L, d, c, X_p clamped to the population, c < d/2), the seeds
//!    whose cells reach deepest or shallowest in d four times as often as the others (the L0
//!    bounds are decided there);
//! 3. the new flats and the seeds form a local population: neighbours in the same stretched
//!    metric (sensitivities per mm × the local box), cells as in the bank, the same
//!    falsification at the same points and thresholds (EIP and envelope points, per-point
//!    probability of the bank-only answer, thresholds at the prediction's force) with the same
//!    κ, then, with `shared_gains`, the same shared-gain stage at every PIP candidate and
//!    envelope point (one gain per sensor, [`super::domain::shared_gain`]);
//! 4. its survivors are the next round's seeds; the answer is the union of the last round's
//!    surviving cells. A round with no survivor ends the refinement and the previous round's
//!    answer stands (said in the result).
//!
//! The budget is a number of simulations (deterministic: same inputs, same answer on any
//! thread count), not a time; 640 simulations take about 1.2 s on 2 cores.
//!
//! Two studied variants were taken out of the product (their figures, in
//! docs/severity.md and docs/decisions.md, were measured at commit 1e7f4f2 with
//! `examples/refine_study.rs`, now `studies/src/bin/refine_study.rs`): a witness search
//! (flats that pass every point with no widening; coverage 0.78–0.83 on 100 cases) and a last
//! round judged at every sample of the record (severity right 0.73 against 0.63, coverage
//! 0.80–0.87 on the finer-model cases).

mod bounds;
mod judge;
mod landing;
mod local;
mod points;

use super::answer::identification::Identification;
pub use super::answer::refinement::{RefineRound, RefineStrategy, Refinement};
use super::domain::falsify::largest_step;
use crate::identify::error::IdentifyError;
use crate::identify::identifier::Identifier;
use crate::model::{Flat, Simulator, WheelPosition};
pub use bounds::{CALM_ROUNDS, DECIDING_CELLS};
use judge::Judge;
use local::{ranges_of, sample_in_cells};
use points::Comparison;

/// The most simulations one refinement may ask for (a resource bound: 20,000 take about
/// 40 s on 2 cores).
pub const MAX_SIMULATIONS: usize = 20_000;
/// [`MAX_SIMULATIONS`] as a range in words.
const SIMULATIONS_RANGE: &str = "1–20000";

/// How much refinement to do.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefineSettings {
    /// How the simulations are spent: spread over every surviving cell in `rounds` rounds,
    /// or at the cells that decide the L0 bounds until they stop moving.
    pub strategy: RefineStrategy,
    /// Simulations in all (1–[`MAX_SIMULATIONS`]): split evenly over the rounds (spread), or
    /// the most the bounds may take (bounds).
    pub simulations: usize,
    /// Rounds of the spread strategy (1–8).
    pub rounds: usize,
    /// Simulations a round of the bounds strategy (8–1024).
    pub per_round: usize,
    /// The bounds strategy stops when neither L0 bound moved by more than this over
    /// [`CALM_ROUNDS`] rounds in a row (mm; 0.05–10).
    pub tolerance_mm: f64,
    /// Seed of the sampling inside the cells.
    pub seed: u64,
    /// κ of the local cells (`None`: the identification's `bank_resolution` when spreading,
    /// its `refine_resolution` when settling the bounds).
    pub kappa: Option<f64>,
    /// Each round, the seeds whose cells reach deepest or shallowest in d (an eighth of them
    /// at each end, at least one) are sampled this many times as often as the others: the
    /// answer's L0 bounds are decided there (1: an even share; 1–16; default 4, measured in
    /// docs/performance.md, "Refinement").
    pub ends_weight: usize,
    /// Simulations on the landings calibration that check the landing flats at the L0 bounds
    /// without the landing allowance ([`landing`]; 0: none; 0–256; `None`: the settings'
    /// `refine_landings`).
    pub landings: Option<usize>,
}

impl Default for RefineSettings {
    fn default() -> Self {
        RefineSettings {
            strategy: RefineStrategy::Bounds,
            simulations: 640,
            rounds: 2,
            per_round: 64,
            tolerance_mm: 0.5,
            seed: 1,
            kappa: None,
            ends_weight: 4,
            landings: None,
        }
    }
}

impl RefineSettings {
    /// Checks the ranges: a refusal names the setting and its value.
    pub fn check(&self) -> Result<(), IdentifyError> {
        if !(1..=MAX_SIMULATIONS).contains(&self.simulations) {
            return Err(IdentifyError::Setting {
                setting: "simulations",
                value: self.simulations.to_string(),
                range: SIMULATIONS_RANGE,
            });
        }
        if let Some(k) = self
            .kappa
            .filter(|k| !(k.is_finite() && (0.0..=10.0).contains(k)))
        {
            return Err(IdentifyError::Setting {
                setting: "kappa",
                value: k.to_string(),
                range: "0–10",
            });
        }
        if !(1..=16).contains(&self.ends_weight) {
            return Err(IdentifyError::Setting {
                setting: "ends weight",
                value: self.ends_weight.to_string(),
                range: "1–16",
            });
        }
        if let Some(l) = self.landings.filter(|&l| l > 256) {
            return Err(IdentifyError::Setting {
                setting: "landing simulations",
                value: l.to_string(),
                range: "0–256",
            });
        }
        if !(8..=1024).contains(&self.per_round) {
            return Err(IdentifyError::Setting {
                setting: "simulations a round",
                value: self.per_round.to_string(),
                range: "8–1024",
            });
        }
        if !(self.tolerance_mm.is_finite() && (0.05..=10.0).contains(&self.tolerance_mm)) {
            return Err(IdentifyError::Setting {
                setting: "bound tolerance (mm)",
                value: self.tolerance_mm.to_string(),
                range: "0.05–10",
            });
        }
        if !(1..=8).contains(&self.rounds) {
            return Err(IdentifyError::Setting {
                setting: "rounds",
                value: self.rounds.to_string(),
                range: "1–8",
            });
        }
        Ok(())
    }
}

/// A flat of the local population with its predictions at the comparison points.
#[derive(Debug, Clone)]
pub(super) struct Member {
    /// L (mm), d (mm), c (mm), X_p (m).
    pub(super) x: [f64; 4],
    pub(super) wheel: WheelPosition,
    /// Half-extent of its cell (same units), set once the population's cells are known.
    pub(super) half: [f64; 4],
    /// Predictions at the comparison points, in the order of [`Comparison::points`].
    pub(super) g: Vec<f32>,
    /// Its steps between adjacent samples at the points ([`crate::identify::domain::falsify::Discretisation`]).
    pub(super) steps: Vec<f32>,
    /// Its discretisation share ([`Identifier::discretisation_share`]).
    pub(super) share: f32,
}

/// The simulator of the bank's own calibration, which [`refine`] needs.
pub fn bank_simulator(identifier: &Identifier) -> Result<Simulator, IdentifyError> {
    simulator_of(identifier, |c| c.clone())
}

/// The simulator of a calibration made from the bank's by `make`.
fn simulator_of(
    identifier: &Identifier,
    make: impl Fn(&crate::model::Calibration) -> crate::model::Calibration,
) -> Result<Simulator, IdentifyError> {
    let bank = identifier.bank().metadata();
    make(&bank.calibration)
        .check()
        .map_err(|e| e.to_string())
        .and_then(|c| Simulator::new(&c).map_err(|e| e.to_string()))
        .map_err(|reason| IdentifyError::StoredCalibration {
            bank_id: bank.bank_id.clone(),
            reason,
        })
}

/// Refines an identification made by `identifier` (see the module docs). `sim` must be the
/// bank calibration's simulator ([`bank_simulator`]). An identification with no survivor is returned as it is
/// (nothing to refine).
pub fn refine(
    identifier: &Identifier,
    sim: &Simulator,
    id: &Identification,
    settings: RefineSettings,
) -> Result<Refinement, IdentifyError> {
    refine_from(identifier, sim, id, settings, &[])
}

/// [`refine`], with `anchors` — flats (L, d, c, X_p in mm, mm, mm, m; the wheel) simulated
/// into the first population beside the bank's — for studies that seed it where the truth
/// lies (the floor of docs/identification.md, "Bounds settled": `studies/src/bin/floor_study.rs`). With the spread strategy
/// the anchors are among the first round's seeds.
pub fn refine_from(
    identifier: &Identifier,
    sim: &Simulator,
    id: &Identification,
    settings: RefineSettings,
    anchors: &[([f64; 4], WheelPosition)],
) -> Result<Refinement, IdentifyError> {
    settings.check()?;
    let t0 = std::time::Instant::now();
    let bank = identifier.bank();
    let cal = &bank.metadata().calibration;
    let pop = &cal.population;
    let radius = cal.vehicle.wheel_radius_m;
    // κ of the local cells: the bank's when spreading over its cells, the refinement's own
    // when settling the bounds among simulated neighbours.
    let kappa = settings.kappa.unwrap_or(match settings.strategy {
        RefineStrategy::Spread => identifier.settings().bank_resolution,
        RefineStrategy::Bounds => identifier.settings().refine_resolution,
    });
    let Some(sizing) = id.sizing.as_ref() else {
        let mut out = finish(Refinement::empty(), t0, identifier);
        out.summary =
            "refinement: nothing to refine (no flat detected: the pass was not sized)".into();
        return Ok(out);
    };
    let cmp = Comparison::of(identifier, id, sizing);

    // Seeds: the bank's survivors with their cells and their stored predictions. With a
    // discretisation allowance each point is read over the samples its step spans (a sample
    // point's neighbours too).
    let shares = identifier.discretisation();
    let mut columns: Vec<usize> = Vec::new();
    let mut spans: Vec<(usize, usize, usize)> = Vec::new(); // (first column, first, last sample)
    for &at in &cmp.at {
        let (lo, hi) = if shares.is_some() {
            Comparison::step_span(at, cmp.axes[at.0].samples - 1)
        } else {
            (at.1, at.2)
        };
        spans.push((columns.len(), lo, hi));
        columns.extend((lo..=hi).map(|k| bank.sample_index(at.0, k)));
    }
    let stored = bank.read_columns(&columns)?;
    let params = identifier.params();
    let bank_member = |k: usize| {
        let half = identifier
            .resolution()
            .map_or([0.0; 4], |r| r.cells.half_extent(k));
        let (mut g, mut steps) = (Vec::new(), Vec::new());
        for (&at, &(first, lo, hi)) in cmp.at.iter().zip(&spans) {
            let read = |j: usize| stored[first + j - lo][k];
            g.push(Comparison::value(at, read));
            if shares.is_some() {
                steps.push(largest_step((lo..=hi).map(read)));
            }
        }
        Member {
            x: [
                params.length_mm[k],
                params.depth_mm[k],
                params.curvature_mm[k],
                params.impact_position_m[k],
            ],
            wheel: WheelPosition::from_code(params.flat_wheel[k]),
            half,
            g,
            steps,
            share: shares.map_or(0.0, |d| d[k]),
        }
    };
    let survivors: Vec<usize> = sizing.cms.iter().map(|s| s.instance as usize).collect();
    let mut seeds: Vec<Member> = survivors.iter().map(|&k| bank_member(k)).collect();

    let mut out = Refinement {
        ranges: ranges_of(seeds.iter(), pop, radius),
        survivors: seeds.len(),
        strategy: settings.strategy,
        ..Refinement::empty()
    };
    if seeds.is_empty() {
        return Ok(finish(out, t0, identifier));
    }
    let rough_bounds = id
        .roughness
        .clone()
        .unwrap_or_else(|| crate::identify::detect::roughness::RoughnessUse::none(0.0, 0.0))
        .bounds(identifier.bounds);
    let judge = Judge {
        identifier,
        cmp: &cmp,
        kappa,
        rough_bounds: &rough_bounds,
        shared: !sizing.shared_gains_fallback,
    };
    if !anchors.is_empty() {
        let flats: Vec<(Flat, [f64; 4], WheelPosition)> = anchors
            .iter()
            .filter_map(|&(x, w)| {
                Flat::from_mm(x[0], x[1], x[2], x[3])
                    .ok()
                    .map(|f| (f.on_wheel(w), x, w))
            })
            .collect();
        seeds.extend(simulated(&judge, sim, &cmp, flats, &mut out)?);
    }
    let mut state = settings.seed ^ 0x5DEE_CE66_D1CE_4E5B;
    // The last round's population, for the landing check.
    let mut last: Option<judge::Round> = None;
    match settings.strategy {
        RefineStrategy::Spread => {
            for round in 0..settings.rounds {
                let budget = settings.simulations / settings.rounds
                    + usize::from(round < settings.simulations % settings.rounds);
                let flats = sample_in_cells(
                    &weighted_ends(&seeds, settings.ends_weight),
                    budget,
                    pop,
                    &mut state,
                );
                let mut members: Vec<Member> = std::mem::take(&mut seeds);
                members.extend(simulated(&judge, sim, &cmp, flats, &mut out)?);
                let judged = judge.round(members);
                let kept: Vec<Member> = judged
                    .alive
                    .iter()
                    .map(|&k| judged.members[k as usize].clone())
                    .collect();
                let ranges = ranges_of(kept.iter(), pop, radius);
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
                last = Some(judged);
            }
        }
        RefineStrategy::Bounds => {
            // The survivors' bank neighbours join them: each survivor's first local cell is
            // then its bank cell (bounds.rs).
            let mut population = seeds.clone();
            let mut taken: std::collections::HashSet<usize> = survivors.iter().copied().collect();
            if let Some(r) = identifier.resolution() {
                for &k in &survivors {
                    for &j in r.cells.neighbours(k) {
                        if taken.insert(j as usize) {
                            population.push(bank_member(j as usize));
                        }
                    }
                }
            }
            let done = bounds::settle(
                &judge,
                sim,
                &cmp,
                &seeds,
                population,
                settings.simulations,
                settings.per_round,
                settings.tolerance_mm,
                pop,
                radius,
                &mut state,
            )?;
            out.simulations += done.simulated;
            out.rounds = done.rounds;
            out.bounds_settled = Some(done.settled);
            // A last round that kept nothing lets the round before it stand (said).
            out.stopped_early = done.last.alive.is_empty() && done.ranges.is_some();
            if done.ranges.is_some() {
                out.ranges = done.ranges;
                out.survivors = done.kept.len();
                seeds = done.kept;
            }
            if !done.last.alive.is_empty() {
                last = Some(done.last);
            }
        }
    }
    // Landings resolved by simulation where they decide the bounds (landing.rs).
    let landings = settings
        .landings
        .unwrap_or(identifier.settings().refine_landings);
    if let (Some(round), true) = (
        last.filter(|_| !out.stopped_early),
        landings > 0 && shares.is_some(),
    ) {
        let lsim = simulator_of(identifier, |c| c.with_converged_landings())?;
        let (alive, done) = landing::check(
            identifier,
            &lsim,
            &cmp,
            &round,
            kappa,
            &rough_bounds,
            landings,
        )?;
        out.simulations += done.simulated;
        out.landings_simulated = done.simulated;
        out.landings_removed = done.removed;
        out.landings_settled = Some(done.settled);
        // A check that would leave nothing lets the answer before it stand (a refuted class
        // is diagnose's to name, not the landing check's).
        if !alive.is_empty() {
            seeds = alive
                .iter()
                .map(|&k| round.members[k as usize].clone())
                .collect();
            out.ranges = ranges_of(seeds.iter(), pop, radius);
            out.survivors = seeds.len();
        }
    }
    if out.ranges.is_some() {
        let clamp = [pop.length_mm, pop.depth_mm, pop.curvature_mm];
        out.cells = seeds
            .iter()
            .map(|m| {
                let mut b = [0.0; 6];
                for t in 0..3 {
                    b[2 * t] = (m.x[t] - m.half[t]).max(clamp[t][0]);
                    b[2 * t + 1] = (m.x[t] + m.half[t]).min(clamp[t][1]);
                }
                (b, m.wheel)
            })
            .collect();
        // Where the kept flats themselves lie (no cell): the set's extent resolved so far.
        let [lo, hi] = seeds.iter().fold([f64::MAX, f64::MIN], |[lo, hi], m| {
            [lo.min(m.x[1]), hi.max(m.x[1])]
        });
        out.kept_l0_mm = Some([
            Flat::fresh_length_mm(lo, radius),
            Flat::fresh_length_mm(hi, radius),
        ]);
    }
    Ok(finish(out, t0, identifier))
}

/// `flats` simulated at the comparison points, as members of the local population (counted
/// in `out.simulations`).
fn simulated(
    judge: &Judge,
    sim: &Simulator,
    cmp: &Comparison,
    flats: Vec<(Flat, [f64; 4], WheelPosition)>,
    out: &mut Refinement,
) -> Result<Vec<Member>, IdentifyError> {
    out.simulations += flats.len();
    bounds::simulated_members(judge, sim, cmp, flats)
}

/// `seeds`, with those whose cells reach deepest or shallowest in d repeated so that each
/// appears `weight` times (an eighth of the seeds at each end, at least one).
fn weighted_ends(seeds: &[Member], weight: usize) -> Vec<Member> {
    let mut out = seeds.to_vec();
    if weight <= 1 || seeds.is_empty() {
        return out;
    }
    let q = (seeds.len() / 8).max(1);
    let mut by: Vec<usize> = (0..seeds.len()).collect();
    let mut ends: Vec<usize> = Vec::new();
    by.sort_by(|&a, &b| {
        (seeds[b].x[1] + seeds[b].half[1]).total_cmp(&(seeds[a].x[1] + seeds[a].half[1]))
    });
    ends.extend(&by[..q]);
    by.sort_by(|&a, &b| {
        (seeds[a].x[1] - seeds[a].half[1]).total_cmp(&(seeds[b].x[1] - seeds[b].half[1]))
    });
    ends.extend(
        by[..q]
            .iter()
            .filter(|i| !ends.contains(i))
            .collect::<Vec<_>>(),
    );
    for _ in 1..weight {
        out.extend(ends.iter().map(|&i| seeds[i].clone()));
    }
    out
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
            let landings = if out.landings_simulated > 0 {
                format!(
                    " Landings: {} flats at the L0 bounds simulated on the landings calibration, {} ruled out without the allowance{}.",
                    out.landings_simulated,
                    out.landings_removed,
                    match out.landings_settled {
                        Some([true, true]) | None => "",
                        Some(_) => " (the budget spent before a bound was settled)",
                    }
                )
            } else {
                String::new()
            };
            let settled = match out.bounds_settled {
                Some(true) => ", the L0 bounds settled",
                Some(false) => ", the budget spent before the L0 bounds settled",
                None => "",
            };
            format!(
                "refined: {} flats survive after {} simulations in {rounds} rounds ({:.1} s{settled}){early}: L in [{:.0}, {:.0}] mm, d in [{:.2}, {:.2}] mm, L0 in [{:.0}, {:.0}] mm, X_p in [{:.3}, {:.3}] m.{landings}",
                out.survivors, out.simulations, out.time_ms / 1e3,
                r.length_mm[0], r.length_mm[1], r.depth_mm[0], r.depth_mm[1],
                r.l0_mm[0], r.l0_mm[1], r.impact_position_m[0], r.impact_position_m[1]
            )
        }
    };
    out.severity = match &out.ranges {
        Some(r) if !out.rounds.is_empty() => Some(super::SeverityRange::of_l0(
            r.l0_mm,
            s.urgent_l0_mm,
            s.inspect_l0_mm,
        )),
        _ => None,
    };
    out.maintenance_hint = match (&out.ranges, out.severity) {
        (Some(r), Some(_)) => format!(
            "refined verdict: {}",
            super::Severity::maintenance_hint(Some(r.l0_mm[1]), s)
        ),
        _ => "refined verdict: none; the bank-only verdict stands.".into(),
    };
    out
}
