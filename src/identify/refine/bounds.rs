//! The L0 bounds settled by simulation (docs/identification.md, "Bounds settled"):
//! instead of spreading the simulations over every surviving cell, each round simulates only
//! inside the cells that decide the answer's L0 bounds — the survivors whose cells reach
//! deepest and shallowest in d (L0 = √(8 d R) follows d alone) — in the half of the cell that
//! lies beyond the survivor, and judges the whole local population again. Every flat
//! simulated stays in the population, kept or ruled out, so a survivor's cell reaches only
//! half-way to its nearest simulated neighbours: where the set of flats that fit ends, its
//! edge is bisected round by round, and the union of the surviving cells shrinks towards the
//! set itself while the cell rule (κ × the spread across each cell) still stands for the flats
//! between members.
//!
//! Stopping rule: the answer's L0 bounds moved by at most `tolerance_mm` over
//! [`CALM_ROUNDS`] consecutive rounds (settled), or the budget is spent (said in the result).
//!
//! The first population is the bank's survivors **and their bank neighbours** (their stored
//! predictions, read with the survivors'), so each survivor's first local cell is its bank
//! cell and nothing is lost between the bank-only answer and the first round.

use super::judge::Judge;
use super::judge::Round;
use super::local::{draw_in_cell, ranges_of, sample_in_cells};
use super::points::{simulate_at, Comparison};
use super::{Member, RefineRound};
use crate::identify::answer::result::ParamRanges;
use crate::identify::error::IdentifyError;
use crate::model::calibration::PopulationParams;
use crate::model::{Flat, Simulator, WheelPosition};

/// Rounds in a row whose L0 bounds moved by at most the tolerance before the bounds are
/// taken as settled.
pub const CALM_ROUNDS: usize = 2;
/// Cells sampled at each bound per round (the survivors whose cells reach farthest).
pub const DECIDING_CELLS: usize = 4;
/// The most rounds a settling may take (a resource bound beside the simulations').
const MAX_ROUNDS: usize = 64;

/// What settling the bounds did.
pub(super) struct Settled {
    /// The last round judged (its members, cells and survivors).
    pub(super) last: Round,
    /// Every round's record.
    pub(super) rounds: Vec<RefineRound>,
    /// Simulations run.
    pub(super) simulated: usize,
    /// Whether the bounds settled (else the budget or the round limit ended it).
    pub(super) settled: bool,
    /// The answer: the union of the last surviving round's cells.
    pub(super) ranges: Option<ParamRanges>,
    /// The flats that stand for it (the last surviving round's survivors, with their cells).
    pub(super) kept: Vec<Member>,
}

/// Settles the L0 bounds of `population` (see the module docs) with at most `budget`
/// simulations, `per_round` a round; `seeds` are the bank's survivors with their bank cells,
/// sampled while no member fits.
#[allow(clippy::too_many_arguments)]
pub(super) fn settle(
    judge: &Judge,
    sim: &Simulator,
    cmp: &Comparison,
    seeds: &[Member],
    mut population: Vec<Member>,
    budget: usize,
    per_round: usize,
    tolerance_mm: f64,
    pop: &PopulationParams,
    radius_m: f64,
    state: &mut u64,
) -> Result<Settled, IdentifyError> {
    let mut rounds: Vec<RefineRound> = Vec::new();
    let mut simulated = 0usize;
    let mut last_batch = 0usize;
    let mut prev: Option<[f64; 2]> = None;
    let mut calm = 0usize;
    let mut answer: Option<ParamRanges> = None;
    let mut answer_kept: Vec<Member> = Vec::new();
    loop {
        let round = judge.round(population);
        let kept: Vec<&Member> = round
            .alive
            .iter()
            .map(|&k| &round.members[k as usize])
            .collect();
        let ranges = ranges_of(kept.iter().copied(), pop, radius_m);
        rounds.push(RefineRound {
            simulated: last_batch,
            survivors: kept.len(),
            ranges: ranges.clone(),
        });
        let Some(r) = ranges else {
            if answer.is_some() || simulated >= budget || rounds.len() >= MAX_ROUNDS {
                // Nothing kept: the previous round's answer stands (the caller says so).
                return Ok(Settled {
                    last: round,
                    rounds,
                    simulated,
                    settled: false,
                    ranges: answer,
                    kept: answer_kept,
                });
            }
            // No member fits yet (with κ = 0, a bank whose survivors fit only through their
            // cells): a round spread over the bank's surviving cells looks for flats that do.
            let n = per_round.min(budget - simulated);
            let flats = sample_in_cells(seeds, n, pop, state);
            last_batch = flats.len();
            simulated += flats.len();
            population = round.members;
            population.extend(simulated_members(judge, sim, cmp, flats)?);
            continue;
        };
        if let Some(p) = prev {
            let moved = (r.l0_mm[0] - p[0]).abs().max((r.l0_mm[1] - p[1]).abs());
            calm = if moved <= tolerance_mm { calm + 1 } else { 0 };
        }
        prev = Some(r.l0_mm);
        answer = Some(r);
        answer_kept = kept.iter().map(|&m| m.clone()).collect();
        let settled = calm >= CALM_ROUNDS;
        if settled || simulated >= budget || rounds.len() >= MAX_ROUNDS {
            return Ok(Settled {
                last: round,
                rounds,
                simulated,
                settled,
                ranges: answer,
                kept: answer_kept,
            });
        }
        let n = per_round.min(budget - simulated);
        let flats = sample_beyond(&kept, n, pop, state);
        simulated += flats.len();
        last_batch = flats.len();
        population = round.members;
        population.extend(simulated_members(judge, sim, cmp, flats)?);
    }
}

/// `flats` simulated at the comparison points, as members of the local population.
pub(super) fn simulated_members(
    judge: &Judge,
    sim: &Simulator,
    cmp: &Comparison,
    flats: Vec<(Flat, [f64; 4], WheelPosition)>,
) -> Result<Vec<Member>, IdentifyError> {
    let predictions = simulate_at(sim, cmp, &flats)?;
    Ok(flats
        .into_iter()
        .zip(predictions)
        .map(|((_, x, wheel), (g, steps, peak_kn))| Member {
            x,
            wheel,
            half: [0.0; 4],
            g,
            steps,
            share: judge.identifier.discretisation_share(peak_kn),
        })
        .collect())
}

/// `n` new flats in the cells that decide the L0 bounds: half at the upper bound (the
/// [`DECIDING_CELLS`] survivors whose cells reach deepest, d drawn between the survivor's and
/// its cell's top), half at the lower (shallowest, d between the cell's bottom and the
/// survivor's); L, c and X_p uniform over the cell, clamped to the population, c < d/2, on the
/// survivor's wheel. A cell that reaches no farther than the deepest (shallowest) survivor
/// itself is resolved and not sampled while another is not.
fn sample_beyond(
    kept: &[&Member],
    n: usize,
    pop: &PopulationParams,
    state: &mut u64,
) -> Vec<(Flat, [f64; 4], WheelPosition)> {
    // `sign` +1: the upper bound (reach x_d + half_d, past the deepest flat); −1: the lower.
    let deciding = |sign: f64| -> Vec<&Member> {
        let reach = |m: &Member| sign * (m.x[1] + sign * m.half[1]);
        let hull = kept.iter().map(|m| sign * m.x[1]).fold(f64::MIN, f64::max);
        let mut by: Vec<&Member> = kept.to_vec();
        by.sort_by(|a, b| reach(b).total_cmp(&reach(a)));
        let beyond = by.iter().take_while(|m| reach(m) > hull).count();
        by.truncate(beyond.clamp(1, DECIDING_CELLS));
        by
    };
    let ends = [deciding(1.0), deciding(-1.0)];
    (0..n)
        .map(|j| {
            // Even draws at the upper bound, in the deeper half; odd at the lower, the shallower.
            let (cells, d_span) = match j % 2 {
                0 => (&ends[0], [0.0, 1.0]),
                _ => (&ends[1], [-1.0, 0.0]),
            };
            draw_in_cell(cells[(j / 2) % cells.len()], d_span, pop, state)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Calibration;

    fn member(x: [f64; 4], half: [f64; 4]) -> Member {
        Member {
            x,
            wheel: WheelPosition::Trailing,
            half,
            g: Vec::new(),
            steps: Vec::new(),
            share: 0.0,
        }
    }

    /// The new flats go into the cells that reach past the deepest and the shallowest kept
    /// flat, in the half of each cell beyond its own flat, and into no other cell.
    #[test]
    fn new_flats_go_beyond_the_deciding_cells_only() {
        let pop = Calibration::default().population;
        let h = [2.0, 0.05, 0.01, 0.002];
        // Depths 0.30 … 0.60 mm; the middle flats' cells reach past neither end.
        let kept: Vec<Member> = [0.30, 0.40, 0.45, 0.50, 0.60]
            .iter()
            .map(|&d| member([60.0, d, 0.05, 12.5], h))
            .collect();
        let refs: Vec<&Member> = kept.iter().collect();
        let mut state = 7u64;
        let flats = sample_beyond(&refs, 40, &pop, &mut state);
        assert_eq!(flats.len(), 40);
        for (j, (_, x, wheel)) in flats.iter().enumerate() {
            assert_eq!(*wheel, WheelPosition::Trailing);
            // Even draws at the upper bound: d in [0.60, 0.65]; odd at the lower: [0.25, 0.30].
            let (lo, hi) = if j % 2 == 0 {
                (0.60, 0.65)
            } else {
                (0.25, 0.30)
            };
            assert!(
                x[1] >= lo - 1e-12 && x[1] <= hi + 1e-12,
                "flat {j}: d {} outside [{lo}, {hi}]",
                x[1]
            );
            assert!((x[0] - 60.0).abs() <= 2.0 + 1e-9, "L {}", x[0]);
            assert!((x[3] - 12.5).abs() <= 0.002 + 1e-12, "X_p {}", x[3]);
            assert!(x[2] < 0.5 * x[1], "c < d/2");
        }
    }

    /// A cell that reaches farther than the deepest flat although its own flat is shallower
    /// decides the bound too, and is sampled; at most [`DECIDING_CELLS`] cells a bound.
    #[test]
    fn a_wide_cell_below_the_deepest_flat_decides_the_bound() {
        let pop = Calibration::default().population;
        let narrow = [2.0, 0.01, 0.01, 0.002];
        let wide = [2.0, 0.2, 0.01, 0.002];
        let kept = [
            member([60.0, 0.50, 0.05, 12.5], narrow),
            member([90.0, 0.45, 0.05, 12.6], wide),
            member([60.0, 0.40, 0.05, 12.5], narrow),
        ];
        let refs: Vec<&Member> = kept.iter().collect();
        let mut state = 3u64;
        let flats = sample_beyond(&refs, 16, &pop, &mut state);
        // Upper bound: the wide cell (reach 0.65) and the deepest flat's (0.51) both pass
        // the deepest flat (0.50); alternating between them.
        let upper: Vec<f64> = flats.iter().step_by(2).map(|f| f.1[0]).collect();
        assert!(upper.iter().any(|&l| (l - 90.0).abs() <= 2.0));
        assert!(upper.iter().any(|&l| (l - 60.0).abs() <= 2.0));
    }
}
