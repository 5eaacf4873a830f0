//! Information entropy of the bank's predictions at candidate points, and greedy selection of
//! the points with the most joint entropy (paper §3.2, docs/model.md §8).
//!
//! At a point, the predictions of all N instances are binned with bin width equal to the
//! combined-uncertainty interval width there: instances in one bin cannot be told apart by a
//! measurement at that point. Shannon entropy `H = −Σ (c/N)·log2(c/N)` over bins.
//!
//! Joint entropy of a set of points is the entropy of the partition of the instances by their
//! tuple of bins. Greedy selection adds, each step, the point that raises it most, and stops
//! when the gain drops below α. The partition is kept as groups of instances (contiguous runs
//! of a permutation) and *refined* by the chosen point's bins, so evaluating a candidate costs
//! one pass over the instances that still share a group with another — singletons can gain
//! nothing and are skipped. With `H = log2 N − (1/N)·Σ_cells c·log2 c`, the gain of a candidate
//! is `(1/N)·Σ_groups (n_g·log2 n_g − Σ_b c_gb·log2 c_gb)`.

use rayon::prelude::*;

/// The most bins a point has: a prediction more than this many bin widths above the point's
/// smallest shares the last bin. (The default uncertainty table gives a few hundred bins at
/// most; the bound keeps the counting tables small whatever the settings.)
pub const MAX_BINS: usize = 1 << 16;

/// The predictions at one point, as bin numbers, with their entropy.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Binned {
    /// Bin of every instance (two bytes: the counting passes are memory-bound).
    pub bins: Vec<u16>,
    /// Number of bins.
    pub nbins: usize,
    /// Shannon entropy of the bins (bits).
    pub entropy_bits: f64,
}

/// Bins `values` with width `width` starting at their minimum (at most [`MAX_BINS`] bins).
pub fn bin_predictions(values: &[f32], width: f64) -> Binned {
    let mut b = Binned::default();
    bin_predictions_into(values, width, &mut b);
    b
}

/// [`bin_predictions`] into a reused buffer (the hot path allocates nothing per call).
pub fn bin_predictions_into(values: &[f32], width: f64, out: &mut Binned) {
    out.bins.clear();
    if values.is_empty() {
        out.nbins = 0;
        out.entropy_bits = 0.0;
        return;
    }
    // One pass for the range, one to bin, one to count. The bin map is monotone, so the
    // largest value's bin is the last one.
    let (lo, hi) = values
        .iter()
        .fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    let lo = lo as f64;
    let inv = 1.0 / width.max(1e-12);
    let last = (MAX_BINS - 1) as f64;
    let bin = |v: f32| ((v as f64 - lo) * inv).min(last) as u16;
    out.nbins = bin(hi) as usize + 1;
    out.bins.extend(values.iter().map(|&v| bin(v)));
    let mut counts = vec![0u32; out.nbins];
    for &b in &out.bins {
        counts[b as usize] += 1;
    }
    out.entropy_bits = entropy_of_counts(&counts, values.len());
}

/// Shannon entropy (bits) of `n` instances counted into bins.
fn entropy_of_counts(counts: &[u32], n: usize) -> f64 {
    let s: f64 = counts
        .iter()
        .filter(|&&c| c > 0)
        .map(|&c| c as f64 * (c as f64).log2())
        .sum();
    (n as f64).log2() - s / n as f64
}

/// `c·log2(c)` for c = 0…n.
fn clog_table(n: usize) -> Vec<f64> {
    (0..=n)
        .map(|c| {
            if c == 0 {
                0.0
            } else {
                c as f64 * (c as f64).log2()
            }
        })
        .collect()
}

/// Shannon entropy (bits) of one binned point, from its bins.
pub fn entropy(b: &Binned) -> f64 {
    let n = b.bins.len();
    if n == 0 {
        return 0.0;
    }
    let mut counts = vec![0u32; b.nbins];
    for &x in &b.bins {
        counts[x as usize] += 1;
    }
    entropy_of_counts(&counts, n)
}

/// The outcome of a greedy selection.
#[derive(Debug, Clone, PartialEq)]
pub struct Selection {
    /// Chosen candidates, in order.
    pub order: Vec<usize>,
    /// Joint entropy after each choice (bits).
    pub joint_bits: Vec<f64>,
}

/// Greedy joint-entropy selection among `allowed` candidates: stop when the best gain is below
/// `alpha_bits`, when nothing can be gained, or after `max_points`. Ties go to the earlier
/// candidate in `allowed` (deterministic).
///
/// Joint entropy is submodular (a point never gains more after others have been chosen), so
/// the selection is *lazy* (Minoux): every candidate keeps its last gain as an upper bound and
/// only the candidate with the highest bound is re-evaluated, until one is best with a fresh
/// gain — the same choice as re-evaluating all, at a fraction of the work. Only the *active*
/// instances (those still sharing a group with another) are visited.
pub fn greedy_joint_entropy(
    candidates: &[Binned],
    allowed: &[usize],
    alpha_bits: f64,
    max_points: usize,
) -> Selection {
    let n = candidates.first().map_or(0, |c| c.bins.len());
    let mut sel = Selection {
        order: Vec::new(),
        joint_bits: Vec::new(),
    };
    if n < 2 || allowed.is_empty() {
        return sel;
    }
    let clog = clog_table(n);
    let threads = rayon::current_num_threads().max(1);
    let max_bins = candidates.iter().map(|c| c.nbins).max().unwrap_or(1).max(1);
    // Active instances in group order; groups are (start, len) runs of it, all len ≥ 2.
    let mut active: Vec<u32> = (0..n as u32).collect();
    let mut groups: Vec<(usize, usize)> = vec![(0, n)];
    let gain_of = |bins: &[u16],
                   active: &[u32],
                   groups: &[(usize, usize)],
                   counts: &mut Vec<u32>,
                   touched: &mut Vec<u16>| {
        let mut gain = 0.0;
        for &(start, len) in groups {
            for &k in &active[start..start + len] {
                let b = bins[k as usize];
                if counts[b as usize] == 0 {
                    touched.push(b);
                }
                counts[b as usize] += 1;
            }
            let mut cells = 0.0;
            for &b in touched.iter() {
                cells += clog[counts[b as usize] as usize];
                counts[b as usize] = 0;
            }
            touched.clear();
            gain += clog[len] - cells;
        }
        gain / n as f64
    };
    let mut remaining: Vec<usize> = allowed.to_vec();
    // First round: the gains are the single-point entropies, computed while binning.
    let mut bounds: Vec<f64> = remaining
        .iter()
        .map(|&c| candidates[c].entropy_bits)
        .collect();
    let mut fresh = vec![true; remaining.len()];
    let mut counts = vec![0u32; max_bins];
    let mut touched: Vec<u16> = Vec::with_capacity(64);
    let mut joint = 0.0;
    while !remaining.is_empty() && sel.order.len() < max_points && !groups.is_empty() {
        let best = loop {
            let pos = bounds
                .iter()
                .enumerate()
                .fold((0, f64::MIN), |(bp, bg), (p, &g)| {
                    if g > bg + 1e-12 {
                        (p, g)
                    } else {
                        (bp, bg)
                    }
                })
                .0;
            if fresh[pos] {
                break pos;
            }
            // Re-evaluate the stale candidates with the highest bounds, one per thread, in
            // parallel; the choice is the same as one at a time (a stale bound only ever
            // falls when refreshed).
            let mut stale: Vec<usize> = (0..remaining.len()).filter(|&p| !fresh[p]).collect();
            stale.sort_by(|&a, &b| bounds[b].total_cmp(&bounds[a]).then(a.cmp(&b)));
            stale.truncate(threads);
            let gains: Vec<f64> = stale
                .par_iter()
                .map_init(
                    || (vec![0u32; max_bins], Vec::with_capacity(64)),
                    |(counts, touched), &p| {
                        gain_of(
                            &candidates[remaining[p]].bins,
                            &active,
                            &groups,
                            counts,
                            touched,
                        )
                    },
                )
                .collect();
            for (&p, g) in stale.iter().zip(gains) {
                bounds[p] = g;
                fresh[p] = true;
            }
        };
        let best_gain = bounds[best];
        if best_gain < alpha_bits || best_gain <= 1e-12 {
            break;
        }
        let chosen = remaining.remove(best);
        bounds.remove(best);
        fresh.remove(best);
        joint += best_gain;
        sel.order.push(chosen);
        sel.joint_bits.push(joint);

        // Refine every group by the chosen bins (counting sort within the run, over the bins
        // the run touches only, so a small group costs its size, not the number of bins); keep
        // only the sub-groups of two or more.
        let bins = &candidates[chosen].bins;
        let mut next_active: Vec<u32> = Vec::with_capacity(active.len());
        let mut next_groups: Vec<(usize, usize)> = Vec::new();
        let mut slots = vec![0u32; candidates[chosen].nbins];
        for &(start, len) in &groups {
            let run = &active[start..start + len];
            for &k in run {
                let b = bins[k as usize] as usize;
                if counts[b] == 0 {
                    touched.push(b as u16);
                }
                counts[b] += 1;
            }
            // Lay the sub-groups of two or more out in `next_active`, in first-seen bin order.
            let base = next_active.len();
            let mut acc = base as u32;
            for &b in touched.iter() {
                let c = counts[b as usize];
                if c > 1 {
                    next_groups.push((acc as usize, c as usize));
                    slots[b as usize] = acc;
                    acc += c;
                }
            }
            next_active.resize(acc as usize, 0);
            for &k in run {
                let b = bins[k as usize] as usize;
                if counts[b] > 1 {
                    next_active[slots[b] as usize] = k;
                    slots[b] += 1;
                }
            }
            for &b in touched.iter() {
                counts[b as usize] = 0;
            }
            touched.clear();
        }
        active = next_active;
        groups = next_groups;
        fresh.iter_mut().for_each(|f| *f = false);
    }
    sel
}

#[cfg(test)]
mod tests {
    use super::*;

    fn binned(bins: Vec<u32>) -> Binned {
        let bins: Vec<u16> = bins.into_iter().map(|b| b as u16).collect();
        let nbins = bins.iter().copied().max().unwrap() as usize + 1;
        let mut b = Binned {
            bins,
            nbins,
            entropy_bits: 0.0,
        };
        b.entropy_bits = entropy(&b);
        b
    }

    #[test]
    fn entropy_of_uniform_bins_is_log2_of_their_number() {
        let b = binned((0..1024).map(|i| i % 8).collect());
        assert!((entropy(&b) - 3.0).abs() < 1e-12);
        assert!(entropy(&binned(vec![0; 100])).abs() < 1e-12);
    }

    #[test]
    fn greedy_selection_matches_brute_force_joint_entropy() {
        // Four points over 16 instances: a = bit 0, b = bit 1, c = a (redundant), d = bits 2-3.
        let n = 16u32;
        let a = binned((0..n).map(|i| i & 1).collect());
        let b = binned((0..n).map(|i| (i >> 1) & 1).collect());
        let c = binned((0..n).map(|i| i & 1).collect());
        let d = binned((0..n).map(|i| i >> 2).collect());
        let cands = vec![a, b, c, d];
        let s = greedy_joint_entropy(&cands, &[0, 1, 2, 3], 0.0, 10);
        assert_eq!(
            s.order,
            vec![3, 0, 1],
            "d (2 bits) first, then a, then b; c adds nothing"
        );
        let expected = [2.0, 3.0, 4.0];
        for (j, e) in s.joint_bits.iter().zip(expected) {
            assert!((j - e).abs() < 1e-12, "{j} vs {e}");
        }
    }

    /// Joint entropy of a set of points by hashing the bin tuples from scratch.
    fn brute_joint(cands: &[Binned], set: &[usize]) -> f64 {
        let n = cands[0].bins.len();
        let mut cells = std::collections::HashMap::<Vec<u16>, usize>::new();
        for k in 0..n {
            *cells
                .entry(set.iter().map(|&c| cands[c].bins[k]).collect())
                .or_default() += 1;
        }
        let s: f64 = cells.values().map(|&c| c as f64 * (c as f64).log2()).sum();
        (n as f64).log2() - s / n as f64
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(24))]
        #[test]
        fn group_refinement_equals_hashing_tuples_from_scratch(seed in 0u64..1000, nbins in 2u32..9) {
            let mut state = seed;
            let cands: Vec<Binned> = (0..7)
                .map(|_| binned((0..300).map(|_| (crate::identify::uncertainty::uniform(&mut state) * nbins as f64) as u32).collect()))
                .collect();
            let all: Vec<usize> = (0..7).collect();
            let s = greedy_joint_entropy(&cands, &all, 0.0, 7);
            for (j, &h) in s.joint_bits.iter().enumerate() {
                let exact = brute_joint(&cands, &s.order[..=j]);
                proptest::prop_assert!((h - exact).abs() < 1e-9, "step {}: {} vs {}", j, h, exact);
                // Greedy: no other remaining candidate would have done better at this step.
                for c in all.iter().filter(|c| !s.order[..=j].contains(c)) {
                    let mut alt = s.order[..j].to_vec();
                    alt.push(*c);
                    proptest::prop_assert!(brute_joint(&cands, &alt) <= exact + 1e-9);
                }
            }
        }
    }

    #[test]
    fn alpha_stops_the_selection() {
        let n = 64u32;
        let a = binned((0..n).map(|i| i % 4).collect());
        let tiny = binned((0..n).map(|i| u32::from(i == 0)).collect()); // gain ≈ 0.1 bit
        let s = greedy_joint_entropy(&[a, tiny], &[0, 1], 0.2, 10);
        assert_eq!(s.order, vec![0]);
    }

    #[test]
    fn binning_uses_the_width_from_the_minimum() {
        let b = bin_predictions(&[1.0, 1.9, 2.1, 5.0], 1.0);
        assert_eq!(b.bins, vec![0, 0, 1, 4]);
        assert_eq!(b.nbins, 5);
        assert!(
            (b.entropy_bits - entropy(&b)).abs() < 1e-12 && (b.entropy_bits - 1.5).abs() < 1e-12
        );
    }
}
