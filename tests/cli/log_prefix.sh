#!/usr/bin/env bash
# Every process's log lines carry the time, the process name and a level
# (`2026-11-24T10:15:03.123 sirupp-sim info: ...`, runtime/log_prefix.hpp): sirupp-sim and
# sirupp-logger run briefly on an in-process LCM (memq://), and a bad argument gives an error line
# followed by the usage text as it is.
set -u
fail=0
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
prefix='^[0-9]{4}-[0-9]{2}-[0-9]{2}T[0-9]{2}:[0-9]{2}:[0-9]{2}\.[0-9]{3} '
every_line() {  # every_line NAME FILE PROCESS: each non-empty line carries the prefix
  local n bad
  n=$(grep -c . "$2")
  [[ $n -ge 1 ]] || { echo "FAIL $1: no lines"; fail=1; return; }
  bad=$(grep . "$2" | grep -Evc "${prefix}$3 (info|warn|error): ")
  [[ $bad -eq 0 ]] || { echo "FAIL $1: $bad of $n lines without the prefix:"; cat "$2"; fail=1; }
  echo "$1: $n lines, all prefixed; first: $(head -1 "$2")"
}

"$SIRUPP_SIM" --mode fast --idle limp --duration 0.05 --lcm-url memq:// 2>"$work/sim.err" >"$work/sim.out"
rc=$?
[[ $rc -eq 0 ]] || { echo "FAIL sim: exit $rc"; cat "$work/sim.err"; fail=1; }
every_line sim "$work/sim.err" sirupp-sim
grep -Eq "${prefix}sirupp-sim info: final joint positions" "$work/sim.err" ||
  { echo "FAIL sim: no final positions line"; fail=1; }

"$SIRUPP_LOGGER" --lcm-url memq:// --out "$work/data" --duration 0.2 2>"$work/logger.err" >"$work/logger.out"
rc=$?
[[ $rc -eq 0 ]] || { echo "FAIL logger: exit $rc"; cat "$work/logger.err"; fail=1; }
every_line logger "$work/logger.err" sirupp-logger

"$SIRUPP_SIM" --bogus 2>"$work/bad.err" >/dev/null
rc=$?
[[ $rc -eq 2 ]] || { echo "FAIL bad flag: exit $rc, expected 2"; fail=1; }
head -1 "$work/bad.err" | grep -Eq "${prefix}sirupp-sim error: .*--bogus" ||
  { echo "FAIL bad flag: first line is not an error line:"; head -3 "$work/bad.err"; fail=1; }
# One line, no usage text after it (the flags are in --help).
[[ $(wc -l <"$work/bad.err") -eq 1 ]] || { echo "FAIL bad flag: more than one line:"; head -5 "$work/bad.err"; fail=1; }

if [[ $fail -ne 0 ]]; then echo "log_prefix: FAILED"; exit 1; fi
echo "log_prefix: all checks passed"
