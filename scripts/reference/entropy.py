"""Binning and the two-pass lazy greedy joint-entropy selection (src/identify/entropy.rs)."""

import math
import sys

import numpy as np

# src/identify/entropy.rs `MAX_BINS`: bins are u16, a value past the last bin lands in it.
MAX_BINS = 1 << 16


def bin_predictions(values, width):
    """Bins of width `width` from the minimum (at most `MAX_BINS`), their count, and their
    entropy (bits).

    As the Rust `((v as f64 - lo) * inv).min(65535) as u16`: the offset scaled in f64, capped
    at the last bin, then truncated (the values are finite and at least `lo`, so truncation
    is the Rust's saturating cast).
    """
    lo = float(values.min())
    inv = 1.0 / max(width, 1e-12)
    x = values.astype(np.float64)
    x -= lo
    x *= inv
    np.minimum(x, float(MAX_BINS - 1), out=x)
    bins = x.astype(np.int64)
    nbins = int(bins.max()) + 1
    counts = np.bincount(bins)
    c = counts[counts > 0].astype(np.float64)
    n = values.size
    # numpy's pairwise sum, not Rust's sequential one: equal up to rounding (~1e-15 bit).
    entropy = math.log2(n) - float((c * np.log2(c)).sum()) / n
    return bins, nbins, entropy


def best_position(bounds):
    """The Rust fold: the first candidate, replaced only by one better by more than 1e-12."""
    bp, bg = 0, -sys.float_info.max
    for p, g in enumerate(bounds):
        if g > bg + 1e-12:
            bp, bg = p, g
    return bp


def greedy_joint_entropy(binned, allowed, alpha_bits, max_points, n):
    """Greedy joint-entropy selection, lazy (Minoux) like the Rust: every candidate keeps its
    last gain as an upper bound and only the best bound is re-evaluated until a fresh one is
    best. The partition of the instances by their tuple of chosen bins is kept as a dense group
    id over the *active* instances (those sharing a group with another); singletons gain nothing.

    Gain of candidate c: `(Σ_groups clog(n_g) − Σ_cells clog(c_gb)) / n`, clog(c) = c·log2(c).
    """
    order, joint_bits = [], []
    if n < 2 or not allowed:
        return order, joint_bits
    counts_range = np.arange(n + 1, dtype=np.float64)
    clog = np.zeros(n + 1)
    clog[1:] = counts_range[1:] * np.log2(counts_range[1:])
    active = np.arange(n)
    gid = np.zeros(n, dtype=np.int64)
    ngroups = 1
    group_term = float(clog[n])

    def cells_of(c):
        bins, nbins, _ = binned[c]
        key = gid * nbins + bins[active]
        size = ngroups * nbins
        if size <= 4 * key.size + 65536:
            counts = np.bincount(key, minlength=size)
        else:
            counts = np.unique(key, return_counts=True)[1]
        return counts

    def gain(c):
        return (group_term - float(clog[cells_of(c)].sum())) / n

    remaining = list(allowed)
    bounds = [binned[c][2] for c in remaining]
    fresh = [True] * len(remaining)
    joint = 0.0
    while remaining and len(order) < max_points and ngroups > 0:
        while True:
            pos = best_position(bounds)
            if fresh[pos]:
                break
            bounds[pos] = gain(remaining[pos])
            fresh[pos] = True
        best_gain = bounds[pos]
        if best_gain < alpha_bits or best_gain <= 1e-12:
            break
        chosen = remaining.pop(pos)
        bounds.pop(pos)
        fresh.pop(pos)
        joint += best_gain
        order.append(chosen)
        joint_bits.append(joint)
        # Refine the groups by the chosen bins; keep the sub-groups of two or more.
        bins, nbins, _ = binned[chosen]
        _, inverse, counts = np.unique(gid * nbins + bins[active], return_inverse=True, return_counts=True)
        keep_group = counts >= 2
        keep = keep_group[inverse]
        dense = np.cumsum(keep_group) - 1
        active = active[keep]
        gid = dense[inverse[keep]]
        ngroups = int(keep_group.sum())
        group_term = float(clog[counts[keep_group]].sum())
        fresh = [False] * len(remaining)
    return order, joint_bits
