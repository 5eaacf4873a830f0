"""The measurement (src/identify/measurement.rs): the CSV checked once, its alignment (the laser
trigger, or cross-correlation against the flat-free template) and its series on the bank
windows."""

import math

import numpy as np

from .errors import Failure


class Measurement:
    """A checked measurement: finite samples on a uniform, increasing time grid."""

    def __init__(self, path, expected_rate_hz):
        self.path = path
        self.laser_trigger_s = None
        self.speed_km_per_h = None
        lines = path.read_text().splitlines()
        header_at = None
        for i, raw in enumerate(lines):
            line = raw.strip()
            if not line:
                continue
            if line.startswith("#"):
                key, eq, value = line[1:].partition("=")
                if eq and key.strip() in ("laser_trigger_s", "speed_km_per_h"):
                    try:
                        v = float(value.strip())
                    except ValueError:
                        v = math.nan
                    if not math.isfinite(v):
                        raise Failure(f"{path}, line {i + 1}: `{key.strip()}` is not a finite number")
                    setattr(self, key.strip(), v)
                continue
            if header_at is None:
                header_at = i
                fields = [f.strip() for f in line.split(",")]
                if fields[0] != "time_s":
                    raise Failure(f"{path}, line {i + 1}: the header must start with `time_s`")
                names = []
                for f in fields[1:]:
                    if not f.endswith("_kn") or f == "_kn":
                        raise Failure(f"{path}, line {i + 1}: column `{f}`: force columns are `<sensor>_kn`")
                    if f[:-3] in names:
                        raise Failure(f"{path}, line {i + 1}: sensor `{f[:-3]}` appears twice")
                    names.append(f[:-3])
                if not names:
                    raise Failure(f"{path}, line {i + 1}: no sensor columns")
                self.sensors = names
        if header_at is None:
            raise Failure(f"{path}: no header line `time_s,<sensor>_kn,…`")
        try:
            data = np.loadtxt(lines[header_at + 1:], delimiter=",", comments="#", ndmin=2)
        except ValueError as e:
            raise Failure(f"{path}: {e}") from None
        if data.shape[0] < 2 or data.shape[1] != len(self.sensors) + 1:
            raise Failure(f"{path}: {data.shape[0]} data rows of {data.shape[1]} fields")
        if not np.isfinite(data).all():
            raise Failure(f"{path}: a value is not a finite number")
        time_s = data[:, 0]
        dt = np.diff(time_s)
        expected = 1.0 / expected_rate_hz
        if (dt <= 0).any():
            raise Failure(f"{path}: time does not increase")
        if (np.abs(dt - expected) > 0.01 * expected).any():
            raise Failure(f"{path}: time step does not match the bank's sample rate {expected_rate_hz} Hz")
        self.values_kn = np.ascontiguousarray(data[:, 1:].T)
        for name, col in zip(self.sensors, self.values_kn, strict=True):
            if np.abs(col).max() > 2000.0:
                raise Failure(f"{path}: `{name}_kn` reaches {np.abs(col).max():.0f}: newtons, not kN?")
        n = len(time_s)
        self.t0_s = float(time_s[0])
        self.dt_s = float((time_s[-1] - time_s[0]) / (n - 1))
        self.samples = n

    def on_window(self, s, axis, shift_s):
        """Sensor `s` on a bank window, linearly interpolated (bank time = file time + shift)."""
        k = np.arange(axis["samples"])
        t_bank = (axis["first_sample"] + k) / axis["sample_rate_hz"]
        x = (t_bank - shift_s - self.t0_s) / self.dt_s
        n = self.samples
        if (x < -1e-9).any() or (x > (n - 1) + 1e-9).any():
            raise Failure(
                f"{self.path}: sensor `{self.sensors[s]}` needs samples from "
                f"{axis['t0_s'] - shift_s:.4f} s to "
                f"{axis['t0_s'] + (axis['samples'] - 1) / axis['sample_rate_hz'] - shift_s:.4f} s (file clock); "
                f"the record spans {self.t0_s:.4f} s to {self.t0_s + (n - 1) * self.dt_s:.4f} s")
        x = np.clip(x, 0.0, n - 1)
        i = np.minimum(np.floor(x).astype(np.int64), n - 2)
        f = x - i
        v = self.values_kn[s]
        return v[i] * (1.0 - f) + v[i + 1] * f


def cross_correlate(m, pairs):
    """Best whole-sample shift by normalised cross-correlation with the flat-free template.

    `pairs`: (measurement sensor, axis, template). Offset o: bank sample G is file sample G − o,
    over the offsets that keep every window inside the record; ties to the smallest o. The sums
    are numpy's (np.correlate, cumulative sums), not the Rust loop's order: the correlation can
    differ in its last digits, which moves the shift only between offsets tied to ~1e-15.
    """
    lo = min(a["first_sample"] for _, a, _ in pairs)
    hi = max(a["first_sample"] + a["samples"] for _, a, _ in pairs)
    offsets = np.arange(hi - m.samples, lo + 1)
    if offsets.size == 0:
        return None
    num = np.zeros(offsets.size)
    yy = np.zeros(offsets.size)
    gg = 0.0
    for s, axis, template in pairs:
        y = m.values_kn[s]
        g = template.astype(np.float64)
        # File index of template sample 0 at offset o: first − o.
        start = axis["first_sample"] - offsets
        full = np.correlate(y, g, mode="valid")  # full[j] = Σ_k y[j + k]·g[k]
        num += full[start]
        c2 = np.concatenate([[0.0], np.cumsum(y * y)])
        yy += c2[start + len(g)] - c2[start]
        gg += float(g @ g)
    c = num / np.maximum(np.sqrt(yy * gg), 1e-300)
    best = int(np.argmax(c))
    rate = 1.0 / m.dt_s
    return float(offsets[best] / rate - m.t0_s), float(c[best])
