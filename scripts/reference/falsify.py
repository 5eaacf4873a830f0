"""Falsification with the cell widening and the ranges of L, d, c, X_p and L0 as the union of
the surviving cells (src/identify/falsify.rs, ranges.rs)."""

import math

import numpy as np


def falsify(points, neighbours, kappa):
    """Rows that no point falsifies. `points`: (predictions f32, measured, low, high, curve).
    A row whose prediction exceeds the measurement and lies outside the measured force's band
    is judged with the band at its own force (`curve`, src/identify/uncertainty.rs); a row
    outside its band passes when some neighbour predicts at least (distance to the band)/κ
    away from it (the cell widening κ·max_j |g_j − g_i|)."""
    n = points[0][0].size if points else 0
    alive = np.arange(n)
    for g_all, y, low, high, curve in points:
        lo, hi = y + low, y + high
        g = g_all[alive].astype(np.float64)
        inside = (g >= lo) & (g <= hi)
        out = np.flatnonzero(~inside)
        go = g[out]
        blo = np.full(go.size, lo)
        bhi = np.full(go.size, hi)
        if curve is not None:
            above = np.abs(go) > abs(y)
            if above.any():
                clo, chi = curve.at(go[above])
                blo[above] = y + clo
                bhi[above] = y + chi
        ok = (go >= blo) & (go <= bhi)
        if kappa > 0.0:
            rest = np.flatnonzero(~ok)
            gr = go[rest]
            need = np.where(gr > bhi[rest], gr - bhi[rest], blo[rest] - gr) / kappa
            gj = g_all[neighbours[alive[out[rest]]]].astype(np.float64)
            ok[rest] = (np.abs(gj - gr[:, None]) >= need[:, None]).any(axis=1)
        inside[out] = ok
        alive = alive[inside]
        if alive.size == 0:
            break
    return alive


def fresh_length_mm(depth_mm, wheel_radius_m):
    """L0 = sqrt(8·d·R_w) (src/model/flat.rs)."""
    return math.sqrt(8.0 * depth_mm * wheel_radius_m * 1e3)


def ranges_of(params, half_extent, population, wheel_radius_m, members):
    """Union of the members' cells (their hull when `half_extent` is None), clamped to the
    population, with L0 from the depth bounds; None for no members."""
    if members.size == 0:
        return None
    out = {}
    for t, name in enumerate(["length_mm", "depth_mm", "curvature_mm", "impact_position_m"]):
        v = params[name][members]
        h = half_extent[members, t] if half_extent is not None else 0.0
        lo, hi = float((v - h).min()), float((v + h).max())
        out[name] = [max(lo, population[name][0]), min(hi, population[name][1])]
    d = out["depth_mm"]
    out["l0_mm"] = [fresh_length_mm(d[0], wheel_radius_m), fresh_length_mm(d[1], wheel_radius_m)]
    codes = params["flat_wheel"][members]
    out["flat_wheels"] = [w for w, present in (("leading", (codes == 0).any()), ("trailing", (codes != 0).any()))
                          if present]
    return out
