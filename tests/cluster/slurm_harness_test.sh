#!/usr/bin/env bash
# The one-node Slurm cluster of slurm_cluster.sh: it starts with the node idle, a job submitted
# with sbatch runs within 5 s, scancel ends it and its process, and stop leaves nothing behind
# (also when this test fails: trap). Skips (77) where Slurm is not installed, except in CI.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
# shellcheck source=tests/cluster/lib.sh
source "$here/lib.sh"
require_slurm

work=$(mktemp -d /tmp/sirupp-slurm-harness.XXXXXX)
cleanup() {
  local status=$?
  "$here/slurm_cluster.sh" stop "$work/cluster" || status=1
  rm -rf "$work"
  exit $status
}
trap cleanup EXIT

fail() {
  echo "FAIL: $*" >&2
  exit 1
}

t0=$(date +%s.%N)
eval "$("$here/slurm_cluster.sh" start "$work/cluster")"
echo "cluster up in $(echo "$(date +%s.%N) - $t0" | bc) s"
[[ $(sinfo -h -N -o %T) == idle ]] || fail "node not idle after start"

# A sleep whose argument no other process has, so pgrep finds this job's process alone.
marker="sleep 300.$$"
left="sleep 301.$$"
id=$(sbatch --parsable -J harness -o "$work/job.out" --wrap "$marker")
[[ $id =~ ^[0-9]+$ ]] || fail "sbatch printed '$id', not a job id"
state=""
for _ in $(seq 100); do
  state=$(squeue -h -j "$id" -o %T)
  [[ $state == RUNNING ]] && break
  sleep 0.05
done
[[ $state == RUNNING ]] || fail "job $id is '$state' 5 s after sbatch, not RUNNING"
# RUNNING comes a moment before slurmstepd has started the script.
for _ in $(seq 100); do
  pgrep -f "^$marker" >/dev/null && break
  sleep 0.05
done
pgrep -f "^$marker" >/dev/null || fail "job $id runs but its process '$marker' is not seen in 5 s"
echo "job $id RUNNING"

scancel "$id"
for _ in $(seq 100); do
  pgrep -f "^$marker" >/dev/null || break
  sleep 0.05
done
! pgrep -f "^$marker" >/dev/null || fail "the job's process is alive 5 s after scancel"
for _ in $(seq 100); do
  state=$(squeue -h -t all -j "$id" -o %T)
  [[ $state == CANCELLED ]] && break
  sleep 0.05
done
[[ $state == CANCELLED ]] || fail "job $id is shown '$state' 5 s after scancel, not CANCELLED"
echo "job $id CANCELLED, its process gone"

# A second job left running: stop must cancel it and leave no process.
sbatch --parsable -o /dev/null --wrap "$left" >/dev/null
for _ in $(seq 100); do
  pgrep -f "^$left" >/dev/null && break
  sleep 0.05
done
"$here/slurm_cluster.sh" stop "$work/cluster" || fail "stop found processes left behind"
! pgrep -f "^$left" >/dev/null || fail "a job's process outlived stop"
for daemon in munged slurmctld slurmd; do
  pid=$(cat "$work/cluster/$daemon.pid" 2>/dev/null || true)
  [[ -z "$pid" ]] || ! kill -0 "$pid" 2>/dev/null || fail "$daemon (pid $pid) outlived stop"
done
echo "stop: every job cancelled, every daemon ended, nothing left"
echo "1 passed, 0 failed"
