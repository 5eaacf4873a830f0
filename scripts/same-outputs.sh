#!/usr/bin/env bash
# Same outputs before and after a restructuring step (docs/architecture.md, "House steps"):
# runs two wheelflat binaries on the independent passes (identify --report --db, --refine,
# history, train --db, audit, diagnose, demo) and compares what they write, timings, wall
# clocks and folder names aside (scripts/same_outputs.py).
#
#   scripts/same-outputs.sh OLD_BINARY NEW_BINARY BANK WORK PASSES_DIR
#
# PASSES_DIR: a folder of folders each holding measured.csv (the 40 + 5 independent passes
# of the converged second implementation). WORK is made afresh.
# Exit status 0 when every output matches, 1 with the differences listed.
set -euo pipefail
old=$(realpath "$1"); new=$(realpath "$2"); bank=$(realpath "$3"); work=$4
passes=$(realpath "$5")
here=$(cd "$(dirname "$0")" && pwd)
rm -rf "$work"; mkdir -p "$work"; work=$(realpath "$work")

run_all() { # NAME BINARY
  local name=$1 bin=$2 out="$work/$1"
  mkdir -p "$out/passes" "$out/id" "$out/refine"
  for dir in "$passes"/*/; do
    p=$(basename "$dir")
    [ -f "$dir/measured.csv" ] || continue
    # A bogie id, so that the pass is stored and `history` has wheels to show.
    { echo "# bogie_id = $p"; cat "$dir/measured.csv"; } > "$out/passes/$p.csv"
    "$bin" identify --bank "$bank" --measured "$out/passes/$p.csv" --out "$out/id/$p" \
      --report --no-baselines --db "$out/results.db" > "$out/id/$p.stdout" 2>&1 || echo "exit $?" >> "$out/id/$p.stdout"
    "$bin" identify --bank "$bank" --measured "$out/passes/$p.csv" --out "$out/refine/$p" \
      --refine > "$out/refine/$p.stdout" 2>&1 || echo "exit $?" >> "$out/refine/$p.stdout"
  done
  "$bin" history --db "$out/results.db" > "$out/history.stdout" 2>&1 || echo "exit $?" >> "$out/history.stdout"
  if [ -f "$work/train.csv" ]; then
    "$bin" train --bank "$bank" --recording "$work/train.csv" --triggers "$work/train.triggers.csv" \
      --out "$out/train" --db "$out/train.db" > "$out/train.stdout" 2>&1 || echo "exit $?" >> "$out/train.stdout"
  fi
  "$bin" audit --bank "$bank" --instance 1234 --measured "$out/passes/flat01.csv" --out "$out/audit" \
    > "$out/audit.stdout" 2>&1 || echo "exit $?" >> "$out/audit.stdout"
  for p in flat03 rough-flat1; do
    "$bin" diagnose --bank "$bank" --measured "$out/passes/$p.csv" --out "$out/diagnose-$p" \
      > "$out/diagnose-$p.stdout" 2>&1 || echo "exit $?" >> "$out/diagnose-$p.stdout"
  done
  # The demo with a small bank of its own, built by each binary: compared byte for byte below.
  (cd "$out" && "$bin" demo --out demo --bank demo-bank --instances 2000 > demo.stdout 2>&1 ||
    echo "exit $?" >> demo.stdout)
}

# One synthetic train (flats on bogies 2, 7 and 11), made once by the old binary, for both.
"$old" synth --train --bogies 12 --out "$work/train.csv" > /dev/null 2>&1
run_all old "$old"
run_all new "$new"
status=0
python3 "$here/same_outputs.py" "$work/old" "$work/new" || status=1
# The small bank: every file of it byte for byte (the lock and the manifest's times aside).
if diff -r -q -x '*.lock' -x 'lock' "$work/old/demo-bank" "$work/new/demo-bank"; then
  echo "demo bank: byte-identical"
else
  echo "demo bank: differs"; status=1
fi
exit $status
