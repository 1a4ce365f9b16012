#!/usr/bin/env bash
# The main job under load, as on a student's PC with a browser or a build beside it: the demo's
# seven movement sets once on a quiet machine, then again with one CPU-bound loop per core at
# normal priority. Both must complete 7/7, and the set-point vs virtual rows of Table II must be
# the same to the printed digit: the virtual arm no longer depends on the scheduler (realtime
# mode waits for every answer; the sim time slips instead). Run by CTest from the source root;
# long (about three minutes on two cores).
set -u
source "$(dirname "$0")/lib.sh"
dir=$(mktemp -d)
busy=()
stop_busy() { [[ ${#busy[@]} -gt 0 ]] && kill "${busy[@]}" 2>/dev/null; wait "${busy[@]}" 2>/dev/null; busy=(); }
trap 'stop_busy; rm -rf "$dir" "$out" "$err"' EXIT

demo() {  # demo NAME: runs the full demo into $dir/NAME
  "$SIRUPP" demo --out "$dir/$1" >"$dir/$1.out" 2>&1
  local rc=$?
  [[ $rc -eq 0 ]] || { echo "FAIL demo $1: exit $rc"; cat "$dir/$1.out"; for f in "$dir/$1"/logs/*; do echo "== $f"; tail -5 "$f"; done; fail=1; }
  has "$1 all sets" "$dir/$1.out" "set VII  (7/7)"
  grep -q FAILED "$dir/$1.out" && { echo "FAIL demo $1: a set failed"; grep FAILED "$dir/$1.out"; fail=1; }
  grep "set-point vs virtual" "$dir/$1/report/report.md" >"$dir/$1.virtual"
  grep -o "realtime factor [0-9.]*, [0-9]* ticks caught up late, [0-9.e+-]* s slipped" "$dir/$1/logs/sim.log" >"$dir/$1.factor"
  echo "$1: $(cat "$dir/$1.factor")"
}

demo idle
for ((i = 0; i < $(nproc); ++i)); do (while :; do :; done) & busy+=($!); done
demo loaded
stop_busy

[[ $(wc -l <"$dir/idle.virtual") -eq 12 ]] || { echo "FAIL: $(wc -l <"$dir/idle.virtual") set-point vs virtual rows, expected 12"; fail=1; }
diff "$dir/idle.virtual" "$dir/loaded.virtual" >"$dir/diff" ||
  { echo "FAIL: set-point vs virtual differs between the idle and the loaded run:"; cat "$dir/diff"; fail=1; }
finish demo_load "idle: $(cat "$dir/idle.factor"); loaded: $(cat "$dir/loaded.factor")"
