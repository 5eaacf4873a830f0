#!/usr/bin/env bash
# A real Slurm run on this machine: starts a one-node cluster (munge, slurmctld, slurmd),
# builds a small bank with scripts/slurm/submit-bank.sh (an array of shard jobs, then the
# merge job), builds the same bank on one machine with `bank generate`, and checks that the
# two are byte-identical. Needs root and the distribution's packages:
#
#   apt-get install slurm-wlm munge
#   scripts/slurm/local-cluster-test.sh [WORK_DIR] [TASKS]
#
# Leaves the daemons stopped and WORK_DIR (default /tmp/wheelflat-slurm) with the logs.
set -euo pipefail
cd "$(dirname "$0")/../.."
work=${1:-/tmp/wheelflat-slurm}
tasks=${2:-3}
for tool in munged slurmctld slurmd sbatch squeue sacct; do
  command -v "$tool" >/dev/null || { echo "$tool missing: apt-get install slurm-wlm munge" >&2; exit 1; }
done
cargo build --release --quiet
export WHEELFLAT="$PWD/target/release/wheelflat"
rm -rf "$work" && mkdir -p "$work"/{state,spool,log}
chown -R slurm:slurm "$work/state" "$work/spool" "$work/log" 2>/dev/null || true
node=$(hostname -s)
cpus=$(nproc)
mem=$(( $(awk '/MemTotal/ {print $2}' /proc/meminfo) / 1024 - 512 ))
conf="$work/slurm.conf"
cat >"$conf" <<EOF
ClusterName=wheelflat-test
SlurmctldHost=$node
AuthType=auth/munge
CredType=cred/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
SlurmUser=root
SlurmdUser=root
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/log/slurmctld.log
SlurmdLogFile=$work/log/slurmd.log
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MpiDefault=none
NodeName=$node CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=test Nodes=$node Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF="$conf"

cleanup() {
  local pids=()
  for d in slurmd slurmctld munged; do
    [ -f "$work/$d.pid" ] && pids+=("$(cat "$work/$d.pid")")
  done
  kill "${pids[@]}" 2>/dev/null || true
  # Until they are gone (slurmctld saves its state first).
  for _ in $(seq 50); do
    local alive=0
    for p in "${pids[@]}"; do kill -0 "$p" 2>/dev/null && alive=1; done
    [ "$alive" = 0 ] && break
    sleep 0.2
  done
}
trap cleanup EXIT

# A munged of our own (as root: --force), on the distribution's key and socket.
mkdir -p /run/munge
munged --force --pid-file="$work/munged.pid" --log-file="$work/log/munged.log"
slurmctld -f "$conf"
slurmd -f "$conf"
for _ in $(seq 60); do
  sinfo -h -o '%T' 2>/dev/null | grep -qE '^idle' && break
  sleep 1
done
sinfo

# Until every job left the queue (10 min at most).
wait_for_queue() {
  for _ in $(seq 600); do
    [ -z "$(squeue -h)" ] && break
    sleep 1
  done
}

# Builds `cluster-NAME` with the array and the merge and `single-NAME` on one machine, with
# the same `bank generate` arguments; every file of the two, byte for byte (the empty
# writer-lock files included).
cluster_vs_single() {
  local name=$1 started
  shift
  started=$(date +%s)
  WHEELFLAT_SBATCH_ARGS="--cpus-per-task=1 --chdir=$work" \
    scripts/slurm/submit-bank.sh "$tasks" "$cal" "$work/cluster-$name" "$@"
  wait_for_queue
  echo "cluster $name build: $(( $(date +%s) - started )) s"
  "$WHEELFLAT" bank verify "$work/cluster-$name"
  "$WHEELFLAT" bank generate --calibration "$cal" --out "$work/single-$name" "$@" >/dev/null
  if diff -r "$work/cluster-$name" "$work/single-$name"; then
    echo "cluster $name and single-machine $name are byte-identical ($tasks array tasks + merge)"
  else
    cat "$work"/wheelflat-bank-*.log 2>/dev/null | tail -n 20 || true
    echo "the cluster $name differs from the single-machine $name" >&2
    exit 1
  fi
}

cal="$work/track.toml"
"$WHEELFLAT" calibration --out "$cal" >/dev/null
# A small bank, with as many shard files as tasks have to share (360 instances as read: the
# default calibration folds, so 90 are stored, in 9 files).
cluster_vs_single bank --instances 360 --shard-size 10
# A bank family the same way: every task builds its part of every member, the merge completes
# the members and writes family.json.
cluster_vs_single family --instances 40 --shard-size 10 --speeds 48:52:2
