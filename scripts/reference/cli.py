"""The command line (same arguments as before the split into modules) and the stage timings."""

import argparse
import json
import os
import pathlib
import sys
import time

from .bank import PARAMETER_COLUMNS, Bank
from .cells import half_extents
from .errors import Failure
from .identify import identify, verdict
from .measurement import Measurement
from .settings import load_settings
from .uncertainty import CombinedUncertainty

DESCRIPTION = "Python reference pipeline for `wheelflat identify`: the speed peer of issue 13."

# The stages of the Rust `timings_ms`, in its order.
IDENTIFY_STAGES = ["align and pip", "read columns", "resolution", "binning 1", "greedy 1", "binning 2",
                   "greedy 2", "falsify", "ranges"]


class Stopwatch:
    """Named laps in milliseconds, in the order taken."""

    def __init__(self):
        self.laps = {}
        self.clock = time.perf_counter()

    def lap(self, name):
        now = time.perf_counter()
        self.laps[name] = (now - self.clock) * 1e3
        self.clock = now


def main(argv=None, started_s=None):
    """Runs the peer; `started_s`: the caller's `time.perf_counter()` before it imported this
    package (its imports and numpy's and pyarrow's are timed from there). Returns the exit
    status: 0, or 1 after printing a `Failure`."""
    imported_s = time.perf_counter()
    if started_s is None:
        started_s = imported_s
    ap = argparse.ArgumentParser(description=DESCRIPTION)
    ap.add_argument("--bank", type=pathlib.Path, default=pathlib.Path("bank"), help="bank directory")
    ap.add_argument("--measurement", "--measured", dest="measurement", type=pathlib.Path, required=True,
                    help="measurement CSV (time_s,<sensor>_kn,…)")
    ap.add_argument("--sensors", help="only these sensors, e.g. rps1,rps2")
    ap.add_argument("--calibration", type=pathlib.Path,
                    help="identification settings from this calibration TOML instead of the bank's")
    ap.add_argument("--out", type=pathlib.Path, help="result JSON (default: print only the verdict)")
    ap.add_argument("--threads", type=int, default=os.cpu_count() or 1, help="shard-reading threads")
    a = ap.parse_args(argv)
    sensors = a.sensors.split(",") if a.sensors else None

    watch = Stopwatch()
    try:
        bank = Bank(a.bank, a.threads, watch)
        settings = load_settings(bank.meta, a.calibration)
        # Each cell reaches half-way to the farthest neighbour in L, d, c, X_p (cells.rs).
        half_extent = half_extents(bank.params, bank.neighbours, PARAMETER_COLUMNS[:4])
        watch.lap("cells")
        uncertainty = CombinedUncertainty(settings)
        watch.lap("uncertainty samples")
        m = Measurement(a.measurement, bank.axes[0]["sample_rate_hz"])
        watch.lap("read measurement")
        result = identify(bank, settings, uncertainty, half_extent, m, sensors, watch)
        bank.close()
        watch.lap("close bank")
    except Failure as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    result["measurement"] = str(a.measurement)
    laps = dict(watch.laps)
    laps["identify (sum of its stages)"] = sum(laps[s] for s in IDENTIFY_STAGES)
    laps["imports"] = (imported_s - started_s) * 1e3
    laps["in process"] = (time.perf_counter() - started_s) * 1e3
    result["timings_ms"] = laps
    if a.out is not None:
        a.out.parent.mkdir(parents=True, exist_ok=True)
        a.out.write_text(json.dumps(result, indent=1) + "\n")
    print(verdict(result))
    return 0
