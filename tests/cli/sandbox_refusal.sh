#!/bin/bash
# Where the sandbox cannot be had (played with SIRUPP_BWRAP: a bubblewrap that fails, as without
# user namespaces, or none), students' code is refused with the reason and exit 2:
# sirupp-control --controller, sirupp grade LIB.so, sirupp controller build; --no-sandbox runs it.
# And `sirupp controller build` of a source with an error prints it at its line, exit 1.
# Needs SIRUPP_BIN_DIR, LIB_DIR (build/lib).
set -u
bin=$SIRUPP_BIN_DIR
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
url="udpm://239.255.76.67:$((20000 + $$ % 9000))?ttl=0"

SIRUPP_BWRAP=/bin/false "$bin/sirupp-control" --controller "$LIB_DIR/pd_gravity.so" --lcm-url "$url" \
  >"$work/control.txt" 2>&1
code=$?; cat "$work/control.txt"
[ $code = 2 ] || fail "sirupp-control: exit $code, expected 2"
grep -q "pd_gravity.so: the sandbox cannot be had on this machine: bubblewrap cannot make its sandbox here" \
  "$work/control.txt" || fail "sirupp-control: no reason"
grep -q "unprivileged user namespaces" "$work/control.txt" || fail "sirupp-control: no remedy"

# --no-sandbox: it runs (until interrupted).
SIRUPP_BWRAP=/bin/false timeout -s INT 3 "$bin/sirupp-control" --controller "$LIB_DIR/pd_gravity.so" \
  --no-sandbox --lcm-url "$url" >"$work/plain.txt" 2>&1
cat "$work/plain.txt"
grep -q "no sandbox (--no-sandbox)" "$work/plain.txt" || fail "sirupp-control --no-sandbox did not start"

SIRUPP_BWRAP=/bin/false "$bin/sirupp" grade "$LIB_DIR/pd_gravity.so" --suite tests/data/grade_small.yaml \
  --out "$work/grade" >"$work/grade.txt" 2>&1
code=$?; cat "$work/grade.txt"
[ $code = 2 ] || fail "sirupp grade: exit $code, expected 2"
grep -q "grade: the sandbox cannot be had on this machine" "$work/grade.txt" || fail "sirupp grade: no reason"

SIRUPP_BWRAP=/nonexistent "$bin/sirupp" controller build examples/02_pd_gravity/pd_gravity.cpp \
  --out "$work/build" >"$work/build.txt" 2>&1
code=$?; cat "$work/build.txt"
[ $code = 2 ] || fail "controller build: exit $code, expected 2"
grep -q "bubblewrap (bwrap) is not installed" "$work/build.txt" || fail "controller build: no reason"

# A source with an error, in the sandbox: the error at its line, exit 1, no library.
mkdir "$work/src"
printf '#include <sirupp/controller.h>\n\nint f() { return 1 }\n' >"$work/src/mine.cpp"
"$bin/sirupp" controller build "$work/src/mine.cpp" --out "$work/out" >"$work/mine.txt" 2>&1
code=$?; cat "$work/mine.txt"
[ $code = 1 ] || fail "controller build mine.cpp: exit $code, expected 1"
grep -q "^mine.cpp:3:19: error: expected ';' before '}' token" "$work/mine.txt" || fail "no error at mine.cpp:3"
[ -e "$work/out/mine.so" ] && fail "a library from a source that does not build"
echo "PASS sandbox_refusal"
