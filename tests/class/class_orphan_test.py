#!/usr/bin/python3
"""No rig process outlives the class server, even when it is killed with SIGKILL: starts
`sirupp class serve` with two students, opens both pages (which start their rigs: sirupp-sim,
sirupp-control, sirupp-logger each), kills the server with SIGKILL and checks that none of the six
rig processes is left 5 s later. Usage: class_orphan_test.py BIN_DIR SOURCE_DIR."""

import os
import signal
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from class_run import ClassRun, alive  # noqa: E402

run = ClassRun(sys.argv[1], sys.argv[2], ["alice", "bob"]).start()
ok = False
pids = []
try:
    for name in ("alice", "bob"):
        status, body = run.http("GET", f"/s/{name}/", run.token(name))
        assert status == 200, f"{name}'s page: {status} {body!r:.300}"
    pids = run.rig_pids()
    names = sorted(open(f"/proc/{p}/comm").read().strip() for p in pids)
    print(f"rig processes before: {len(pids)} {names}")
    assert len(pids) == 6, f"expected 3 processes per rig, found {names}"
    run.proc.send_signal(signal.SIGKILL)
    run.proc.wait()
    t0 = time.time()
    while time.time() - t0 < 5 and any(alive(p) for p in pids):
        time.sleep(0.05)
    left = [p for p in pids if alive(p)]
    print(f"rig processes left {time.time() - t0:.2f} s after kill -9 of the server: {len(left)}")
    assert not left, f"left behind: {left}"
    ok = True
finally:
    for p in pids:  # whatever happened, nothing of ours stays
        if alive(p):
            os.kill(p, signal.SIGKILL)
    run.stop()
    if ok:
        run.clean()
    else:
        print("server log:\n" + run.server_log())
print("ok" if ok else "FAIL")
sys.exit(0 if ok else 1)
