#!/bin/bash
# Fault: a flood of malformed LCM traffic on every channel of core's channel table
# (tests/tools/lcm_flood.cpp: random bytes, other types' messages, altered fingerprints, messages
# cut short, and decodable messages with NaN or infinite values, wrong joint counts or enums out of
# range), 8 s at about 2000 messages a second, while the linked rig runs as processes on a private
# network: sim (realtime), controller, emulator and bridge, logger (and sirupp-viewer if built).
#  - the paper's set VII, run during the flood, finishes;
#  - no process crashes: all still run, and each exits 0 on SIGINT at the end;
#  - every process counts what it refused on its heartbeat: on each channel it receives, decode
#    errors, and rejected messages where the flood sent decodable ones (all channels but ESTOP);
#  - no NaN reached the logger's data file, and the arm still works: a move reaches its goal on
#    both arms.
# Needs SIRUPP, SIRUPP_SIM, SIRUPP_CONTROL, SIRUPP_HARDWARE, SIRUPP_EMU, SIRUPP_LOGGER, ARM_WATCH,
# LCM_FLOOD; SIRUPP_VIEWER is optional.
set -u
PRIVATE_NET_PORT=7745
source "$(dirname "$0")/private_net.sh"
source "$(dirname "$0")/lib.sh"
source "$(dirname "$0")/rig.sh"
work=$(mktemp -d)
trap 'rig_cleanup; rm -rf "$work" "$out" "$err"' EXIT
started=$SECONDS

rig_start "" "" "" || finish fault_flood
roles=(emu sim control hardware logger)
processes=sirupp-sim,sirupp-control,sirupp-hardware,sirupp-logger
viewer=${SIRUPP_VIEWER:-$(dirname "$SIRUPP_SIM")/sirupp-viewer}
if [[ -x "$viewer" ]]; then
  mkdir -p "$work/viewer"
  spawn viewer "" env -C "$work/viewer" "$viewer" --lcm-url "$URL"
  roles+=(viewer)
  processes+=,sirupp-viewer
  sleep 1
else
  echo "note: no sirupp-viewer built ($viewer): flooding the rig without it"
fi

# The paper's set VII runs through the flood (which includes commands with NaN efforts from
# senders that are not participants): it must finish on both arms.
"$LCM_FLOOD" flood --lcm-url "$URL" --seconds 8 --rate 2000 >"$work/flood.out" 2>&1 &
flood=$!
"$SIRUPP" plan run config/plans/set7.plan --wait --timeout 60 --lcm-url "$URL" >"$work/set7.out" 2>&1 ||
  { echo "FAIL: set VII during the flood"; cat "$work/set7.out"; fail=1; }
has "set VII finished during the flood" "$work/set7.out" "finished"
wait "$flood" || { echo "FAIL: lcm_flood flood"; fail=1; }
cat "$work/flood.out"
expect_alive "${roles[@]}"

# The counters on the heartbeats (sent once a second, so wait for the next round).
# sirupp-viewer reads its per-tick channels newest-only (core/tick_reader.hpp): which bad messages
# it decodes there is chance, so one decode error or rejection per channel is asked of it.
"$LCM_FLOOD" check --processes "$processes" --newest-only sirupp-viewer --lcm-url "$URL" \
  --seconds 2.5 >"$work/check.out" 2>&1 ||
  fail=1
cat "$work/check.out"

# The arm still works: a move to its goal on both arms.
"$SIRUPP" move joints --deg 40 -90 90 0 45 0 --wait --lcm-url "$URL" --timeout 30 >"$work/move.out" 2>&1 ||
  { echo "FAIL: move after the flood"; cat "$work/move.out"; fail=1; }
real_reaches "" 1 40 2.5 20  # the fitted real arm stops short by its friction (docs/emulator-fit.md)
watch_arms "" 0.5 "$work/move.watch"
cat "$work/move.watch"
within virtual_goal "$(arm_value "$work/move.watch" virtual last 1)" 40 1.0

expect_alive "${roles[@]}"
rig_stop logger
[[ " ${roles[*]} " == *" viewer "* ]] && rig_stop viewer
rig_stop control hardware emu sim
# Nothing the flood sent made it into the data files.
bad_rows=$(awk '!/^#/ && tolower($0) ~ /nan|inf/ { print FILENAME ":" FNR ": " $0 }' "$work"/data/*.csv)
[[ -z "$bad_rows" ]] || { echo "FAIL: NaN or infinite values in the data:"; echo "$bad_rows" | head -3; fail=1; }
ls "$work"/data/*.csv >/dev/null 2>&1 || { echo "FAIL: no data file"; fail=1; }
finish fault_flood "$TEST_NET network, $((SECONDS - started)) s"
