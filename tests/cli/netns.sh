# Source this in a test script that spreads processes over several "PCs": network namespaces
# joined by veth pairs to a Linux bridge. The bridge lives in a namespace of its own (the
# "switch"), so nothing is added to this machine's own network: no interface, route or address
# of the host is touched, and no datagram can leave.
#
#   netns_setup robot-pc server student-pc   # the switch, then one namespace per name
#   ns_run server LOG CMD...                 # CMD in the background on "server"; pid in $ns_pid
#   ns_exec student-pc CMD...                # CMD in the foreground on "student-pc"
#   link_down student-pc; link_up student-pc # pull and plug the namespace's cable
#   netns_atexit 'rm -rf "$work"'            # more clean-up for the exit trap
#
# Each namespace gets eth0 (10.A.B.k/24, A and B from this shell's pid), lo up, and the multicast
# route 224.0.0.0/4 via eth0; its processes run with their own host name (the namespace's short
# name), so heartbeats say which "PC" they come from. NETNS_URL is an LCM URL with ttl=1 on
# NETNS_PORT (default 7740; set it before sourcing).
#
# Clean-up: on exit (normal, failure, SIGINT/SIGTERM, or the script's own deadline
# NETNS_DEADLINE seconds, default 240) every process started in the namespaces is killed and every
# namespace deleted (their veths go with them). Namespaces left by an earlier run that was killed
# outright (ctest's timeout sends SIGKILL) are removed at the next setup if their script is gone.
#
# Where namespaces cannot be made (not root, no `ip`, no bridge or veth support) the script prints
# "SKIP: reason" and exits 77, which tests/CMakeLists.txt maps to a skipped test (SKIP_RETURN_CODE).

NETNS_SKIP=77
NETNS_PORT=${NETNS_PORT:-7740}
NETNS_URL="udpm://239.255.76.67:${NETNS_PORT}?ttl=1"
NETNS_TAG="sirupp-ns-$$"
NETNS_SWITCH="$NETNS_TAG-switch"
NETNS_DEADLINE=${NETNS_DEADLINE:-240}
netns_names=()     # short names, in setup order
netns_pids=()      # every process started with ns_run
netns_exit_hooks=()
declare -A netns_addr  # short name -> IPv4 address

netns_full() { echo "$NETNS_TAG-$1"; }

netns_skip() {
  echo "SKIP: $*"
  exit "$NETNS_SKIP"
}

# Kills what runs in one of our namespaces and deletes it. By pid only: `ip netns pids` lists the
# processes whose network namespace it is, all of them started by this script (or its dead twin).
netns_remove() {
  local ns=$1 pid
  for pid in $(ip netns pids "$ns" 2>/dev/null); do kill -9 "$pid" 2>/dev/null; done
  ip netns del "$ns" 2>/dev/null
}

netns_cleanup() {
  local status=$? pid name hook
  trap - EXIT INT TERM
  [[ -n "${netns_watchdog:-}" ]] && kill "$netns_watchdog" 2>/dev/null
  for pid in "${netns_pids[@]}"; do kill -CONT "$pid" 2>/dev/null; kill -TERM "$pid" 2>/dev/null; done
  # Give them a moment to stop their motors and close their files, then make sure.
  for _ in $(seq 20); do
    local alive=0
    for pid in "${netns_pids[@]}"; do kill -0 "$pid" 2>/dev/null && alive=1; done
    [[ $alive -eq 0 ]] && break
    sleep 0.1
  done
  for name in "${netns_names[@]}"; do netns_remove "$(netns_full "$name")"; done
  netns_remove "$NETNS_SWITCH"
  # `ip netns add` bind-mounts /run/netns the first time; if that was us, and no namespace is
  # left, the mount goes too (in a chroot it would otherwise keep the root from being removed).
  if [[ ${netns_run_was_mounted:-1} -eq 0 ]] && [[ -z $(ip netns list 2>/dev/null) ]]; then
    umount /run/netns 2>/dev/null
  fi
  wait 2>/dev/null
  for hook in "${netns_exit_hooks[@]}"; do eval "$hook"; done
  [[ -n "${out:-}" ]] && rm -f "$out" "${err:-}"
  exit "$status"
}

netns_atexit() { netns_exit_hooks+=("$1"); }

# Namespaces of an earlier run of any of our scripts that died without its trap.
netns_sweep_stale() {
  local ns pid
  for ns in $(ip netns list 2>/dev/null | awk '{print $1}' | grep '^sirupp-ns-[0-9]*-'); do
    pid=${ns#sirupp-ns-}
    pid=${pid%%-*}
    [[ "$pid" == "$$" ]] && continue
    kill -0 "$pid" 2>/dev/null && continue
    echo "note: removing $ns, left by a run that was killed"
    netns_remove "$ns"
  done
}

# netns_setup NAME...: the switch and one namespace per NAME on it.
netns_setup() {
  [[ $(id -u) -eq 0 ]] || netns_skip "network namespaces need root (this is uid $(id -u))"
  command -v ip >/dev/null || netns_skip "no 'ip' command (Debian package iproute2)"
  trap netns_cleanup EXIT
  trap 'exit 130' INT
  trap 'exit 143' TERM
  netns_sweep_stale
  mountpoint -q /run/netns 2>/dev/null && netns_run_was_mounted=1 || netns_run_was_mounted=0
  ip netns add "$NETNS_SWITCH" 2>/dev/null || netns_skip "cannot create a network namespace"
  ip -n "$NETNS_SWITCH" link add br0 type bridge 2>/dev/null ||
    netns_skip "no Linux bridge support (kernel module bridge)"
  # No IGMP snooping: a bridge without a querier must flood multicast to every port, as a plain
  # lab switch does.
  ip -n "$NETNS_SWITCH" link set br0 type bridge mcast_snooping 0 2>/dev/null
  ip -n "$NETNS_SWITCH" link set br0 up
  ip -n "$NETNS_SWITCH" link set lo up
  # The deadline: a hung test still ends and cleans up before ctest kills it outright.
  # It checks each second that this script is still the process with this pid (its start time in
  # /proc), so a script killed outright never has its pid, reused, signalled.
  local me=$$ born
  born=$(awk '{ print $22 }' "/proc/$me/stat")
  (
    for _ in $(seq "$NETNS_DEADLINE"); do
      sleep 1
      [[ "$(awk '{ print $22 }' "/proc/$me/stat" 2>/dev/null)" == "$born" ]] || exit 0
    done
    echo "FAIL: netns: the script ran over its deadline of $NETNS_DEADLINE s; stopping it"
    kill -TERM $$ 2>/dev/null
  ) &
  netns_watchdog=$!
  # 10.A.B.0/24 from the pid, so that two tests (or an admin looking at a dump) never see the
  # same subnet. The addresses exist only inside our namespaces.
  local a=$((($$ >> 8) % 200 + 20)) b=$(($$ % 250 + 1)) k=1 name ns
  for name in "$@"; do
    ns=$(netns_full "$name")
    ip netns add "$ns" || netns_skip "cannot create network namespace $ns"
    netns_names+=("$name")
    ip -n "$NETNS_SWITCH" link add "p$k" type veth peer name eth0 netns "$ns" 2>/dev/null ||
      netns_skip "no veth support (kernel module veth)"
    ip -n "$NETNS_SWITCH" link set "p$k" master br0
    ip -n "$NETNS_SWITCH" link set "p$k" up
    netns_addr[$name]="10.$a.$b.$k"
    ip -n "$ns" link set lo up
    ip -n "$ns" addr add "10.$a.$b.$k/24" dev eth0
    ip -n "$ns" link set eth0 up
    ip -n "$ns" route add 224.0.0.0/4 dev eth0
    k=$((k + 1))
  done
  # Wait until every port forwards (a bridge port starts in "learning" only with STP, which is
  # off, but the link takes a moment to report carrier).
  for _ in $(seq 50); do
    ip -n "$NETNS_SWITCH" -br link show master br0 | grep -qv 'UP' || break
    sleep 0.1
  done
}

# The port of NAME on the switch ("p1", ...).
netns_port() {
  local k=1 name
  for name in "${netns_names[@]}"; do
    [[ "$name" == "$1" ]] && { echo "p$k"; return; }
    k=$((k + 1))
  done
  echo "netns: no namespace '$1'" >&2
  return 1
}

# ns_exec NAME CMD...: runs CMD in namespace NAME with host name NAME, in the foreground (for a
# process in the background use ns_run, whose pid is the process's own).
ns_exec() {
  local name=$1
  shift
  ip netns exec "$(netns_full "$name")" unshare --uts \
    bash -c 'echo "$0" >/proc/sys/kernel/hostname; exec "$@"' "$name" "$@"
}

# ns_run NAME LOG CMD...: CMD in the background on NAME, stdout and stderr to LOG; its pid in
# $ns_pid. Killed by the exit trap if still running.
ns_run() {
  local name=$1 log=$2
  shift 2
  # A simple command, not a function, in the background: $! is then the command itself (ip,
  # unshare and bash each exec the next), so kill -9 $ns_pid hits the process under test.
  ip netns exec "$(netns_full "$name")" unshare --uts \
    bash -c 'echo "$0" >/proc/sys/kernel/hostname; exec "$@"' "$name" "$@" >"$log" 2>&1 &
  ns_pid=$!
  netns_pids+=("$ns_pid")
}

# link_down NAME: the cable of NAME is pulled: its port on the switch goes down, so NAME's eth0
# loses carrier (as with a real cable) and nothing passes either way. NAME's own interface stays
# configured, like a PC whose cable is unplugged. link_up NAME plugs it in again.
link_down() { ip -n "$NETNS_SWITCH" link set "$(netns_port "$1")" down; }
link_up() {
  ip -n "$NETNS_SWITCH" link set "$(netns_port "$1")" up
  local ns
  ns=$(netns_full "$1")
  for _ in $(seq 50); do
    ip -n "$ns" -br link show eth0 | grep -q 'LOWER_UP' && break
    sleep 0.1
  done
  # The multicast route survives a carrier loss; put it back if the kernel dropped it anyway.
  ip -n "$ns" route show 224.0.0.0/4 | grep -q . || ip -n "$ns" route add 224.0.0.0/4 dev eth0
}
