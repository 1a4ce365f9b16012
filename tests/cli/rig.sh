# Helpers for tests that run the whole linked rig as processes: sirupp-picservo-emu and
# sirupp-hardware (the robot PC), sirupp-sim and sirupp-logger (the server), sirupp-control (the
# student PC). Source it after lib.sh and after either private_net.sh (everything on one private
# network; host names are ignored) or netns.sh (one namespace per PC, named by the host
# arguments). Needs $URL, $work (a directory of the test's own), and SIRUPP, SIRUPP_SIM,
# SIRUPP_CONTROL, SIRUPP_HARDWARE, SIRUPP_EMU, SIRUPP_LOGGER, ARM_WATCH.
#
#   rig_start ROBOT SERVER STUDENT   # the five processes, linked and ready for a move
#   on HOST CMD...                   # CMD in the foreground on HOST
#   spawn ROLE HOST CMD...           # CMD in the background; output in $work/ROLE.log
#   watch_arms HOST SECONDS FILE     # arm_watch: both arms' joints over a window, into FILE
#   arm_value FILE ARM KIND J        # from a watch_arms FILE: ARM virtual|real, KIND last|min|max
#   rig_stop ROLE...                 # SIGINT, then the exit code must be 0
#   rig_cleanup                      # for the exit trap under private_net.sh

declare -A rig_pid rig_host
rig_all=()

on() {
  local host=$1
  shift
  if [[ -n "${NETNS_TAG:-}" ]]; then ns_exec "$host" "$@"; else "$@"; fi
}

spawn() {
  local role=$1 host=$2
  shift 2
  if [[ -n "${NETNS_TAG:-}" ]]; then
    ns_run "$host" "$work/$role.log" "$@"
    rig_pid[$role]=$ns_pid
  else
    "$@" >"$work/$role.log" 2>&1 &
    rig_pid[$role]=$!
  fi
  rig_host[$role]=$host
  rig_all+=("${rig_pid[$role]}")
}

# wait_for WHAT SECONDS CMD...: polls CMD (quietly) until it succeeds; FAIL naming WHAT if it never
# does within SECONDS. Returns CMD's last status.
wait_for() {
  local what=$1 seconds=$2
  shift 2
  local deadline=$((SECONDS + seconds))
  while :; do
    "$@" >/dev/null 2>&1 && return 0
    if [[ $SECONDS -ge $deadline ]]; then
      echo "FAIL: $what: not within $seconds s"
      fail=1
      return 1
    fi
    sleep 0.2
  done
}

alive() {  # alive ROLE...: every ROLE's process still runs
  local role
  for role in "$@"; do kill -0 "${rig_pid[$role]}" 2>/dev/null || return 1; done
}

expect_alive() {  # expect_alive ROLE...: FAIL for each ROLE whose process has gone
  local role
  for role in "$@"; do
    kill -0 "${rig_pid[$role]}" 2>/dev/null && continue
    echo "FAIL: $role (pid ${rig_pid[$role]}) is not running; its output:"
    tail -20 "$work/$role.log"
    fail=1
  done
}

bridge_state() {  # bridge_state HOST TEXT: `sirupp hardware status` from HOST contains TEXT
  on "$1" "$SIRUPP" hardware status --lcm-url "$URL" --timeout 1 >"$work/hw_status.out" 2>&1
  grep -qF -- "$2" "$work/hw_status.out"
}

rig_start() {
  local robot=$1 server=$2 student=$3
  mkdir -p "$work/data"
  spawn emu "$robot" "$SIRUPP_EMU" --socket "$work/bus" --start-pose ready
  wait_for "the emulator's serial line $work/bus" 20 test -S "$work/bus" || return 1
  # The start order of docs/channels.md; realtime, as with a real arm, both arms upright.
  spawn sim "$server" "$SIRUPP_SIM" --lcm-url "$URL" --mode realtime --pose ready
  spawn control "$student" "$SIRUPP_CONTROL" --lcm-url "$URL"
  spawn hardware "$robot" "$SIRUPP_HARDWARE" --port "$work/bus" --emulated --calibrate --arm \
    --link --settings tests/data/hardware/patient.yaml --lcm-url "$URL"
  spawn logger "$server" "$SIRUPP_LOGGER" --lcm-url "$URL" --out "$work/data" --name run
  wait_for "the bridge linked (seen from $student)" 60 bridge_state "$student" "bridge: linked" ||
    { cat "$work/hw_status.out" "$work/hardware.log"; return 1; }
  wait_for "the controller's status (seen from $student)" 30 \
    on "$student" "$SIRUPP" status --lcm-url "$URL" --timeout 0.5 || return 1
  # Past the bridge's start guard (0.5 s in patient.yaml) with room to spare.
  sleep 0.5
  expect_alive emu sim control hardware logger
}

watch_arms() {  # watch_arms HOST SECONDS FILE
  on "$1" "$ARM_WATCH" --lcm-url "$URL" --seconds "$2" >"$3" 2>&1
}

arm_value() {  # arm_value FILE ARM KIND J
  awk -v arm="$2" -v kind="$3" -v j="$4" \
    '$1 == arm { for (i = 1; i <= NF; i++) if ($i == kind) { print $(i + j); exit } }' "$1"
}

arm_states() {  # arm_states FILE ARM: how many states arm_watch saw
  awk -v arm="$2" '$1 == arm { print $2 }' "$1"
}

# within NAME VALUE CENTRE TOLERANCE: FAIL unless |VALUE - CENTRE| <= TOLERANCE.
within() {
  awk -v v="${2:-x}" -v c="$3" -v t="$4" 'BEGIN { if (v == "x" || v == "") exit 1; d = v - c; if (d < 0) d = -d; exit !(d <= t) }' ||
    { echo "FAIL $1: ${2:-nothing} is not within $4 of $3"; fail=1; return 1; }
}

# band NAME FILE ARM TOLERANCE: every joint's max - min in a watch_arms FILE is within TOLERANCE.
band() {
  local j lo hi
  [[ "$(arm_states "$2" "$3")" -gt 0 ]] 2>/dev/null ||
    { echo "FAIL $1: no $3 arm states heard"; cat "$2"; fail=1; return 1; }
  for j in 1 2 3 4 5 6; do
    lo=$(arm_value "$2" "$3" min "$j")
    hi=$(arm_value "$2" "$3" max "$j")
    awk -v lo="$lo" -v hi="$hi" -v t="$4" 'BEGIN { exit !(hi - lo <= t) }' ||
      { echo "FAIL $1: $3 joint $j moved from $lo to $hi deg (allowed band $4)"; cat "$2"; fail=1; return 1; }
  done
}

# real_reaches HOST J GOAL TOLERANCE SECONDS: polls until the real arm's joint J is at GOAL.
real_at() {
  watch_arms "$1" 1.0 "$work/real_at.out"
  awk -v v="$(arm_value "$work/real_at.out" real last "$2")" -v g="$3" -v t="$4" \
    'BEGIN { if (v == "") exit 1; d = v - g; if (d < 0) d = -d; exit !(d <= t) }'
}
real_reaches() {
  wait_for "the real arm's joint $2 at $3 deg (+-$4)" "$5" real_at "$1" "$2" "$3" "$4" ||
    { cat "$work/real_at.out"; return 1; }
}

rig_stop() {  # rig_stop ROLE...: SIGINT to each, then each must exit 0 within 15 s
  local role pid rc
  for role in "$@"; do
    pid=${rig_pid[$role]}
    kill -INT "$pid" 2>/dev/null || { echo "FAIL: $role (pid $pid) was gone before SIGINT"; fail=1; continue; }
    for _ in $(seq 150); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    if kill -0 "$pid" 2>/dev/null; then
      echo "FAIL: $role did not stop within 15 s of SIGINT"
      fail=1
      kill -9 "$pid" 2>/dev/null
    fi
    wait "$pid"
    rc=$?
    [[ $rc -eq 0 ]] || { echo "FAIL: $role exit $rc after SIGINT; its output:"; tail -20 "$work/$role.log"; fail=1; }
  done
}

rig_cleanup() {
  local pid
  for pid in "${rig_all[@]}"; do kill -CONT "$pid" 2>/dev/null; kill -TERM "$pid" 2>/dev/null; done
  for _ in $(seq 30); do
    local alive=0
    for pid in "${rig_all[@]}"; do kill -0 "$pid" 2>/dev/null && alive=1; done
    [[ $alive -eq 0 ]] && break
    sleep 0.1
  done
  for pid in "${rig_all[@]}"; do kill -9 "$pid" 2>/dev/null; done
  wait 2>/dev/null
}

# heard HOST SECONDS WHO...: `sirupp status` run on HOST lists the heartbeat of every WHO
# (process@host) within SECONDS; FAIL naming the ones missing.
heard() {
  local host=$1 seconds=$2 who
  shift 2
  local deadline=$((SECONDS + seconds)) missing
  while :; do
    on "$host" "$SIRUPP" status --lcm-url "$URL" --timeout 2.5 >"$work/heard.out" 2>&1
    missing=()
    for who in "$@"; do grep -qF "process $who pid" "$work/heard.out" || missing+=("$who"); done
    [[ ${#missing[@]} -eq 0 ]] && return 0
    if [[ $SECONDS -ge $deadline ]]; then
      echo "FAIL: on $host, no heartbeat of ${missing[*]} within $seconds s"
      cat "$work/heard.out"
      fail=1
      return 1
    fi
  done
}
