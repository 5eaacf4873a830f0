"""The neighbour graph searched by brute force (src/bank/neighbours.rs): the fallback for a
bank written without `neighbours.bin`, slow on a large bank."""

import numpy as np

NEIGHBOURS = 8


def unit_points(p, pop):
    """Unit-cube coordinates (L, d, c/c_max, X_p) of every instance."""

    def unit(v, r):
        return (v - r[0]) / (r[1] - r[0]) if r[1] > r[0] else np.zeros_like(v)

    c_lo = pop["curvature_mm"][0]
    c_max = np.minimum(pop["curvature_mm"][1], p["depth_mm"] / 2.0)
    c = np.where(c_max > c_lo, (p["curvature_mm"] - c_lo) / np.where(c_max > c_lo, c_max - c_lo, 1.0), 0.0)
    return np.stack(
        [unit(p["length_mm"], pop["length_mm"]), unit(p["depth_mm"], pop["depth_mm"]), c,
         unit(p["impact_position_m"], pop["impact_position_m"])],
        axis=1,
    )


def nearest(points, k):
    """The `k` nearest other points of each point (ties to the lower index), brute force in
    row blocks: the fallback for a bank written without `neighbours.bin`."""
    n = len(points)
    if n <= k:
        return np.array([[i if t + 1 >= n else (t if t < i else t + 1) for t in range(k)] for i in range(n)],
                        dtype=np.int64).reshape(n, k)
    out = np.empty((n, k), dtype=np.int64)
    block = max(1, 4_000_000 // n)
    for start in range(0, n, block):
        x = points[start:start + block]
        d2 = np.zeros((len(x), n))
        for t in range(4):  # summed in dimension order, as the Rust search does
            d2 += (x[:, t, None] - points[None, :, t]) ** 2
        d2[np.arange(len(x)), np.arange(start, start + len(x))] = np.inf
        part = np.argpartition(d2, k, axis=1)[:, :k + 1]
        for r in range(len(x)):
            cand = np.sort(part[r])
            order = cand[np.argsort(d2[r, cand], kind="stable")]
            if d2[r, order[k]] == d2[r, order[k - 1]]:  # a tie across the partition: sort all
                order = np.argsort(d2[r], kind="stable")
            out[start + r] = order[:k]
    return out


def neighbour_graph(p, pop):
    """The graph among the instances of the same wheel (src/bank/neighbours.rs)."""
    unit = unit_points(p, pop)
    graph = np.zeros((len(unit), NEIGHBOURS), dtype=np.int64)
    for wheel in (0, 1):
        members = np.flatnonzero(p["flat_wheel"] == wheel)
        if members.size:
            graph[members] = members[nearest(unit[members], NEIGHBOURS)]
    return graph
