#!/bin/bash
# sirupp-sim as a real process over UDP multicast, in a network namespace made for this test (or,
# where none is allowed, with ttl=0 on this host): lockstep runs with a participant process are
# bit-identical, a silent participant is reported by name and the sim waits, teleports apply, bad
# arguments exit 2 with one clear line, sirupp-control closes the loop. Needs SIRUPP_SIM,
# SIRUPP_CONTROL, SIRUPP and SIM_PROBE (program paths).
set -u
fail() { echo "FAIL: $*"; exit 1; }

source "$(dirname "$0")/private_net.sh"
work=$(mktemp -d)
trap 'kill $(jobs -p) 2>/dev/null; rm -rf "$work"' EXIT

run_pair() {  # $1: output prefix
  "$SIRUPP_SIM" --lcm-url "$URL" --mode lockstep --participants probe --lockstep-timeout 0.5 \
    --duration 0.4 2>"$work/$1.sim" &
  local sim=$!
  "$SIM_PROBE" --lcm-url "$URL" --name probe --ticks 700 >"$work/$1.probe" || fail "probe: $(cat "$work/$1.probe")"
  kill "$sim" 2>/dev/null
  wait "$sim" 2>/dev/null
}
run_pair first
run_pair second
cat "$work/first.probe" "$work/second.probe"
grep -q "^states 70[01] " "$work/first.probe" || fail "first run saw: $(cat "$work/first.probe")"
cmp -s "$work/first.probe" "$work/second.probe" || fail "the two lockstep runs differ"

# A registered participant that never answers: named on stderr, and the sim does not step.
"$SIRUPP_SIM" --lcm-url "$URL" --mode lockstep --participants probe ghost --lockstep-timeout 0.2 \
  2>"$work/ghost.sim" &
sim=$!
"$SIM_PROBE" --lcm-url "$URL" --name probe --ticks 5 >"$work/ghost.probe" &
probe=$!
sleep 1.5
kill "$probe" "$sim" 2>/dev/null
wait "$sim" 2>/dev/null
cat "$work/ghost.sim"
grep -q "tick 0: no answer from ghost" "$work/ghost.sim" || fail "silent participant not reported"
grep -q "stopped at tick 0 " "$work/ghost.sim" || fail "the sim stepped without ghost's answer"

# Teleport from the command line: the running sim applies it and says so.
"$SIRUPP_SIM" --lcm-url "$URL" --mode realtime 2>"$work/reset.sim" &
sim=$!
sleep 0.5
"$SIRUPP" reset --lcm-url "$URL" --deg 10 20 30 40 50 60 >"$work/reset.out" || fail "sirupp reset failed"
"$SIRUPP" reset --lcm-url "$URL" --pose ready --objects >>"$work/reset.out" || fail "sirupp reset --pose failed"
sleep 0.5
kill "$sim"
wait "$sim" 2>/dev/null
cat "$work/reset.out" "$work/reset.sim"
[ "$(grep -c "reset by 'sirupp reset'" "$work/reset.sim")" = 2 ] || fail "the sim did not apply both resets"
grep -q "2 resets" "$work/reset.sim" || fail "reset count missing from the summary"
"$SIRUPP" reset --lcm-url "$URL" --deg 0 0 0 400 0 0 >"$work/out" 2>&1; code=$?
[ "$code" = 2 ] || fail "reset beyond the limits exited $code"
grep -q "joint 4 (wrist_roll)" "$work/out" || fail "$(cat "$work/out")"
"$SIRUPP" reset --lcm-url "$URL" --pose nowhere >"$work/out" 2>&1; code=$?
[ "$code" = 2 ] || fail "reset to an unknown pose exited $code"

# The controller process closes the loop: a joint target from the command line moves the
# simulated joint 1 to 90 degrees (within 1 degree: P control against static friction).
"$SIRUPP_CONTROL" --lcm-url "$URL" 2>"$work/loop.control" &
control=$!
sleep 0.5
# Sent before the sim starts: the controller keeps it and starts the move with the first state.
"$SIRUPP" move joints --lcm-url "$URL" --deg 90 0 0 0 0 0 >"$work/move.out" || fail "sirupp move failed"
sleep 0.2
"$SIRUPP_SIM" --lcm-url "$URL" --mode lockstep --duration 5 --lockstep-timeout 5 2>"$work/loop.sim" &
sim=$!
for _ in $(seq 1 300); do kill -0 "$sim" 2>/dev/null || break; sleep 0.1; done
kill "$sim" "$control" 2>/dev/null  # the sim has normally ended by itself; never wait forever
wait "$sim" "$control" 2>/dev/null
cat "$work/move.out" "$work/loop.sim" "$work/loop.control"
q1=$(sed -n 's/^.* sirupp-sim info: final joint positions (rad or m): \([^ ]*\).*/\1/p' "$work/loop.sim")
[ -n "$q1" ] || fail "the sim did not finish its 5 s"
awk -v q="$q1" 'BEGIN { d = q - 1.5707963; exit !(d < 0.0175 && d > -0.0175) }' ||
  fail "joint 1 ended at $q1 rad, not within 1 degree of 90"
"$SIRUPP" move joints --lcm-url "$URL" --deg 0 0 0 400 0 0 >"$work/out" 2>&1; code=$?
[ "$code" = 2 ] || fail "move beyond the limits exited $code"

# Bad arguments: exit 2, one line naming the problem.
"$SIRUPP_SIM" --mode warp >"$work/out" 2>&1; code=$?
[ "$code" = 2 ] || fail "--mode warp exited $code"
grep -q -- "--mode: 'warp' is not allowed; allowed: lockstep, realtime, fast, freerun" "$work/out" || fail "$(cat "$work/out")"
"$SIRUPP_SIM" --model tests/data/bad_models/$(ls tests/data/bad_models | head -1) >"$work/out" 2>&1; code=$?
[ "$code" = 2 ] || fail "bad model exited $code"
"$SIRUPP_SIM" --environment /nonexistent.xml >"$work/out" 2>&1; code=$?
[ "$code" = 2 ] || fail "missing environment exited $code"
grep -q "/nonexistent.xml" "$work/out" || fail "$(cat "$work/out")"
"$SIRUPP_SIM" --deg 0 0 0 400 0 0 >"$work/out" 2>&1; code=$?
[ "$code" = 2 ] || fail "--deg beyond limits exited $code"
grep -q "joint 4 (wrist_roll)" "$work/out" || fail "$(cat "$work/out")"
# Options the sim's own rules refuse: exit 2, the flag and its value named.
for bad in "--step 0.5|--step: step 0.5 s: allowed 0 < step <= 0.01 s" \
           "--watchdog 0|--watchdog 0: watchdog 0 s: allowed > 0" \
           "--participants a a|--participants a a: participant 'a' is listed twice" \
           "--lockstep-timeout -1|--lockstep-timeout -1: lockstep timeout -1 s: allowed > 0" \
           "--mode fast --duration -2|--duration -2: duration -2 s: allowed >= 0" \
           "--state-every 0|--state-every: '0' is not allowed; allowed: a whole number >= 1" \
           "--pace-ticks 65|--pace-ticks: '65' is not allowed; allowed: a whole number from 1 to 64"; do
  flags=${bad%%|*}
  # shellcheck disable=SC2086  # the flags are words
  "$SIRUPP_SIM" $flags --lcm-url memq:// >"$work/out" 2>&1; code=$?
  [ "$code" = 2 ] || fail "$flags exited $code: $(cat "$work/out")"
  grep -qF -- "${bad#*|}" "$work/out" || fail "$flags: lacks '${bad#*|}': $(cat "$work/out")"
done
"$SIRUPP_SIM" --rt-priority 100 >"$work/out" 2>&1; code=$?
[ "$code" = 2 ] || fail "--rt-priority 100 exited $code"
grep -q "rt-priority: '100' is not allowed; allowed: a whole number from 0 to 99" "$work/out" || fail "$(cat "$work/out")"
# A granted or refused priority: either way the sim runs (one line says which).
"$SIRUPP_SIM" --mode fast --duration 0.05 --rt-priority 10 >"$work/out" 2>&1; code=$?
[ "$code" = 0 ] || fail "--rt-priority 10 exited $code: $(cat "$work/out")"
grep -qE "SCHED_FIFO priority 10|--rt-priority 10 not granted" "$work/out" || fail "$(cat "$work/out")"
echo "sim process: OK"
