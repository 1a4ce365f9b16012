#!/usr/bin/env bash
# Raw logs and log timestamps (issue 21), on a demo-like run: `sirupp demo --sets 1` with the demo's
# processes but no viewer (tests/data/labs/demo-raw.yaml), on the demo's private udpm port (ttl=0).
#  - the logger records the whole bus beside its data files (raw/demo.lcmlog, lcm-logger's format);
#  - the layout sees the run's bus as ${LCM_URL};
#  - `sirupp-logger --from-log` writes the data files again from the raw log (the run's name and
#    the live logger's settings, --velocities --max-age 0.03, taken from it): the same files byte
#    for byte (the writer's passes are recorded on LOGGER_PASS), and
#    `sirupp report` on them prints exactly the live run's Table II;
#  - every line of launch.log and of each process's log carries the ISO-time-with-milliseconds,
#    name and level prefix.
# Needs SIRUPP and SIRUPP_LOGGER; the other programs are found beside SIRUPP. Run from the source root.
set -u
source "$(dirname "$0")/lib.sh"
dir=$(mktemp -d)
trap 'rm -rf "$dir" "$out" "$err"' EXIT

# Bad input: exit 2 naming the problem.
"$SIRUPP_LOGGER" --from-log "$dir/none.lcmlog" --out "$dir/x" >"$out" 2>"$err"; rc=$?
[[ $rc -eq 2 ]] || { echo "FAIL missing log: exit $rc"; cat "$err"; fail=1; }
has "missing log" "$err" "none.lcmlog"
"$SIRUPP_LOGGER" --from-log "$dir/none.lcmlog" --raw "$dir/r.lcmlog" >"$out" 2>"$err"; rc=$?
[[ $rc -eq 2 ]] || { echo "FAIL --from-log with --raw: exit $rc"; cat "$err"; fail=1; }
has "from-log with raw" "$err" "--from-log reads a recorded log: --raw, --lcm-url and --duration do not apply"
"$SIRUPP_LOGGER" --from-log tests/data/bad_logs/25_lcm_bad_sync_word.lcm --out "$dir/x" >"$out" 2>"$err"; rc=$?
[[ $rc -eq 2 ]] || { echo "FAIL damaged log: exit $rc"; cat "$err"; fail=1; }
has "damaged log" "$err" "expected the event sync word 0xEDA1DA01"

layout=$PWD/tests/data/labs/demo-raw.yaml
(cd "$dir" && "$SIRUPP" demo --sets 1 --layout "$layout" --out live >"$dir/demo.out" 2>&1)
rc=$?
live=$dir/live
[[ $rc -eq 0 ]] || { echo "FAIL demo: exit $rc"; cat "$dir/demo.out"; for f in "$live"/logs/*; do echo "== $f"; cat "$f"; done; }
[[ $rc -eq 0 ]] || { echo "raw_log: FAILED"; exit 1; }
raw=$live/raw/demo.lcmlog
[[ -s $raw ]] || { echo "FAIL: no raw log $raw"; ls -R "$live"; exit 1; }
head -c 4 "$raw" | od -An -tx1 | grep -q "ed a1 da 01" || { echo "FAIL: $raw does not start with LCM's event sync word"; fail=1; }
# The whole bus: our channels and every process's heartbeat.
for channel in ROBOT_MODEL SIM_ARM_STATE ARM_SETPOINT REAL_ARM_STATE CONTROLLER_STATUS HARDWARE_STATUS HEARTBEAT ARM_PLAN; do
  grep -qa "$channel" "$raw" || { echo "FAIL: no $channel in the raw log"; fail=1; }
done
has "layout sees the bus" "$live/bus-url.txt" "bus udpm://239.255.76.67:"
has "private port" "$dir/demo.out" "bus udpm://239.255.76.67:"
url=$(sed -n 's/.*, bus \(udpm:[^ ]*\)$/\1/p' "$dir/demo.out")
has "the same URL" "$live/bus-url.txt" "bus $url prefix"

grep -qa "LOGGER_PASS" "$raw" || { echo "FAIL: no LOGGER_PASS (the writer's passes) in the raw log"; fail=1; }

# The data files again, from the raw log alone (the name too), run where the live logger ran (the
# header names the model file as found from there).
(cd "$dir" && "$SIRUPP_LOGGER" --from-log "$raw" --out "$dir/again" >"$out" 2>"$err")
rc=$?
[[ $rc -eq 0 ]] || { echo "FAIL --from-log: exit $rc"; cat "$err"; fail=1; }
live_files=$(cd "$live/data" && ls)
again_files=$(cd "$dir/again" && ls)
[[ "$live_files" == "$again_files" ]] || { echo "FAIL: files differ: live [$live_files], from the log [$again_files]"; fail=1; }
rows=0
for f in $(cd "$live/data" && ls *.csv); do
  if ! cmp -s "$live/data/$f" "$dir/again/$f"; then
    echo "FAIL: $f differs (live < > from the log):"
    diff "$live/data/$f" "$dir/again/$f" | head -6
    fail=1
  fi
  rows=$((rows + $(grep -vc '^#' "$live/data/$f")))
done

# Table II: the demo's own report (live) against `sirupp report` on the files from the log.
"$SIRUPP" report "$dir"/again/*-set*.csv --last-move --reference paper --no-plots --out "$dir/report" >"$out" 2>"$err" ||
  { echo "FAIL report: $(cat "$err")"; fail=1; }
table() { awk '/^## Table II/ {on = 1; print; next} on && /^## / {exit} on' "$1"; }
table "$live/report/report.md" >"$dir/live-table.md"
table "$dir/report/report.md" >"$dir/again-table.md"
[[ $(grep -c '^| set1 ' "$dir/live-table.md") -ge 1 ]] || { echo "FAIL: no set I rows in the live Table II"; cat "$dir/live-table.md"; fail=1; }
if ! cmp -s "$dir/live-table.md" "$dir/again-table.md"; then
  echo "FAIL: Table II from the raw log differs from the live run's:"
  diff "$dir/live-table.md" "$dir/again-table.md"
  fail=1
fi

# Timestamps: every line of launch.log and of each process's log (continuation lines of a
# multi-line event start with "    |").
stamp='^[0-9]{4}-[0-9]{2}-[0-9]{2}T[0-9]{2}:[0-9]{2}:[0-9]{2}\.[0-9]{3} [a-z0-9-]+ (info|warn|error): '
[[ $(grep -c . "$live/logs/launch.log") -ge 10 ]] || { echo "FAIL: launch.log has few lines"; cat "$live/logs/launch.log"; fail=1; }
for log in "$live"/logs/*.log; do
  bad=$(grep -Ev "$stamp" "$log" | grep -v '^    |' | grep -v '^$' | head -3)
  [[ -z $bad ]] || { echo "FAIL: lines of $(basename "$log") without the time prefix:"; echo "$bad"; fail=1; }
done
has "launcher line in a process log" "$live/logs/sim.log" "sirupp-launch info: starting sim:"
has "end noted" "$live/logs/sim.log" "sirupp-launch info: sim (pid "
has "launch.log prefix" "$live/logs/launch.log" "sirupp-launch info: [local] started emulator"
finish raw_log "$rows rows in $(wc -w <<<"$live_files") data files the same byte for byte; Table II the same ($(grep -c '^| set' "$dir/live-table.md") rows)"
