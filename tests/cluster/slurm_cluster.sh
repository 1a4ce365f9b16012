#!/usr/bin/env bash
# A Slurm cluster of one node for tests, in a folder of its own: munged, slurmctld and slurmd from
# Debian (scripts/install-deps.sh installs them), their key, socket, state, spool, logs and
# slurm.conf all under DIR, the node and controller addressed as 127.0.0.1 on two free ports.
# Runs as root (slurmd starts jobs as their user); installs nothing.
#
#   tests/cluster/slurm_cluster.sh start DIR   # prints "export SLURM_CONF=DIR/slurm.conf"
#   tests/cluster/slurm_cluster.sh stop DIR    # cancels every job, stops the daemons, checks
#   tests/cluster/slurm_cluster.sh status DIR  # sinfo and squeue
#
# `start` returns once the node is idle (or fails, stopping whatever it started). DIR/slurm.env holds the
# export line for `source`. `stop` cancels every job first and waits for them to leave (killing the
# daemons under running jobs leaves slurmstepd and the jobs' processes behind), then stops slurmd,
# slurmctld and munged, then checks that no process of this cluster is left: any left is named,
# killed with SIGKILL, and the exit status is 1. Call `stop` from a trap so it runs when a test
# fails. Environment: SLURM_TEST_CPUS (the node's CPUs, default what slurmd -C reports),
# SLURM_TEST_OVERSUBSCRIBE (jobs per CPU, default 8; rigs are one-CPU jobs that each use a fraction
# of a core).
set -euo pipefail

usage() {
  echo "usage: $0 start|stop|status DIR" >&2
  exit 2
}
[[ $# -eq 2 ]] || usage
action=$1
dir=$2
case "$action" in start | stop | status) ;; *) usage ;; esac

conf="$dir/slurm.conf"
node=$(hostname -s)

say() { echo "slurm_cluster: $*" >&2; }

# A TCP port nobody listens on now (bound and released; the daemons take it at once).
free_port() {
  /usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'
}

pid_of() { [[ -s "$1" ]] && cat "$1" || true; }

alive() { [[ -n "$1" ]] && kill -0 "$1" 2>/dev/null; }

# Processes of this cluster: its daemons and job scripts (their command lines name DIR), and the
# job steps and job processes (slurmstepd gives them SLURM_CONF=DIR/slurm.conf and SLURM_JOB_ID).
# Not this script, nor the shell or test that called it (they may have SLURM_CONF exported).
cluster_processes() {
  local real pid cmd comm environ
  real=$(readlink -f "$dir")
  local ancestors=" " up=$$
  while [[ -n "$up" && "$up" != 0 ]]; do
    ancestors+="$up "
    up=$(awk '{print $4}' "/proc/$up/stat" 2>/dev/null || true)
  done
  for pid in $(ls /proc | grep -E '^[0-9]+$'); do
    [[ $ancestors == *" $pid "* || $pid == "$BASHPID" ]] && continue
    { cmd=$(tr '\0' ' ' <"/proc/$pid/cmdline"); } 2>/dev/null || continue
    [[ -z "$cmd" ]] && continue  # a zombie, or a kernel thread
    { comm=$(cat "/proc/$pid/comm"); environ=$(tr '\0' '\n' <"/proc/$pid/environ"); } 2>/dev/null || continue
    local ours=0
    [[ $cmd == *"$real"* ]] && ours=1
    if grep -qxF "SLURM_CONF=$real/slurm.conf" <<<"$environ"; then
      grep -q '^SLURM_JOB_ID=' <<<"$environ" && ours=1
      [[ $comm == slurm* || $cmd == *slurmscriptd* ]] && ours=1
    fi
    if [[ $ours == 1 && $cmd != *slurm_cluster.sh* ]]; then echo "$pid $cmd"; fi
  done
  return 0
}

stop_daemon() {  # name pidfile
  local pid
  pid=$(pid_of "$2")
  alive "$pid" || return 0
  kill -TERM "$pid" 2>/dev/null || true
  for _ in $(seq 100); do
    alive "$pid" || return 0
    sleep 0.05
  done
  say "$1 (pid $pid) did not end on SIGTERM within 5 s; SIGKILL"
  kill -KILL "$pid" 2>/dev/null || true
}

do_stop() {
  local status=0 jobs left
  if [[ -f "$conf" ]]; then
    export SLURM_CONF="$conf"
    if alive "$(pid_of "$dir/slurmctld.pid")"; then
      jobs=$(timeout 10 squeue -h -o %i 2>/dev/null || true)
      if [[ -n "$jobs" ]]; then
        # shellcheck disable=SC2086
        timeout 10 scancel $jobs 2>/dev/null || true
        for _ in $(seq 300); do
          left=$(timeout 10 squeue -h -o %i 2>/dev/null || echo "?")
          [[ -z "$left" ]] && break
          sleep 0.1
        done
        [[ -z "$left" ]] || say "jobs still listed 30 s after scancel: $left"
      fi
      # The job steps, and what the jobs started, end a little after the jobs leave the queue
      # (seconds on a loaded machine: a soak run found a cancelled job's `sleep 300` still there
      # after 5 s, once slurmd had been stopped under its step). Wait for every process of the
      # cluster but its daemons (munged, slurmctld with its slurmscriptd, slurmd).
      for _ in $(seq 300); do
        [[ -n "$(cluster_processes | grep -vE '^[0-9]+ [^ ]*(munged|slurmctld|slurmd) |slurmscriptd' || true)" ]] || break
        sleep 0.1
      done
    fi
  fi
  stop_daemon slurmd "$dir/slurmd.pid"
  stop_daemon slurmctld "$dir/slurmctld.pid"
  stop_daemon munged "$dir/munged.pid"
  left=$(cluster_processes)
  for _ in $(seq 20); do  # what was signalled may still be ending (slowly on a loaded machine)
    [[ -z "$left" ]] && break
    sleep 0.5
    left=$(cluster_processes)
  done
  if [[ -n "$left" ]]; then
    say "left behind, killed now (pid, state, parent, what it waits in, command):"
    local pid
    for pid in $(echo "$left" | awk '{print $1}'); do
      echo "  $pid $(awk '{print $3, "parent", $4}' "/proc/$pid/stat" 2>/dev/null)" \
        "$(cat "/proc/$pid/wchan" 2>/dev/null) $(grep "^$pid " <<<"$left" | cut -d' ' -f2-)" >&2
    done
    echo "$left" | awk '{print $1}' | xargs -r kill -KILL 2>/dev/null || true
    status=1
  fi
  return $status
}

do_start() {
  [[ $(id -u) -eq 0 ]] || { say "needs root (slurmd runs jobs as their users)"; exit 1; }
  local tool
  for tool in munged mungekey slurmctld slurmd sbatch squeue scancel sinfo; do
    command -v "$tool" >/dev/null || {
      say "$tool is not installed; run scripts/install-deps.sh (slurmctld, slurmd, slurm-client, munge)"
      exit 1
    }
  done
  mkdir -p "$dir"
  dir=$(readlink -f "$dir")
  conf="$dir/slurm.conf"
  if alive "$(pid_of "$dir/slurmctld.pid")"; then
    say "a cluster already runs in $dir"
    exit 1
  fi
  trap 'say "start failed; stopping what started"; do_stop || true' ERR
  mkdir -p "$dir/state" "$dir/spool" "$dir/munge"
  chmod 0700 "$dir/munge"
  rm -f "$dir/munge/munge.key"
  mungekey --create --keyfile="$dir/munge/munge.key" 2>/dev/null
  chmod 0600 "$dir/munge/munge.key"
  munged --key-file="$dir/munge/munge.key" --socket="$dir/munge/munge.sock" \
    --pid-file="$dir/munged.pid" --log-file="$dir/munged.log" --seed-file="$dir/munge/munge.seed" \
    --force
  local cpus memory ctld_port slurmd_port
  cpus=${SLURM_TEST_CPUS:-$(slurmd -C | sed -n 's/.*CPUs=\([0-9]*\).*/\1/p' | head -1)}
  memory=$(slurmd -C | sed -n 's/.*RealMemory=\([0-9]*\).*/\1/p' | head -1)
  ctld_port=$(free_port)
  slurmd_port=$(free_port)
  while [[ $slurmd_port == "$ctld_port" ]]; do slurmd_port=$(free_port); done
  cat >"$conf" <<EOF
# Written by tests/cluster/slurm_cluster.sh: one node, everything under $dir.
ClusterName=sirupptest
SlurmctldHost=$node(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$dir/munge/munge.sock
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
MailProg=/bin/true
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SwitchType=switch/none
MpiDefault=none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
SchedulerParameters=batch_sched_delay=0
MinJobAge=30
KillWait=5
NodeName=$node NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$memory State=UNKNOWN
PartitionName=debug Nodes=$node Default=YES MaxTime=INFINITE State=UP OverSubscribe=FORCE:${SLURM_TEST_OVERSUBSCRIBE:-8}
EOF
  echo "export SLURM_CONF=$conf" >"$dir/slurm.env"
  export SLURM_CONF="$conf"
  slurmctld -i
  slurmd -N "$node"
  local state=""
  for _ in $(seq 200); do
    state=$(timeout 5 sinfo -h -N -n "$node" -o %T 2>/dev/null || true)
    [[ $state == idle ]] && break
    sleep 0.1
  done
  if [[ $state != idle ]]; then
    say "the node is '${state:-unknown}' after 20 s, not idle; logs: $dir/slurmctld.log $dir/slurmd.log"
    tail -5 "$dir/slurmctld.log" "$dir/slurmd.log" >&2 || true
    false
  fi
  trap - ERR
  echo "export SLURM_CONF=$conf"
}

case "$action" in
  start) do_start ;;
  stop) do_stop ;;
  status)
    export SLURM_CONF="$conf"
    sinfo
    squeue
    ;;
esac
