#!/usr/bin/env python3
"""Python reference pipeline for `wheelflat identify`: the speed peer of issue 13.

Issue 13 asks for the time of a new-process `wheelflat identify` to JSON on the full 50k bank
*and its ratio to a Python reference pipeline that runs the same method*. This is that peer: a
plain pyarrow + numpy implementation, vectorised where numpy makes it natural, with no compiled
code of its own and no call into the Rust binary. It is kept in the repository so the ratio can
be measured again whenever the Rust path changes.

What it implements (the Rust source it follows, docs/identification.md for the method):

1. the bank: `CURRENT` or a version directory, `manifest.json`, the shards memory-mapped with
   pyarrow, the `wheelflat.bank` JSON of the first shard's footer (sensor axes, flat-free
   template, calibration with the identification settings), the parameter columns, and the
   stored neighbour graph `neighbours.bin` (src/bank/{reader,schema,neighbours}.rs; a folded
   bank, the site population's default, read as the Rust reader presents it, src/bank/fold.rs;
   a bank
   without one, or with one of the earlier format, gets the graph searched by brute force,
   slowly). The footers are read through
   pyarrow: a `layout.bin` the bank may carry (src/bank/layout.rs) is not needed;
2. the measurement CSV, its alignment (laser trigger, or cross-correlation against the
   flat-free template) and its series on the bank windows (src/identify/measurement.rs);
   then put on the bank's load: the sensors' least-squares levels over the flat-free
   template against the table's mean level factor, scaled down when heavier, the static part
   added when lighter (src/identify/load.rs);
3. top-down perceptually important points per series, on the record as recorded
   (src/identify/pip.rs);
4. the bank columns of the candidate points, read by column projection;
5. the combined uncertainty: Monte Carlo samples from the same SplitMix64 stream, so they are
   the same numbers, shortest intervals on the |y| grid and interpolation between grid rows
   (src/identify/uncertainty.rs, src/bank/population.rs);
6. the bank resolution: cells from the neighbour graph and the typical widening at a point,
   κ × the median neighbour spread over ~1024 anchors (src/identify/cells.rs, `typical_widening`);
7. binning (at most 65,536 bins, `MAX_BINS`) and the two-pass lazy greedy joint-entropy
   selection (src/identify/entropy.rs, `Identifier::identify` in src/identify/mod.rs);
8. envelope points at the impact spikes (src/identify/envelope.rs), falsification with the cell
   widening (neighbours in the sensitivity-stretched metric) and the thresholds at the
   prediction's force where it exceeds the measurement (src/identify/uncertainty.rs), the
   candidate model set and the ranges of L, d, c, X_p and L0 as the union of the surviving
   cells (src/identify/{falsify,ranges}.rs).

It writes a JSON (CMS count and instances, the selected points, per-point probability,
ranges, timings per stage) and prints one verdict line. The baselines of `--report` (random
subsets, equidistant points) and the entropy curves are not part of the peer: plain `identify`
does not run them either.

The code is the package `scripts/reference/`, one module per step (its `__init__.py` lists
them); this file is its entry point. Run:

    pip install pyarrow numpy
    python3 scripts/reference_identify.py --bank bank --measurement m.csv \
        [--sensors rps1,rps2] [--calibration track.toml] [--out result.json]

(or `python3 -m reference …` from `scripts/`). tests/it/peer.rs runs it against `wheelflat
identify` on a small bank when the interpreter has pyarrow and numpy.

`timings_ms` in the JSON has the stages of the Rust `timings_ms` (align and pip … falsify) and
those the Rust does before or after them: imports (numpy, pyarrow and the modules of
`scripts/reference/`, compiled on each run); opening the bank (open footers, read
parameters, neighbour graph, cells); uncertainty samples, read measurement, ranges, close bank;
and `in process`, from the first line of this script to the verdict. Whole-process time
(interpreter start and exit included) is for `time` or a subprocess loop.

Checked against `wheelflat identify` (same PIPs, EIP points, per-point probability and CMS
instances, thresholds bit for bit) on small paper, narrow and train-profile banks and on the
50k default bank, with laser trigger and cross-correlation alignment, sensor subsets, κ = 0 and
the other PIP distances. Where floating-point summation order differs from the Rust (entropy
sums, cross-correlation sums) the code says so; it moves results only at ties within ~1e-15.
"""

import time

_T_START = time.perf_counter()

import os
import sys

# The package beside this file, found also where the script's folder is not on the path (-P).
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
# No __pycache__ in the source tree: the modules are compiled on every run, as the one-file
# script was (the time is in `imports`; numpy and pyarrow take ten times as long).
sys.dont_write_bytecode = True

from reference.cli import main

if __name__ == "__main__":
    sys.exit(main(started_s=_T_START))
