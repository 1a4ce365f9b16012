#!/bin/bash
# sirupp grade end to end, with real processes (each task on its own udpm port with ttl=0).
#   grade.sh bad       bad controllers each end their tasks with the right reason and the grade
#                      goes on; two runs give identical results.json; -j 2 gives what -j 1 gives;
#                      two graders at once give what one gives
#   grade.sh examples  examples 02, 03 and 04 (Java, following {reference_csv}; skipped with a
#                      note only without a JDK) graded against config/grading/basic.yaml beside
#                      the baseline; example 05 (C++) against config/grading/advanced.yaml twice,
#                      ramping to {goal_deg} on its own and following {reference_csv}: the
#                      reference lowers its tracking error on every task that moves; following
#                      it twice gives the same results.json (long)
#   grade.sh batch     a class folder: the examples, bad controllers, one that does not build and
#                      one that does not load give class.csv and class.md
# Needs SIRUPP_BIN_DIR, LIB_DIR (build/lib), TEST_CONTROLLERS, JAVA_CP (may be empty).
set -u
mode=$1
bin=$SIRUPP_BIN_DIR
small=tests/data/grade_small.yaml
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
# grade OUT ARGS...: runs sirupp grade, prints its output, fails on a non-zero exit.
grade() {
  local out=$1; shift
  "$bin/sirupp" grade --out "$work/$out" "$@" >"$work/$out.txt" 2>&1 || {
    cat "$work/$out.txt"; fail "sirupp grade $* exited $?"; }
  cat "$work/$out.txt"
}
# reason OUT TASK: the controller's status and reason for TASK in OUT/results.json.
reason() {
  python3 -c 'import json,sys; d=json.load(open(sys.argv[1]))
for t in d["tasks"]:
  if t["name"]==sys.argv[2]: c=t["controller"]; print(c["status"], c.get("reason",""), " ".join(c.get("failed_checks",[])))' \
    "$work/$1/results.json" "$2"
}
expect() {  # expect OUT TASK TEXT
  local got; got=$(reason "$1" "$2")
  echo "$1 $2: $got"
  [[ "$got" == *"$3"* ]] || fail "$1 task $2: expected '$3', got '$got'"
}

case "$mode" in
bad)
  grade nan "$TEST_CONTROLLERS/nan_effort.so" --suite $small --no-baseline -j 2
  expect nan set1 "ended fault: controller 'nan_effort.so' at tick 200: returned effort nan"
  expect nan step_j2 "returned effort nan"
  grade segv "$TEST_CONTROLLERS/segfault.so" --suite $small --no-baseline -j 2
  expect segv set1 "crashed with SIGSEGV"
  grade hang "$TEST_CONTROLLERS/hang.so" --suite $small --no-baseline -j 2
  expect hang set1 "did not return from Update within 1 s"
  grade osc "$TEST_CONTROLLERS/oscillates.so" --suite $small --no-baseline -j 2
  # It rings until the servo's position-error limit trips, or it never settles.
  for task in set1 step_j2; do
    got=$(reason osc $task); echo "osc $task: $got"
    echo "$got" | grep -Eq "tripped its position-error limit|did not settle|overshoot" ||
      fail "osc $task: expected ringing, got '$got'"
  done
  grep -q "0/2 tasks passed, score 0.0" "$work/osc.txt" || fail "the oscillating controller passed a task"
  # A process controller that never answers (sleeps), and one that does not exist.
  grade silent --suite $small --no-baseline -j 2 -- sleep 100
  expect silent set1 "never answered"
  grade missing --suite $small --no-baseline -j 2 -- /nonexistent/controller
  expect missing set1 "the controller process ended (exit code 127)"
  # Determinism: the same controller twice, and with -j 1 and -j 2.
  grade one "$LIB_DIR/pd_gravity.so" --suite $small -j 1
  grade two "$LIB_DIR/pd_gravity.so" --suite $small -j 2
  grade three "$LIB_DIR/pd_gravity.so" --suite $small -j 2
  cmp "$work/one/results.json" "$work/two/results.json" || fail "-j 1 and -j 2 differ"
  cmp "$work/two/results.json" "$work/three/results.json" || fail "two runs differ"
  grep -q "missing_rows\": 0" "$work/one/results.json" || fail "rows missing"
  # Two graders at once (two teachers, or CI jobs): each task's port is leased (an flock per
  # port), so no task hears another's and both give what one grader alone gives.
  "$bin/sirupp" grade "$LIB_DIR/pd_gravity.so" --suite $small -j 2 --out "$work/par1" >"$work/par1.txt" 2>&1 &
  p1=$!
  "$bin/sirupp" grade "$LIB_DIR/pd_gravity.so" --suite $small -j 2 --out "$work/par2" >"$work/par2.txt" 2>&1 &
  p2=$!
  wait $p1 || fail "the first of two graders at once exited $?: $(cat "$work/par1.txt")"
  wait $p2 || fail "the second of two graders at once exited $?: $(cat "$work/par2.txt")"
  cmp "$work/one/results.json" "$work/par1/results.json" || fail "two graders at once: the first differs"
  cmp "$work/one/results.json" "$work/par2/results.json" || fail "two graders at once: the second differs"
  h1=$(sed -n 's/.*results fnv1a //p' "$work/one.txt"); h2=$(sed -n 's/.*results fnv1a //p' "$work/three.txt")
  [ -n "$h1" ] && [ "$h1" = "$h2" ] || fail "hashes differ: $h1 $h2"
  grep -q "$h1" "$work/one/report.md" || fail "the report does not give the hash"
  ls "$work/one/plots/"*.png >/dev/null || fail "no plots"
  # Bad options and a bad suite: exit 2, one line naming the place.
  printf 'format: sirupp-grade-suite-1\nname: x\ntasks:\n  - {name: a, step: {joint: 9, to_deg: 3}, duration_s: 1}\n' >"$work/bad.yaml"
  "$bin/sirupp" grade "$LIB_DIR/pd_gravity.so" --suite "$work/bad.yaml" >"$work/bad.txt" 2>&1
  [ $? = 2 ] || fail "a bad suite did not exit 2: $(cat "$work/bad.txt")"
  grep -q "bad.yaml:4:" "$work/bad.txt" || fail "the error does not name the line: $(cat "$work/bad.txt")"
  cat "$work/bad.txt"
  "$bin/sirupp" grade "$LIB_DIR/pd_gravity.so" --suite $small -j 0 >"$work/j0.txt" 2>&1
  [ $? = 2 ] || fail "-j 0 did not exit 2"
  ;;
examples)
  grade pd "$LIB_DIR/pd_gravity.so" --suite config/grading/basic.yaml -j 2
  grade ct "$LIB_DIR/computed_torque.so" --suite config/grading/basic.yaml -j 2 --no-baseline
  for out in pd ct; do
    grep -q "tasks passed, score" "$work/$out.txt" || fail "no summary line"
    [ "$(python3 -c "import json;print(json.load(open('$work/$out/results.json'))['passed'])")" -ge 7 ] ||
      fail "$out passed fewer than 7 basic tasks"
  done
  if [ -n "${JAVA_CP:-}" ] && command -v java >/dev/null; then
    grade java --suite config/grading/basic.yaml -j 2 --no-baseline -- java -Djava.net.preferIPv4Stack=true \
      -cp "$JAVA_CP" JointPid --reference '{reference_csv}' --lcm-url '{url}' --name '{name}'
    grep -q "tasks passed, score" "$work/java.txt" || fail "no summary line for Java"
    grep -q '"status": "ended"' "$work/java/results.json" && fail "a Java task ended early"
  else
    echo "note: no JDK or no joint_pid.jar: example 04 (Java) not graded"
  fi
  # Example 05 (C++; not built in sanitizer builds) without and with the reference file.
  if [ -x "$bin/joint_pid" ]; then
    grade ramp --suite config/grading/advanced.yaml -j 2 --no-baseline -- \
      "$bin/joint_pid" --deg '{goal_deg}' --lcm-url '{url}' --name '{name}'
    grade given --suite config/grading/advanced.yaml -j 2 --no-baseline -- \
      "$bin/joint_pid" --reference '{reference_csv}' --lcm-url '{url}' --name '{name}'
    # Bit for bit: a second grade of the same process controller gives the same results.json and
    # hash (example 05 answers no state before ROBOT_MODEL, so its law always starts at tick 0).
    grade given2 --suite config/grading/advanced.yaml -j 2 --no-baseline -- \
      "$bin/joint_pid" --reference '{reference_csv}' --lcm-url '{url}' --name '{name}'
    g1=$(sed -n 's/.*results fnv1a //p' "$work/given.txt"); g2=$(sed -n 's/.*results fnv1a //p' "$work/given2.txt")
    echo "example 05 graded twice: results fnv1a $g1 and $g2"
    cmp "$work/given/results.json" "$work/given2/results.json" || fail "example 05: two grades differ"
    [ -n "$g1" ] && [ "$g1" = "$g2" ] || fail "example 05: hashes differ: $g1 $g2"
    python3 - "$work/ramp/results.json" "$work/given/results.json" <<'PY' || fail "example 05: the reference did not lower the tracking error"
import json, sys
ramp, given = (json.load(open(f)) for f in sys.argv[1:3])
ok = True
print("example 05, worst joint's RMS tracking error (deg): own ramp to {goal_deg} -> {reference_csv}")
for a, b in zip(ramp["tasks"], given["tasks"]):
    if a["controller"]["status"] == "ended" or b["controller"]["status"] == "ended":
        print("  %s ended: %s / %s" % (a["name"], a["controller"].get("reason"), b["controller"].get("reason")))
        ok = False
        continue
    worst = [max(j["rms_tracking"] for j in t["controller"]["joints"]) for t in (a, b)]
    moves = not a["what"].startswith("hold")  # a hold's reference stays at the start
    print("  %-22s %8.4f -> %8.4f %s" % (a["name"], worst[0], worst[1], b["controller"]["status"]))
    if moves and not worst[1] < worst[0] / 5:
        ok = False
print("  passed: %d -> %d of %d" % (ramp["passed"], given["passed"], len(given["tasks"])))
sys.exit(0 if ok and given["passed"] >= ramp["passed"] else 1)
PY
  else
    echo "note: no $bin/joint_pid (sanitizer build): example 05 not graded"
  fi
  ;;
batch)
  class=$work/class; mkdir -p "$class"/{a_pd,b_ct,c_segv,d_nobuild,e_noload,f_osc_src,g_empty}
  cp "$LIB_DIR/pd_gravity.so" "$class/a_pd/"
  cp "$LIB_DIR/computed_torque.so" "$class/b_ct/"
  cp "$TEST_CONTROLLERS/segfault.so" "$class/c_segv/"
  printf 'int main( {\n' >"$class/d_nobuild/controller.cpp"
  cp "$TEST_CONTROLLERS/wrong_abi.so" "$class/e_noload/"
  cp tests/controllers/oscillates.cpp "$class/f_osc_src/"
  grade batch --batch "$class" --suite $small -j 2
  cat "$work/batch/class.csv" "$work/batch/class.md"
  csv=$work/batch/class.csv
  [ "$(wc -l <"$csv")" = 9 ] || fail "class.csv: expected a header, the baseline and 7 rows"
  grep -q '^"a_pd",100.0,2,2,' "$csv" || fail "a_pd row"
  grep -q '^"c_segv",0.0,0,2,"set1 step_j2"' "$csv" || fail "c_segv row"
  grep -q '^"d_nobuild",.*does not build' "$csv" || fail "d_nobuild row"
  grep -q '^"e_noload",.*does not load.*ABI' "$csv" || fail "e_noload row"
  grep -q '^"f_osc_src",0.0,0,2' "$csv" || fail "f_osc_src row (built from source, graded)"
  grep -q '^"g_empty",.*no controller' "$csv" || fail "g_empty row"
  [ -f "$work/batch/a_pd/report.md" ] || fail "no report for a_pd"
  ;;
*) fail "mode $mode" ;;
esac
echo "PASS grade $mode"
