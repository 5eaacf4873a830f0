"""Perceptually important points (src/identify/pip.rs)."""

import bisect
import math

import numpy as np


def pips(y, j, distance):
    """Indices of the `j` most important points of `y`, in the order found (ends first).

    Each point keeps its distance to the line between the PIPs around it; adding a PIP
    recomputes only the two gaps it splits. The next PIP is the first maximum in index order,
    as in the Rust gap scan.
    """
    n = y.size
    if n == 0:
        return []
    j = min(j, n)
    lo, hi = y.min(), y.max()
    sy = 1.0 / (hi - lo) if hi > lo else 1.0
    sx = 1.0 / (n - 1) if n > 1 else 1.0
    chosen = [0]
    if j >= 2 and n >= 2:
        chosen.append(n - 1)
    dist = np.full(n, -np.inf)
    xs = np.arange(n, dtype=np.float64)

    def gap(left, right):
        if right - left < 2:
            return
        x1, y1, x2, y2 = float(left), y[left], float(right), y[right]
        xk, yk = xs[left + 1:right], y[left + 1:right]
        if distance == "vertical":
            slope = (y2 - y1) / (x2 - x1)
            d = np.abs(yk - (y1 + slope * (xk - x1)))
        elif distance == "perpendicular":
            dx, dy = (x2 - x1) * sx, (y2 - y1) * sy
            px, py = (xk - x1) * sx, (yk - y1) * sy
            d = np.abs(dx * py - dy * px) / math.sqrt(dx * dx + dy * dy)
        else:  # euclidean
            d1 = np.sqrt(((xk - x1) * sx) ** 2 + ((yk - y1) * sy) ** 2)
            d2 = np.sqrt(((x2 - xk) * sx) ** 2 + ((y2 - yk) * sy) ** 2)
            d = d1 + d2
        dist[left + 1:right] = d

    if len(chosen) == 2:
        gap(0, n - 1)
    ordered = sorted(chosen)
    while len(chosen) < j:
        k = int(np.argmax(dist))
        if dist[k] == -np.inf:
            break
        at = bisect.bisect_left(ordered, k)
        left, right = ordered[at - 1], ordered[at]
        ordered.insert(at, k)
        chosen.append(k)
        dist[k] = -np.inf
        gap(left, k)
        gap(k, right)
    return chosen
