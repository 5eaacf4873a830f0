"""The Python peer of `wheelflat identify` (issue 13), one module per step of the method.

`scripts/reference_identify.py` is the entry point and says what the peer is, what it
implements and how to run it; `python3 -m reference` from `scripts/` runs the same command.
Each module names the Rust source it follows:

    errors       Failure: a problem with the user's input, printed, exit 1
    bank         the bank: version, manifest, shard footers, parameters, neighbour graph
    neighbours   the neighbour graph searched by brute force (a bank without neighbours.bin)
    settings     the identification settings and their defaults
    uncertainty  the SplitMix64 stream and the combined uncertainty's thresholds
    measurement  the measurement CSV, its alignment and its series on the bank windows
    pip          perceptually important points
    cells        the bank resolution: cell extents and the typical widening at a point
    entropy      binning and the lazy greedy joint-entropy selection
    falsify      falsification and the ranges of the candidate model set
    identify     the pipeline (`Identifier::identify`) and the verdict line
    cli          the command line and the stage timings
"""
