#!/bin/bash
# The hostile controllers (tests/controllers/hostile/) through `sirupp grade`, sandboxed as it is
# by default: each ends its tasks with a named reason, nothing reaches another rig's port, the
# other student's file is not read, no process and no file is left behind; the grade goes on.
# The example graded sandboxed and with --no-sandbox gives the same results.json. Prints each
# run's wall time (build + grade for a .cpp submission).
# Needs SIRUPP_BIN_DIR, HOSTILE_DIR (build/tests/hostile), LIB_DIR (build/lib).
set -u
bin=$SIRUPP_BIN_DIR
small=tests/data/grade_small.yaml
work=$(mktemp -d)
listener_pid=
cleanup() { [ -n "$listener_pid" ] && kill "$listener_pid" 2>/dev/null; rm -rf "$work"; }
trap cleanup EXIT
fail() { echo "FAIL: $*"; exit 1; }
grade() {  # grade OUT ARGS...
  local out=$1; shift
  local start; start=$(date +%s.%N)
  "$bin/sirupp" grade --out "$work/$out" --no-baseline -j 2 "$@" >"$work/$out.txt" 2>&1 || {
    cat "$work/$out.txt"; fail "sirupp grade $* exited $?"; }
  cat "$work/$out.txt"
  echo "time $out: $(echo "$(date +%s.%N) - $start" | bc) s"
}
reason() {  # reason OUT TASK
  /usr/bin/python3 -c 'import json,sys; d=json.load(open(sys.argv[1]))
for t in d["tasks"]:
  if t["name"]==sys.argv[2]: c=t["controller"]; print(c["status"], c.get("reason",""))' \
    "$work/$1/results.json" "$2"
}
expect() {  # expect OUT TEXT: both tasks ended with TEXT in their reason
  for task in set1 step_j2; do
    local got; got=$(reason "$1" $task)
    echo "$1 $task: $got"
    [[ "$got" == *"$2"* ]] || fail "$1 task $task: expected '$2', got '$got'"
  done
}

# Another rig's port: leased like a grading task's (grade/port_lease.hpp), a listener on it.
/usr/bin/python3 - "$work/port" "$work/heard" <<'PY' &
import fcntl, os, socket, struct, sys
locks = "/tmp/sirupp-grade-ports"  # grade/port_lease.hpp: machine-wide, whatever TMPDIR
os.makedirs(locks, exist_ok=True)
for port in range(20000 + os.getpid() % 9000, 30000):
    lock = open(os.path.join(locks, "%d.lock" % port), "a")
    try:
        fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        break
    except OSError:
        lock.close()
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
s.bind(("", port))
s.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP,
             struct.pack("4s4s", socket.inet_aton("239.255.76.67"), socket.inet_aton("0.0.0.0")))
heard = 0
open(sys.argv[2], "w").write("0\n")
open(sys.argv[1], "w").write("%d\n" % port)
while True:
    s.recv(1024)
    heard += 1
    open(sys.argv[2], "w").write("%d\n" % heard)
PY
listener_pid=$!
for _ in $(seq 100); do [ -s "$work/port" ] && break; sleep 0.1; done
port=$(cat "$work/port") || fail "no listener port"

grade net "$HOSTILE_DIR/net_publish/net_publish.so" --suite $small --args "$port"
expect net "socket(AF_INET, SOCK_DGRAM): Permission denied"
sleep 0.3
[ "$(cat "$work/heard")" = 0 ] || fail "the listener on port $port heard $(cat "$work/heard") datagrams"

other=$work/other_student; mkdir -p "$other"; chmod 755 "$other"
echo "the other student's secret gains" >"$other/controller.cpp"; chmod 644 "$other/controller.cpp"
grade read "$HOSTILE_DIR/read_other/read_other.so" --suite $small --args "$other/controller.cpp"
expect read "cannot open $other/controller.cpp: No such file or directory"
grep -q "secret" "$work/read/results.json" && fail "the secret is in results.json"

bomb=fb-$$
grade fork "$HOSTILE_DIR/fork_bomb/fork_bomb.so" --suite $small --args "$bomb"
expect fork "fork failed after"
sleep 0.5
pgrep -x "$bomb" >/dev/null && fail "fork bomb processes survived: $(pgrep -x "$bomb" | wc -l)"

grade alloc "$HOSTILE_DIR/allocate/allocate.so" --suite $small
expect alloc "could not be loaded"

huge=/tmp/sirupp-hostile-huge-$$
grade huge "$HOSTILE_DIR/huge_file/huge_file.so" --suite $small --args "$huge"
expect huge "crashed with SIGXFSZ (File size limit exceeded) in Update"
[ -e "$huge" ] && fail "$huge was written outside the sandbox"

grade spin "$HOSTILE_DIR/spin_constructor/spin_constructor.so" --suite $small
expect spin "did not finish loading within"

# A submission as source: built and graded in the sandbox; the same results as unsandboxed.
mkdir -p "$work/src"; cp examples/02_pd_gravity/pd_gravity.cpp "$work/src/"; chmod -R a+rX "$work/src"
grade src "$work/src/pd_gravity.cpp" --suite $small
grade src_plain "$work/src/pd_gravity.cpp" --suite $small --no-sandbox
cmp "$work/src/results.json" "$work/src_plain/results.json" || fail "results differ sandboxed and not"
grep -q "score 100.0" "$work/src.txt" || fail "the example did not pass the small suite"
# A source that does not build: its error at its line, exit 2, nothing graded.
printf '#include <sirupp/controller.h>\nint f() { return 1 }\n' >"$work/src/broken.cpp"
"$bin/sirupp" grade "$work/src/broken.cpp" --suite $small --out "$work/broken" >"$work/broken.txt" 2>&1
code=$?; cat "$work/broken.txt"
[ $code = 2 ] || fail "broken.cpp: exit $code, expected 2"
grep -q "^broken.cpp:2:.*error: expected ';'" "$work/broken.txt" || fail "broken.cpp: no error at line 2"
echo "PASS grade_hostile"
