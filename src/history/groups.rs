//! Whether groups of a wheel's passes (a site's each) leave the others: one grid and one
//! hypothesis set a pass, then each group's intersection, and each "all groups but one" from
//! prefix and suffix intersections — linear in the groups, where fusing every "all but one"
//! afresh was quadratic (a wheel seen at 50 sites: 52 fusions of 100 passes each).

use super::grid::Hyp;

/// For the informative passes' marks on one grid, labelled with their group (`labels[i] <
/// groups`): whether every pass allows a common hypothesis, and, for each group, whether the
/// passes of the other groups do (none when no other group has a pass). "Allows" is the
/// fusion's: a grid cell touched by a surviving cell, a good wheel, a flat below the population.
pub(super) fn from_marks(
    marks: &[Hyp],
    labels: &[usize],
    groups: usize,
) -> (Option<bool>, Vec<Option<bool>>) {
    let mut per: Vec<Option<Hyp>> = vec![None; groups];
    for (h, &g) in marks.iter().zip(labels) {
        let slot = &mut per[g];
        *slot = Some(match slot.take() {
            None => h.clone(),
            Some(o) => o.and(h),
        });
    }
    let and = |a: Option<Hyp>, b: &Option<Hyp>| match (a, b) {
        (None, b) => b.clone(),
        (Some(a), None) => Some(a),
        (Some(a), Some(b)) => Some(a.and(b)),
    };
    // prefix[g]: groups before g; suffix[g]: groups after g.
    let mut prefix = vec![None; groups + 1];
    for g in 0..groups {
        prefix[g + 1] = and(prefix[g].clone(), &per[g]);
    }
    let mut suffix = vec![None; groups + 1];
    for g in (0..groups).rev() {
        suffix[g] = and(suffix[g + 1].clone(), &per[g]);
    }
    let all = prefix[groups].as_ref().map(|h| !h.is_empty());
    let without = (0..groups)
        .map(|g| and(prefix[g].clone(), &suffix[g + 1]).map(|h| !h.is_empty()))
        .collect();
    (all, without)
}
