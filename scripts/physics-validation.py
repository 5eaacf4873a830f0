#!/usr/bin/env python3
"""Physics-varied validation (issue 56): identify every pass of a cache made by
`physics_passes` with `wheelflat identify` and judge it against its truth.

    scripts/physics-validation.py WHEELFLAT BANK CACHE [--calibration F] [--refine]
        [--refine-strategy bounds|spread] [--refine-simulations N] [--jobs 2] [--cases FROM:TO]

CACHE may also be a folder of independent passes (one folder a pass: `measured.csv`,
`truth.json` with `flat` {L_mm, d_mm, L0_fresh_mm} or none).

Per pass: a flat's truth held (its L and d inside the reported ranges; a flat answered
"below the population" holds when its L0 is below the population's floor), refuted (no
instance survives and not below the population), the L0 width, the classes the answer
spans; a good wheel quiet (no flat detected). Printed: one line a pass, then held / refuted /
median L0 width / one class / below-inspect flats told urgent / good wheels quiet, bank-only
and (with --refine) refined.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor

CLASSES = ["none", "monitor", "inspect", "urgent"]


def measured_path(cache, case):
    if isinstance(case, str):
        return os.path.join(cache, case, "measured.csv")
    return os.path.join(cache, f"case-{case}.csv")


def load_truth(cache, case):
    """The truth in the study's form: l0_mm, length_mm, depth_mm, flat_wheel."""
    if isinstance(case, int):
        with open(os.path.join(cache, f"case-{case}.truth.json")) as f:
            return json.load(f)
    with open(os.path.join(cache, case, "truth.json")) as f:
        t = json.load(f)
    flat = t.get("flat")
    if not flat or "L_mm" not in flat:
        return {"l0_mm": 0.0, "length_mm": 0.0, "depth_mm": 0.0, "flat_wheel": None,
                "real": bool(flat)}
    return {"l0_mm": flat.get("L0_fresh_mm", flat.get("L0_mm")), "length_mm": flat["L_mm"], "depth_mm": flat["d_mm"],
            "flat_wheel": flat.get("wheel", "flat")}


def identify(args, case, work):
    out = os.path.join(work, f"out-{case}")
    cmd = [args.wheelflat, "identify", "--bank", args.bank,
           "--measured", measured_path(args.cache, case), "--out", out]
    if args.calibration:
        cmd += ["--calibration", args.calibration]
    if args.refine:
        cmd += ["--refine"]
        if args.refine_strategy:
            cmd += ["--refine-strategy", args.refine_strategy]
        if args.refine_simulations:
            cmd += ["--refine-simulations", str(args.refine_simulations)]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        return {"error": (p.stderr or p.stdout).strip().splitlines()[-1:]}
    with open(os.path.join(out, "identification.json")) as f:
        return json.load(f)


def judge(ident, truth, ranges_key, insp, urg):
    """(held, refuted, l0 range or None, lowest class, highest class) of one answer."""
    det = ident.get("detection") or {}
    if not det.get("flat_detected", False):
        return (False, False, None, "none", "none")
    if ranges_key == "bank":
        f = (ident.get("falsifications") or [None])[0]
        r = f and f.get("ranges")
    else:
        ref = ident.get("refinement") or {}
        r = ref.get("ranges")
    pop = ident.get("population") or {}
    if r is None:
        below = ident.get("below_population") or (ident.get("model_class_refuted") is False)
        floor = (pop.get("l0_mm") or [0, 0])[0]
        held = below and truth["l0_mm"] < floor
        return (held, not below, None, "monitor", "monitor")
    inside = lambda b, v: b[0] <= v <= b[1]
    held = inside(r["length_mm"], truth["length_mm"]) and inside(r["depth_mm"], truth["depth_mm"])
    l0 = r["l0_mm"]
    cls = lambda v: "urgent" if v >= urg else ("inspect" if v >= insp else "monitor")
    return (held, False, l0, cls(l0[0]), cls(l0[1]))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("wheelflat")
    ap.add_argument("bank")
    ap.add_argument("cache")
    ap.add_argument("--calibration")
    ap.add_argument("--refine", action="store_true")
    ap.add_argument("--refine-strategy", choices=["bounds", "spread"],
                    help="how the refinement spends its simulations (default: the binary's)")
    ap.add_argument("--refine-simulations", type=int,
                    help="the refinement's most simulations (default: the binary's)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--cases", help="FROM:TO, the numbered cases judged (a subset of a cache)")
    ap.add_argument("--inspect", type=float, default=25.0)
    ap.add_argument("--urgent", type=float, default=40.0)
    args = ap.parse_args()
    names = os.listdir(args.cache)
    # A case is complete once its physics.json is written (physics_passes writes it last).
    cases = sorted(int(n[5:-4]) for n in names if n.startswith("case-") and n.endswith(".csv")
                   and f"{n[:-4]}.physics.json" in names)
    if not cases:
        cases = sorted(n for n in names if os.path.isfile(os.path.join(args.cache, n, "measured.csv")))
    if args.cases:
        lo, hi = (int(v) for v in args.cases.split(":"))
        cases = [k for k in cases if isinstance(k, int) and lo <= k < hi]
    truths = {k: load_truth(args.cache, k) for k in cases}
    with tempfile.TemporaryDirectory() as work:
        with ThreadPoolExecutor(args.jobs) as ex:
            idents = dict(zip(cases, ex.map(lambda k: identify(args, k, work), cases)))
    kinds = ["bank"] + (["refined"] if args.refine else [])
    rows = {k: [] for k in kinds}
    good = []
    errors = 0
    for k in cases:
        t, ident = truths[k], idents[k]
        if "error" in ident:
            errors += 1
            print(f"{k!s:>14} error: {ident['error']}")
            continue
        if t.get("real"):
            continue  # a real flat's profile has no L and d to hold
        flat = t.get("flat_wheel") is not None
        line = f"{k!s:>14} {'flat' if flat else 'good'} L0 {t['l0_mm']:5.1f} off {t.get('contact_loss_ms', 0):4.1f} ms"
        for kind in kinds:
            j = judge(ident, t, kind, args.inspect, args.urgent)
            l0 = j[2]
            line += f" | {kind} {'held' if j[0] else ('REFUTED' if j[1] else 'out ')}"
            line += f" [{l0[0]:5.1f},{l0[1]:5.1f}] {j[3]}–{j[4]}" if l0 else f" {j[3]}"
            if flat:
                rows[kind].append((t, j))
        if not flat:
            good.append(not ident["detection"]["flat_detected"])
        print(line)
    for kind in kinds:
        r = rows[kind]
        n = len(r)
        if n == 0:
            continue
        held = sum(j[0] for _, j in r)
        refuted = sum(j[1] for _, j in r)
        widths = [j[2][1] - j[2][0] for _, j in r if j[2]]
        one = sum(j[3] == j[4] for _, j in r if j[2])
        small = [(t, j) for t, j in r if t["l0_mm"] < args.inspect]
        small_urgent = sum(j[4] == "urgent" for _, j in small)
        print(f"{kind}: flats {n}: held {held} ({held / n:.3f}), refuted {refuted}, "
              f"median L0 width {statistics.median(widths) if widths else float('nan'):.1f} mm "
              f"(of {len(widths)} sized), one class {one} ({one / max(1, len(widths)):.3f}), "
              f"flats below the inspect limit told urgent {small_urgent} of {len(small)}")
    if good:
        print(f"good wheels quiet: {sum(good)} of {len(good)}")
    if errors:
        print(f"errors: {errors}")


if __name__ == "__main__":
    sys.exit(main())
