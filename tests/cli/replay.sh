#!/usr/bin/env bash
# `sirupp replay`: a short sirupp-sim run recorded with lcm-logger, replayed at twice the speed to a
# second lcm-logger, which must receive the same messages (channel and bytes) in the same order,
# spread over about half the time; bad arguments and a missing file. On a private network
# (private_net.sh: a namespace, or udpm with ttl=0).
source "$(dirname "$0")/private_net.sh"
source "$(dirname "$0")/lib.sh"
work=$(mktemp -d)
pids=()
cleanup() {
  for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null; done
  wait 2>/dev/null
  rm -rf "$work" "$out" "$err"
}
trap cleanup EXIT
for tool in lcm-logger python3; do
  command -v "$tool" >/dev/null || { echo "FAIL: $tool not found (scripts/install-deps.sh)"; exit 1; }
done

# The recorders' sockets take a 4 MiB buffer (as far as net.core.rmem_max allows): on a loaded
# machine a recorder with the default 208 KiB lost a datagram of the replay.
REC_URL="$URL&recv_buf_size=4194304"
# Record: sirupp-sim for 0.4 s of real time, states at 1/8 of the servo rate.
lcm-logger --lcm-url="$REC_URL" -f -q "$work/run.lcm" 2>"$work/rec.err" &
rec=$!; pids+=("$rec")
# A recorder listens once its socket is bound (a fixed sleep was too short on a loaded machine:
# the replay's recorder once heard 1 message of 105).
port=${URL##*:}; port=${port%%\?*}
wait_bound() {
  for _ in $(seq 200); do
    ss -Hulnp "sport = :$port" 2>/dev/null | grep -q "pid=$1," && { sleep 0.2; return 0; }
    sleep 0.05
  done
  echo "FAIL: lcm-logger (pid $1) did not bind udp port $port within 10 s"; fail=1
}
wait_bound "$rec"
"$SIRUPP_SIM" --lcm-url "$URL" --mode realtime --idle limp --duration 0.4 --state-every 8 \
  2>"$work/sim.err" || { echo "FAIL sim"; cat "$work/sim.err"; fail=1; }
sleep 0.3  # lcm-logger 1.3.1 flushes every 100 ms and not on exit
kill -INT "$rec"; wait "$rec" 2>/dev/null

# Replay at speed 2 to a second recorder.
lcm-logger --lcm-url="$REC_URL" -f -q "$work/replayed.lcm" 2>"$work/rep.err" &
rep=$!; pids+=("$rep")
wait_bound "$rep"
run replay 0 replay "$work/run.lcm" --lcm-url "$URL" --speed 2
cat "$out"
has replay "$out" "replay: "
sleep 0.3
kill -INT "$rep"; wait "$rep" 2>/dev/null

python3 - "$work/run.lcm" "$work/replayed.lcm" <<'PY' || fail=1
import struct, sys
def events(path):
    data, at, out = open(path, "rb").read(), 0, []
    while at + 28 <= len(data):
        sync, _num, stamp, clen, dlen = struct.unpack_from(">IqqII", data, at)
        assert sync == 0xEDA1DA01, "bad sync word in " + path
        at += 28
        channel = data[at:at + clen].decode(); at += clen
        out.append((channel, data[at:at + dlen], stamp)); at += dlen
    return out
rec, rep = events(sys.argv[1]), events(sys.argv[2])
channels = sorted({c for c, _, _ in rec})
print(f"recorded {len(rec)} messages on {len(channels)} channels ({', '.join(channels)}); "
      f"replayed and received {len(rep)}")
if len(rec) < 50 or "SIM_ARM_STATE" not in channels:
    sys.exit("FAIL: the recording is too short")
if [(c, d) for c, d, _ in rec] != [(c, d) for c, d, _ in rep]:
    first = next((i for i, (a, b) in enumerate(zip(rec, rep)) if a[:2] != b[:2]), min(len(rec), len(rep)))
    sys.exit(f"FAIL: the replayed messages differ from the recording, first at message {first}")
span_rec = (rec[-1][2] - rec[0][2]) / 1e6
span_rep = (rep[-1][2] - rep[0][2]) / 1e6
print(f"span recorded {span_rec:.3f} s, replayed {span_rep:.3f} s at speed 2")
if abs(span_rep - span_rec / 2) > 0.1:
    sys.exit("FAIL: the replay did not keep the recorded timing at speed 2")
PY

run "no log" 2 replay
run "bad speed" 2 replay "$work/run.lcm" --speed 0
has "bad speed" "$err" "--speed: '0' is not allowed; allowed: a number > 0"
run "unknown flag" 2 replay "$work/run.lcm" --rate 3
run "missing file" 1 replay "$work/none.lcm" --lcm-url "$URL"
has "missing file" "$err" "cannot open LCM log"

finish replay "$TEST_NET network"
