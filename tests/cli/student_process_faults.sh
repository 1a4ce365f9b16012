#!/bin/bash
# Issue 22: a student's controller running as its own process, broken three ways, against
# sirupp-sim in lockstep with the student registered as participant 'student': one effort too few,
# NaN for joint 1, and a misspelled sender name ('studnet'). Each time the sim prints the reason
# within a second of the controller's start, naming the sender and what is allowed, and the arm
# does not move. Needs SIRUPP_SIM and SIM_PROBE.
set -u
PRIVATE_NET_PORT=7751
source "$(dirname "$0")/private_net.sh"
source "$(dirname "$0")/lib.sh"
work=$(mktemp -d)
trap 'kill $(jobs -p) 2>/dev/null; wait 2>/dev/null; rm -rf "$work" "$out" "$err"' EXIT

check() {  # check NAME EXPECTED PROBE_ARGS...: the sim's stderr shows EXPECTED within 1 s
  local name=$1 expected=$2; shift 2
  "$SIRUPP_SIM" --lcm-url "$URL" --mode lockstep --participants student 2>"$work/$name.err" &
  local sim=$!
  sleep 1  # the sim is up (it publishes states and waits for 'student')
  "$SIM_PROBE" --lcm-url "$URL" --ticks 100 "$@" >/dev/null 2>&1 &
  local probe=$!
  local start=$SECONDS found=0
  for ((i = 0; i < 10; ++i)); do  # 10 x 0.1 s
    grep -qF -- "$expected" "$work/$name.err" && { found=1; break; }
    sleep 0.1
  done
  if [[ $found -eq 0 ]]; then
    echo "FAIL $name: the sim did not print '$expected' within 1 s"; cat "$work/$name.err"; fail=1
  else
    echo "$name: $(grep -F -- "$expected" "$work/$name.err" | head -1 | sed 's/^[^ ]* //')"
  fi
  kill "$probe" 2>/dev/null
  kill -INT "$sim"
  wait "$sim" "$probe" 2>/dev/null
  # The arm never moved: the sim held it while the only participant's answers were refused.
  local final
  final=$(sed -n 's/.*final joint positions (rad or m): //p' "$work/$name.err")
  awk -v q="$final" 'BEGIN { n = split(q, v, " "); if (n != 6) exit 1;
                             for (i = 1; i <= n; ++i) if (v[i] > 1e-6 || v[i] < -1e-6) exit 1 }' ||
    { echo "FAIL $name: the arm moved (final joint positions: '$final')"; fail=1; }
}

check wrong_joint_count "num_joints" --name student --fault joints
check nan_effort "effort" --name student --fault nan
check misspelled_sender "sender: 'studnet' is not a registered participant (student" --name studnet
finish student_process_faults "$TEST_NET network"
