#!/usr/bin/env python3
"""Compares two output trees of scripts/same-outputs.sh: every file by name, JSON by value
with timings, wall clocks and paths set aside, text with the numbers of its timing lines set
aside, SQLite databases by their rows (time stamps aside), figures (PNG) by size only.

    scripts/same_outputs.py OLD_TREE NEW_TREE

Exit status 0 when they match, 1 with the differences listed (at most 40)."""

import json
import os
import re
import sqlite3
import sys

# JSON keys whose values are timings or clocks, not results.
CLOCK_KEY = re.compile(r"(^|_)(timings?|ms|elapsed|wall|seconds|started|finished|time)$|_ms$|_secs?$|^timings_|^time_s$")
# The HTML report's timings table.
CLOCK_TABLE = re.compile(r"<h2>Timings</h2>.*?</table>", re.S)
# Text: durations and dates.
CLOCK_TEXT = re.compile(r"\d+(\.\d+)?\s*(ms|s|min|instances/s)\b|\d{4}-\d\d-\d\dT[\d:.]+Z?|\(\d+(\.\d+)? s\)")


def scrub(value, roots):
    """`value` with clock keys dropped and the two trees' roots replaced by one name."""
    if isinstance(value, dict):
        return {k: scrub(v, roots) for k, v in value.items() if not CLOCK_KEY.search(k)}
    if isinstance(value, list):
        return [scrub(v, roots) for v in value]
    if isinstance(value, str):
        for r in roots:
            value = value.replace(r, "<tree>")
        return CLOCK_TEXT.sub("<clock>", value)
    return value


def text(path, roots):
    with open(path, encoding="utf-8", errors="replace") as f:
        s = f.read()
    for r in roots:
        s = s.replace(r, "<tree>")
    s = CLOCK_TABLE.sub("<timings>", s)
    return CLOCK_TEXT.sub("<clock>", s)


def rows(path, roots):
    """The tables' rows, time stamps and ids aside, the trees' roots (in result folders and
    reasons) replaced by one name."""
    con = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
    out = {}
    for (name,) in con.execute("SELECT name FROM sqlite_master WHERE type='table' ORDER BY name"):
        cols = [c[1] for c in con.execute(f"PRAGMA table_info({name})")]
        keep = [c for c in cols if not CLOCK_KEY.search(c) and c not in ("id", "measurement")]
        sel = ", ".join(keep) or "1"
        scrubbed = (
            tuple(scrub(v, roots) if isinstance(v, str) else v for v in row)
            for row in con.execute(f"SELECT {sel} FROM {name}")
        )
        out[name] = sorted(map(repr, scrubbed))
    con.close()
    return out


def main():
    old, new = (os.path.realpath(a) for a in sys.argv[1:3])
    roots = (old, new)
    files = set()
    for base in (old, new):
        for d, _, fs in os.walk(base):
            for f in fs:
                files.add(os.path.relpath(os.path.join(d, f), base))
    diffs = []
    compared = 0
    for rel in sorted(files):
        a, b = os.path.join(old, rel), os.path.join(new, rel)
        if not (os.path.exists(a) and os.path.exists(b)):
            diffs.append(f"{rel}: only in {'old' if os.path.exists(a) else 'new'}")
            continue
        if any(part.endswith("bank") for part in rel.split(os.sep)[:-1]):
            continue  # a bank: compared byte for byte by scripts/same-outputs.sh
        compared += 1
        if rel.endswith(".json"):
            same = scrub(json.load(open(a)), roots) == scrub(json.load(open(b)), roots)
        elif rel.endswith(".db"):
            same = rows(a, roots) == rows(b, roots)
        elif rel.endswith((".png", ".svg")):
            same = True  # figures: presence only (their text is the JSON's, compared)
        elif rel.endswith((".db-wal", ".db-shm", ".lock")):
            same = True
        else:
            same = text(a, roots) == text(b, roots)
        if not same:
            diffs.append(f"{rel}: differs")
    for d in diffs[:40]:
        print(d)
    print(f"{compared} files compared, {len(diffs)} differ")
    sys.exit(1 if diffs else 0)


if __name__ == "__main__":
    main()
