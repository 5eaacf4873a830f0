//! The witness search ([`super::RefineMode::Witnesses`]): a measuring instrument for studies.

use super::local::{local_cells, ranges_of, sample_in_cells};
use super::points::{misfit, simulate_at, Comparison};
use super::{Member, RefineRound, RefineSettings, Refinement};
use crate::identify::IdentifyError;
use crate::model::calibration::PopulationParams;
use crate::model::Simulator;

/// The witness refinement ([`RefineMode::Witnesses`]): a search in every bank cell for the
/// flats closest to passing (each round samples around the cell's best flat so far in a box
/// half as wide as the round before), then a last round around the witnesses at the ends of
/// L and d, where the answer's bounds are decided.
#[allow(clippy::too_many_arguments)]
pub(super) fn witnesses(
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
        for ((_, x, wheel), (g, steps, _)) in flats.into_iter().zip(predictions) {
            // (Witnesses are judged at κ = 0 by their misfit, with no discretisation share.)
            all.push(Member {
                x,
                wheel,
                half: [0.0; 4],
                g,
                steps,
                share: 0.0,
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
