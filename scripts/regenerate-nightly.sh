#!/usr/bin/env bash
# Nightly model-bank regeneration, for cron. Rebuilds the bank only when the calibration (or
# the bank arguments, or the generator) changed: `bank generate` then builds the new version
# beside the old one and switches CURRENT atomically when it is complete, so identification
# keeps reading the old bank until then. An unchanged calibration is reported "up to date".
# An interrupted run (reboot, kill) resumes the next night, keeping finished shard files.
# BANK_DIR may be a bank family (`bank generate --speeds FROM:TO:STEP` built it): its band is
# read from family.json, every member is regenerated, and family.json switches all members at
# once when the last one is complete; verify and prune act on every member.
#
#   scripts/regenerate-nightly.sh CALIBRATION.toml BANK_DIR [extra `bank generate` args]
#
# With WHEELFLAT_PASSES set to a folder of the day's good-wheel passes, or WHEELFLAT_DB to the
# results database `watch --db` writes (its last 24 hours' "no flat" passes), `wheelflat
# calibrate --check` first compares the site's track and sensors with CALIBRATION.toml
# (docs/calibration.md, "Drift and the nightly rebuild"): when they drifted (exit 3) the new
# calibration replaces CALIBRATION.toml atomically (the old one kept as CALIBRATION.toml.prev)
# and the bank below is rebuilt from it; `watch` answers from the old bank until the new one
# is complete and verified (CURRENT switches atomically).
#
# Environment: WHEELFLAT (the binary; default `wheelflat` on PATH), WHEELFLAT_KEEP (complete
# versions to keep, CURRENT's included; default 2).
# Crontab line (01:15 every night, log appended):
#   15 1 * * *  /opt/wheelflat/scripts/regenerate-nightly.sh /etc/wheelflat/track.toml /srv/wheelflat/bank >>/var/log/wheelflat-bank.log 2>&1
set -euo pipefail
calibration=${1:?usage: regenerate-nightly.sh CALIBRATION.toml BANK_DIR [args]}
bank=${2:?usage: regenerate-nightly.sh CALIBRATION.toml BANK_DIR [args]}
shift 2
wheelflat=${WHEELFLAT:-wheelflat}

mkdir -p "$bank"
exec 9>"$bank/.regenerate.lock"
if ! flock -n 9; then
  echo "$(date -Is) another regeneration holds $bank/.regenerate.lock; skipping"
  exit 0
fi
source=()
if [ -n "${WHEELFLAT_PASSES:-}" ]; then
  source=(--passes "$WHEELFLAT_PASSES")
elif [ -n "${WHEELFLAT_DB:-}" ]; then
  source=(--db "$WHEELFLAT_DB" --hours 24)
fi
if [ ${#source[@]} -gt 0 ]; then
  set +e
  "$wheelflat" calibrate --check --calibration "$calibration" "${source[@]}" \
    --out "$calibration.new" --report "$bank/calibration-$(date +%F).json"
  status=$?
  set -e
  case $status in
    0) echo "$(date -Is) calibration: no drift" ;;
    3) cp -p "$calibration" "$calibration.prev"
       mv "$calibration.new" "$calibration"
       echo "$(date -Is) calibration drifted: $calibration replaced (previous kept as $calibration.prev)" ;;
    *) echo "$(date -Is) calibrate failed (exit $status); the bank stays on $calibration" ;;
  esac
fi
echo "$(date -Is) regenerating $bank from $calibration"
"$wheelflat" bank generate --calibration "$calibration" --out "$bank" "$@"
"$wheelflat" bank verify "$bank"
# Old versions go (1 GB each at 50k); the one CURRENT names and the one before it stay.
"$wheelflat" bank prune --keep "${WHEELFLAT_KEEP:-2}" "$bank"
echo "$(date -Is) done"
