//! The uncertainty table split into what a site keeps and what changes pass to pass
//! (docs/calibration.md, "The table split"), and the table of a calibrated site: the
//! site-fixed entries replaced by the calibration's residual measured on the site's own
//! held-back passes, never narrower than the scatter those passes show.

use crate::model::calibration::{UncertaintyGroup, UncertaintyKind, UncertaintySource};
use serde::{Deserialize, Serialize};

/// Whether an entry is the same pass after pass at one site.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Scope {
    /// Fixed at a site: track, sensors, the model's form at this track.
    Site,
    /// Drawn afresh each pass: vehicle, load, roughness, noise.
    Pass,
}

/// The name of the entry a calibrated site carries in place of the site-fixed ones.
pub const SITE_RESIDUAL: &str = "site residual";

/// The scope of entry `u`, by its name (docs/calibration.md gives each one's reason). An entry
/// of another name is taken as drawn each pass: calibration never narrows what it does not
/// know to be fixed.
pub fn scope(u: &UncertaintySource) -> Scope {
    match (u.group, u.name.as_str()) {
        (
            UncertaintyGroup::Model,
            "finite element model" | "mesh refinement" | "track calibration" | "additional",
        )
        | (UncertaintyGroup::Measurement, "sensor accuracy") => Scope::Site,
        (_, SITE_RESIDUAL) => Scope::Site,
        _ => Scope::Pass,
    }
}

/// Draws of the relative departure `y/g − 1` the table's per-pass relative entries give one
/// sensor when every sensor's common part is taken off (as a pass's own load takes it), for
/// `sensors` sensors (Monte Carlo, seeded).
pub fn per_pass_draws(table: &[UncertaintySource], sensors: usize, seed: u64) -> Vec<f64> {
    let rel: Vec<&UncertaintySource> = table
        .iter()
        .filter(|u| scope(u) == Scope::Pass && u.kind == UncertaintyKind::Relative)
        .collect();
    let mut state = seed ^ 0x7AB1_E5C0;
    let mut e = Vec::with_capacity(DRAWS * sensors);
    for _ in 0..DRAWS {
        let draw: Vec<f64> = (0..sensors)
            .map(|_| {
                rel.iter()
                    .map(|u| {
                        let x = u.min + (u.max - u.min) * crate::model::random::uniform(&mut state);
                        // y = g·(1 − ε_model)·(1 + ε_measurement) (synth's Eq. 1 sign).
                        match u.group {
                            UncertaintyGroup::Model => -x,
                            UncertaintyGroup::Measurement => x,
                        }
                    })
                    .sum()
            })
            .collect();
        let mean = draw.iter().sum::<f64>() / sensors as f64;
        e.extend(draw.iter().map(|x| x - mean));
    }
    e
}

/// Monte Carlo draws of the per-pass departure.
const DRAWS: usize = 20_000;

/// The 2.5 % and 97.5 % quantiles of `x` (sorted in place).
pub fn quantiles(x: &mut [f64]) -> [f64; 2] {
    x.sort_by(f64::total_cmp);
    let at = |q: f64| x[((q * (x.len() - 1) as f64).round() as usize).min(x.len() - 1)];
    [at(0.025), at(0.975)]
}

/// The calibrated site's residual: the half-width `h` of a uniform `[−h, h]` (relative) such
/// that the per-pass departures `per_pass` plus it reach the held-back passes' 2.5 % and
/// 97.5 % quantiles (`held_back`: relative departures per sensor, common part off) — never
/// narrower than the scatter they show — and at least the gains' own interval half-width.
/// Found by bisection on the Monte Carlo (seeded).
pub fn site_residual(
    held_back: &mut [f64],
    per_pass: &[f64],
    gains_half_width: f64,
    seed: u64,
) -> f64 {
    let [lo, hi] = quantiles(held_back);
    let covers = |h: f64| {
        let mut state = seed ^ 0x00B1_5EC7;
        let mut sum: Vec<f64> = per_pass
            .iter()
            .map(|x| x + h * (2.0 * crate::model::random::uniform(&mut state) - 1.0))
            .collect();
        let [a, b] = quantiles(&mut sum);
        a <= lo && b >= hi
    };
    let (mut a, mut b) = (gains_half_width.max(0.0), 1.0);
    if covers(a) {
        return a;
    }
    for _ in 0..30 {
        let m = 0.5 * (a + b);
        if covers(m) {
            b = m;
        } else {
            a = m;
        }
    }
    b
}

/// Whether a site-fixed entry is what a site's good wheels measure: the track's calibration
/// (its shape at the sensors) and the sensors' accuracy (their gains). The finite element
/// model's and the mesh's errors and the model's additional one are fixed at a site too, but
/// they are the model's error in a flat's *impact*, which no good wheel shows: they stay.
pub fn learnable(u: &UncertaintySource) -> bool {
    matches!(
        (u.group, u.name.as_str()),
        (UncertaintyGroup::Model, "track calibration")
            | (UncertaintyGroup::Measurement, "sensor accuracy")
            | (_, SITE_RESIDUAL)
    )
}

/// `table` with its entries the good wheels measure ([`learnable`]) replaced by one relative
/// entry `±half_width`.
pub fn calibrated(table: &[UncertaintySource], half_width: f64) -> Vec<UncertaintySource> {
    let mut out: Vec<UncertaintySource> = table.iter().filter(|u| !learnable(u)).cloned().collect();
    out.push(UncertaintySource {
        group: UncertaintyGroup::Model,
        name: SITE_RESIDUAL.to_string(),
        kind: UncertaintyKind::Relative,
        min: -half_width,
        max: half_width,
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::calibration::IdentificationParams;

    #[test]
    fn the_default_table_splits_into_site_and_pass_entries() {
        let t = IdentificationParams::default().uncertainty;
        let site: Vec<&str> = t
            .iter()
            .filter(|u| scope(u) == Scope::Site)
            .map(|u| u.name.as_str())
            .collect();
        assert_eq!(
            site,
            [
                "finite element model",
                "mesh refinement",
                "additional",
                "track calibration",
                "sensor accuracy"
            ]
        );
        let c = calibrated(&t, 0.02);
        // Only the track's calibration and the sensors' accuracy are replaced.
        assert_eq!(c.len(), t.len() - 2 + 1);
        assert!(c.iter().any(|u| u.name == "finite element model"));
        assert!(c
            .iter()
            .any(|u| u.name == SITE_RESIDUAL && (u.max - 0.02).abs() < 1e-12));
    }

    #[test]
    fn a_scatter_wider_than_the_per_pass_entries_widens_the_residual() {
        let t = IdentificationParams::default().uncertainty;
        let draws = per_pass_draws(&t, 5, 1);
        let q = quantiles(&mut draws.clone());
        // Train system −15..+5 % and the measurement's ±2 %, the common part off: about
        // ±8 %, inside the entries' own spans.
        assert!(
            q[0] < -0.05 && q[1] > 0.05 && q[0] > -0.2 && q[1] < 0.2,
            "{q:?}"
        );
        let mut inside: Vec<f64> = (0..1000)
            .map(|k| q[0] + (q[1] - q[0]) * k as f64 / 999.0)
            .collect();
        assert!(site_residual(&mut inside, &draws, 0.01, 1) <= 0.01 + 1e-12);
        // Twice the spread: a uniform added reaches the tails only in part, so the residual is
        // more than the gap between the quantiles (q[1]).
        let mut wider: Vec<f64> = inside.iter().map(|x| 2.0 * x).collect();
        let h = site_residual(&mut wider, &draws, 0.01, 1);
        assert!(h > q[1], "{h} vs {q:?}");
    }
}
