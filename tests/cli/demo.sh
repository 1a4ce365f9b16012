#!/usr/bin/env bash
# The main job, shortened to movement sets I and VII: every process starts, both sets run on the
# virtual and the emulated real arm, the processes stop cleanly, and the results folder holds data
# files, a Table II report whose virtual and real final angles are near the goals, plots, PNG frames
# and a video. Then a demo whose emulated arm fails in set I must say so and exit 1. Run by CTest
# from the source root.
set -u
source "$(dirname "$0")/lib.sh"
dir=$(mktemp -d)
trap 'rm -rf "$dir" "$out" "$err"' EXIT

run "bad sets" 2 demo --sets 9
has "bad sets" "$err" "--sets: '9' is not a movement set; allowed: 1 to 7"
mkdir -p "$dir/full" && touch "$dir/full/x"
run "out not empty" 2 demo --out "$dir/full"
has "out not empty" "$err" "exists and is not empty"

# From another working directory: the demo finds its layout, model and plans itself.
(cd "$dir" && "$SIRUPP" demo --sets 1 VII --out r >"$dir/demo.out" 2>&1)
rc=$?
[[ $rc -eq 0 ]] || { echo "FAIL demo: exit $rc"; cat "$dir/demo.out"; for f in "$dir"/r/logs/*; do echo "== $f"; cat "$f"; done; fail=1; }
has "progress" "$dir/demo.out" "set I    (1/2)"
has "stopped" "$dir/demo.out" "stopped cleanly"
has "done" "$dir/demo.out" "demo: done"
for f in data/demo-02-set1.csv data/demo-03-set7.csv report/report.md report/report_errors.csv demo.avi logs/launch.log; do
  [[ -s "$dir/r/$f" ]] || { echo "FAIL results: $f missing or empty"; ls -R "$dir/r"; fail=1; }
done
ls "$dir"/r/report/*.png >/dev/null 2>&1 || { echo "FAIL: no plots"; fail=1; }
n=$(ls "$dir"/r/images/*.png 2>/dev/null | wc -l)
[[ $n -ge 2 ]] || { echo "FAIL: $n viewer frames"; fail=1; }
head -c 4 "$dir/r/demo.avi" | grep -q RIFF || { echo "FAIL: demo.avi is not a RIFF file"; fail=1; }
[[ -e "$dir/r/puma-bus" ]] && { echo "FAIL: the emulator's link was left behind"; fail=1; }
# Table II holds each set's measured move only, not its return to zero (set I's move 1).
grep -q "^| set1 | 1 |" "$dir/r/report/report.md" && { echo "FAIL: set I's return to zero is in Table II"; fail=1; }
# Set I moves j1 to 90 degrees: in the response table the virtual and the real arm end within 3
# degrees of the set-point (the last column, "Final error").
rows=$(grep -A2 "^| set1 | 2 | 1 (waist) | set-point |" "$dir/r/report/report.md")
finals=$(awk -F'|' '/\| (virtual|real) \|/ {gsub(/ /, "", $10); print $10}' <<<"$rows")
[[ $(wc -w <<<"$finals") -eq 2 ]] || { echo "FAIL: no set I j1 response rows"; cat "$dir/r/report/report.md"; fail=1; }
for v in $finals; do
  awk -v v="$v" 'BEGIN { exit !(v > -3 && v < 3) }' ||
    { echo "FAIL: set I j1 final error $v deg, expected within 3"; echo "$rows"; fail=1; }
done
# The bridge stops the emulated boards' motors before the emulator ends (the launcher stops one
# process at a time, last started first): no serial error at shutdown.
grep -q "FAULT" "$dir/r/logs/hardware.log" && { echo "FAIL: the bridge faulted"; cat "$dir/r/logs/hardware.log"; fail=1; }
has "bridge stopped" "$dir/r/logs/hardware.log" "stopped (motors off, amplifiers disabled)"

# A module of the emulated arm goes silent during set I: the demo names the fault, marks the set
# failed and exits 1, instead of printing a Table II of a real arm that stopped following.
layout=$PWD/tests/data/labs/demo-silent-module.yaml
(cd "$dir" && "$SIRUPP" demo --sets 1 --layout "$layout" --out f >"$dir/fault.out" 2>&1)
rc=$?
[[ $rc -eq 1 ]] || { echo "FAIL fault demo: exit $rc, expected 1"; cat "$dir/fault.out"; fail=1; }
has "fault named" "$dir/fault.out" "FAILED: the real arm's bridge stopped following: module 1 (j1 waist)"
has "fault summary" "$dir/fault.out" "sets that failed: I"
finish demo "$(grep -c . "$dir/demo.out") lines of output"
