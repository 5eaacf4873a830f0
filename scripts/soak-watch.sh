#!/usr/bin/env bash
# The `watch --db` soak (docs/history.md): one pass a second into an inbox for SECONDS, while
# `watch --db` identifies and stores them; samples the watcher's memory (RSS) and the inbox
# backlog every 10 s, reads a wheel's history every 30 s (a reader beside the writer), and
# deletes what `watch` has finished with (done/ inputs, result folders) older than a minute,
# as a site's archiving would.
#
#   scripts/soak-watch.sh BANK PASSES_DIR SECONDS WORK [WHEELFLAT]
#
# PASSES_DIR: measurement CSVs `w<k>-p<j>.csv` (e.g. studies/src/bin/history_study's cache); each is
# dropped with `# bogie_id = S<k>` and a line that makes it a new pass. WORK gets inbox/,
# out/, results.sqlite, watch.log, rss.tsv (seconds, RSS kB, backlog) and history.tsv.
#
# WHEELFLAT_WATCH_ARGS: more arguments for `watch` (e.g. `--metrics 127.0.0.1:9187 --alarms
# alarms.toml`, docs/alarms.md); WHEELFLAT_SCRAPE: a URL fetched with curl every second
# (e.g. http://127.0.0.1:9187/metrics), its time written to WORK/scrape.tsv (seconds, ms).
set -euo pipefail
bank=$1 passes=$2 seconds=$3 work=$4 wf=${5:-target/release/wheelflat}
mkdir -p "$work/inbox" "$work/out"
"$wf" watch --bank "$bank" --inbox "$work/inbox" --out "$work/out" --db "$work/results.sqlite" \
  --poll-ms 50 ${WHEELFLAT_WATCH_ARGS:-} > "$work/watch.log" 2>&1 &
watcher=$!
trap 'kill -TERM $watcher 2>/dev/null || true' EXIT
mapfile -t files < <(ls "$passes"/w*-p*.csv | sort)
start=$(date +%s)
: > "$work/rss.tsv"; : > "$work/history.tsv"; : > "$work/scrape.tsv"
i=0
while :; do
  now=$(date +%s); t=$((now - start))
  [ "$t" -ge "$seconds" ] && break
  f=${files[$((i % ${#files[@]}))]}
  w=$(basename "$f" | sed 's/^w\([0-9]*\)-.*/\1/')
  { echo "# bogie_id = S$w"; echo "# soak pass $i"; cat "$f"; } > "$work/inbox/.s$i.part"
  mv "$work/inbox/.s$i.part" "$work/inbox/s$(printf %06d $i).csv"
  if [ $((i % 10)) -eq 0 ]; then
    backlog=$(find "$work/inbox" -maxdepth 1 -name 's*.csv' | wc -l)
    rss=$(awk '/VmRSS/ {print $2}' /proc/$watcher/status)
    printf '%s\t%s\t%s\n' "$t" "$rss" "$backlog" >> "$work/rss.tsv"
    find "$work/inbox/done" -name 's*.csv' -mmin +1 -delete 2>/dev/null || true
    find "$work/out" -mindepth 1 -maxdepth 1 -type d -mmin +1 -exec rm -rf {} + 2>/dev/null || true
  fi
  if [ $((i % 30)) -eq 0 ]; then
    s=$(date +%s.%N)
    "$wf" history --db "$work/results.sqlite" --wheel "S$w/trailing" --last 10 > /dev/null 2>&1 \
      && ok=ok || ok=fail
    e=$(date +%s.%N)
    printf '%s\t%s\t%.1f ms\n' "$t" "$ok" "$(echo "($e - $s) * 1000" | bc)" >> "$work/history.tsv"
  fi
  if [ -n "${WHEELFLAT_SCRAPE:-}" ]; then
    ms=$(curl -s -o /dev/null -w '%{time_total}' "$WHEELFLAT_SCRAPE" | awk '{printf "%.2f", $1 * 1000}')
    printf '%s\t%s\n' "$t" "$ms" >> "$work/scrape.tsv"
  fi
  i=$((i + 1))
  # One pass a second, on the second.
  sleep "$(echo "$start + $i - $(date +%s.%N)" | bc | sed 's/^-.*/0/')"
done
sleep 5
backlog=$(find "$work/inbox" -maxdepth 1 -name 's*.csv' | wc -l)
echo "dropped $i passes in $seconds s; backlog at the end $backlog"
kill -TERM $watcher; wait $watcher || true
trap - EXIT
