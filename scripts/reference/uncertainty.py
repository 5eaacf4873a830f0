"""The combined uncertainty (src/identify/uncertainty.rs) and its random numbers
(src/bank/population.rs).

Monte Carlo samples of `U_c = y·S − T` from the same SplitMix64 stream as the Rust, so they
are the same numbers; shortest intervals on the |y| grid and interpolation between grid rows.
"""

import bisect
import math

import numpy as np

MASK64 = (1 << 64) - 1
GOLDEN = 0x9E3779B97F4A7C15


def splitmix64(state):
    """One SplitMix64 step on a Python int: (new state, output), every product masked to 64 bits."""
    state = (state + GOLDEN) & MASK64
    z = state
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & MASK64
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK64
    return state, z ^ (z >> 31)


def uniform_stream(seed_state, count):
    """The first `count` values of `uniform(&mut state)` from `seed_state`, vectorised.

    SplitMix64's i-th state is `seed + (i+1)·GOLDEN mod 2^64`, so the whole stream is one
    array expression; numpy's uint64 arithmetic wraps mod 2^64 like Rust's `wrapping_*`.
    `uniform` = top 53 bits / 2^53, exact in f64.
    """
    with np.errstate(over="ignore"):
        i = np.arange(1, count + 1, dtype=np.uint64)
        z = np.uint64(seed_state) + i * np.uint64(GOLDEN)
        z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
        z = z ^ (z >> np.uint64(31))
    u = (z >> np.uint64(11)).astype(np.float64) / float(1 << 53)
    # The vectorised stream must be the scalar one: check its first values (microseconds).
    state = seed_state
    for k in range(min(count, 4)):
        state, out = splitmix64(state)
        assert u[k] == (out >> 11) / float(1 << 53), "vectorised SplitMix64 drifted"
    return u


def shortest_interval(sorted_values, p):
    """Shortest `[lo, hi]` holding a fraction `p` of sorted samples; ties to the first."""
    n = sorted_values.size
    k = min(max(math.ceil(p * n), 1), n)
    widths = sorted_values[k - 1:] - sorted_values[:n - k + 1]
    i = int(np.argmin(widths))
    return float(sorted_values[i]), float(sorted_values[i + k - 1])


class CombinedUncertainty:
    """`U_c = y·S − T` by Monte Carlo; thresholds from shortest intervals on a |y| grid."""

    def __init__(self, settings):
        sources = settings["uncertainty"]
        m = settings["monte_carlo_samples"]
        seed_state = (settings["seed"] ^ 0x0005EED0F0C0FFEE) & MASK64
        u = uniform_stream(seed_state, m * len(sources)).reshape(m, len(sources))
        self.s = np.zeros(m)
        self.t = np.zeros(m)
        # Accumulated source by source, in table order: the same sums as the Rust loop.
        for j, src in enumerate(sources):
            x = src["min"] + (src["max"] - src["min"]) * u[:, j]
            sign = 1.0 if src["group"] == "model" else -1.0
            if src["kind"] == "relative":
                self.s += sign * x
            else:
                self.t += sign * x
        grid = [0.0]
        g = 0.05
        while g < 2000.0:
            grid.append(g)
            g *= 1.15
        grid.append(2000.0)
        self.grid = grid
        self.rows = {}
        self.intervals = {}
        self.s_range = (float(self.s.min()), float(self.s.max()))
        self.minus_t_max = float((-self.t).max())

    def interval(self, row, p):
        key = (row, p)
        if key not in self.intervals:
            if row not in self.rows:
                self.rows[row] = np.sort(self.grid[row] * self.s + self.t)
            self.intervals[key] = shortest_interval(self.rows[row], p)
        return self.intervals[key]

    def thresholds(self, y_kn, p):
        """`(low, high)` on prediction − measurement (kN) at force `y_kn`, probability `p`."""
        a = min(abs(y_kn), self.grid[-1])
        i = min(max(bisect.bisect_right(self.grid, a), 1), len(self.grid) - 1)
        g0, g1 = self.grid[i - 1], self.grid[i]
        w = (a - g0) / (g1 - g0) if g1 > g0 else 0.0
        l0, h0 = self.interval(i - 1, p)
        l1, h1 = self.interval(i, p)
        lo, hi = l0 + w * (l1 - l0), h0 + w * (h1 - h0)
        return (-hi, -lo) if y_kn < 0.0 else (lo, hi)

    def curve(self, y_kn, p):
        """The thresholds of a point measured at `y_kn` as a function of the prediction's force
        (src/identify/uncertainty.rs `ThresholdCurve`)."""
        return ThresholdCurve(self, y_kn, p)


class ThresholdCurve:
    """Thresholds at a prediction's own force where it exceeds the measurement: the grid rows
    from |y| to the force beyond which nothing passes even the hard bounds, interpolated as
    `thresholds` does, extended beyond by the extreme slopes of S."""

    def __init__(self, cu, y_kn, p):
        grid = cu.grid
        last = grid[-1]
        a0 = min(abs(y_kn), last)
        s_lo, s_hi = cu.s_range
        reach = min((a0 + cu.minus_t_max) / (1.0 - s_hi), last) if s_hi < 1.0 else last
        first = min(max(bisect.bisect_right(grid, a0), 1), len(grid) - 1) - 1
        end = min(max(bisect.bisect_left(grid, reach), first + 1), len(grid) - 1)
        self.from_kn = a0
        self.reach_kn = reach
        self.slopes = (s_lo, s_hi)
        self.g = np.array([grid[i] for i in range(first, end + 1)])
        iv = [cu.interval(i, p) for i in range(first, end + 1)]
        self.lo = np.array([v[0] for v in iv])
        self.hi = np.array([v[1] for v in iv])
        self.at_reach = self._interpolate(np.array([reach]))

    def _interpolate(self, a):
        i = np.clip(np.searchsorted(self.g, a, side="right"), 1, self.g.size - 1)
        g0, g1 = self.g[i - 1], self.g[i]
        w = np.where(g1 > g0, (a - g0) / np.where(g1 > g0, g1 - g0, 1.0), 0.0)
        l0, l1, h0, h1 = self.lo[i - 1], self.lo[i], self.hi[i - 1], self.hi[i]
        return l0 + w * (l1 - l0), h0 + w * (h1 - h0)

    def at(self, g):
        """`(low, high)` arrays on g − y for predictions `g` (f64 array)."""
        a = np.maximum(np.abs(g), self.from_kn)
        lo, hi = self._interpolate(np.minimum(a, self.reach_kn))
        beyond = a > self.reach_kn
        d = a - self.reach_kn
        lo = np.where(beyond, self.at_reach[0] + d * min(self.slopes[0], 0.0), lo)
        hi = np.where(beyond, self.at_reach[1] + d * max(self.slopes[1], 0.0), hi)
        return np.where(g < 0.0, -hi, lo), np.where(g < 0.0, -lo, hi)
