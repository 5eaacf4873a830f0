#!/usr/bin/env bash
# Times a new-process `wheelflat identify` to JSON (RPS1+RPS2 and all five sensors) with
# hyperfine, and the Python reference pipeline (scripts/reference_identify.py) on the same
# bank and measurement: the figures of docs/cold-start.md.
#
#   scripts/bench-cold-start.sh [BANK] [PYTHON]
#
# BANK defaults to `bank` (the demo's 50k bank); PYTHON to `python3` and needs pyarrow and
# numpy (`python3 -m pip install pyarrow numpy`; without them the peer is skipped). Needs
# hyperfine (`apt-get install hyperfine`). Writes bench-cold-start/ with the JSON exports.
set -euo pipefail
cd "$(dirname "$0")/.."
bank="${1:-bank}"
python="${2:-python3}"
command -v hyperfine >/dev/null || { echo "hyperfine is needed: apt-get install hyperfine" >&2; exit 1; }
[ -d "$bank" ] || { echo "no bank at $bank: cargo run --release -- demo builds one" >&2; exit 1; }
cargo build --release --quiet
bin="$PWD/target/release/wheelflat"
out="bench-cold-start"
mkdir -p "$out"
"$bin" synth --out "$out/measurement.csv" >/dev/null
id() { echo "$bin identify --bank $bank --measured $out/measurement.csv --out $out/identify $1"; }
hyperfine -N --warmup 3 --runs 30 --export-json "$out/identify.json" \
  -n "identify rps1,rps2" "$(id '--sensors rps1,rps2')" \
  -n "identify, five sensors" "$(id '')"
if "$python" -c 'import pyarrow, numpy' 2>/dev/null; then
  peer() { echo "$python scripts/reference_identify.py --bank $bank --measurement $out/measurement.csv --out $out/peer.json $1"; }
  hyperfine -N --warmup 1 --runs 10 --export-json "$out/peer.json.times" \
    -n "python peer rps1,rps2" "$(peer '--sensors rps1,rps2')" \
    -n "python peer, five sensors" "$(peer '')"
else
  echo "skipping the Python peer: $python cannot import pyarrow and numpy" >&2
fi
