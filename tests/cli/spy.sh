#!/usr/bin/env bash
# `sirupp spy`: lcm-spy with our types jar. Without a display it refuses clearly; --check lists the
# types lcm-spy discovers (every .lcm of lcmtypes/); under a virtual X server (xvfb-run) the real
# lcm-spy starts with our types while traffic flows. Run by CTest from the source root.
set -u
source "$(dirname "$0")/lib.sh"
source "$(dirname "$0")/private_net.sh"

types=$(ls lcmtypes/*.lcm | wc -l)
run "check" 0 spy --check
has "check count" "$out" "lcm-spy finds $types sirupp types"
has "check lists" "$out" "sirupp.arm_state_t"
has "check plugin" "$out" "plugin sirupp.spy.ImagePlugin"

DISPLAY= run "no display" 1 spy --lcm-url "$URL"
has "no display" "$err" "lcm-spy needs a display and DISPLAY is not set"
run "bad flag" 2 spy --colour red
has "bad flag" "$err" "colour"
run "missing jar" 1 spy --check --jar /nonexistent.jar
has "missing jar" "$err" "types jar /nonexistent.jar not found"
run "print" 0 spy --print-command --lcm-url "$URL"
has "print" "$out" "lcm.spy.Spy --lcm-url=$URL"
has "print classpath" "$out" "/usr/share/java/jchart2d.jar"

if command -v xvfb-run >/dev/null; then
  spy_out=$(mktemp)
  setsid xvfb-run -a "$SIRUPP" spy --lcm-url "$URL" >"$spy_out" 2>&1 &
  spy_pid=$!
  # Some traffic for it to decode while it runs.
  for _ in 1 2 3 4 5 6; do
    "$SIRUPP" estop --release --lcm-url "$URL" >/dev/null 2>&1
    sleep 1
    grep -q "Found [0-9]* plugins" "$spy_out" && break
  done
  sleep 1
  kill -TERM -- "-$spy_pid" 2>/dev/null
  wait "$spy_pid" 2>/dev/null
  has "spy types" "$spy_out" "Found $types LCM types"
  # Our image_t plugin (lcmtypes/java/sirupp/spy/ImagePlugin.java) is in the types jar.
  has "spy image plugin" "$spy_out" "Found 1 plugins"
  if grep -q "Exception\|Unrecognized option" "$spy_out"; then
    echo "FAIL spy: Java reported a problem"; cat "$spy_out"; fail=1
  fi
  rm -f "$spy_out"
  finish spy "lcm-spy started under xvfb-run with $types types"
else
  finish spy "xvfb-run missing: lcm-spy itself not started (scripts/install-deps.sh installs it)"
fi
