//! Information entropy of the bank's predictions at candidate points, and greedy selection of
//! the points with the most joint entropy (paper §3.2, MODEL.md §8).
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

/// The predictions at one point, as bin numbers.
#[derive(Debug, Clone, PartialEq)]
pub struct Binned {
    /// Bin of every instance.
    pub bins: Vec<u32>,
    /// Number of bins.
    pub nbins: usize,
}

/// Bins `values` with width `width` starting at their minimum.
pub fn bin_predictions(values: &[f32], width: f64) -> Binned {
    let lo = values.iter().copied().fold(f32::MAX, f32::min) as f64;
    let w = width.max(1e-12);
    let bins: Vec<u32> = values
        .iter()
        .map(|&v| ((v as f64 - lo) / w).floor() as u32)
        .collect();
    let nbins = bins.iter().copied().max().map_or(0, |m| m as usize + 1);
    Binned { bins, nbins }
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

/// Shannon entropy (bits) of one binned point.
pub fn entropy(b: &Binned) -> f64 {
    let n = b.bins.len();
    if n == 0 {
        return 0.0;
    }
    let mut counts = vec![0usize; b.nbins];
    for &x in &b.bins {
        counts[x as usize] += 1;
    }
    let s: f64 = counts
        .iter()
        .filter(|&&c| c > 0)
        .map(|&c| c as f64 * (c as f64).log2())
        .sum();
    (n as f64).log2() - s / n as f64
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
/// `alpha_bits`, when nothing can be gained, or after `max_points`. Candidates are evaluated in
/// parallel on the current rayon pool; ties go to the lowest candidate index (deterministic).
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
    if n == 0 {
        return sel;
    }
    let clog = clog_table(n);
    let max_bins = candidates.iter().map(|c| c.nbins).max().unwrap_or(1).max(1);
    let mut perm: Vec<u32> = (0..n as u32).collect();
    // Non-singleton groups as (start, len) runs of `perm`.
    let mut groups: Vec<(usize, usize)> = vec![(0, n)];
    let mut joint = 0.0;
    let mut remaining: Vec<usize> = allowed.to_vec();
    let mut scratch_perm = vec![0u32; n];
    while !remaining.is_empty() && sel.order.len() < max_points && !groups.is_empty() {
        let gains: Vec<f64> = remaining
            .par_iter()
            .map_init(
                || (vec![0u32; max_bins], Vec::<u32>::with_capacity(64)),
                |(counts, touched), &c| {
                    let bins = &candidates[c].bins;
                    let mut gain = 0.0;
                    for &(start, len) in &groups {
                        for &k in &perm[start..start + len] {
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
                },
            )
            .collect();
        let (best_pos, best_gain) =
            gains
                .iter()
                .enumerate()
                .fold((0, f64::MIN), |(bp, bg), (p, &g)| {
                    if g > bg + 1e-12 {
                        (p, g)
                    } else {
                        (bp, bg)
                    }
                });
        if best_gain < alpha_bits || best_gain <= 1e-12 {
            break;
        }
        let chosen = remaining.remove(best_pos);
        joint += best_gain;
        sel.order.push(chosen);
        sel.joint_bits.push(joint);
        // Refine every group by the chosen point's bins (counting sort within the run).
        let bins = &candidates[chosen].bins;
        let mut next = Vec::with_capacity(groups.len() * 2);
        let mut counts = vec![0usize; candidates[chosen].nbins + 1];
        for &(start, len) in &groups {
            let run = &perm[start..start + len];
            for &k in run {
                counts[bins[k as usize] as usize + 1] += 1;
            }
            // Prefix sums give each bin's offset; remember the sizes first.
            let mut offsets = Vec::new();
            let mut acc = 0;
            for c in counts.iter_mut() {
                let size = *c;
                *c = acc;
                acc += size;
                offsets.push(size);
            }
            for &k in run {
                let b = bins[k as usize] as usize + 1;
                scratch_perm[start + counts[b]] = k;
                counts[b] += 1;
            }
            let mut s = start;
            for &size in &offsets[1..] {
                if size > 1 {
                    next.push((s, size));
                }
                s += size;
            }
            perm[start..start + len].copy_from_slice(&scratch_perm[start..start + len]);
            counts.iter_mut().for_each(|c| *c = 0);
        }
        groups = next;
    }
    sel
}

#[cfg(test)]
mod tests {
    use super::*;

    fn binned(bins: Vec<u32>) -> Binned {
        let nbins = bins.iter().copied().max().unwrap() as usize + 1;
        Binned { bins, nbins }
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
    }
}
