#!/usr/bin/env bash
# The sirupp command line as a user meets it: exit codes and messages of `model check`, `model show`,
# `demo` and bad arguments. Run by CTest from the source root with SIRUPP set to the binary.
set -u
fail=0
check() {  # check NAME EXPECTED_EXIT COMMAND...
  local name=$1 expected=$2; shift 2
  "$@" >/tmp/sirupp_cli_out.$$ 2>/tmp/sirupp_cli_err.$$
  local rc=$?
  if [[ $rc -ne $expected ]]; then
    echo "FAIL $name: exit $rc, expected $expected"; cat /tmp/sirupp_cli_err.$$; fail=1
  fi
}
contains() {  # contains NAME FILE TEXT
  grep -qF -- "$3" "$2" || { echo "FAIL $1: output lacks '$3'"; head -5 "$2"; fail=1; }
}

for model in config/robots/*.yaml; do
  check "check $model" 0 "$SIRUPP" model check "$model"
  contains "check $model" /tmp/sirupp_cli_out.$$ "$model: ok:"
done

check "show puma" 0 "$SIRUPP" model show config/robots/puma260.yaml
contains "show puma" /tmp/sirupp_cli_out.$$ "DH table (standard convention)"
contains "show puma d1 in SI" /tmp/sirupp_cli_out.$$ "0.33020"
contains "show puma masses" /tmp/sirupp_cli_out.$$ "moving mass 6.800 kg"

count=0
for bad in tests/data/bad_models/*.yaml; do
  expect=$(sed -n 's/^# expect: //p' "$bad")
  check "check $bad" 2 "$SIRUPP" model check "$bad"
  contains "message of $bad" /tmp/sirupp_cli_err.$$ "error: $bad:$expect"
  count=$((count + 1))
done
[[ $count -ge 20 ]] || { echo "FAIL corpus has only $count files"; fail=1; }

check "no arguments" 2 "$SIRUPP"
check "unknown command" 2 "$SIRUPP" frobnicate
contains "unknown command" /tmp/sirupp_cli_err.$$ "unknown command 'frobnicate'"
check "model without file" 2 "$SIRUPP" model check
check "show two files" 2 "$SIRUPP" model show a b
check "demo bad flag" 2 "$SIRUPP" demo --speed 3
check "help" 0 "$SIRUPP" help
# The demo itself (processes, sets, report) is tests/cli/demo.sh.

rm -f /tmp/sirupp_cli_out.$$ /tmp/sirupp_cli_err.$$
if [[ $fail -ne 0 ]]; then echo "cli_model_commands: FAILED"; exit 1; fi
echo "cli_model_commands: all checks passed ($count malformed models)"
