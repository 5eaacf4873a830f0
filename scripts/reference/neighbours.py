"""The neighbour graph searched by brute force (src/bank/neighbours.rs): the fallback for a
bank written without `neighbours.bin`, slow on a large bank."""

import numpy as np

NEIGHBOURS = 8

# Threshold half-widths per mm (L, d, c, X_p): src/bank/neighbours.rs SENSITIVITY_PER_MM.
SENSITIVITY_PER_MM = (0.27, 30.0, 22.5, 0.8)


def cell_weights(pop):
    """The axis weights of the cells' metric (src/bank/neighbours.rs `cell_weights`)."""

    def span(r):
        return max(r[1] - r[0], 0.0)

    mid_depth = 0.5 * (pop["depth_mm"][0] + pop["depth_mm"][1])
    c_span = max(min(pop["curvature_mm"][1], mid_depth / 2.0) - pop["curvature_mm"][0], 0.0)
    w = (
        SENSITIVITY_PER_MM[0] * span(pop["length_mm"]),
        SENSITIVITY_PER_MM[1] * span(pop["depth_mm"]),
        SENSITIVITY_PER_MM[2] * c_span,
        SENSITIVITY_PER_MM[3] * span(pop["impact_position_m"]) * 1e3,
    )
    return tuple(max(v, 1e-6) for v in w)


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


def nearest(points, k, weights=(1.0, 1.0, 1.0, 1.0)):
    """The `k` nearest other points of each point (ties to the lower index; distance
    Σ (w_t·Δx_t)²), brute force in row blocks: the fallback for a bank written without
    `neighbours.bin`."""
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
            d2 += (weights[t] * (x[:, t, None] - points[None, :, t])) ** 2
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
    """The graph among the instances of the same wheel, in the metric of `cell_weights`
    (src/bank/neighbours.rs)."""
    unit = unit_points(p, pop)
    weights = cell_weights(pop)
    graph = np.zeros((len(unit), NEIGHBOURS), dtype=np.int64)
    for wheel in (0, 1):
        members = np.flatnonzero(p["flat_wheel"] == wheel)
        if members.size:
            graph[members] = members[nearest(unit[members], NEIGHBOURS, weights)]
    return graph
