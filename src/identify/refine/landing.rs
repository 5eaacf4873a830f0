//! Landings resolved by simulation (docs/identification.md, "Landings resolved"):
//! after the rounds, the surviving flats that land — those judged with the bank mesh's
//! landing allowance — are simulated again where it decides the answer, at the L0 bounds, on
//! the landings calibration (`Calibration::with_converged_landings`: the rail refined around
//! the sensors, 4 µs steps; within 4.4 % of the converged reference's peak at the 99th
//! percentile), and judged at every point without the allowance. A bound's flat kept so is
//! settled; one ruled out is dropped and the next one in from that bound is simulated, until
//! a flat is kept, a flat that keeps contact is reached (it needs no allowance) or the budget
//! is spent (the rest keep their allowance).

use super::judge::Round;
use super::points::{simulate_at, Comparison};
use crate::identify::domain::falsify::{falsify, Resolution};
use crate::identify::domain::shared_gain::keep_resolved;
use crate::identify::domain::table_bounds::TableBounds;
use crate::identify::error::IdentifyError;
use crate::identify::identifier::Identifier;
use crate::model::{Flat, Simulator};

/// What the landing check did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(super) struct Checked {
    /// Flats simulated on the landings calibration.
    pub(super) simulated: usize,
    /// Flats ruled out there.
    pub(super) removed: usize,
    /// Whether each bound (lower, upper L0) was settled (a flat kept, or one that keeps
    /// contact reached) within the budget.
    pub(super) settled: [bool; 2],
}

/// Checks `round`'s landing survivors from each L0 bound inwards (see the module docs) with at
/// most `budget` simulations; returns the survivors left and what was done.
#[allow(clippy::too_many_arguments)]
pub(super) fn check(
    identifier: &Identifier,
    sim: &Simulator,
    cmp: &Comparison,
    round: &Round,
    kappa: f64,
    bounds: &TableBounds,
    budget: usize,
) -> Result<(Vec<u32>, Checked), IdentifyError> {
    let mut done = Checked::default();
    let mut alive = round.alive.clone();
    let m = &round.members;
    let res = (kappa > 0.0).then_some(Resolution {
        cells: &round.cells,
        kappa,
    });
    // The population's predictions, each judged flat's put in its place while it is judged.
    let mut columns = round.columns.clone();
    for (end, upper) in [(0, false), (1, true)] {
        loop {
            // From this bound inwards: the flats whose cells reach furthest in d.
            let mut order: Vec<u32> = alive.clone();
            let reach = |k: u32| {
                let x = &m[k as usize];
                if upper {
                    -(x.x[1] + x.half[1])
                } else {
                    x.x[1] - x.half[1]
                }
            };
            order.sort_by(|&a, &b| reach(a).total_cmp(&reach(b)).then(a.cmp(&b)));
            let batch: Vec<u32> = order
                .iter()
                .copied()
                .take_while(|&k| m[k as usize].share > 0.0)
                .take(8.min(budget - done.simulated))
                .collect();
            if batch.is_empty() {
                // A flat that keeps contact holds the bound, or nothing is left to check.
                done.settled[end] = order.first().is_none_or(|&k| m[k as usize].share <= 0.0);
                break;
            }
            let flats: Vec<(Flat, [f64; 4], crate::model::WheelPosition)> = batch
                .iter()
                .map(|&k| {
                    let x = &m[k as usize];
                    let f = Flat::from_mm(x.x[0], x.x[1], x.x[2], x.x[3])
                        .map_err(|e| {
                            IdentifyError::Simulation(crate::model::SimError::Setup(e.to_string()))
                        })?
                        .on_wheel(x.wheel);
                    Ok((f, x.x, x.wheel))
                })
                .collect::<Result<_, IdentifyError>>()?;
            let values = simulate_at(sim, cmp, &flats)?;
            done.simulated += batch.len();
            let mut kept_one = false;
            for (&k, (g, _, _)) in batch.iter().zip(&values) {
                if judge(identifier, cmp, &mut columns, k as usize, g, res, bounds) {
                    kept_one = true;
                } else {
                    alive.retain(|&a| a != k);
                    done.removed += 1;
                }
            }
            if kept_one {
                done.settled[end] = true;
                break;
            }
            if done.simulated >= budget {
                break;
            }
        }
    }
    Ok((alive, done))
}

/// Whether member `k`, predicting `g` at every point of `cmp` (landings calibration), passes
/// every point without the landing allowance (its cell's resolution kept). `columns` are the
/// population's predictions at every point; `k`'s are swapped for `g` while it is judged.
fn judge(
    identifier: &Identifier,
    cmp: &Comparison,
    columns: &mut [Vec<f32>],
    k: usize,
    g: &[f32],
    res: Option<Resolution<'_>>,
    bounds: &TableBounds,
) -> bool {
    let bank_mesh: Vec<f32> = columns.iter().map(|c| c[k]).collect();
    for (c, &v) in columns.iter_mut().zip(g) {
        c[k] = v;
    }
    let kept = {
        let points = cmp.points(columns, 0..cmp.method, &[], None);
        falsify(&points, res).contains(&(k as u32))
    } && (cmp.at.len() == cmp.method || {
        let shared = cmp.shared_points(columns, &[], None, bounds);
        let form = identifier.settings().shared_model_form;
        !keep_resolved(&shared, &[k as u32], bounds, form, res).is_empty()
    });
    for (c, v) in columns.iter_mut().zip(bank_mesh) {
        c[k] = v;
    }
    kept
}
