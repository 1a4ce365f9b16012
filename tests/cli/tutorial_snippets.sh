#!/bin/bash
# The tutorial (docs/student-controllers.md) as a student follows it, on a bus of their own set up
# as its "Sharing a PC" section says (LCM_DEFAULT_URL, no --lcm-url on any command):
#  - the `Hold` controller is taken from the page (the code block after `<!-- tested: hold.cpp`),
#    built with the page's own build line (`<!-- tested: build hold.cpp`) against the source tree's
#    include/ in a folder of its own, run with sirupp-sim and sirupp-control, moved with `sirupp move
#    --wait`, and every joint `sirupp status` shows must be within the accuracy the page states (the
#    marker's "within X deg", which the page's text must say too);
#  - examples/05_cpp_process_controller is built with the page's two lines (lcm-gen, g++ with
#    `pkg-config lcm`; `<!-- tested: build joint_pid`) and run as the sim's participant cpp-pid;
#    its largest error must be within the stated accuracy.
# Needs SIRUPP (the sirupp program) and SIRUPP_BIN_DIR; runs from the source root.
set -u
PRIVATE_NET_PORT=7747
source "$(dirname "$0")/private_net.sh"
source "$(dirname "$0")/lib.sh"
doc=docs/student-controllers.md
bin=$SIRUPP_BIN_DIR
root=$PWD  # the page's $SIRUPP (lib.sh's $SIRUPP is the sirupp program)
export LCM_DEFAULT_URL=$URL  # "Sharing a PC": one export for every command below
work=$(mktemp -d)
trap 'kill $(jobs -p) 2>/dev/null; wait 2>/dev/null; rm -rf "$work" "$out" "$err"' EXIT
TARGET_DEG=(30 -20 40 25 -30 45)

# block MARKER: the fenced block after the line starting "<!-- tested: MARKER" in the page.
block() {
  awk -v marker="<!-- tested: $1" 'index($0, marker) == 1 { found = 1; next }
    found && /^```/ { if (inside) exit; inside = 1; next }
    inside { print }' "$doc"
}
# tolerance MARKER: X of the marker's "within X deg", after checking the page's text says "within X°".
tolerance() {
  local value
  value=$(grep -m1 "^<!-- tested: $1" "$doc" | sed -n 's/.*, within \([0-9.]*\) deg.*/\1/p')
  [[ -n "$value" ]] || { echo "FAIL: no 'within X deg' in the marker of $1" >&2; return 1; }
  grep -qF "within ${value}°" "$doc" || { echo "FAIL: the page does not say 'within ${value}°'" >&2; return 1; }
  echo "$value"
}
# largest_error "Q1 .. Q6" (deg): the largest |Q - target| over the joints.
largest_error() {
  awk -v final="$1" -v target="${TARGET_DEG[*]}" 'BEGIN {
    n = split(final, q, " "); split(target, t, " "); worst = -1
    for (j = 1; j <= n; ++j) { e = q[j] - t[j]; if (e < 0) e = -e; if (e > worst) worst = e }
    if (n == 6) printf "%.3f", worst }'
}

# ---- A. the Hold library -------------------------------------------------------------------------
mkdir -p "$work/hold"
block hold.cpp >"$work/hold/hold.cpp"
grep -q "SIRUPP_EXPORT_CONTROLLER(Hold)" "$work/hold/hold.cpp" || { echo "FAIL: no Hold snippet in $doc"; fail=1; }
build_hold=$(block "build hold.cpp")
echo "building hold.cpp as the page says: $build_hold"
(cd "$work/hold" && SIRUPP=$root bash -euc "$build_hold") >"$work/hold/build.log" 2>&1 ||
  { echo "FAIL: the page's build line for hold.cpp"; cat "$work/hold/build.log"; fail=1; }
hold_tolerance=$(tolerance hold.cpp) || fail=1

"$bin/sirupp-sim" --mode lockstep 2>"$work/hold/sim" &
sim=$!
"$bin/sirupp-control" --controller "$work/hold/hold.so" 2>"$work/hold/control" &
control=$!
sleep 0.5
run hold_move 0 move joints --deg "${TARGET_DEG[@]}" --wait --timeout 30
has hold_move "$out" "done"
sleep 1  # the arm settles (the lockstep sim runs several times faster than real time)
run hold_status 0 status --timeout 0.5
has hold_status "$out" "controller: manual, idle"
joints=$(sed -n 's/^joints (deg): \[\([^]]*\)\].*/\1/p' "$out")
hold_error=$(largest_error "$joints")
echo "Hold: joints [$joints] deg; largest error ${hold_error:-?} deg (the page: within ${hold_tolerance:-?} deg)"
awk -v e="${hold_error:-x}" -v t="${hold_tolerance:-0}" 'BEGIN { exit !(e != "x" && e <= t) }' ||
  { echo "FAIL: Hold ended ${hold_error:-?} deg off, the page says within ${hold_tolerance:-?} deg"; cat "$out"; fail=1; }
kill "$control" "$sim" 2>/dev/null
wait "$control" "$sim" 2>/dev/null
grep -q "controller hold.so (no arguments) in place of the PID" "$work/hold/control" ||
  { echo "FAIL: sirupp-control did not load hold.so"; cat "$work/hold/control"; fail=1; }

# ---- B. the C++ process controller ---------------------------------------------------------------
mkdir -p "$work/cpp"
build_cpp=$(block "build joint_pid")
echo "building joint_pid as the page says: $build_cpp"
(cd "$work/cpp" && SIRUPP=$root bash -euc "$build_cpp") >"$work/cpp/build.log" 2>&1 ||
  { echo "FAIL: the page's build lines for joint_pid"; cat "$work/cpp/build.log"; fail=1; }
cpp_tolerance=$(tolerance "build joint_pid") || fail=1
if [[ -x "$work/cpp/joint_pid" ]]; then
  "$work/cpp/joint_pid" --deg "${TARGET_DEG[@]}" >"$work/cpp/out" 2>"$work/cpp/err" &
  cpp=$!
  "$bin/sirupp-sim" --participants cpp-pid --duration 4 2>"$work/cpp/sim" &
  sim=$!
  for _ in $(seq 1 600); do kill -0 "$cpp" 2>/dev/null || break; sleep 0.1; done
  wait "$sim" 2>/dev/null
  wait "$cpp"
  code=$?
  cat "$work/cpp/out"
  [[ $code -eq 0 ]] || { echo "FAIL: joint_pid exited $code"; cat "$work/cpp/err" "$work/cpp/sim"; fail=1; }
  cpp_error=$(sed -n 's/^JointPid: largest error \([0-9.]*\) deg$/\1/p' "$work/cpp/out")
  echo "joint_pid: largest error ${cpp_error:-?} deg (the page: within ${cpp_tolerance:-?} deg)"
  awk -v e="${cpp_error:-x}" -v t="${cpp_tolerance:-0}" 'BEGIN { exit !(e != "x" && e <= t) }' ||
    { echo "FAIL: joint_pid ended ${cpp_error:-?} deg off, the page says within ${cpp_tolerance:-?} deg"; fail=1; }
fi
finish tutorial_snippets "$TEST_NET network"
