# Helpers shared by the command-line test scripts (source it; $SIRUPP is the binary under test).
# Each check prints "FAIL ..." and sets fail=1; the script ends with `finish NAME`.
fail=0
out=$(mktemp) err=$(mktemp)
trap 'rm -f "$out" "$err"' EXIT
run() {  # run NAME EXPECTED_EXIT ARGS...: runs $SIRUPP ARGS, output in $out and $err
  local name=$1 expected=$2; shift 2
  "$SIRUPP" "$@" >"$out" 2>"$err"
  local rc=$?
  [[ $rc -eq $expected ]] || { echo "FAIL $name: exit $rc, expected $expected"; cat "$out" "$err"; fail=1; }
}
has() {  # has NAME FILE TEXT
  grep -qF -- "$3" "$2" || { echo "FAIL $1: lacks '$3'"; head -20 "$2"; fail=1; }
}
lines() {  # lines NAME FILE COUNT
  local n; n=$(wc -l <"$2")
  [[ $n -eq $3 ]] || { echo "FAIL $1: $n lines, expected $3"; cat "$2"; fail=1; }
}
finish() {  # finish NAME [DETAIL]
  [[ $fail -eq 0 ]] || { echo "$1: FAILED"; exit 1; }
  echo "$1: all checks passed${2:+ ($2)}"
}
