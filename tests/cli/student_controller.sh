#!/bin/bash
# A student controller drives the simulated PUMA 260 (sirupp-sim in lockstep, friction on) to a
# joint target and the arm ends within TOLERANCE_DEG of it on every joint:
#   student_controller.sh library LIB.so   sirupp-control --controller LIB.so; the target goes to it
#                                          with `sirupp move joints`. Also: unusable libraries and
#                                          bad arguments exit 2 with one line and nothing moves.
#   student_controller.sh java CLASSPATH   examples/04_java_controller (JointPid) as the sim's only
#                                          participant, target on its command line, rig prefix T4_.
#   student_controller.sh cpp PROGRAM      examples/05_cpp_process_controller (joint_pid) the same
#                                          way, as participant student-cpp under the rig prefix T5_.
# TOLERANCE_DEG (environment, default 0.5): the largest final error allowed on any joint.
# Processes talk over UDP multicast in a network namespace made for the test (or, where none is
# allowed, on this host with ttl=0 and a port of its own). Needs SIRUPP_BIN_DIR.
set -u
mode=$1
subject=$2
bin=$SIRUPP_BIN_DIR
TARGET_DEG=(30 -20 40 25 -30 45)
TOLERANCE_DEG=${TOLERANCE_DEG:-0.5}
DURATION_S=4
fail() { echo "FAIL: $*"; exit 1; }

PRIVATE_NET_PORT=7733
source "$(dirname "$0")/private_net.sh"
work=$(mktemp -d)
trap 'kill $(jobs -p) 2>/dev/null; wait 2>/dev/null; rm -rf "$work"' EXIT

# Waits up to $2 seconds for process $1 to end by itself, then ends it.
wait_for() {
  for _ in $(seq 1 $(($2 * 10))); do kill -0 "$1" 2>/dev/null || break; sleep 0.1; done
  kill "$1" 2>/dev/null
  wait "$1" 2>/dev/null
}

# Checks the sim's "final joint positions" line in file $1 against the target; prints the errors.
check_final() {
  local final
  final=$(sed -n 's/^.* sirupp-sim info: final joint positions (rad or m): //p' "$1")
  [ -n "$final" ] || fail "the sim did not finish its ${DURATION_S} s: $(cat "$1")"
  awk -v final="$final" -v target="${TARGET_DEG[*]}" -v tol="$TOLERANCE_DEG" 'BEGIN {
    n = split(final, q, " "); split(target, t, " "); worst = 0; line = ""
    for (j = 1; j <= n; ++j) {
      e = q[j] * 180 / 3.14159265358979 - t[j]; a = e < 0 ? -e : e
      if (a > worst) worst = a
      line = line sprintf(" %+.3f", e)
    }
    printf "final error per joint (deg):%s; largest %.3f (tolerance %s)\n", line, worst, tol
    exit !(n == 6 && worst <= tol) }' || fail "the arm did not reach the target"
}

if [ "$mode" = library ]; then
  name=$(basename "$subject")
  "$bin/sirupp-control" --lcm-url "$URL" --controller "$subject" 2>"$work/control" &
  control=$!
  sleep 0.5
  # Sent before the sim starts: sirupp-control keeps it and starts the move with the first state.
  "$bin/sirupp" move joints --lcm-url "$URL" --deg "${TARGET_DEG[@]}" >"$work/move" 2>&1 ||
    fail "sirupp move: $(cat "$work/move")"
  "$bin/sirupp-sim" --lcm-url "$URL" --mode lockstep --participants sirupp-control \
    --duration "$DURATION_S" --lockstep-timeout 5 2>"$work/sim" &
  sim=$!
  wait_for "$sim" 120
  kill "$control" 2>/dev/null
  wait "$control" 2>/dev/null
  cat "$work/move" "$work/sim" "$work/control"
  grep -q "controller $name (no arguments) in place of the PID" "$work/control" ||
    fail "sirupp-control did not load $name"
  grep -q " 0 lockstep timeouts" "$work/sim" || fail "the sim waited for the controller"
  check_final "$work/sim"

  # Unusable libraries and bad arguments: exit 2 with one line naming the problem, before the
  # controller answers any state, so the lockstep sim never steps.
  "$bin/sirupp-sim" --lcm-url "$URL" --mode lockstep --participants sirupp-control \
    --duration 1 --lockstep-timeout 0.3 2>"$work/held" &
  held=$!
  expect_refusal() {  # expect_refusal TEXT ARGS...
    local text=$1; shift
    "$bin/sirupp-control" --lcm-url "$URL" "$@" >"$work/out" 2>&1; local code=$?
    [ "$code" = 2 ] || fail "sirupp-control $* exited $code: $(cat "$work/out")"
    [ "$(wc -l <"$work/out")" = 1 ] || fail "more than one line for $*: $(cat "$work/out")"
    grep -qF -- "$text" "$work/out" || fail "sirupp-control $* said: $(cat "$work/out")"
    cat "$work/out"
  }
  expect_refusal "/nonexistent/ctl.so: cannot load the controller library" \
    --controller /nonexistent/ctl.so
  expect_refusal "README.md: cannot load the controller library" --controller README.md
  expect_refusal "$name: the controller refused its arguments 'wn=fast'" \
    --controller "$subject" --controller-args wn=fast
  sleep 1
  kill "$held" 2>/dev/null
  wait "$held" 2>/dev/null
  grep -q "stopped at tick 0 " "$work/held" || fail "the arm moved: $(cat "$work/held")"
elif [ "$mode" = java ]; then
  java -Djava.net.preferIPv4Stack=true -cp "$subject" JointPid --lcm-url "$URL" --prefix T4_ \
    --name student-java --deg "${TARGET_DEG[@]}" >"$work/java" 2>"$work/java.err" &
  java_pid=$!
  "$bin/sirupp-sim" --lcm-url "$URL" --prefix T4_ --mode lockstep --participants student-java \
    --duration "$DURATION_S" --lockstep-timeout 1 2>"$work/sim" &
  sim=$!
  wait_for "$sim" 120
  wait_for "$java_pid" 10  # it ends one second after the last state
  cat "$work/sim" "$work/java" "$work/java.err"
  grep -q "^JointPid: final joint positions (deg):" "$work/java" ||
    fail "the Java controller printed no final joints"
  grep -q " 0 rejected" "$work/sim" || fail "the sim refused commands from the Java controller"
  check_final "$work/sim"
elif [ "$mode" = cpp ]; then
  "$subject" --lcm-url "$URL" --prefix T5_ --name student-cpp --deg "${TARGET_DEG[@]}" \
    >"$work/cpp" 2>"$work/cpp.err" &
  cpp_pid=$!
  "$bin/sirupp-sim" --lcm-url "$URL" --prefix T5_ --mode lockstep --participants student-cpp \
    --duration "$DURATION_S" --lockstep-timeout 1 2>"$work/sim" &
  sim=$!
  wait_for "$sim" 120
  wait_for "$cpp_pid" 10  # it ends one second after the last state
  cat "$work/sim" "$work/cpp" "$work/cpp.err"
  grep -q "^JointPid: puma260, 6 joints, from T5_ROBOT_MODEL" "$work/cpp.err" ||
    fail "the C++ controller did not learn the arm from T5_ROBOT_MODEL"
  grep -q "^JointPid: final joint positions (deg):" "$work/cpp" ||
    fail "the C++ controller printed no final joints"
  grep -q " 0 rejected" "$work/sim" || fail "the sim refused commands from the C++ controller"
  check_final "$work/sim"
else
  fail "mode '$mode': allowed library, java, cpp"
fi
echo "student controller ($mode, $(basename "${subject%%:*}")): OK"
