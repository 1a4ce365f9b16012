#!/bin/bash
# Every command line (runtime/args.hpp, on CLI11): `sirupp` and each of its commands and
# subcommands answers --help with exit 0 and a usage text no wider than 80 columns and wrapped once
# (no line starting mid-sentence after a short line), and refuses an unknown flag with exit 2
# naming it; every sirupp-* process does the same, answers --version, and refuses a value outside
# its declared check with exit 2 naming the flag and the value.
# Needs $SIRUPP and $BIN (the folder of the sirupp-* programs).
set -u
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail=0
bad() { echo "FAIL $*"; fail=1; }

# $1 label, $2 expected exit, then the command; leaves $work/out and $work/err.
expect() {
  local label=$1 want=$2
  shift 2
  "$@" >"$work/out" 2>"$work/err" </dev/null
  local code=$?
  [[ $code -eq $want ]] || bad "$label: exit $code, expected $want: $(head -3 "$work/err")"
}
narrow() {  # $1 label, $2 file: no line wider than 80 columns, and the text wrapped once
  local wide ragged
  wide=$(awk 'length($0) > 80' "$2")
  [[ -z $wide ]] || bad "$1: lines wider than 80 columns: $wide"
  # Wrapped once: no line starts mid-sentence (a lower-case word or a parenthesis, the line before
  # not ending a sentence or a clause) when its first word would have fitted on the line before
  # (text wrapped twice leaves such a short line: "... closed-form solver / (8 configurations").
  # Only lines at the same indentation are compared (a flag's text under its column is another
  # column); a row of a table ("  name   text") and the line after "usage:" start lines of their own.
  ragged=$(awk -v width=80 '
    function indent(s) { match(s, /^ */); return RLENGTH }
    {
      if (NR > 1 && prev != "" && $0 != "" && indent($0) == indent(prev) && prev !~ /^usage:/) {
        body = substr($0, indent($0) + 1); split(body, w, " ")
        row = (body ~ /^[^ ]+( [^ ]+)?   */)
        if (w[1] ~ /^[a-z(]/ && prev !~ /[.:;!?]$/ && !row && length(prev) + 1 + length(w[1]) <= width)
          printf "\n    line %d: \"%s\" after \"%s\"", NR, $0, prev
      }
      prev = $0
    }' "$2")
  [[ -z $ragged ]] || bad "$1: wrapped twice (a line starts mid-sentence after a short line):$ragged"
}
commands_of() {  # the names listed under "Commands:" in a help text
  awk '/^Commands:/ {on = 1; next} on && /^  [a-z]/ {print $1} on && /^$/ {on = 0}' "$1"
}

expect "sirupp --version" 0 "$SIRUPP" --version
grep -Eq "^sirupp [0-9]+\.[0-9]+\.[0-9]+$" "$work/out" || bad "sirupp --version: $(cat "$work/out")"
expect "sirupp help" 0 "$SIRUPP" help
narrow "sirupp help" "$work/out"
for program in sim control hardware picservo-emu logger viewer panel; do
  grep -q "sirupp-$program" "$work/out" || bad "sirupp help does not list sirupp-$program"
done
cp "$work/out" "$work/top"
walked=0
for command in $(commands_of "$work/top"); do
  [[ $command == help ]] && continue
  expect "sirupp $command --help" 0 "$SIRUPP" "$command" --help
  [[ -s $work/out || -s $work/err ]] || bad "sirupp $command --help printed nothing"
  narrow "sirupp $command --help" "$work/out"
  walked=$((walked + 1))
  if grep -q "^Commands:" "$work/out"; then
    cp "$work/out" "$work/group"
    expect "sirupp $command" 2 "$SIRUPP" "$command"
    grep -q "expected a subcommand" "$work/err" || bad "sirupp $command: $(cat "$work/err")"
    for sub in $(commands_of "$work/group"); do
      expect "sirupp $command $sub --help" 0 "$SIRUPP" "$command" "$sub" --help
      grep -q "^usage: sirupp $command $sub" "$work/out" || bad "sirupp $command $sub --help: $(head -2 "$work/out")"
      narrow "sirupp $command $sub --help" "$work/out"
      expect "sirupp $command $sub --bogus-flag" 2 "$SIRUPP" "$command" "$sub" --bogus-flag
      grep -q -- "--bogus-flag" "$work/err" || bad "sirupp $command $sub --bogus-flag: $(cat "$work/err")"
      walked=$((walked + 1))
    done
  elif [[ $command != panel ]]; then  # sirupp panel hands its flags to sirupp-panel (below)
    grep -q "^usage: sirupp $command" "$work/out" || bad "sirupp $command --help: $(head -2 "$work/out")"
    expect "sirupp $command --bogus-flag" 2 "$SIRUPP" "$command" --bogus-flag
    grep -q -- "--bogus-flag" "$work/err" || bad "sirupp $command --bogus-flag: $(cat "$work/err")"
  fi
done
[[ $walked -ge 40 ]] || bad "walked only $walked commands"
echo "walked $walked sirupp commands and subcommands"
expect "sirupp nosuch" 2 "$SIRUPP" nosuch
grep -q "unknown command 'nosuch'" "$work/err" || bad "sirupp nosuch: $(cat "$work/err")"
expect "sirupp model nosuch" 2 "$SIRUPP" model nosuch
grep -q "unknown subcommand 'nosuch'; allowed: check, show, export" "$work/err" || bad "sirupp model nosuch: $(cat "$work/err")"
# --flag=value is the same as --flag value.
expect "fk --deg=..." 0 "$SIRUPP" fk --model=config/robots/puma260.yaml --deg 0 -45 180 0 45 0
expect "fk --scale=2" 2 "$SIRUPP" move joints --pose home --scale=2
grep -q -- "--scale: '2' is not allowed; allowed: a number > 0 and <= 1" "$work/err" || bad "move joints --scale=2: $(cat "$work/err")"

# Flags whose count and range are declared with them (issue 21): bad count, out of range, not whole.
for case in "gains --kp 40000|--kp: '40000' is not allowed; allowed: a whole number from 0 to 32767" \
            "gains --kd 2.5|--kd: '2.5' is not allowed; allowed: a whole number from 0 to 32767" \
            "gains --joint 0|--joint: '0' is not allowed; allowed: a whole number >= 1" \
            "gains --joint 7 --kp 5|--joint: '7' is not allowed; allowed: a whole number from 1 to 6" \
            "report x.csv --max-age -1|--max-age: '-1' is not allowed; allowed: a number >= 0" \
            "report x.csv --joints 1 0|--joints: '0' is not allowed; allowed: a whole number >= 1" \
            "view --duration 0|--duration: '0' is not allowed; allowed: a number > 0" \
            "fit-emulator --evaluations 0|--evaluations: '0' is not allowed; allowed: a whole number from 1 to 10000" \
            "fit-emulator --leave-out V-2|--leave-out: 'V-2' is not allowed; allowed: a comma list of the paper's rows (I-1, II-2" \
            "move pose --position 1 2|--position: At least 3 required but received 2" \
            "ik --pose 0.3 0 0.3 0 0 0 --from 1 2|--from Q1 .. QN takes 6 value(s), got 2" \
            "spy --check=yes|--check takes no value, got 'yes'" \
            "estop --reason|--reason: 1 required TEXT missing"; do
  IFS='|' read -r line message <<<"$case"
  # shellcheck disable=SC2086  # the command line is several words
  expect "sirupp $line" 2 "$SIRUPP" $line
  grep -qF -- "$message" "$work/err" || bad "sirupp $line: lacks '$message': $(cat "$work/err")"
done

# Each process: --help, --version, an unknown flag, a value outside the declared check.
for case in "sim|--mode=warp|--mode: 'warp' is not allowed; allowed: lockstep, realtime, fast, freerun" \
            "control|--sim-timeout 0|--sim-timeout: '0' is not allowed; allowed: a number > 0 and <= 3600" \
            "hardware|--rate 5000|--rate: '5000' is not allowed; allowed: a number from 1 to 1000" \
            "picservo-emu|--seed -1|--seed: '-1' is not allowed; allowed: a whole number from 0 to 4294967295" \
            "logger|--split=bogus|--split: 'bogus' is not allowed; allowed: plan, none" \
            "viewer|--format bmp|--format: 'bmp' is not allowed; allowed: jpeg, rgb" \
            "panel|--port 70000|--port: '70000' is not allowed; allowed: a whole number from 0 to 65535"; do
  IFS='|' read -r program flag message <<<"$case"
  exe="$BIN/sirupp-$program"
  expect "sirupp-$program --help" 0 "$exe" --help
  grep -q "^usage: sirupp-$program" "$work/out" || bad "sirupp-$program --help: $(head -2 "$work/out")"
  narrow "sirupp-$program --help" "$work/out"
  expect "sirupp-$program --version" 0 "$exe" --version
  grep -Eq "^sirupp-$program [0-9]+\.[0-9]+\.[0-9]+$" "$work/out" || bad "sirupp-$program --version: $(cat "$work/out")"
  expect "sirupp-$program --bogus-flag" 2 "$exe" --bogus-flag --lcm-url memq://
  grep -q -- "unknown option '--bogus-flag'" "$work/err" || bad "sirupp-$program --bogus-flag: $(cat "$work/err")"
  # shellcheck disable=SC2086  # the flag and its value are two words
  expect "sirupp-$program $flag" 2 "$exe" $flag --lcm-url memq://
  grep -qF -- "$message" "$work/err" || bad "sirupp-$program $flag: lacks '$message': $(cat "$work/err")"
  [[ $(wc -l <"$work/err") -eq 1 ]] || bad "sirupp-$program $flag: more than one line: $(cat "$work/err")"
done

# Bash completion (scripts/sirupp-completion.bash) reads the same generated help.
# shellcheck source=/dev/null
source "$(dirname "$0")/../../scripts/sirupp-completion.bash"
PATH="$(dirname "$SIRUPP"):$BIN:$PATH"
complete_line() {  # the words of a command line, the last one being completed
  COMP_WORDS=("$@")
  COMP_CWORD=$(($# - 1))
  COMPREPLY=()
  _sirupp
  echo "${COMPREPLY[*]}"
}
[[ $(complete_line sirupp mo) == "model move" ]] || bad "completion of 'sirupp mo': $(complete_line sirupp mo)"
[[ $(complete_line sirupp move j) == "joints" ]] || bad "completion of 'sirupp move j': $(complete_line sirupp move j)"
[[ $(complete_line sirupp move joints --sc) == "--scale" ]] || bad "completion of '--sc': $(complete_line sirupp move joints --sc)"
[[ $(complete_line sirupp-sim --gra) == "--gravity-off" ]] || bad "completion of 'sirupp-sim --gra': $(complete_line sirupp-sim --gra)"

if [[ $fail -ne 0 ]]; then echo "command_lines: FAILED"; exit 1; fi
echo "command_lines: all checks passed"
