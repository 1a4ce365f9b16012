#!/bin/bash
# Misbehaving controller libraries as processes (issue 22): sirupp-sim in lockstep and
# sirupp-control --controller LIB.so over UDP multicast (private_net.sh). Each library
# (tests/controllers/: segfault, hang, aborts, throws, nan_effort) drives the arm well until a move
# takes joint 1's goal past 0.5 rad, then misbehaves. For each:
#  - a move below the trigger is done; the move past it answers `fault: controller 'LIB' at tick
#    N: <what happened>` (exit 1), and `sirupp status` shows the fault with the same cause;
#  - sirupp-control is alive and still answers the sim (the lockstep ticks go on), with the arm
#    braked (no joint moves); a target is refused naming the fault;
#  - `sirupp clear-fault` starts the library afresh in a new host process, and a move is done.
# Needs SIRUPP, SIRUPP_SIM, SIRUPP_CONTROL, ARM_WATCH and TEST_CONTROLLERS (the libraries' folder).
set -u
PRIVATE_NET_PORT=7746
source "$(dirname "$0")/private_net.sh"
source "$(dirname "$0")/lib.sh"
work=$(mktemp -d)
trap 'kill $(jobs -p) 2>/dev/null; wait 2>/dev/null; rm -rf "$work" "$out" "$err"' EXIT

# still NAME FILE: arm_watch saw many states (the loop runs) and no joint moved more than 0.01 deg.
still() {
  awk '$1 == "virtual" {
         seen = 1; if ($2 < 100) { print "only " $2 " states: the loop is not running"; exit 1 }
         for (i = 1; i <= NF; i++) { if ($i == "min") lo = i; if ($i == "max") hi = i }
         for (j = 1; j <= 6; j++) if ($(hi + j) - $(lo + j) > 0.01) {
           print "joint " j " moved from " $(lo + j) " to " $(hi + j) " deg"; exit 1 } }
       END { if (!seen) { print "no virtual arm states"; exit 1 } }' "$2" ||
    { echo "FAIL $1: the arm is not held still with the loop running"; cat "$2"; fail=1; }
}

# check_library LIB TEXT [sirupp-control flags...]: the whole story above for one library.
check_library() {
  local lib=$1 text=$2
  shift 2
  "$SIRUPP_SIM" --lcm-url "$URL" --mode lockstep --lockstep-timeout 5 2>"$work/$lib.sim" &
  local sim=$!
  "$SIRUPP_CONTROL" --lcm-url "$URL" --controller "$TEST_CONTROLLERS/$lib" \
    --controller-args goal=0.5 "$@" 2>"$work/$lib.control" &
  local control=$!
  sleep 0.5

  run "$lib.below" 0 move joints --lcm-url "$URL" --deg 10 -10 10 0 0 0 --wait --timeout 30
  has "$lib.below" "$out" "done"
  run "$lib.past" 1 move joints --lcm-url "$URL" --deg 40 -10 10 0 0 0 --wait --timeout 30
  has "$lib.past" "$out" "fault: controller '$lib' at tick "
  has "$lib.past" "$out" "$text"
  echo "$lib: $(grep '^fault: ' "$out")"
  run "$lib.status" 0 status --lcm-url "$URL" --timeout 0.5
  has "$lib.status" "$out" "controller: manual, fault"
  has "$lib.status" "$out" "last error: controller '$lib' at tick "
  has "$lib.status" "$out" "$text"

  "$ARM_WATCH" --lcm-url "$URL" --seconds 0.5 >"$work/$lib.watch"
  still "$lib.braked" "$work/$lib.watch"
  kill -0 "$control" 2>/dev/null || { echo "FAIL $lib: sirupp-control ended"; fail=1; }
  run "$lib.refused" 1 move joints --lcm-url "$URL" --deg 20 -10 10 0 0 0
  has "$lib.refused" "$out" "the controller is faulted: controller '$lib' at tick "

  run "$lib.clear" 0 clear-fault --lcm-url "$URL"
  run "$lib.after" 0 move joints --lcm-url "$URL" --deg 20 -10 10 0 0 0 --wait --timeout 30
  has "$lib.after" "$out" "done"

  kill "$control" "$sim" 2>/dev/null
  wait "$control" "$sim" 2>/dev/null
  has "$lib.log" "$work/$lib.control" "fault: controller '$lib' at tick "
  has "$lib.log" "$work/$lib.control" "fault cleared"
  has "$lib.log" "$work/$lib.control" "stopped after answering"
}

check_library segfault.so "crashed with SIGSEGV (Segmentation fault) in Update"
check_library hang.so "did not return from Update within 0.3 s (the per-tick limit" \
  --controller-tick-limit 0.3
check_library aborts.so "crashed with SIGABRT (Aborted) in Update"
check_library throws.so "Update threw std::out_of_range: vector::_M_range_check"
check_library nan_effort.so "returned effort nan for joint 2 (allowed: finite values)"

# No host process is left behind.
if pgrep -f "sirupp-controller-host $TEST_CONTROLLERS" >/dev/null; then
  echo "FAIL: a sirupp-controller-host is still running: $(pgrep -af sirupp-controller-host)"
  fail=1
fi
finish controller_faults_process "$TEST_NET network"
