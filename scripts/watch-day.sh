#!/usr/bin/env bash
# A day's traffic through `watch` (docs/performance.md, "A day's traffic"): PASSES passes
# (default 1,000) into an inbox, FLATS of every hundred with a flat (default 10: 20 seeded
# flat sizes of the population), the rest good wheels (20 seeds), all five sensors; then
# `watch --once` identifies them in one process, the first pass included, and the per-pass
# times of its log are summarised (first, median, p90, p99, max; flats and good wheels apart).
#
#   scripts/watch-day.sh BANK WORK [PASSES] [FLATS] [WHEELFLAT]
#
# WORK gets passes/ (the distinct passes, made once with `wheelflat synth` and kept),
# inbox/, out/, watch.log and summary.txt. The passes are made with the bank's default
# calibration (`synth` without --calibration): use the demo's bank or one of the same site.
set -euo pipefail
bank=$1 work=$2 passes=${3:-1000} flats=${4:-10} wf=${5:-target/release/wheelflat}
mkdir -p "$work/passes"
if [ ! -f "$work/passes/.complete" ]; then
  for i in $(seq 0 19); do
    l=$((30 + (i * 37) % 60)); d=$(awk "BEGIN {print 0.3 + (($i * 0.13) % 1) * 0.9}")
    "$wf" synth --l-mm "$l" --d-mm "$d" --seed $((100 + i)) --out "$work/passes/flat$i.csv" >/dev/null
    "$wf" synth --no-flat --seed $((200 + i)) --out "$work/passes/good$i.csv" >/dev/null
  done
  touch "$work/passes/.complete"
fi
rm -rf "$work/inbox" "$work/out"
mkdir -p "$work/inbox" "$work/out"
for i in $(seq 0 $((passes - 1))); do
  if [ $((i % 100)) -lt "$flats" ]; then src="flat$((i % 20))"; else src="good$((i % 20))"; fi
  cp "$work/passes/$src.csv" "$work/inbox/p$(printf %05d "$i")-$src.csv"
done
"$wf" watch --bank "$bank" --inbox "$work/inbox" --out "$work/out" --once > "$work/watch.log" 2>&1
python3 - "$work/watch.log" > "$work/summary.txt" <<'EOF'
import re, statistics, sys
rows = []
for line in open(sys.argv[1]):
    m = re.search(r" (p\d+-(flat|good)\d+)\.csv ok ([0-9.]+) ms", line)
    if m:
        rows.append((m.group(1), m.group(2), float(m.group(3))))
def q(xs, p):
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(round(p / 100 * (len(xs) - 1))))]
def line(name, xs):
    return (f"{name:>6}: {len(xs)} passes, median {statistics.median(xs):.1f} ms, "
            f"p90 {q(xs, 90):.1f}, p99 {q(xs, 99):.1f}, max {max(xs):.1f} ms")
every = [r[2] for r in rows]
print(f"first pass ({rows[0][0]}): {rows[0][2]:.1f} ms")
print(line("all", every))
for kind in ("flat", "good"):
    xs = [r[2] for r in rows if r[1] == kind]
    if xs:
        print(line(kind, xs))
EOF
cat "$work/summary.txt"
