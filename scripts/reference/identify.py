"""The pipeline (src/identify/mod.rs `Identifier::identify`) and its verdict line.

Sensors and alignment, PIPs per series, the bank columns of the candidate points read by column
projection, the bank resolution, binning and the greedy selection twice (at m = 1, then at the
Šídák width for the m found), falsification and the ranges of the candidate model set.
"""

import math

import numpy as np

from .cells import typical_spread
from .entropy import bin_predictions, greedy_joint_entropy
from .errors import Failure
from .falsify import falsify, ranges_of
from .measurement import cross_correlate
from .pip import pips


def envelope_windows(series, templates, per_series, half_width):
    """Window centres (series, sample): per series the samples departing most from the
    flat-free signature, at least 2w + 1 apart (src/identify/envelope.rs `windows`)."""
    out = []
    for si, y in enumerate(series):
        n = min(len(y), len(templates[si]))
        if per_series == 0 or n < 2 * half_width + 1:
            continue
        dev = [(abs(float(y[k]) - float(templates[si][k])), k) for k in range(half_width, n - half_width)]
        dev.sort(key=lambda t: (-t[0], t[1]))
        chosen = []
        for _, k in dev:
            if len(chosen) == per_series:
                break
            if all(abs(c - k) > 2 * half_width for c in chosen):
                chosen.append(k)
        out.extend((si, k) for k in sorted(chosen))
    return out


def fitted_level(y, template):
    """A sensor's level over the flat-free prediction (src/identify/detect.rs `test_sensor`):
    least squares over the loaded samples, summed in order as the Rust sums."""
    peak = 0.0
    for g in template:
        peak = max(peak, abs(float(g)))
    floor = max(0.25 * peak, 2.0)
    yg = gg = 0.0
    n = 0
    for yk, g in zip(y, template):
        g = float(g)
        if abs(g) >= floor:
            yg += float(yk) * g
            gg += g * g
            n += 1
    fitted = yg / gg if gg > 0.0 and math.isfinite(yg / gg) else 1.0
    return fitted, n


def at_bank_load(series, templates, table, vehicle):
    """The record put on the bank's load (src/identify/load.rs `at_bank_load`): the sensors'
    mean level over the table's mean level factor gives the load's ratio to the bank's; a pass
    heavier than the bank is scaled down, a lighter one has the static part added."""
    levels = []
    for y, t in zip(series, templates):
        fitted, n = fitted_level(y, t)
        if n > 0 and math.isfinite(fitted) and fitted > 0.0:
            levels.append(fitted)
    if not levels:
        return series
    mean_level = 0.0
    for a in levels:
        mean_level += a
    mean_level /= len(levels)

    def mid(group):
        total = 0.0
        for u in table:
            if u["group"] == group and u["kind"] == "relative":
                total += 0.5 * (u["min"] + u["max"])
        return total

    level_at_bank = (1.0 - mid("model")) * (1.0 + mid("measurement"))
    # As the Rust computes it: the load shown = mean level × the bank's load ÷ that factor.
    v = vehicle
    bank_kn = (0.5 * (v["car_body_mass_kg"] + v["bogie_mass_kg"]) + v["wheel_mass_kg"]) * v["gravity_m_per_s2"] / 1e3
    shown_kn = mean_level * bank_kn / level_at_bank
    r = bank_kn / shown_kn
    out = []
    for y, t in zip(series, templates):
        y = np.array(y, dtype=np.float64)
        if r < 1.0:
            y = y * r
        else:
            excess = mean_level * (1.0 - r)
            y = y - excess * t.astype(np.float64)
        out.append(y)
    return out


def identify(bank, settings, uncertainty, half_extent, m, sensors, watch):
    """Identifies measurement `m` against `bank` with only `sensors` (None: all the file has):
    the result as a dict for the JSON, each stage lapped on `watch`."""
    meta = bank.meta
    cal = meta["calibration"]
    n = bank.n
    kappa = settings["bank_resolution"]
    if settings["pip_distance"] not in ("vertical", "perpendicular", "euclidean"):
        raise Failure(f"unknown PIP distance `{settings['pip_distance']}`")

    # Sensors: those in the file (and asked for), in file order; each must be in the bank.
    axis_names = [a["name"] for a in bank.axes]
    used = []
    for mi, name in enumerate(m.sensors):
        if sensors is not None and name not in sensors:
            continue
        if name not in axis_names:
            raise Failure(f"{m.path}: sensor `{name}` is not in the bank (bank sensors: {', '.join(axis_names)})")
        used.append((mi, axis_names.index(name)))
    for name in sensors or []:
        if name not in m.sensors:
            raise Failure(f"{m.path}: sensor `{name}` was asked for but the file has no `{name}_kn` column")
    if not used:
        raise Failure(f"{m.path}: no usable sensor")
    bank_speed = cal["run"]["speed_km_per_h"]
    if m.speed_km_per_h is not None and abs(m.speed_km_per_h / bank_speed - 1.0) > 0.02:
        raise Failure(f"{m.path}: speed {m.speed_km_per_h} km/h differs from the bank's {bank_speed} km/h "
                      "by more than 2 %")

    # Alignment.
    speed = bank_speed / 3.6
    if m.laser_trigger_s is not None:
        t_bank = (cal["sensors"]["laser_trigger_m"] - cal["run"]["leading_wheel_start_m"]) / speed
        alignment = {"method": "laser trigger", "shift_s": t_bank - m.laser_trigger_s, "correlation": None}
    else:
        found = cross_correlate(m, [(mi, bank.axes[bi], bank.template[bi]) for mi, bi in used])
        if found is None:
            raise Failure(f"{m.path}: the record is shorter than the bank windows")
        alignment = {"method": "cross-correlation", "shift_s": found[0], "correlation": found[1]}
    series = [m.on_window(mi, bank.axes[bi], alignment["shift_s"]) for mi, bi in used]
    recorded = series
    # The record put on the bank's load (src/identify/load.rs); its PIPs are the record's own.
    series = at_bank_load(series, [bank.template[bi] for _, bi in used], settings["uncertainty"],
                          cal["vehicle"])

    # PIPs → candidate points (series, sample, PIP order).
    cands = []
    for si, y in enumerate(recorded):
        for order, k in enumerate(pips(y, settings["pips_per_series"], settings["pip_distance"])):
            cands.append((si, k, order))
    watch.lap("align and pip")

    # The bank's predictions at the candidates: one f32 row per candidate.
    predictions = bank.read_samples([bank.column_name(used[si][1], k) for si, k, _ in cands])
    watch.lap("read columns")

    measured = np.array([series[si][k] for si, k, _ in cands])
    alpha = settings["alpha_fraction"] * math.log2(n)
    allowed = list(range(len(cands)))
    widening = kappa * typical_spread(predictions, bank.neighbours) if kappa > 0.0 else np.zeros(len(cands))
    watch.lap("resolution")

    def bin_all(p):
        binned = []
        for i in range(len(cands)):
            lo, hi = uncertainty.thresholds(float(measured[i]), p)
            lo, hi = lo - widening[i], hi + widening[i]
            binned.append(bin_predictions(predictions[i], hi - lo))
        return binned

    # Bins at the Šídák width for m points; m comes from the selection itself, so select with
    # m = 1, then again with the m found.
    phi = settings["phi"]
    binned = bin_all(phi)
    watch.lap("binning 1")
    first, _ = greedy_joint_entropy(binned, allowed, alpha, len(cands), n)
    m1 = max(len(first), 1)
    p = phi ** (1.0 / m1)
    watch.lap("greedy 1")
    binned = bin_all(p)
    watch.lap("binning 2")
    eip, joint_bits = greedy_joint_entropy(binned, allowed, alpha, m1, n)
    m_final = max(len(eip), 1)
    watch.lap("greedy 2")

    # Envelope points at the impact spikes (src/identify/envelope.rs); Šídák over every point.
    hw = settings["envelope_half_width_samples"]
    centres = envelope_windows(series, [bank.template[bi] for _, bi in used],
                               settings["envelope_windows_per_sensor"], hw)
    p_final = phi ** (1.0 / (m_final + 2 * len(centres)))
    env_points = []
    if centres:
        rows = bank.read_samples([bank.column_name(used[si][1], j)
                                  for si, k in centres for j in range(k - hw, k + hw + 1)])
        per = 2 * hw + 1
        for c, (si, k) in enumerate(centres):
            window = rows[c * per:(c + 1) * per]
            for use_max in (True, False):
                feature = window.max(axis=0) if use_max else window.min(axis=0)
                y_window = series[si][k - hw:k + hw + 1]
                y_feature = float(max(y_window) if use_max else min(y_window))
                lo, hi = uncertainty.thresholds(y_feature, p_final)
                env_points.append((feature, y_feature, lo, hi, uncertainty.curve(y_feature, p_final)))
    watch.lap("envelope")

    thresholds = [uncertainty.thresholds(float(y), p_final) for y in measured]
    points = [(predictions[i], float(measured[i]), thresholds[i][0], thresholds[i][1],
               uncertainty.curve(float(measured[i]), p_final)) for i in eip]
    cms = falsify(points + env_points, bank.neighbours, kappa)
    watch.lap("falsify")

    params = bank.params
    radius = cal["vehicle"]["wheel_radius_m"]
    cells = half_extent if kappa > 0.0 else None
    ranges = ranges_of(params, cells, bank.population, radius, cms)
    wheel_ranges = []
    for code, wheel in ((0, "leading"), (1, "trailing")):
        members = cms[(params["flat_wheel"][cms] != 0) == bool(code)]
        r = ranges_of(params, cells, bank.population, radius, members)
        if r is not None:
            wheel_ranges.append({"wheel": wheel, "cms_count": int(members.size), "ranges": r})
    residual = np.zeros(n)
    for g, y, _, _, _ in points:
        residual += (g.astype(np.float64) - y) ** 2
    rm = int(np.argmin(residual)) if points else 0
    watch.lap("ranges")

    return {
        "bank_id": meta["bank_id"],
        "bank_instances": n,
        "alignment": alignment,
        "sensors": [bank.axes[bi]["name"] for _, bi in used],
        "pip_distance": settings["pip_distance"],
        "pips_per_series": settings["pips_per_series"],
        "candidates": len(cands),
        "candidate_points": {
            "series": [c[0] for c in cands],
            "sample": [c[1] for c in cands],
            "measured_kn": measured.tolist(),
            "entropy_bits": [b[2] for b in binned],
            "threshold_low_kn": [t[0] for t in thresholds],
            "threshold_high_kn": [t[1] for t in thresholds],
            "resolution_kn": widening.tolist(),
        },
        "alpha_bits": alpha,
        "phi": phi,
        "first_pass_points": m1,
        "eip": [
            {
                "candidate": i,
                "series": cands[i][0],
                "sensor": bank.axes[used[cands[i][0]][1]]["name"],
                "sample": cands[i][1],
                "time_s": bank.axes[used[cands[i][0]][1]]["t0_s"]
                + cands[i][1] / bank.axes[used[cands[i][0]][1]]["sample_rate_hz"],
                "measured_kn": float(measured[i]),
                "entropy_bits": binned[i][2],
                "threshold_low_kn": thresholds[i][0],
                "threshold_high_kn": thresholds[i][1],
                "resolution_kn": float(widening[i]),
            }
            for i in eip
        ],
        "eip_joint_entropy_bits": [float(b) for b in joint_bits],
        "envelope_points": len(env_points),
        "per_point_probability": p_final,
        "cms_count": int(cms.size),
        "cms_instances": [int(params["instance"][k]) for k in cms],
        "ranges": ranges,
        "wheel_ranges": wheel_ranges,
        "residual_minimisation": int(params["instance"][rm]),
        "model_class_refuted": bool(cms.size == 0),
    }


def verdict(result):
    r = result["ranges"]
    points = len(result["eip"])
    if r is None:
        return (f"refuted: every one of the {result['bank_instances']} instances is falsified at {points} points "
                f"(φ = {result['phi']})")
    return (f"CMS {result['cms_count']} of {result['bank_instances']} instances at {points} points: "
            f"L0 {r['l0_mm'][0]:.1f}–{r['l0_mm'][1]:.1f} mm, L {r['length_mm'][0]:.1f}–{r['length_mm'][1]:.1f} mm, "
            f"d {r['depth_mm'][0]:.3f}–{r['depth_mm'][1]:.3f} mm, wheels {'+'.join(r['flat_wheels'])}")
