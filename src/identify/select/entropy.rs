//! Information entropy of the bank's predictions at candidate points, and greedy selection of
//! the points with the most joint entropy (paper §3.2, docs/model.md §8).
//!
//! At a point, the predictions of all N instances are binned with bin width equal to the
//! combined-uncertainty interval width there: instances in one bin cannot be told apart by a
//! measurement at that point. Shannon entropy `H = −Σ (c/N)·log2(c/N)` over bins.
//!
//! Joint entropy of a set of points is the entropy of the partition of the instances by their
//! tuple of bins. Greedy selection adds, each step, the point that raises it most, and stops
//! when the gain drops below α. With `H = log2 N − (1/N)·Σ_cells c·log2 c`, the gain of a
//! candidate is `(1/N)·Σ_groups (n_g·log2 n_g − Σ_b c_gb·log2 c_gb)` over the groups of the
//! partition so far. The partition and the gains are counted over each point's instances
//! outside its most populated bin only ([`crate::identify::select::sparse`]): a quarter of the instances on the
//! default bank.

use rayon::prelude::*;

use crate::identify::select::sparse::{GroupTally, Groups, Sparse};

/// The most bins a point has: a prediction more than this many bin widths above the point's
/// smallest shares the last bin. (The default uncertainty table gives a few hundred bins at
/// most; the bound keeps the counting tables small whatever the settings.)
pub(crate) const MAX_BINS: usize = 1 << 16;

/// The predictions at one point, as bin numbers, with their entropy. `B` holds the bins: an
/// owned vector, or a slice of the identifier's bin buffer (see [`bin_into`]).
#[derive(Debug, Clone, PartialEq, Default)]
pub(crate) struct Binned<B = Vec<u16>> {
    /// Bin of every instance (two bytes: the counting passes are memory-bound).
    pub bins: B,
    /// Number of bins.
    pub nbins: usize,
    /// Shannon entropy of the bins (bits).
    pub entropy_bits: f64,
    /// The instances outside the most populated bin, by bin (what the selection counts).
    pub others: Sparse,
}

/// What binning finds besides the bins: their number, entropy and the instances outside the
/// most populated one.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Histogram {
    /// Number of bins.
    pub nbins: usize,
    /// Shannon entropy of the bins (bits).
    pub entropy_bits: f64,
    /// The instances outside the most populated bin, by bin.
    pub others: Sparse,
}

/// Shannon entropy (bits) of one binned point, from its bins (the tests' reference for the
/// entropy the histograms carry).
#[cfg(test)]
pub(crate) fn entropy<B: AsRef<[u16]>>(b: &Binned<B>) -> f64 {
    let bins = b.bins.as_ref();
    let n = bins.len();
    if n == 0 {
        return 0.0;
    }
    let mut counts = vec![0u32; b.nbins];
    for &x in bins {
        counts[x as usize] += 1;
    }
    entropy_of_counts(&counts, n)
}

/// Bins `values` with width `width` starting at their minimum (at most [`MAX_BINS`] bins; the
/// tests' reference for [`bin_into`]).
#[cfg(test)]
pub(crate) fn bin_predictions(values: &[f32], width: f64) -> Binned {
    let mut bins = vec![0; values.len()];
    let h = bin_into(values, width, &mut bins);
    Binned {
        bins,
        nbins: h.nbins,
        entropy_bits: h.entropy_bits,
        others: h.others,
    }
}

/// Bins `values` into `bins` (one per value): returns the number of bins, their entropy and
/// the instances outside the most populated bin.
///
/// Three passes, each written so the compiler vectorises it or keeps it free of chains: the
/// range in eight lanes; the bin numbers; the counts in four interleaved tables, so that
/// instances in the same bin one after the other do not wait on each other's increment.
/// The result is the same, bit for bit, as binning one value at a time.
pub(crate) fn bin_into(values: &[f32], width: f64, bins: &mut [u16]) -> Histogram {
    assert_eq!(values.len(), bins.len(), "one bin per value");
    if values.is_empty() {
        return Histogram {
            nbins: 0,
            entropy_bits: 0.0,
            others: Sparse::default(),
        };
    }
    // The range; `<` skips a NaN as `f32::min` does (the simulator refuses a non-finite state,
    // so a bank holds none).
    let (mut lo8, mut hi8) = ([f32::MAX; 8], [f32::MIN; 8]);
    let mut chunks = values.chunks_exact(8);
    for c in &mut chunks {
        for i in 0..8 {
            if c[i] < lo8[i] {
                lo8[i] = c[i];
            }
            if c[i] > hi8[i] {
                hi8[i] = c[i];
            }
        }
    }
    let (mut lo, mut hi) = (f32::MAX, f32::MIN);
    for &v in lo8.iter().chain(chunks.remainder()) {
        if v < lo {
            lo = v;
        }
    }
    for &v in hi8.iter().chain(chunks.remainder()) {
        if v > hi {
            hi = v;
        }
    }
    // The bin map is monotone, so the largest value's bin is the last one.
    let lo = lo as f64;
    let inv = 1.0 / width.max(1e-12);
    let last = (MAX_BINS - 1) as f64;
    let bin = |v: f32| {
        let x = (v as f64 - lo) * inv;
        // Clamped to [0, last] as `x.min(last) as u16` does: NaN takes the last bin, below
        // zero (only when every value is NaN) the first.
        let y = if x < last { x } else { last };
        let y = if y > 0.0 { y } else { 0.0 };
        // SAFETY: y is in [0, MAX_BINS − 1] (clamped above). In range, the unchecked
        // conversion truncates as `as` does, without the saturation code that keeps the loop
        // from vectorising.
        unsafe { y.to_int_unchecked::<i32>() as u16 }
    };
    let nbins = bin(hi) as usize + 1;
    for (b, &v) in bins.iter_mut().zip(values) {
        *b = bin(v);
    }
    let mut tables = vec![0u32; 4 * nbins];
    let (c0, rest) = tables.split_at_mut(nbins);
    let (c1, rest) = rest.split_at_mut(nbins);
    let (c2, c3) = rest.split_at_mut(nbins);
    let mut quads = bins.chunks_exact(4);
    for q in &mut quads {
        c0[q[0] as usize] += 1;
        c1[q[1] as usize] += 1;
        c2[q[2] as usize] += 1;
        c3[q[3] as usize] += 1;
    }
    for &b in quads.remainder() {
        c0[b as usize] += 1;
    }
    for (i, c) in c0.iter_mut().enumerate() {
        *c += c1[i] + c2[i] + c3[i];
    }
    Histogram {
        nbins,
        entropy_bits: entropy_of_counts(c0, values.len()),
        others: Sparse::new(bins, c0),
    }
}

/// Views a buffer of binned columns (`n` bins each, as [`bin_into`] wrote them) with their
/// number, entropy and other instances, as [`greedy_joint_entropy`] reads them.
pub(crate) fn binned_columns(bins: &[u16], n: usize, hists: Vec<Histogram>) -> Vec<Binned<&[u16]>> {
    bins.chunks(n.max(1))
        .zip(hists)
        .map(|(b, h)| Binned {
            bins: b,
            nbins: h.nbins,
            entropy_bits: h.entropy_bits,
            others: h.others,
        })
        .collect()
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
pub(crate) fn clog_table(n: usize) -> Vec<f64> {
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

/// The outcome of a greedy selection.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Selection {
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
/// gain — the same choice as re-evaluating all, at a fraction of the work. An evaluation visits
/// the candidate's instances outside its most populated bin only, skipping those alone in
/// their group.
pub(crate) fn greedy_joint_entropy<B: AsRef<[u16]> + Sync>(
    candidates: &[Binned<B>],
    allowed: &[usize],
    alpha_bits: f64,
    max_points: usize,
) -> Selection {
    let n = candidates.first().map_or(0, |c| c.bins.as_ref().len());
    let mut sel = Selection {
        order: Vec::new(),
        joint_bits: Vec::new(),
    };
    if n < 2 || allowed.is_empty() {
        return sel;
    }
    let clog = clog_table(n);
    let threads = rayon::current_num_threads().max(1);
    let mut groups = Groups::whole(n);
    // One counting table a thread.
    let mut tallies: Vec<GroupTally> = (0..threads).map(|_| GroupTally::default()).collect();
    let mut remaining: Vec<usize> = allowed.to_vec();
    // First round: the gains are the single-point entropies, computed while binning.
    let mut bounds: Vec<f64> = remaining
        .iter()
        .map(|&c| candidates[c].entropy_bits)
        .collect();
    let mut fresh = vec![true; remaining.len()];
    let mut joint = 0.0;
    while !remaining.is_empty() && sel.order.len() < max_points {
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
            // A fresh gain never exceeds its stale bound: when even the highest bound is below
            // α, nothing more will be chosen and no evaluation can change that.
            if fresh[pos] || bounds[pos] < alpha_bits || bounds[pos] <= 1e-12 {
                break pos;
            }
            // Re-evaluate the stale candidates with the highest bounds, a few per thread, in
            // parallel; the choice is the same as one at a time (a stale bound only ever
            // falls when refreshed). A step re-evaluates about a seventh of the candidates
            // (9 of 60, 21 of 150 on the default bank), and each round is a hand-over between
            // threads: one candidate a thread below 40 candidates, one more each 40 more, up to
            // four (docs/cold-start.md).
            let mut stale: Vec<usize> = (0..remaining.len()).filter(|&p| !fresh[p]).collect();
            stale.sort_by(|&a, &b| bounds[b].total_cmp(&bounds[a]).then(a.cmp(&b)));
            let per = (1 + remaining.len() / 40).min(4);
            stale.truncate(threads * per);
            let gains: Vec<f64> = stale
                .par_chunks(per)
                .zip(tallies.par_iter_mut())
                .flat_map_iter(|(ps, tally)| {
                    let gain = |&p: &usize| {
                        let others = &candidates[remaining[p]].others;
                        tally.gain_cells(others, &groups, &clog) / n as f64
                    };
                    ps.iter().map(gain).collect::<Vec<_>>()
                })
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

        groups.refine(&candidates[chosen].others);
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
        let mut counts = vec![0u32; nbins];
        bins.iter().for_each(|&b| counts[b as usize] += 1);
        let others = Sparse::new(&bins, &counts);
        let mut b = Binned {
            bins,
            nbins,
            entropy_bits: 0.0,
            others,
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
                .map(|_| binned((0..300).map(|_| (crate::identify::domain::uncertainty::uniform(&mut state) * nbins as f64) as u32).collect()))
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
    fn the_selection_is_the_same_on_any_thread_count() {
        // The rounds of evaluations differ with the number of threads (90 candidates: three a
        // thread and round at first); bins clustered like a bank's, so groups of many sizes
        // form.
        let mut state = 7u64;
        let n = 20_000;
        let cands: Vec<Binned> = (0..90)
            .map(|j| {
                binned(
                    (0..n)
                        .map(|k| {
                            let u = crate::identify::domain::uncertainty::uniform(&mut state);
                            ((k % (3 + j)) as f64 * 0.7 + u * 2.5) as u32
                        })
                        .collect(),
                )
            })
            .collect();
        let all: Vec<usize> = (0..cands.len()).collect();
        let on = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| greedy_joint_entropy(&cands, &all, 0.0, 6))
        };
        let one = on(1);
        assert_eq!(one.order.len(), 6);
        for threads in [2, 3, 5] {
            let s = on(threads);
            assert_eq!(s.order, one.order, "{threads} threads");
            for (a, b) in s.joint_bits.iter().zip(&one.joint_bits) {
                assert_eq!(a.to_bits(), b.to_bits(), "{threads} threads");
            }
        }
        let exact = brute_joint(&cands, &one.order);
        let last = *one.joint_bits.last().unwrap();
        assert!((last - exact).abs() < 1e-9, "{last} vs {exact}");
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
    fn binning_matches_the_plain_conversion_bit_for_bit() {
        // The vectorised binning against `((v − lo)·(1/w)).min(last) as u16` one value at a
        // time, on values that land on bin edges, in the last bin, and past MAX_BINS widths.
        let mut state = 3u64;
        for &(n, width) in &[
            (1usize, 0.5),
            (7, 1.0),
            (1000, 0.1),
            (4099, 0.013),
            (300, 1e-9),
        ] {
            let values: Vec<f32> = (0..n)
                .map(|i| {
                    let u = crate::identify::domain::uncertainty::uniform(&mut state);
                    if i % 5 == 0 {
                        (i / 5) as f32 * width as f32 - 3.0
                    } else {
                        (u * 40.0 - 7.0) as f32
                    }
                })
                .collect();
            let lo = values.iter().fold(f32::MAX, |a, &v| a.min(v)) as f64;
            let last = (MAX_BINS - 1) as f64;
            let plain: Vec<u16> = values
                .iter()
                .map(|&v| ((v as f64 - lo) * (1.0 / width)).min(last) as u16)
                .collect();
            let b = bin_predictions(&values, width);
            assert_eq!(b.bins, plain, "n {n}, width {width}");
            assert_eq!(b.nbins, *plain.iter().max().unwrap() as usize + 1);
            assert!((b.entropy_bits - entropy(&b)).abs() < 1e-12);
        }
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
