//! The greedy selection's partition and gains, counted over the instances *outside each point's
//! modal bin* only.
//!
//! At most sample points most of the bank's predictions share one bin: the instances whose
//! flat leaves no mark there (on the default 50k bank, 45–100 % of the instances a point,
//! 80–88 % on average). Within a group of the partition, the instances in that *modal* bin
//! number the group's size less the others, so a group's share of the gain,
//! `n_g·log2 n_g − Σ_b c_gb·log2 c_gb`, needs only the others: a group with none of them
//! gains nothing and is never visited. [`Sparse`] lists a point's other instances by bin;
//! [`Groups`] keeps the partition as each instance's group number, so that refining it by the
//! chosen point moves only that point's other instances into new groups (the modal ones stay
//! where they are); [`GroupTally`] counts a candidate's other instances group by group.

/// No group: the instance shares its tuple of bins with no other, so it can gain nothing.
pub(crate) const NO_GROUP: u32 = u32::MAX;

/// A point's instances outside its modal bin, bin by bin (ascending instance numbers within a
/// bin).
#[derive(Debug, Clone, PartialEq, Default)]
pub(crate) struct Sparse {
    /// `members[starts[b]..starts[b + 1]]` are the instances in bin `b`; the modal bin's run is
    /// empty.
    starts: Vec<u32>,
    members: Vec<u32>,
}

impl Sparse {
    /// Lists the instances of `bins` outside the most populated bin (the lowest of equals),
    /// given the bins' counts.
    pub(crate) fn new(bins: &[u16], counts: &[u32]) -> Sparse {
        let modal = (0..counts.len())
            .max_by_key(|&b| (counts[b], std::cmp::Reverse(b)))
            .unwrap_or(0);
        let mut starts = Vec::with_capacity(counts.len() + 1);
        let mut total = 0u32;
        starts.push(0);
        for (b, &c) in counts.iter().enumerate() {
            total += if b == modal { 0 } else { c };
            starts.push(total);
        }
        // The others flagged 64 instances at a time (a comparison the compiler vectorises),
        // then, eight flags a word, each flagged instance into its bin's run.
        let modal = modal as u16; // fewer than MAX_BINS bins
        let mut next = starts[..starts.len() - 1].to_vec();
        let mut members = vec![0u32; total as usize];
        let mut flags = [0u8; 64];
        for (c, chunk) in bins.chunks(64).enumerate() {
            if chunk.len() < 64 {
                flags.fill(0);
            }
            for (f, &b) in flags.iter_mut().zip(chunk) {
                *f = u8::from(b != modal);
            }
            for (w, word) in flags.chunks_exact(8).enumerate() {
                let mut bits = u64::from_le_bytes(word.try_into().expect("eight flags"));
                while bits != 0 {
                    let i = w * 8 + bits.trailing_zeros() as usize / 8;
                    bits &= bits - 1;
                    let b = chunk[i] as usize;
                    members[next[b] as usize] = (c * 64 + i) as u32;
                    next[b] += 1;
                }
            }
        }
        Sparse { starts, members }
    }

    /// The runs of instances, one a bin (the modal bin's empty).
    fn runs(&self) -> impl Iterator<Item = &[u32]> {
        self.starts
            .windows(2)
            .map(|w| &self.members[w[0] as usize..w[1] as usize])
    }
}

/// The partition of the instances by their tuple of bins at the chosen points: each
/// instance's group number ([`NO_GROUP`] once alone) and each group's size.
#[derive(Debug, Clone)]
pub(crate) struct Groups {
    of: Vec<u32>,
    len: Vec<u32>,
    /// Scratch for [`Groups::refine`], by group number: members met in the current bin, and
    /// the number of the group they move to.
    count: Vec<u32>,
    moved_to: Vec<u32>,
    met: Vec<u32>,
}

impl Groups {
    /// `n` instances in one group.
    pub(crate) fn whole(n: usize) -> Groups {
        Groups {
            of: vec![0; n],
            len: vec![n as u32],
            count: Vec::new(),
            moved_to: Vec::new(),
            met: Vec::new(),
        }
    }

    /// Group numbers in use so far (every counting table needs this many entries).
    pub(crate) fn numbers(&self) -> usize {
        self.len.len()
    }

    /// Refines the partition by a point, given as its [`Sparse`] list: in each group, the
    /// members in one of the point's other bins move to a new group together (one a group and
    /// bin, numbered in the order met); those in the modal bin stay. A member left alone in a
    /// new group leaves the partition; one left alone in its old group stays in it (it gains
    /// nothing there either: its group's share is `1·log2 1 − 1·log2 1 = 0`).
    pub(crate) fn refine(&mut self, point: &Sparse) {
        self.count.resize(self.len.len(), 0);
        self.moved_to.resize(self.len.len(), 0);
        for run in point.runs() {
            count_by_group(run, &self.of, &mut self.count, &mut self.met);
            for &g in &self.met {
                let c = std::mem::take(&mut self.count[g as usize]);
                self.len[g as usize] -= c;
                self.moved_to[g as usize] = if c > 1 {
                    self.len.push(c);
                    (self.len.len() - 1) as u32
                } else {
                    NO_GROUP
                };
            }
            for &k in run {
                let g = self.of[k as usize];
                if g != NO_GROUP {
                    self.of[k as usize] = self.moved_to[g as usize];
                }
            }
            self.met.clear();
        }
    }
}

/// Counts the instances of `run` by their group in `of` into `count` (zero on entry), listing
/// in `met` each group the first time it is met; instances in no group are skipped.
#[inline]
fn count_by_group(run: &[u32], of: &[u32], count: &mut [u32], met: &mut Vec<u32>) {
    for &k in run {
        let g = of[k as usize];
        if g == NO_GROUP {
            continue;
        }
        let c = &mut count[g as usize];
        if *c == 0 {
            met.push(g);
        }
        *c += 1;
    }
}

/// One thread's counting tables for [`GroupTally::gain_cells`], indexed by group number; every
/// entry is zero between evaluations.
#[derive(Debug, Default)]
pub(crate) struct GroupTally {
    /// Instances of the current bin in each group.
    count: Vec<u32>,
    /// Instances outside the modal bin in each group, and `Σ_b c·log2 c` over their bins
    /// (side by side: one cache line a group).
    outside: Vec<(f64, u32)>,
    /// Groups met in the current bin, and in the whole evaluation (first-met order).
    in_bin: Vec<u32>,
    met: Vec<u32>,
}

impl GroupTally {
    /// `Σ_groups (n_g·log2 n_g − Σ_b c_gb·log2 c_gb)` for a candidate given as its [`Sparse`]
    /// list, over the partition `groups` (`clog` from `entropy::clog_table`). Summed group by
    /// group in the order the groups are first met (deterministic for given inputs).
    pub(crate) fn gain_cells(&mut self, sparse: &Sparse, groups: &Groups, clog: &[f64]) -> f64 {
        let numbers = groups.numbers();
        if self.count.len() < numbers {
            self.count.resize(numbers, 0);
            self.outside.resize(numbers, (0.0, 0));
        }
        for run in sparse.runs() {
            count_by_group(run, &groups.of, &mut self.count, &mut self.in_bin);
            for &g in &self.in_bin {
                let g = g as usize;
                let c = std::mem::take(&mut self.count[g]);
                let o = &mut self.outside[g];
                if o.1 == 0 {
                    self.met.push(g as u32);
                }
                o.1 += c;
                o.0 += clog[c as usize];
            }
            self.in_bin.clear();
        }
        let mut sum = 0.0;
        for &g in &self.met {
            let g = g as usize;
            let n = groups.len[g] as usize;
            let (cells, outside) = std::mem::take(&mut self.outside[g]);
            sum += clog[n] - clog[n - outside as usize] - cells;
        }
        self.met.clear();
        sum
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::select::entropy::clog_table as clog;

    fn sparse(bins: &[u16], nbins: usize) -> Sparse {
        let mut counts = vec![0; nbins];
        bins.iter().for_each(|&b| counts[b as usize] += 1);
        Sparse::new(bins, &counts)
    }

    #[test]
    fn the_modal_bin_is_left_out_and_the_rest_kept_in_order() {
        let s = sparse(&[2, 0, 2, 1, 2, 0, 3], 4);
        assert_eq!(s.starts, vec![0, 2, 3, 3, 4]);
        assert_eq!(s.members, vec![1, 5, 3, 6]);
        // Equal counts: the lowest bin is modal.
        assert_eq!(sparse(&[1, 0, 1, 0], 2).members, vec![0, 2]);
        assert!(sparse(&[0, 0, 0], 1).members.is_empty());
    }

    #[test]
    fn refining_moves_the_other_bins_and_drops_new_singletons() {
        let mut g = Groups::whole(6);
        // Bin 0 modal (3 of 6); bin 1 holds 1, 4; bin 2 holds 5 alone.
        g.refine(&sparse(&[0, 1, 0, 0, 1, 2], 3));
        assert_eq!(g.of, vec![0, 1, 0, 0, 1, NO_GROUP]);
        assert_eq!(g.len, vec![3, 2]);
        // Then instance 0 apart from 2 and 3: alone in its new group, it leaves.
        g.refine(&sparse(&[1, 0, 0, 0, 0, 0], 2));
        assert_eq!(g.of, vec![NO_GROUP, 1, 0, 0, 1, NO_GROUP]);
        assert_eq!(g.len, vec![2, 2]);
    }

    /// The partition by the tuples of bins at `points`, as a map from each instance to the
    /// first instance of its tuple.
    fn tuples(points: &[Vec<u16>], n: usize) -> Vec<usize> {
        let mut first = std::collections::HashMap::new();
        (0..n)
            .map(|k| {
                *first
                    .entry(points.iter().map(|p| p[k]).collect::<Vec<_>>())
                    .or_insert(k)
            })
            .collect()
    }

    proptest::proptest! {
        /// Against the plain count of every group's bins, after refining by random points, and
        /// the partition against hashing the tuples of bins from scratch.
        #[test]
        fn sparse_gain_and_refinement_equal_the_full_count(
            points in proptest::collection::vec(proptest::collection::vec(0u16..4, 60), 1..4),
            cand in proptest::collection::vec(0u16..6, 60),
        ) {
            let n = 60;
            let mut groups = Groups::whole(n);
            for p in &points {
                groups.refine(&sparse(p, 4));
            }
            // A group is one tuple's instances, all of them, and its size is right; only an
            // instance alone in its tuple may have none.
            let first = tuples(&points, n);
            for k in 0..n {
                let alone = (0..n).filter(|&j| first[j] == first[k]).count() == 1;
                if groups.of[k] == NO_GROUP {
                    proptest::prop_assert!(alone);
                } else {
                    let members: Vec<usize> = (0..n).filter(|&j| groups.of[j] == groups.of[k]).collect();
                    proptest::prop_assert_eq!(members.len(), groups.len[groups.of[k] as usize] as usize);
                    proptest::prop_assert!(members.iter().all(|&j| first[j] == first[k]));
                    proptest::prop_assert_eq!(members.len(), (0..n).filter(|&j| first[j] == first[k]).count());
                }
            }
            let clog = clog(n);
            let mut plain = 0.0;
            for g in 0..groups.numbers() as u32 {
                let mut counts = [0usize; 6];
                let members: Vec<usize> = (0..n).filter(|&k| groups.of[k] == g).collect();
                members.iter().for_each(|&k| counts[cand[k] as usize] += 1);
                plain += clog[members.len()] - counts.iter().map(|&c| clog[c]).sum::<f64>();
            }
            let mut t = GroupTally::default();
            let s = sparse(&cand, 6);
            let got = t.gain_cells(&s, &groups, &clog);
            proptest::prop_assert!((got - plain).abs() < 1e-9 * (1.0 + plain.abs()), "{} vs {}", got, plain);
            // The tables are left zero: a second evaluation gives the same, bit for bit.
            proptest::prop_assert_eq!(got.to_bits(), t.gain_cells(&s, &groups, &clog).to_bits());
        }
    }
}
