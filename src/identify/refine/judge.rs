//! Judging a refinement's local population: its cells (neighbours among its own members), the
//! method's falsification at the comparison points with the cell rule, then, with
//! `shared_gains`, the shared-gain stage at every point read. Both ways of spending the
//! simulations ([`super::RefineStrategy`]) judge each round with this one rule.

use super::local::local_cells;
use super::points::Comparison;
use super::Member;
use crate::identify::domain::cells::Cells;
use crate::identify::domain::falsify::{falsify, Resolution};
use crate::identify::domain::shared_gain::keep_resolved;
use crate::identify::domain::table_bounds::TableBounds;
use crate::identify::identifier::Identifier;

/// A round's local population: its members, their cells and predictions at every
/// point, and which of them survive.
pub(super) struct Round {
    pub(super) members: Vec<Member>,
    pub(super) cells: Cells,
    pub(super) columns: Vec<Vec<f32>>,
    pub(super) alive: Vec<u32>,
}

/// What a round is judged with: the identification's points and settings.
pub(super) struct Judge<'a> {
    pub(super) identifier: &'a Identifier,
    pub(super) cmp: &'a Comparison,
    /// κ of the local cells (0: each member judged for its own point only).
    pub(super) kappa: f64,
    /// The measurement's bounds with the pass's roughness (the shared-gain stage's).
    pub(super) rough_bounds: &'a TableBounds,
    /// Whether the shared-gain stage judges too (the bank-only answer used it).
    pub(super) shared: bool,
}

impl Judge<'_> {
    /// Judges `members`: sets each one's cell from its neighbours among them and returns the
    /// round with its survivors.
    pub(super) fn round(&self, mut members: Vec<Member>) -> Round {
        let cells = local_cells(&members);
        for (i, m) in members.iter_mut().enumerate() {
            m.half = cells.half_extent(i);
        }
        let all_points = self.cmp.at.len();
        let columns: Vec<Vec<f32>> = (0..all_points)
            .map(|p| members.iter().map(|m| m.g[p]).collect())
            .collect();
        let steps: Vec<Vec<f32>> = (0..all_points)
            .map(|p| {
                members
                    .iter()
                    .map(|m| m.steps.get(p).copied().unwrap_or(0.0))
                    .collect()
            })
            .collect();
        let shares: Vec<f32> = members.iter().map(|m| m.share).collect();
        let any = shares.iter().any(|&s| s > 0.0);
        let alive = {
            let points = self.cmp.points(
                &columns,
                0..self.cmp.method,
                &steps,
                any.then_some(shares.as_slice()),
            );
            let res = (self.kappa > 0.0).then_some(Resolution {
                cells: &cells,
                kappa: self.kappa,
            });
            let mut alive = falsify(&points, res);
            if self.shared && all_points > self.cmp.method {
                // One gain per sensor at every point read (docs/model.md, "Shared gains").
                let shared = self.cmp.shared_points(
                    &columns,
                    &steps,
                    any.then_some(shares.as_slice()),
                    self.rough_bounds,
                );
                let form = self.identifier.settings().shared_model_form;
                let kept = keep_resolved(&shared, &alive, self.rough_bounds, form, res);
                // As the bank-only answer: none explained lets the per-point survivors stand.
                if !kept.is_empty() {
                    alive = kept;
                }
            }
            alive
        };
        Round {
            members,
            cells,
            columns,
            alive,
        }
    }
}
