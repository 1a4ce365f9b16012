#!/usr/bin/env bash
# `sirupp launch`: bad layouts and arguments exit 2 naming file:line; --dry-run shows the command
# lines; a small real layout (sim and controller on a private bus) starts, shows its table from the
# heartbeats, restarts a killed controller and stops cleanly on SIGINT with exit 0; a process that
# crashes for good makes the exit code 1. Run by CTest from the source root.
set -u
source "$(dirname "$0")/lib.sh"
PRIVATE_NET_PORT=7741
source "$(dirname "$0")/private_net.sh"
dir=$(mktemp -d)
launcher=""
cleanup() {
  [[ -n "$launcher" ]] && kill -KILL "$launcher" 2>/dev/null
  rm -rf "$dir" "$out" "$err"
}
trap cleanup EXIT

run "no layout" 2 launch
has "no layout" "$err" "missing LAYOUT"
run "missing file" 2 launch /nonexistent/lab.yaml
has "missing file" "$err" "/nonexistent/lab.yaml"
printf 'lab: x\nprocesses:\n  - name: a\n    run: sirupp-sim\n    restart: sometimes\n' >"$dir/bad.yaml"
run "bad layout" 2 launch "$dir/bad.yaml"
has "bad layout" "$err" "bad.yaml:5:14: processes[0].restart: 'sometimes' is not allowed"
run "bad host" 2 launch config/labs/multi-pc.yaml --host nowhere
has "bad host" "$err" "--host nowhere: not a host of"
has "bad host lists" "$err" "robot-pc, server, student-1"
run "bad prefix" 2 launch config/labs/single-pc.yaml --dry-run --prefix RIG-1
has "bad prefix" "$err" "channel prefix \"RIG-1\" has the character '-'"
run "url override" 0 launch config/labs/single-pc.yaml --dry-run --lcm-url "$URL"
has "url override" "$out" "--lcm-url $URL"
run "dry run" 0 launch config/labs/multi-pc.yaml --host server --dry-run --run-dir /tmp/x
has "dry run sim" "$out" "sim (restart on-failure):"
has "dry run url" "$out" "--lcm-url udpm://239.255.76.67:7667?ttl=1 --prefix RIG1_"
has "dry run var" "$out" "--out /tmp/x/data"
for f in config/labs/*.yaml; do
  run "dry run $f" 0 launch "$f" --host "$(sed -n 's/^    host: //p' "$f" | head -1)" --dry-run
done 2>/dev/null

# A real layout: physics and controller on this test's own bus.
cat >"$dir/lab.yaml" <<YAML
lab: test-lab
lcm_url: $URL
processes:
  - name: sim
    run: sirupp-sim --mode realtime --pose ready
  - name: control
    run: sirupp-control
    restart: on-failure
YAML
"$SIRUPP" launch "$dir/lab.yaml" --run-dir "$dir/run" --status-every 1 >"$dir/launch.out" 2>&1 &
launcher=$!
for _ in $(seq 1 100); do
  grep -q "are up" "$dir/launch.out" && break
  sleep 0.1
done
has "up" "$dir/launch.out" "all 2 processes of host local are up"
sleep 2.5
has "table" "$dir/launch.out" "process             host"
# Running, or degraded when a loaded machine keeps the realtime sim behind the wall clock: both are
# a live sim whose heartbeat the table shows.
grep -qE "^sim +[^ ]+ +[0-9]+  (running|degraded)" "$dir/launch.out" ||
  { echo "FAIL table: sim not running"; cat "$dir/launch.out"; fail=1; }
control_pid=$(awk '/^control / {print $3}' "$dir/launch.out" | tail -1)
kill -KILL "$control_pid"
for _ in $(seq 1 50); do
  grep -q "control ended (killed by SIGKILL); restart 1 of 3" "$dir/launch.out" && break
  sleep 0.1
done
has "restart" "$dir/launch.out" "control ended (killed by SIGKILL); restart 1 of 3"
sleep 2.5
new_pid=$(awk '/^control / {print $3}' "$dir/launch.out" | tail -1)
[[ -n "$new_pid" && "$new_pid" != "$control_pid" ]] && kill -0 "$new_pid" 2>/dev/null ||
  { echo "FAIL restart: no new controller (was $control_pid, now '$new_pid')"; cat "$dir/launch.out"; fail=1; }
kill -INT "$launcher"
wait "$launcher"
rc=$?
launcher=""
# The kill -9 was a failure the launcher reports: exit 1, naming it.
[[ $rc -eq 1 ]] || { echo "FAIL exit: $rc, expected 1 after a crash"; cat "$dir/launch.out"; fail=1; }
has "stop sim" "$dir/launch.out" "stopped sim (exit code 0)"
has "stop control" "$dir/launch.out" "stopped control (exit code 0)"
has "failure named" "$dir/launch.out" "control: killed by SIGKILL"
has "log file" "$dir/run/logs/sim.log" "sirupp-sim info: puma260"
pgrep -f "$dir/lab.yaml" >/dev/null && { echo "FAIL: a launcher is left"; fail=1; }

# A clean run with --duration: exit 0.
"$SIRUPP" launch "$dir/lab.yaml" --run-dir "$dir/run2" --duration 3 >"$dir/clean.out" 2>&1
rc=$?
[[ $rc -eq 0 ]] || { echo "FAIL clean run: exit $rc"; cat "$dir/clean.out"; fail=1; }
has "clean run" "$dir/clean.out" "every process ran and stopped cleanly"
finish launch
