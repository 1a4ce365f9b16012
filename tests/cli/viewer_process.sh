#!/bin/bash
# sirupp-viewer as a real process (OSMesa, no display), over UDP multicast in a private network
# namespace (or ttl=0 on this host):
#  - bad flags and a bad settings file exit 2 with one line naming the flag or file:line;
#  - --once writes a 640x480 PNG; --png/--png-every write PNG frames; --video writes an AVI that
#    is finalised (index written) at the end of --duration and on SIGTERM; SIGUSR1 a snapshot;
#  - beside sirupp-sim it draws the model it receives and its images reach the bus;
#  - it draws the same traffic replayed from an lcm-logger file with lcm-logplayer;
#  - `sirupp view` without a display exits 1 with one line.
# Needs SIRUPP_VIEWER, SIRUPP_SIM and SIRUPP; lcm-logger and lcm-logplayer (liblcm-bin) on PATH.
# Timing is never judged: waits are generous and only bound how long a broken build can hang.
set -u
PRIVATE_NET_PORT=7738
source "$(dirname "$0")/private_net.sh"
source "$(dirname "$0")/lib.sh"
work=$(mktemp -d)
pids=()
cleanup() {
  for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null; done
  wait 2>/dev/null
  rm -rf "$work" "$out" "$err"
}
trap cleanup EXIT
for tool in lcm-logger lcm-logplayer; do
  command -v "$tool" >/dev/null || { echo "FAIL: $tool not found (liblcm-bin)"; exit 1; }
done
unset DISPLAY WAYLAND_DISPLAY

viewer() {  # viewer NAME EXPECTED_EXIT ARGS...: runs sirupp-viewer, output in $out and $err
  local name=$1 expected=$2; shift 2
  "$SIRUPP_VIEWER" "$@" >"$out" 2>"$err"
  local rc=$?
  [[ $rc -eq $expected ]] || { echo "FAIL $name: exit $rc, expected $expected"; cat "$out" "$err"; fail=1; }
}
is_png() {  # is_png NAME FILE: the PNG signature
  [[ -f "$2" && "$(od -An -tx1 -N8 "$2" | tr -d ' \n')" == 89504e470d0a1a0a ]] ||
    { echo "FAIL $1: $2 is not a PNG"; fail=1; }
}
is_finished_avi() {  # is_finished_avi NAME FILE: RIFF AVI with Motion-JPEG and its index
  local file=$2
  [[ -s "$file" && "$(head -c 4 "$file")" == RIFF && "$(head -c 12 "$file" | tail -c 4)" == "AVI " ]] ||
    { echo "FAIL $1: $file is not an AVI file"; fail=1; return; }
  grep -qa MJPG "$file" || { echo "FAIL $1: no MJPG stream in $file"; fail=1; }
  grep -qa idx1 "$file" || { echo "FAIL $1: $file has no index (not finalised)"; fail=1; }
}
wait_for() {  # wait_for SECONDS COMMAND...: polls until COMMAND succeeds
  local until=$((SECONDS + $1)); shift
  until "$@"; do [[ $SECONDS -lt $until ]] || return 1; sleep 0.1; done
}

# Bad flags and files: exit 2, one line naming the flag, the value and what is allowed.
viewer format 2 --format bmp
has format "$err" "--format: 'bmp' is not allowed; allowed: jpeg, rgb"
viewer width 2 --width 8
has width "$err" "--width 8: allowed whole numbers 16..4096"
viewer video_name 2 --video "$work/run.mp4"
has video_name "$err" "run.mp4': the file name must end in .avi"
viewer elevation 2 --camera 30 95 1
has elevation "$err" "--camera elevation 95 deg: allowed -88.8..88.8"
viewer png_every 2 --png-every 1
has png_every "$err" "--png-every needs --png DIR"
viewer unknown 2 --colour red
has unknown "$err" "unknown option '--colour'"
viewer deg_alone 2 --deg 0 0 0 0 0 0
has deg_alone "$err" "--deg only goes with --once OUT.png"
printf 'width: 640\nformat: bmp\n' >"$work/bad.yaml"
viewer config 2 --config "$work/bad.yaml"
has config "$err" "bad.yaml:2"
has config "$err" "bmp"
viewer once_count 2 --once "$work/x.png" --deg 1 2 3
has once_count "$err" "--deg Q ... takes 6 value(s), got 3"
viewer no_dir 2 --png /proc/nope/png --duration 1
has no_dir "$err" "/proc/nope/png: cannot create the directory"

# One frame from joint values: a 640x480 PNG (width and height in the IHDR chunk).
viewer once 0 --once "$work/once.png" --environment config/environments/table.xml \
  --deg 30 -60 120 0 30 0 --ghost-deg 60 -45 100 0 30 0 --real-deg 34 -56 116 0 30 0
is_png once "$work/once.png"
[[ "$(od -An -tx1 -j16 -N8 "$work/once.png" | tr -d ' \n')" == 00000280000001e0 ]] ||
  { echo "FAIL once: not 640x480: $(od -An -tx1 -j16 -N8 "$work/once.png")"; fail=1; }

# Alone on the bus for 2 s (no sim yet): PNG frames, a finished video, exit 0.
viewer alone 0 --lcm-url "$URL" --model config/robots/puma260.yaml --duration 2 \
  --png "$work/alone" --png-every 0.4 --video "$work/alone.avi" --width 320 --height 240
has alone "$err" "images published, model puma260"
is_png alone_png "$work/alone/frame-000001.png"
is_png alone_png2 "$work/alone/frame-000002.png"
is_finished_avi alone_video "$work/alone.avi"

# SIGTERM finalises the video; SIGUSR1 writes a snapshot; exit 0.
"$SIRUPP_VIEWER" --lcm-url "$URL" --video "$work/term.avi" --png "$work/snap" >"$work/term.out" 2>&1 &
term=$!; pids+=("$term")
wait_for 30 grep -q " Hz on " "$work/term.out" || { echo "FAIL term: no start line"; cat "$work/term.out"; fail=1; }
sleep 0.5
kill -USR1 "$term"
wait_for 30 test -s "$work/snap/snapshot-001.png" || { echo "FAIL snapshot: none written"; fail=1; }
kill -TERM "$term"
wait "$term"; rc=$?
[[ $rc -eq 0 ]] || { echo "FAIL term: exit $rc"; cat "$work/term.out"; fail=1; }
is_png snapshot "$work/snap/snapshot-001.png"
is_finished_avi term_video "$work/term.avi"

# Beside the sim: the viewer builds itself from ROBOT_MODEL; its images are on VIEWER_IMAGE.
"$SIRUPP_SIM" --lcm-url "$URL" --mode realtime 2>"$work/sim.err" &
sim=$!; pids+=("$sim")
lcm-logger --lcm-url="$URL" -c 'ROBOT_MODEL|ENVIRONMENT|SIM_ARM_STATE' -f -q "$work/sim.lcm" \
  2>"$work/logger.err" &
recorder=$!; pids+=("$recorder")
lcm-logger --lcm-url="$URL" -c 'VIEWER_IMAGE' -f -q "$work/images.lcm" 2>"$work/images.err" &
images=$!; pids+=("$images")
viewer live 0 --lcm-url "$URL" --duration 3 --rate 5
has live "$err" "model puma260"
sleep 0.3  # lcm-logger 1.3.1 flushes every 100 ms and not on exit
kill -INT "$recorder" "$images" "$sim"
wait "$recorder" "$images" "$sim" 2>/dev/null
grep -qa VIEWER_IMAGE "$work/images.lcm" || { echo "FAIL live: no VIEWER_IMAGE recorded"; fail=1; }
grep -qa ROBOT_MODEL "$work/sim.lcm" || { echo "FAIL live: the recording has no ROBOT_MODEL"; fail=1; }

# The recorded traffic replayed with lcm-logplayer: the same picture, the same model.
"$SIRUPP_VIEWER" --lcm-url "$URL" --duration 6 --png "$work/replay" --png-every 0.5 \
  >"$work/replay.out" 2>&1 &
replay=$!; pids+=("$replay")
wait_for 30 grep -q " Hz on " "$work/replay.out" || { echo "FAIL replay: no start line"; fail=1; }
lcm-logplayer --lcm-url="$URL" "$work/sim.lcm" >/dev/null 2>&1
wait "$replay"; rc=$?
[[ $rc -eq 0 ]] || { echo "FAIL replay: exit $rc"; cat "$work/replay.out"; fail=1; }
has replay "$work/replay.out" "model puma260"
is_png replay_png "$work/replay/frame-000002.png"

# sirupp view needs a display: one line, exit 1; bad arguments exit 2.
"$SIRUPP" view --lcm-url "$URL" >"$out" 2>"$err"; rc=$?
[[ $rc -eq 1 ]] || { echo "FAIL view: exit $rc, expected 1"; cat "$out" "$err"; fail=1; }
has view "$err" "sirupp view: no display (\$DISPLAY is not set)"
"$SIRUPP" view --bogus >"$out" 2>"$err"; rc=$?
[[ $rc -eq 2 ]] || { echo "FAIL view_args: exit $rc, expected 2"; fail=1; }
has view_args "$err" "unknown option '--bogus'"

# With a display (a virtual X server, xvfb-run): the window opens and shows the viewer's frames
# (alone on the bus the viewer still sends one a second).
if command -v xvfb-run >/dev/null; then
  "$SIRUPP_VIEWER" --lcm-url "$URL" --duration 8 >"$work/shown.out" 2>&1 &
  shown=$!; pids+=("$shown")
  wait_for 30 grep -q " Hz on " "$work/shown.out" || { echo "FAIL view_x: viewer did not start"; fail=1; }
  LSAN_OPTIONS="suppressions=$PWD/tests/cli/lsan-highgui.supp" DISPLAY= timeout 60 \
    xvfb-run -a "$SIRUPP" view --lcm-url "$URL" --duration 4 >"$out" 2>"$err"
  rc=$?
  [[ $rc -eq 0 ]] || { echo "FAIL view_x: exit $rc"; cat "$out" "$err"; fail=1; }
  n=$(sed -n 's/^sirupp view: \([0-9]*\) images received$/\1/p' "$out" "$err" | head -1)
  [[ ${n:-0} -ge 2 ]] || { echo "FAIL view_x: ${n:-no} images shown"; cat "$out" "$err"; fail=1; }
  kill -INT "$shown" 2>/dev/null; wait "$shown" 2>/dev/null
fi

finish viewer_process "$TEST_NET network"
