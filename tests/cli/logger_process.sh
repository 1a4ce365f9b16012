#!/bin/bash
# sirupp-logger as a real process beside sirupp-sim (realtime) and sirupp-control over UDP
# multicast (a private network namespace, or ttl=0), with lcm-logger recording the raw traffic:
#  - the paper's set I and set II run; one data file per movement set;
#  - kill -9 mid-move under full traffic leaves a file that `sirupp report` parses; restarted with
#    the same command line, the logger goes on in the next file (b-03-set2.1.csv);
#  - with the rig frozen (SIGSTOP) for 0.1 s, a kill -9 loses nothing: the file ends at the last
#    state lcm-logger recorded (at most one 0.512 ms tick apart);
#  - --duration closes the file with its '# end:' line; `sirupp report` reads the LCM log too;
#  - bad input and bad options exit 2 naming the place.
# Needs SIRUPP_SIM, SIRUPP_CONTROL, SIRUPP_LOGGER and SIRUPP; lcm-logger (liblcm-bin) on PATH.
set -u
PRIVATE_NET_PORT=7733
source "$(dirname "$0")/private_net.sh"
source "$(dirname "$0")/lib.sh"
work=$(mktemp -d)
pids=()
cleanup() {
  for pid in "${pids[@]}"; do kill -CONT "$pid" 2>/dev/null; kill "$pid" 2>/dev/null; done
  wait 2>/dev/null
  rm -rf "$work" "$out" "$err"
}
trap cleanup EXIT
command -v lcm-logger >/dev/null || { echo "FAIL: lcm-logger not found (liblcm-bin)"; exit 1; }

# Bad options and bad files: exit 2, one line naming the place.
"$SIRUPP_LOGGER" --split bogus >"$out" 2>"$err"; rc=$?
[[ $rc -eq 2 ]] || { echo "FAIL split: exit $rc"; fail=1; }
has split "$err" "--split: 'bogus' is not allowed; allowed: plan, none"
run bad_file 2 report tests/data/bad_logs/09_not_a_number.csv --out "$work/bad"
has bad_file "$err" "09_not_a_number.csv:6: column 3 (j1_virt_deg): 'abc' is not a finite decimal number"
run bad_log 2 report tests/data/bad_logs/25_lcm_bad_sync_word.lcm --out "$work/bad"
has bad_log "$err" "byte 37 (event 1): expected the event sync word 0xEDA1DA01"
run no_file 2 report "$work/nothing.csv"
has no_file "$err" "nothing.csv: no such file"

"$SIRUPP_SIM" --lcm-url "$URL" --mode realtime 2>"$work/sim.err" &
sim=$!; pids+=("$sim")
# --sim-timeout 3: this test is about the loggers; a realtime sim starved for half a second by the
# tests beside it (an ASan build on two cores) must not abort its plans.
"$SIRUPP_CONTROL" --lcm-url "$URL" --sim-timeout 3 2>"$work/control.err" &
control=$!; pids+=("$control")
# Raw traffic, with the flags that work on lcm-logger 1.3.1 (docs/logging.md).
lcm-logger --lcm-url="$URL" -c 'ROBOT_MODEL|SIM_ARM_STATE|SIM_ARM_TICKS|ARM_SETPOINT|CONTROLLER_STATUS|ARM_MOVE' -f -q \
  "$work/raw.lcm" 2>"$work/lcm-logger.err" &
raw=$!; pids+=("$raw")
"$SIRUPP_LOGGER" --lcm-url "$URL" --out "$work/data" --name a 2>"$work/a.err" &
logger_a=$!; pids+=("$logger_a")
"$SIRUPP_LOGGER" --lcm-url "$URL" --out "$work/data" --name b 2>"$work/b.err" &
logger_b=$!; pids+=("$logger_b")
sleep 0.5

# A logger stopped by --duration closes its file.
"$SIRUPP_LOGGER" --lcm-url "$URL" --out "$work/data" --name c --split none --duration 0.5 \
  2>"$work/c.err" || { echo "FAIL logger c: $(cat "$work/c.err")"; fail=1; }
grep -q "^# end: " "$work/data/c.csv" || { echo "FAIL c.csv has no end line"; tail -2 "$work/data/c.csv"; fail=1; }

run set1 0 plan run config/plans/set1.plan --wait --lcm-url "$URL" --timeout 60
# Set II (joint 1 back to 0 as move 3, then joint 2 to 90 as move 4), and logger b killed in the
# middle of move 3.
"$SIRUPP" plan run config/plans/set2.plan --wait --lcm-url "$URL" --timeout 60 >"$work/set2.out" 2>&1 &
plan=$!
# Into move 3: once logger b has opened set II's file (polled: a sanitizer build is slower), a
# little more.
for ((i = 0; i < 400; ++i)); do
  [[ -e "$work/data/b-03-set2.csv" ]] && break
  sleep 0.05
done
sleep 0.4
# The rig waits while logger b is killed and restarted: on a loaded PC the restart can take longer
# than the rest of set II, and the restarted logger would then begin after it.
kill -STOP "$sim" "$control"
kill -9 "$logger_b"
wait "$logger_b" 2>/dev/null
# Restarted with the same command line (what a layout's `restart: on-failure` does): it goes on in
# the next file.
"$SIRUPP_LOGGER" --lcm-url "$URL" --out "$work/data" --name b 2>"$work/b2.err" &
logger_b2=$!; pids+=("$logger_b2")
# It has subscribed once it says what it continues.
for ((i = 0; i < 600; ++i)); do
  grep -q "continuing that run" "$work/b2.err" 2>/dev/null && break
  sleep 0.05
done
kill -CONT "$sim" "$control"
wait "$plan" || { echo "FAIL set2: $(cat "$work/set2.out")"; fail=1; }
kill -INT "$logger_b2"
wait "$logger_b2" || { echo "FAIL restarted logger b: $(cat "$work/b2.err")"; fail=1; }
has restarted_b "$work/b2.err" "b-03-set2.csv exists: continuing that run in new files"
# Freeze the rig, give the logger 0.7 s, then kill it: nothing it received may be missing. (Its
# rows follow the receive times, and on a bus gone quiet the last ones are taken after 0.5 s:
# LoggerNode::kQuietUs, docs/logging.md.)
kill -STOP "$sim" "$control"
sleep 0.7
kill -9 "$logger_a"
wait "$logger_a" 2>/dev/null
sleep 0.3  # lcm-logger 1.3.1 flushes every 100 ms and not on exit
kill -INT "$raw"
wait "$raw" 2>/dev/null
kill -CONT "$sim" "$control"

ls "$work/data" >"$work/files"
for f in a-01-manual.csv a-02-set1.csv a-03-set2.csv b-03-set2.csv b-03-set2.1.csv; do
  grep -qx "$f" "$work/files" || { echo "FAIL: no $f among: $(cat "$work/files")"; fail=1; }
done

# The mid-move kill: parseable, the missing close noted, the move analysed.
run killed_mid_move 0 report "$work/data/b-03-set2.csv" --out "$work/report_b" --no-plots
has killed_mid_move "$err" "no '# end:' line: the logger did not close this file"
has killed_mid_move "$out" "| set2 | 3 | 1 (waist) | from 90.0 to "

# The restarted logger's file says what it continues; the report reads the whole folder.
has continued_b "$work/data/b-03-set2.1.csv" "# continues: b-03-set2.csv (the rows between"
run folder 0 report "$work/data" --out "$work/report_all" --no-plots
has folder "$out" "b-03-set2.1.csv continues b-03-set2.csv after a restart of the logger"
grep -q "b-03-set2.1.csv,set2-[0-9],4,2,shoulder,deg,0.00000,[0-9.]*,set_virt," "$work/report_all/report_errors.csv" ||
  { echo "FAIL folder: move 4 of the continued file not in the report"; grep "b-03-set2.1" "$work/report_all/report_errors.csv" | head -3; fail=1; }

# The frozen rig: the data file ends where the raw log ends.
run frozen 0 report "$work/data/a-02-set1.csv" "$work/data/a-03-set2.csv" --out "$work/report_a"
has frozen "$out" "| set1 | 2 | 1 (waist) | from 0.0 to 90.0 deg | set-point vs virtual |"
has frozen "$out" "| set2 | 3 | 1 (waist) | from 90.0 to 0.0 deg | set-point vs virtual |"
has frozen "$out" "| set2 | 4 | 2 (shoulder) | from 0.0 to 90.0 deg | set-point vs virtual |"
[[ -s "$work/report_a/set1-m2-j1-angle.png" && -s "$work/report_a/set1-m2-j1-error.png" ]] ||
  { echo "FAIL: no plots in $(ls "$work/report_a")"; fail=1; }
data_end=$(sed -n 's/^| `[^`]*a-03-set2.csv` | set2 | [0-9]* | [0-9.]* to \([0-9.]*\) |.*/\1/p' "$out")
run raw_log 0 report "$work/raw.lcm" --out "$work/report_raw" --no-plots
has raw_log "$out" "| set2 | 4 | 2 (shoulder) | from 0.0 to 90.0 deg | set-point vs virtual |"
raw_end=$(sed -n 's/^| `[^`]*raw.lcm` | set2 | [0-9]* | [0-9.]* to \([0-9.]*\) |.*/\1/p' "$out")
echo "after kill -9: data file ends at ${data_end:-?} s, the raw log at ${raw_end:-?} s (sim time)"
awk -v d="${data_end:-0}" -v r="${raw_end:-1e9}" 'BEGIN { exit !(d >= r - 0.0006 && d <= r + 0.0006) }' ||
  { echo "FAIL: the killed logger's file ends at ${data_end:-?} s, the raw log at ${raw_end:-?} s"; fail=1; }
finish logger_process "$TEST_NET network"
