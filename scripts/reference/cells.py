"""The bank resolution (src/identify/cells.rs): each instance's cell from the neighbour graph
and the typical widening at a point, κ × the median neighbour spread over ~1024 anchors
(`typical_widening`)."""

import numpy as np


def half_extents(params, neighbours, columns):
    """Half-way to the farthest neighbour in each of `columns` (L, d, c, X_p): n × 4."""
    return np.stack(
        [(0.5 * np.abs(v[neighbours] - v[:, None])).max(axis=1) for v in (params[c] for c in columns)],
        axis=1,
    )


def typical_spread(predictions, neighbours, anchors=1024):
    """Median over ~`anchors` evenly spread instances of max_j |g_j − g_i| (f32, as the Rust),
    for every candidate row of `predictions` at once."""
    n = predictions.shape[1]
    if n == 0:
        return np.zeros(predictions.shape[0])
    step = max(n // min(max(anchors, 1), n), 1)
    idx = np.arange(0, n, step)
    g_i = predictions[:, idx]
    g_j = predictions[:, neighbours[idx]]  # (candidates, anchors, 8)
    spread = np.abs(g_j - g_i[:, :, None]).max(axis=2)
    mid = idx.size // 2
    return np.partition(spread, mid, axis=1)[:, mid].astype(np.float64)
