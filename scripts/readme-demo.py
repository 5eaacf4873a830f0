#!/usr/bin/env python3
"""The README's worked example is the demo's real output: this script runs `wheelflat demo`
and checks (`--check`, what CI runs) or rewrites (`--write`) the README's block that starts
with "3. Synthetic field measurement" — steps 3 and 4 of the demo, up to its "wrote" line.
Timings (milliseconds, a refinement's seconds) are compared as placeholders: they are the
machine's, not the answer's.

    python3 scripts/readme-demo.py --check [--binary target/release/wheelflat] [--bank bank]
    python3 scripts/readme-demo.py --write [...]

The demo builds its bank in `--bank` on first use (27 s on 2 cores) and reuses it after."""

import argparse
import difflib
import os
import re
import subprocess
import sys
import tempfile

FIRST = "3. Synthetic field measurement"
CLOCK = re.compile(r"\d+(\.\d+)? ms\b|\(\d+(\.\d+)? s\b")


def demo_block(binary, bank):
    """Steps 3 and 4 of the demo's output, trailing blanks stripped."""
    with tempfile.TemporaryDirectory() as tmp:
        out = subprocess.run(
            [binary, "demo", "--bank", bank, "--out", os.path.join(tmp, "wheelflat-demo")],
            check=True, capture_output=True, text=True, cwd=tmp,
        ).stdout
    # The demo writes into wheelflat-demo/ beside where it runs, as the README shows it.
    out = out.replace(os.path.join(tmp, "wheelflat-demo"), "wheelflat-demo")
    lines = [l.rstrip() for l in out.splitlines()]
    start = lines.index(FIRST)
    end = next(i for i in range(start, len(lines)) if lines[i].startswith("wrote "))
    return lines[start:end]


def readme_block(text):
    """(start, end) line indices of the README's block (its lines inside the fence)."""
    lines = text.splitlines()
    start = lines.index(FIRST)
    if lines[start - 1] != "```text":
        sys.exit(f"README.md: the line before {FIRST!r} is not a ```text fence")
    end = next(i for i in range(start, len(lines)) if lines[i] == "```")
    return lines, start, end


def main():
    ap = argparse.ArgumentParser()
    mode = ap.add_mutually_exclusive_group(required=True)
    mode.add_argument("--check", action="store_true")
    mode.add_argument("--write", action="store_true")
    ap.add_argument("--binary", default="target/release/wheelflat")
    ap.add_argument("--bank", default="bank")
    ap.add_argument("--readme", default="README.md")
    a = ap.parse_args()
    got = demo_block(os.path.realpath(a.binary), os.path.realpath(a.bank))
    text = open(a.readme, encoding="utf-8").read()
    lines, start, end = readme_block(text)
    if a.write:
        lines[start:end] = got
        open(a.readme, "w", encoding="utf-8").write("\n".join(lines) + "\n")
        print(f"{a.readme}: the demo's block rewritten ({len(got)} lines)")
        return
    mask = lambda ls: [CLOCK.sub("<clock>", l) for l in ls]
    if mask(lines[start:end]) == mask(got):
        print(f"{a.readme}: the demo's block is its real output (timings aside)")
        return
    sys.stdout.writelines(
        difflib.unified_diff(
            [l + "\n" for l in mask(lines[start:end])], [l + "\n" for l in mask(got)],
            "README.md", "wheelflat demo",
        )
    )
    sys.exit(f"{a.readme}: the demo's block differs from its output: "
             "python3 scripts/readme-demo.py --write")


if __name__ == "__main__":
    main()
