#!/bin/bash
# sirupp-control's command line against real processes (sirupp-sim in lockstep + sirupp-control
# over UDP multicast, in a private network namespace or with ttl=0): plans are checked and run to
# their end, pose and joint targets move the arm, targets during a plan are refused by the
# controller, pause/resume/abort and live gains work, bad input exits 2 before anything is sent,
# and with no controller the commands say so. Needs SIRUPP_SIM, SIRUPP_CONTROL and SIRUPP.
set -u
PRIVATE_NET_PORT=7732
source "$(dirname "$0")/private_net.sh"
source "$(dirname "$0")/lib.sh"
work=$(mktemp -d)
trap 'kill $(jobs -p) 2>/dev/null; wait 2>/dev/null; rm -rf "$work" "$out" "$err"' EXIT

# Nothing listening yet: commands that need the controller say so and exit 1.
run no_controller 1 status --lcm-url "$URL" --timeout 0.3
has no_controller "$out" "controller: no CONTROLLER_STATUS heard"
run no_controller_move 1 move joints --lcm-url "$URL" --deg 10 0 0 0 0 0
has no_controller_move "$out" "is sirupp-control running"

# Checks that need no rig.
run check_sets 0 plan check config/plans/set1.plan config/plans/set7.plan config/plans/tour.plan
has check_sets "$out" "config/plans/set7.plan: ok: 6 steps, 2 moves; ends at [90 90 90 0 0 0] deg"
# Bad options of the process itself: exit 2 naming the flag.
"$SIRUPP_CONTROL" --name "" --lcm-url memq:// >"$out" 2>"$err"; rc=$?
[[ $rc -eq 2 ]] || { echo "FAIL control_name: exit $rc, expected 2"; fail=1; }
has control_name "$err" "--name '': allowed a non-empty participant name"
run check_bad 2 plan check tests/data/bad_plans/04_outside_limits.plan
has check_bad "$err" "04_outside_limits.plan:2:9: move: joint j2 (shoulder) goal 200 deg is outside"
run run_bad 2 plan run tests/data/bad_plans/13_unknown_pose.plan --lcm-url "$URL"
has run_bad "$err" "no pose named 'sleep'"
run move_limits 2 move joints --lcm-url "$URL" --deg 0 0 0 400 0 0
run move_nan 2 move joints --lcm-url "$URL" --deg nan 0 0 0 0 0
run pose_far 2 move pose --lcm-url "$URL" --pose 2 0 0.5 0 0 0
has pose_far "$err" "unreachable"
run pose_config 2 move pose --lcm-url "$URL" --pose 0.254 -0.142 0.4 0 90 0 --config up
has pose_config "$err" "--config 'up' is not allowed"
run gains_range 2 gains --lcm-url "$URL" --kp 40000
has gains_range "$err" "kp"
run plan_verb 2 plan start config/plans/set1.plan
has plan_verb "$err" "allowed: check, make, run, pause, resume, abort, manual, automatic"

"$SIRUPP_SIM" --lcm-url "$URL" --mode lockstep --lockstep-timeout 5 2>"$work/sim.err" &
"$SIRUPP_CONTROL" --lcm-url "$URL" 2>"$work/control.err" &
sleep 0.5

run status 0 status --lcm-url "$URL" --timeout 1.2  # heartbeats come at 1 Hz
has status "$out" "controller: manual, idle, move 0"
has status "$out" "process sirupp-sim@"
has status "$out" "process sirupp-control@"

# The paper's set IV, followed to its end; the joints land within 1 degree of 90.
run set4 0 plan run config/plans/set4.plan --wait --lcm-url "$URL" --timeout 60
has set4 "$out" "step 4/6 (line 9): move j1=90 j2=90"
has set4 "$out" "finished; joints ["
sed -n 's/^finished; joints \[\([^ ]*\) \([^ ]*\) .*/\1 \2/p' "$out" |
  awk '{ exit !($1 > 89 && $1 < 91 && $2 > 89 && $2 < 91) }' || { echo "FAIL set4 joints: $(cat "$out")"; fail=1; }

# A tool target through IK, followed to its end.
run pose 0 move pose --lcm-url "$URL" --pose 0.254 -0.142 0.4 0 90 0 --config right-down-noflip --wait
has pose "$out" "(right-down-noflip)"
has pose "$out" "done"

# A plan runs; a target meanwhile is refused by the controller (exit 1, its reason); pause, resume
# and abort answer; after the abort a target is taken. The plan is the tour with an hour's wait at
# its end: a lockstep sim runs at 70 to 90 times real time, so the tour alone (about 12 s of sim
# time) can end before the next command starts, and pause would find no plan.
{ cat config/plans/tour.plan; printf 'wait 3600\n'; } >"$work/tour.plan"
run tour 0 plan run "$work/tour.plan" --lcm-url "$URL"
run refused 1 move joints --lcm-url "$URL" --deg 0 0 0 0 0 0
has refused "$out" "refused by sirupp-control: channel ARM_TARGET: plan $work/tour.plan is running"
run pause 0 plan pause --lcm-url "$URL"
has pause "$out" "controller automatic, paused"
run paused_status 0 status --lcm-url "$URL" --timeout 0.3
has paused_status "$out" "automatic, paused"
run resume 0 plan resume --lcm-url "$URL"
run abort 0 plan abort --lcm-url "$URL"
has abort "$out" "controller manual"
run resume_none 1 plan resume --lcm-url "$URL"
has resume_none "$out" "resume: no plan is paused"
run gains 0 gains --lcm-url "$URL" --joint 2 --kp 300
has gains "$out" "    2    300   1000"
has gains "$out" "virtual servos: running the new gains"
# Only what is named changes: joint 2 keeps the Kp set above (it went back to the file's before).
run gains_kd 0 gains --lcm-url "$URL" --joint 3 --kd 500
has gains_kd "$out" "    2    300   1000"
has gains_kd "$out" "    3    100    500"
run gains_show 0 gains --lcm-url "$URL"
has gains_show "$out" "virtual servos (sirupp-control):"
has gains_show "$out" "    3    100    500"
has gains_show "$out" "real boards: no REAL_ARM_GAINS heard"
run clear_fault 0 clear-fault --lcm-url "$URL"
run home 0 move joints --lcm-url "$URL" --pose zero --wait --scale 1
has home "$out" "done"

kill $(jobs -p) 2>/dev/null
wait 2>/dev/null
grep -q "running plan $work/tour.plan" "$work/control.err" || { echo "FAIL control log: $(cat "$work/control.err")"; fail=1; }
finish control_process "$TEST_NET network"
