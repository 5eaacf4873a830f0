//! Restarting a joint fit from another flat. The flat-only fit absorbs what it can of a missing
//! effect: a speed deviation stretches the series, an out-of-round wheel adds a tone, and the
//! flat that fits best *without* the effect may sit far from the true one — its impact position
//! a strike's oscillation period away, L or d on a population bound. Every later fit starts
//! from that flat and Levenberg–Marquardt, a local method, stays in its basin (the misfit's
//! basin in X_p is about ±10 mm wide). So each joint fit also tries a second start, found with
//! the effects held: first the impact position, every [`XP_STEP_M`] over the fit's X_p range
//! (L, d and c as fitted), then a [`GRID`] × [`GRID`] grid over the population's L and d at
//! the best position — when it fits better than the fit's own start.

use super::fit::{Fitted, FlatVector, Param};
use rayon::prelude::*;

/// Grid points per flat dimension (L and d).
pub(crate) const GRID: usize = 5;
/// Step of the impact-position scan (m): within the ±10 mm basin measured.
pub(crate) const XP_STEP_M: f64 = 0.01;

/// The restart (an apparent flat vector) that fits best under `chi2_of` (χ² of an apparent
/// flat vector, the effects held), when it fits better than `chi2_now`; `start` gives c (and
/// L, d for the position scan).
pub(crate) fn flat_restart(
    flat_params: &[Param],
    start: FlatVector,
    chi2_now: f64,
    chi2_of: &(dyn Fn(&FlatVector) -> f64 + Sync),
) -> Option<FlatVector> {
    let best = |points: Vec<FlatVector>| {
        points
            .par_iter()
            .map(|v| (chi2_of(v), *v))
            .filter(|(chi2, _)| chi2.is_finite())
            .min_by(|a, b| a.0.total_cmp(&b.0))
    };
    let xp = &flat_params[3];
    let scan: Vec<FlatVector> = (0..)
        .map(|k| xp.lo + k as f64 * XP_STEP_M)
        .take_while(|&x| x <= xp.hi + 1e-9)
        .map(|x| [start[0], start[1], start[2], x])
        .collect();
    let at = best(scan).map_or(start[3], |(_, v)| v[3]);
    let level = |p: &Param, i: usize| p.lo + (i as f64 + 0.5) / GRID as f64 * (p.hi - p.lo);
    let mut grid: Vec<FlatVector> = (0..GRID * GRID)
        .map(|k| {
            let (i, j) = (k / GRID, k % GRID);
            [
                level(&flat_params[0], i),
                level(&flat_params[1], j),
                start[2],
                at,
            ]
        })
        .collect();
    grid.push([start[0], start[1], start[2], at]);
    best(grid)
        .filter(|(chi2, _)| *chi2 < chi2_now)
        .map(|(_, v)| v)
}

/// The better of two fits `from` an apparent flat: from `start`, and from [`flat_restart`]'s
/// restart when there is one.
pub(crate) fn fit_with_restart(
    flat_params: &[Param],
    start: FlatVector,
    chi2_now: f64,
    chi2_of: &(dyn Fn(&FlatVector) -> f64 + Sync),
    from: impl Fn(FlatVector) -> Option<Fitted>,
) -> Option<Fitted> {
    let restart = flat_restart(flat_params, start, chi2_now, chi2_of);
    [Some(start), restart]
        .into_iter()
        .flatten()
        .filter_map(from)
        .min_by(|a, b| a.eval.chi2.total_cmp(&b.eval.chi2))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> Vec<Param> {
        vec![
            Param::new("L", 40.0, 80.0, 0.1),
            Param::new("d", 0.3, 0.6, 0.001),
            Param::new("c", 0.0, 0.98, 0.002),
            Param::new("X_p", 12.0, 13.0, 1e-4),
        ]
    }

    #[test]
    fn the_position_then_the_grid_point_nearest_the_minimum_are_returned() {
        // A narrow valley in X_p at 12.43 (a basin ±10 mm wide), a bowl at L 70, d 0.35: the
        // scan finds 12.43, the grid's levels are 44, 52, 60, 68, 76 and 0.33, 0.39, …
        let chi2 = |v: &FlatVector| {
            let valley = if (v[3] - 12.43).abs() < 0.006 {
                0.0
            } else {
                1e6
            };
            valley + (v[0] - 70.0).powi(2) + 1e4 * (v[1] - 0.35).powi(2)
        };
        let start = [45.0, 0.55, 0.4, 12.51];
        let r = flat_restart(&params(), start, chi2(&start), &chi2).unwrap();
        assert!((r[0] - 68.0).abs() < 1e-9, "{r:?}");
        assert!((r[1] - 0.33).abs() < 1e-9, "{r:?}");
        assert!((r[3] - 12.43).abs() < 1e-9, "{r:?}");
        assert!((r[2] - 0.4).abs() < 1e-12, "c is kept: {r:?}");
    }

    #[test]
    fn no_restart_when_nothing_beats_the_start() {
        let chi2 = |v: &FlatVector| {
            (v[0] - 70.0).powi(2) + 1e4 * (v[1] - 0.35).powi(2) + 1e4 * (v[3] - 12.43).powi(2)
        };
        let start = [70.0, 0.35, 0.4, 12.43];
        assert!(flat_restart(&params(), start, chi2(&start), &chi2).is_none());
        // Failed simulations (infinite χ²) are never a restart.
        let broken = |_: &FlatVector| f64::INFINITY;
        assert!(flat_restart(&params(), start, 1.0, &broken).is_none());
    }
}
