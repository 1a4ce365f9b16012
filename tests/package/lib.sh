# Helpers shared by the package tests (source it). Each check prints "FAIL ..." and sets fail=1;
# a script ends with `finish NAME`. They need root (apt, the service user): anyone else gets exit
# 77, which CTest counts as skipped (CI runs as root).
fail=0
[[ $(id -u) -eq 0 ]] || { echo "package tests: need root (apt-get install of the package); skipped"; exit 77; }
check() {  # check NAME COMMAND...: fails NAME unless COMMAND succeeds
  local name=$1; shift
  "$@" || { echo "FAIL $name: $*"; fail=1; }
}
finish() {  # finish NAME [DETAIL]
  [[ $fail -eq 0 ]] || { echo "$1: FAILED"; exit 1; }
  echo "$1: all checks passed${2:+ ($2)}"
}
now() { date +%s.%N; }
since() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.1f", b - a }'; }
