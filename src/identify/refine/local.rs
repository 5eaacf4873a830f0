//! The local population of a refinement: new flats sampled inside cells, their cells, and the
//! ranges a set of them stands for.

use super::Member;
use crate::bank::neighbours::{nearest_weighted, SENSITIVITY_PER_MM};
use crate::identify::answer::result::ParamRanges;
use crate::identify::domain::cells::{Cells, NEIGHBOURS};
use crate::identify::domain::uncertainty::uniform;
use crate::model::calibration::PopulationParams;
use crate::model::{Flat, WheelPosition};

/// `budget` new flats, an even share uniform in every seed's cell (the rest to the first
/// seeds), on the seed's wheel, clamped to the population with c < d/2.
pub(super) fn sample_in_cells(
    seeds: &[Member],
    budget: usize,
    pop: &PopulationParams,
    state: &mut u64,
) -> Vec<(Flat, [f64; 4], WheelPosition)> {
    (0..budget)
        .map(|j| draw_in_cell(&seeds[j % seeds.len()], [-1.0, 1.0], pop, state))
        .collect()
}

/// One new flat uniform in `s`'s cell, d drawn over `d_span` of it (in half-extents from its
/// flat: `[-1, 1]` the whole cell, `[0, 1]` the deeper half), on `s`'s wheel, clamped to the
/// population with c < d/2.
pub(super) fn draw_in_cell(
    s: &Member,
    d_span: [f64; 2],
    pop: &PopulationParams,
    state: &mut u64,
) -> (Flat, [f64; 4], WheelPosition) {
    loop {
        let mut u = |t: usize, r: [f64; 2], [from, to]: [f64; 2]| {
            let v = s.x[t] + s.half[t] * (from + (to - from) * uniform(state));
            v.clamp(r[0], r[1])
        };
        let l = u(0, pop.length_mm, [-1.0, 1.0]);
        let d = u(1, pop.depth_mm, d_span);
        let c = u(
            2,
            [pop.curvature_mm[0], pop.curvature_mm[1].min(0.499 * d)],
            [-1.0, 1.0],
        );
        let xp = u(3, pop.impact_position_m, [-1.0, 1.0]);
        if let Ok(f) = Flat::from_mm(l, d, c, xp) {
            break (f.on_wheel(s.wheel), [l, d, c, xp], s.wheel);
        }
    }
}

/// The cells of a local population: its [`NEIGHBOURS`] nearest members on the same wheel, in
/// the stretched metric of [`crate::bank::neighbours::cell_weights`] over the population's
/// own box (sensitivity per mm × the box's span along each axis).
pub(super) fn local_cells(members: &[Member]) -> Cells {
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
pub(super) fn ranges_of<'a>(
    members: impl Iterator<Item = &'a Member> + Clone,
    pop: &PopulationParams,
    radius_m: f64,
) -> Option<ParamRanges> {
    members.clone().next()?;
    let span = |t: usize, clamp: [f64; 2]| {
        let [lo, hi] = members.clone().fold([f64::MAX, f64::MIN], |[lo, hi], m| {
            [lo.min(m.x[t] - m.half[t]), hi.max(m.x[t] + m.half[t])]
        });
        [lo.max(clamp[0]), hi.min(clamp[1])]
    };
    let depth_mm = span(1, pop.depth_mm);
    let mut wheels: Vec<WheelPosition> = Vec::new();
    for w in [WheelPosition::Leading, WheelPosition::Trailing] {
        if members.clone().any(|m| m.wheel == w) {
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
        impact: None,
    })
}
