#!/bin/bash
# The shipped lab layout config/labs/multi-pc.yaml run by `sirupp launch --host NAME` on three
# "PCs" (network namespaces on one bridge, netns.sh), ttl=1, channel prefix RIG1_ (the layout's):
# robot-pc (emulated boards + bridge), server (sim, logger, viewer), student-1 (controller).
# Checks: each launcher starts its share; the server's table lists the other hosts' processes
# from their heartbeats; the paper's movement set I runs from the student PC; `sirupp status`
# there hears every process; the logger's file has set-point, virtual and real angles; Ctrl-C
# (SIGINT) to each launcher stops its processes cleanly and it exits 0.
# Needs root for the namespaces (else skipped, exit 77).
set -u
NETNS_PORT=7743
source "$(dirname "$0")/lib.sh"
source "$(dirname "$0")/netns.sh"
URL=$NETNS_URL
work=$(mktemp -d)
netns_atexit 'rm -rf "$work"'
netns_setup robot-pc server student-1
started=$SECONDS
hosts=(robot-pc server student-1)
declare -A launcher
for host in "${hosts[@]}"; do
  ns_run "$host" "$work/launch-$host.out" "$SIRUPP" launch config/labs/multi-pc.yaml --host "$host" \
    --lcm-url "$URL" --run-dir "$work/run-$host" --status-every 2
  launcher[$host]=$ns_pid
  for _ in $(seq 1 300); do
    grep -q "are up" "$work/launch-$host.out" && break
    kill -0 "$ns_pid" 2>/dev/null || break
    sleep 0.1
  done
  grep -q "are up" "$work/launch-$host.out" ||
    { echo "FAIL: the launcher on $host did not bring its processes up"; cat "$work/launch-$host.out"; fail=1; }
done
[[ $fail -eq 0 ]] || finish multi_pc_launch
# The bridge refuses moves for 2 s after its start (its start guard, docs/hardware.md).
sleep 2.5

# The paper's set I from the student PC, on the rig's prefix.
ns_exec student-1 "$SIRUPP" plan run config/plans/set1.plan --wait --lcm-url "$URL" --prefix RIG1_ \
  --timeout 90 >"$work/plan.out" 2>&1 || { echo "FAIL: plan set1"; cat "$work/plan.out"; fail=1; }
has plan "$work/plan.out" "finished; joints ["

# Every process of every host heard from the student PC.
expect=(sirupp-sim@server sirupp-logger@server sirupp-viewer@server sirupp-hardware@robot-pc
  sirupp-control@student-1)
deadline=$((SECONDS + 30))
while :; do
  ns_exec student-1 "$SIRUPP" status --lcm-url "$URL" --prefix RIG1_ --timeout 2.5 >"$work/status.out" 2>&1
  missing=()
  for who in "${expect[@]}"; do grep -qF "process $who pid" "$work/status.out" || missing+=("$who"); done
  [[ ${#missing[@]} -eq 0 || $SECONDS -ge $deadline ]] && break
done
[[ ${#missing[@]} -eq 0 ]] || { echo "FAIL: not heard: ${missing[*]}"; cat "$work/status.out"; fail=1; }
# The server's launcher lists the other hosts' processes in its table (in parentheses).
grep -qE "^\(sirupp-control\) +student-1 " "$work/launch-server.out" ||
  { echo "FAIL: the server's table lacks the student PC's controller"; tail -20 "$work/launch-server.out"; fail=1; }
grep -qE "^\(sirupp-hardware\) +robot-pc " "$work/launch-server.out" ||
  { echo "FAIL: the server's table lacks the robot PC's bridge"; tail -20 "$work/launch-server.out"; fail=1; }

# Ctrl-C to each launcher: its processes stop cleanly, it exits 0.
for host in student-1 server robot-pc; do
  kill -INT "${launcher[$host]}"
  wait "${launcher[$host]}"
  rc=$?
  [[ $rc -eq 0 ]] || { echo "FAIL: the launcher on $host exited $rc"; tail -20 "$work/launch-$host.out"; fail=1; }
  has "clean stop $host" "$work/launch-$host.out" "every process ran and stopped cleanly"
done

file="$work/run-server/data/rig1-02-set1.csv"
if [[ -s "$file" ]]; then
  filled=$(awk -F, '/^#/ { next } !header { header = 1; for (i = 1; i <= NF; i++) col[$i] = i; next }
    $col["j1_set_deg"] != "" && $col["j1_virt_deg"] != "" && $col["j1_real_deg"] != "" { n++ }
    END { print n + 0 }' "$file")
  echo "data file: $filled rows with set-point, virtual and real angles of joint 1"
  [[ $filled -ge 20 ]] || { echo "FAIL: only $filled rows have all three columns"; fail=1; }
else
  echo "FAIL: no $file; the logger wrote: $(ls "$work/run-server/data" 2>&1)"
  fail=1
fi
ls "$work"/run-server/images/*.png >/dev/null 2>&1 || { echo "FAIL: the viewer wrote no PNG"; fail=1; }
finish multi_pc_launch "$((SECONDS - started)) s"
