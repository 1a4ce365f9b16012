#!/bin/bash
# Fault: sirupp-control killed (kill -9) in the middle of a move, with the linked rig as processes
# (sim realtime, emulator and bridge linked, logger) on a private network (private_net.sh).
#  - the virtual arm is held: the sim's watchdog brakes it, and its joints stay within a small
#    band, none falls;
#  - the bridge stops the emulated arm by command expiry (`sirupp hardware status` names it), and
#    the emulated joints stay still too, short of the goal;
#  - a restarted sirupp-control starts clean: idle, holding the present pose (no jump);
#  - a new move then runs to its goal on both arms; every process stops with exit 0 on SIGINT.
# Needs SIRUPP, SIRUPP_SIM, SIRUPP_CONTROL, SIRUPP_HARDWARE, SIRUPP_EMU, SIRUPP_LOGGER, ARM_WATCH.
set -u
PRIVATE_NET_PORT=7742
source "$(dirname "$0")/private_net.sh"
source "$(dirname "$0")/lib.sh"
source "$(dirname "$0")/rig.sh"
work=$(mktemp -d)
trap 'rig_cleanup; rm -rf "$work" "$out" "$err"' EXIT
started=$SECONDS

rig_start "" "" "" || finish fault_control_kill

# Joint 1 from 0 to 90 degrees: 2.5 s at the PUMA's default 45 deg/s and 90 deg/s^2.
"$SIRUPP" move joints --deg 90 -90 90 0 45 0 --lcm-url "$URL" >"$work/move1.out" 2>&1 ||
  { echo "FAIL: move 1"; cat "$work/move1.out"; fail=1; }
# Killed once the real arm is under way (it runs on the wall clock; in a sanitizer build the
# virtual arm runs slower than that, so waiting for the virtual one let the real arm finish).
wait_for "joint 1 under way" 10 \
  bash -c '"$ARM_WATCH" --lcm-url "$0" --seconds 0.1 | awk "\$1 == \"real\" { exit !(\$5 > 10) }"' "$URL"
kill -9 "${rig_pid[control]}"
wait "${rig_pid[control]}" 2>/dev/null

# The virtual arm, from 0.3 s after the kill: braked where it was.
sleep 0.3
watch_arms "" 1.5 "$work/after_kill.out"
cat "$work/after_kill.out"
band virtual_held "$work/after_kill.out" virtual 0.5
wait_for "the sim's watchdog report" 5 grep -q "realtime: no answer from 'sirupp-control' to tick .* (watchdog): arm braked" "$work/sim.log"
# The bridge: commands expired (0.5 s), the emulated arm stopped smoothly short of 90 degrees.
wait_for "the bridge's command expiry" 10 bridge_state "" "commands expired: nothing from the controller" ||
  cat "$work/hw_status.out"
sleep 0.5  # the smooth stop's deceleration
watch_arms "" 1.5 "$work/real_stopped.out"
cat "$work/real_stopped.out"
band real_stopped "$work/real_stopped.out" real 0.3
real_j1=$(arm_value "$work/real_stopped.out" real last 1)
awk -v v="${real_j1:-90}" 'BEGIN { exit !(v > 10 && v < 85) }' ||
  { echo "FAIL: the emulated joint 1 at ${real_j1:-?} deg: not stopped mid-move"; fail=1; }
expect_alive emu sim hardware logger

# A new sirupp-control: idle, holding the pose the arm was braked in.
held_j1=$(arm_value "$work/real_stopped.out" virtual last 1)
spawn control2 "" "$SIRUPP_CONTROL" --lcm-url "$URL"
wait_for "the restarted controller's status" 30 "$SIRUPP" status --lcm-url "$URL" --timeout 0.5
"$SIRUPP" status --lcm-url "$URL" --timeout 1 >"$work/status.out" 2>&1
has restarted_idle "$work/status.out" "controller: manual, idle, move 0"
watch_arms "" 1.0 "$work/restarted.out"
cat "$work/restarted.out"
# Held by the PID, the arm sags a little under gravity until the error balances it: no jump.
band virtual_restarted "$work/restarted.out" virtual 1.0
within restarted_j1 "$(arm_value "$work/restarted.out" virtual last 1)" "$held_j1" 1.0
for j in 2 3 5; do
  within "restarted_j$j" "$(arm_value "$work/restarted.out" virtual last "$j")" \
    "$(arm_value "$work/real_stopped.out" virtual last "$j")" 1.0
done

# A new move runs to its goal on both arms (the real arm checked by real_reaches).
"$SIRUPP" move joints --deg -30 -90 90 0 45 0 --wait --lcm-url "$URL" --timeout 30 >"$work/move2.out" 2>&1 ||
  { echo "FAIL: move 2"; cat "$work/move2.out"; fail=1; }
real_reaches "" 1 -30 2.5 20  # the fitted real arm stops short by its friction (docs/emulator-fit.md)
watch_arms "" 0.5 "$work/move2.watch"
cat "$work/move2.watch"
within virtual_goal "$(arm_value "$work/move2.watch" virtual last 1)" -30 1.0

expect_alive emu sim hardware logger control2
rig_stop logger control2 hardware emu sim
finish fault_control_kill "$TEST_NET network, $((SECONDS - started)) s"
