#!/usr/bin/env bash
# `sirupp turns serve` (issue 33) as a teacher runs it on a lab PC without the class server: the
# emulated boards and sirupp-hardware on the arm's bus, two rigs (sirupp-sim realtime +
# sirupp-control) on buses of their own, and the queue's commands typed on its input. Alice joins
# and gets the arm; `may bob` says why not; Alice's turn ends with `done alice`, the handover
# homes and disarms the arm; the log file has her turn. Bad arguments exit 2 naming the flag.
# Needs SIRUPP, SIRUPP_SIM, SIRUPP_CONTROL, SIRUPP_HARDWARE, SIRUPP_EMU. Run from the source root.
set -u
PRIVATE_NET_PORT=7761
source "$(dirname "$0")/private_net.sh"
source "$(dirname "$0")/lib.sh"
work=$(mktemp -d)
trap 'kill $(jobs -p) 2>/dev/null; wait 2>/dev/null; rm -rf "$work" "$out" "$err"' EXIT

run no_arm 2 turns serve --rig alice=udpm://239.255.76.67:7762?ttl=0
has no_arm "$err" "--arm-url URL is needed"
run bad_rig 2 turns serve --arm-url "$URL" --rig alice
has bad_rig "$err" "--rig 'alice': expected NAME=URL"
run bad_turn 2 turns serve --arm-url "$URL" --rig a=x --turn-s -3
has bad_turn "$err" "--turn-s"

# The buses: the arm's is $URL; each rig's its own port.
base=${URL%%\?*}
group=${base%:*}
port=${base##*:}
alice="$group:$((port + 1))?ttl=0"
bob="$group:$((port + 2))?ttl=0"

"$SIRUPP_EMU" --socket "$work/bus" --start-pose ready >"$work/emu.out" 2>"$work/emu.err" &
for _ in $(seq 100); do [[ -S "$work/bus" ]] && break; sleep 0.05; done
"$SIRUPP_HARDWARE" --port "$work/bus" --emulated --calibrate --lcm-url "$URL" \
  --settings tests/data/hardware/quick_guard.yaml 2>"$work/hw.err" &
for rig in "$alice" "$bob"; do
  "$SIRUPP_SIM" --lcm-url "$rig" --mode realtime 2>>"$work/sim.err" &
  "$SIRUPP_CONTROL" --lcm-url "$rig" 2>>"$work/control.err" &
done
for _ in $(seq 200); do grep -q "polling at" "$work/hw.err" && break; sleep 0.05; done

# The teacher's input, one command at a time, with time for each to happen.
mkfifo "$work/input"
"$SIRUPP" turns serve --arm-url "$URL" --rig alice="$alice" bob="$bob" --turn-s 120 \
  --log "$work/turns.jsonl" <"$work/input" >"$work/turns.out" 2>"$work/turns.err" &
turns=$!
exec 3>"$work/input"
wait_line() {  # wait_line TEXT SECONDS
  for _ in $(seq $(($2 * 10))); do grep -qF -- "$1" "$work/turns.out" && return 0; sleep 0.1; done
  return 1
}
echo "join alice" >&3
wait_line "alice's turn on the real arm begins" 60 || { echo "FAIL no turn for alice"; fail=1; }
echo "may bob" >&3
echo "may alice" >&3
echo "status" >&3
wait_line "turns: turn, holder alice" 10 || { echo "FAIL status"; fail=1; }
has may_bob "$work/turns.out" "bob: the real arm is in alice's turn"
has may_alice "$work/turns.out" "alice may command the real arm"
echo "join mallory" >&3
wait_line "refused: no rig 'mallory'" 10 || { echo "FAIL join mallory not refused"; fail=1; }
echo "done alice" >&3
wait_line "handover after alice's turn done in" 60 || { echo "FAIL no handover after alice"; fail=1; }
has homed "$work/turns.out" "the arm is home"
exec 3>&-
kill -INT "$turns"
wait "$turns"
rc=$?
[[ $rc -eq 0 ]] || { echo "FAIL turns serve exit $rc after SIGINT"; fail=1; }
has log "$work/turns.jsonl" '"turn": "alice"'
has log_ok "$work/turns.jsonl" '"handover": "ok"'
if [[ $fail -ne 0 ]]; then
  echo "--- turns.out"; cat "$work/turns.out"; echo "--- turns.err"; cat "$work/turns.err"
  echo "--- hw.err (end)"; tail -5 "$work/hw.err"
  echo "--- emu.err (end)"; tail -8 "$work/emu.err"
fi
finish turns_serve "$(grep -o 'handover after alice.s turn done in [0-9.]* s' "$work/turns.out")"
