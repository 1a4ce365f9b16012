#!/bin/bash
# sirupp-picservo-emu as a process: it prints its device and link, serves until SIGTERM, exits 0
# with its counters, and removes its link; bad arguments exit 2 naming the flag. Needs $SIRUPP_EMU.
set -u
SIRUPP=$SIRUPP_EMU
source "$(dirname "$0")/lib.sh"
work=$(mktemp -d)
trap 'kill $(jobs -p) 2>/dev/null; wait 2>/dev/null; rm -rf "$work" "$out" "$err"' EXIT

run bad_modules 2 --modules 40
has bad_modules "$err" "--modules: '40' is not allowed; allowed: a whole number from 1 to 32"
run bad_rate 2 --drop-bytes 1.5
has bad_rate "$err" "--drop-bytes: '1.5' is not allowed; allowed: a number from 0 to 1"
run bad_fault 2 --overcurrent 7@1
has bad_fault "$err" "--overcurrent '7@1': allowed K or K@SECONDS with K a module 1..6"
run bad_joints 2 --start-joints "0 0 0"
has bad_joints "$err" "3 values given; allowed exactly 6"
run bad_pose 2 --start-pose sleep
has bad_pose "$err" "--start-pose 'sleep': allowed zero, ready, set_end"
run help 0 --help
has help "$out" "usage: sirupp-picservo-emu"

"$SIRUPP_EMU" --link "$work/bus" --modules 3 --start-pose ready --pos-error-trip 2@0.1 \
  >"$work/emu.out" 2>"$work/emu.err" &
pid=$!
for _ in $(seq 100); do
  grep -q "modules on" "$work/emu.out" && break
  sleep 0.05
done
has start_line "$work/emu.out" "sirupp-picservo-emu info: 3 modules on /dev/pts/"
has start_line "$work/emu.out" "(linked as $work/bus)"
lines start_line "$work/emu.out" 1
[[ -L "$work/bus" && -c "$work/bus" ]] || { echo "FAIL link: $work/bus is not a link to a device"; fail=1; }
sleep 0.3
kill -TERM $pid
wait $pid
rc=$?
[[ $rc -eq 0 ]] || { echo "FAIL sigterm: exit $rc"; cat "$work/emu.out" "$work/emu.err"; fail=1; }
has counters "$work/emu.out" "sirupp-picservo-emu info: stopped: 0 commands, 0 checksum errors, 0 replies"
has counters "$work/emu.out" "servo ticks"
has fault "$work/emu.err" "on module 2"
[[ ! -e "$work/bus" ]] || { echo "FAIL link: still there after exit"; fail=1; }
ticks=$(sed -n 's/.* \([0-9]*\) servo ticks.*/\1/p' "$work/emu.out")
[[ ${ticks:-0} -gt 500 ]] || { echo "FAIL ticks: ${ticks:-none} servo ticks in ~0.3 s"; fail=1; }
finish picservo_emu "$ticks servo ticks"
