#!/bin/bash
# Issue 23's restart case as processes: sirupp-sim killed (SIGKILL) in the middle of the paper's
# set VII and started again, in realtime mode and in lockstep mode. The controller takes the new
# sim (no deadlock: the new sim's states are answered), aborts the plan naming the restart (or,
# when the new sim takes longer than 0.5 s to come, the lost sim), and `plan run --wait` fails
# naming it; then a move on the new sim reaches its goal.
# Needs SIRUPP_SIM, SIRUPP_CONTROL and SIRUPP.
set -u
PRIVATE_NET_PORT=7749
source "$(dirname "$0")/private_net.sh"
source "$(dirname "$0")/lib.sh"
work=$(mktemp -d)
trap 'kill $(jobs -p) 2>/dev/null; wait 2>/dev/null; rm -rf "$work" "$out" "$err"' EXIT

for mode in realtime lockstep; do
  "$SIRUPP_SIM" --lcm-url "$URL" --mode "$mode" 2>"$work/sim1-$mode.err" &
  sim=$!
  "$SIRUPP_CONTROL" --lcm-url "$URL" 2>"$work/control-$mode.err" &
  control=$!
  for ((i = 0; i < 40; ++i)); do  # up: the controller answers the sim
    "$SIRUPP" status --timeout 1 --lcm-url "$URL" >"$work/status0-$mode.out" 2>&1 && break
    sleep 0.5
  done
  # Line-buffered (stdbuf preloads a library: tell a sanitizer build's runtime that is fine).
  ASAN_OPTIONS="${ASAN_OPTIONS:-}:verify_asan_link_order=0" stdbuf -oL "$SIRUPP" plan run config/plans/set7.plan --wait --timeout 60 --lcm-url "$URL" \
    >"$work/plan-$mode.out" 2>&1 &
  plan=$!
  # Into the plan's main move (lockstep runs faster than real time: poll, do not sleep).
  for ((i = 0; i < 400; ++i)); do
    grep -q "step 4/6" "$work/plan-$mode.out" 2>/dev/null && break
    sleep 0.02
  done
  kill -KILL "$sim"
  wait "$sim" 2>/dev/null
  "$SIRUPP_SIM" --lcm-url "$URL" --mode "$mode" 2>"$work/sim2-$mode.err" &
  sim=$!
  started=$SECONDS
  wait "$plan"
  rc=$?
  [[ $rc -ne 0 ]] || { echo "FAIL $mode: plan run --wait succeeded through a sim restart"; fail=1; }
  (( SECONDS - started <= 15 )) || { echo "FAIL $mode: plan run --wait took $((SECONDS - started)) s to notice"; fail=1; }
  # Named either way: the restart (the new sim came within 0.5 s) or the loss before it.
  reason='sirupp-sim restarted|no state from sirupp-sim .* the sim is lost'
  grep -qE "plan failed: ($reason)" "$work/plan-$mode.out" ||
    { echo "FAIL plan_$mode: the failure does not name the sim"; cat "$work/plan-$mode.out"; fail=1; }
  grep -qE "$reason" "$work/control-$mode.err" ||
    { echo "FAIL control_$mode: no named abort"; cat "$work/control-$mode.err"; fail=1; }
  # The new sim is answered and the arm moves on it.
  "$SIRUPP" move joints --deg 20 0 0 0 0 0 --wait --timeout 30 --lcm-url "$URL" >"$work/move-$mode.out" 2>&1 ||
    { echo "FAIL $mode: move on the new sim"; cat "$work/move-$mode.out"; fail=1; }
  has "move_$mode" "$work/move-$mode.out" "done"
  echo "$mode: $(grep -o 'plan failed: [^;]*' "$work/plan-$mode.out" | head -1), after $((SECONDS - started)) s"
  kill -INT "$control" "$sim"
  wait "$control" "$sim" 2>/dev/null
done
finish sim_restart "$TEST_NET network"
