#!/usr/bin/python3
"""A notebook server's life (docs/notebooks.md "Culling", "Restarts"): the hub with short
timeouts (notebooks.idle_timeout_s 10, --poll-interval 2) beside a class server, in a temporary
folder, everything stopped at the end, also after a failure.

(e) the hub restarted while alice's server runs: the supervisor is not the hub's child, the new
    hub finds the same server again (same pid, same start time) from its database and the
    spawner's state, and proxies to it;
(d) then left alone: the idle kernel is culled by the server, the server shuts itself down, the
    hub notices (poll) and forgets it (no server, no route), and no process of it is left.

Usage: hub_lifecycle_test.py BIN_DIR SOURCE_DIR"""

import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from hub_run import HubRun, Session  # noqa: E402
from class_run import alive  # noqa: E402


def check(condition, what):
    if not condition:
        raise AssertionError(what)
    print("ok:", what[:160])


def main(bin_dir, source_dir):
    hub = HubRun(bin_dir, source_dir, ["alice"], idle_timeout_s=10, poll_interval_s=2)
    ok = False
    try:
        hub.start()
        alice = hub.front("alice")
        hub.sign_in(alice)
        first = hub.wait_server(alice, "alice")
        token = hub.user_token(alice, "alice")
        supervisors = hub.supervisors()
        check(len(supervisors) == 1, f"one supervisor for alice's server: {supervisors}")
        status, kernel = Session(hub).api("POST", "/user/alice/api/kernels", {"name": "python3"},
                                          token=token)
        check(status in (200, 201), f"a kernel started: {status}")

        # (e) the hub restarted with the server running -----------------------------------------
        hub.stop_hub(keep_servers=True)
        check(all(alive(p) for p in supervisors), "alice's server outlives the hub's stop")
        hub.start_hub()
        status, model = Session(hub).api("GET", "/hub/api/users/alice", token=token)
        check(status == 200 and model.get("server"),
              f"the restarted hub knows alice's server: {status} {model.get('server')}")
        status, again = Session(hub).api("GET", "/user/alice/api/status", token=token)
        check(status == 200 and again["started"] == first["started"],
              f"the same server answers through the new hub's proxy: started {again.get('started')}")
        check(hub.supervisors() == supervisors, f"the same supervisor: {hub.supervisors()}")

        # (d) idle: kernel culled, server shut down, the hub forgets it ---------------------------
        t0 = time.time()
        culled = None
        while time.time() - t0 < 40:
            status, body = Session(hub).api("GET", "/user/alice/api/status", token=token)
            if status == 200 and body.get("kernels") == 0:
                culled = time.time() - t0
                break
            time.sleep(1)
        check(culled is not None, f"the idle kernel was culled ({culled} s after the restart)")
        gone = None
        while time.time() - t0 < 120:
            status, model = Session(hub).api("GET", "/hub/api/users/alice", token=token)
            if status == 200 and not model.get("server") and not hub.supervisors():
                gone = time.time() - t0
                break
            time.sleep(1)
        check(gone is not None, f"the idle server shut itself down and the hub forgot it "
                                f"({gone} s after the restart)")
        status, _ = Session(hub).api("GET", "/user/alice/api/status", token=token)
        check(status != 200, f"no route to alice's server any more: {status}")
        # What may run: the class server and its rig for alice (the class's own idle timeout),
        # the hub and its proxy.
        rig = set(hub.cls.rig_pids())
        left = [p for p in hub.ours() if p[0] not in rig and "sirupp class" not in p[1] and
                "jupyterhub" not in p[1] and "configurable-http-proxy" not in p[1]]
        check(not left, f"nothing of alice's notebook server is left: {left}")
        ok = True
    finally:
        if not ok:
            print(hub.hub_log()[-8000:])
            print("alice's server:\n" + hub.server_log("alice")[-4000:])
        left = hub.stop()
        if left:
            print("left running (killed):", left)
            ok = False
        else:
            print("ok: nothing of the test is left running")
        if ok:
            hub.clean()
    print("ok" if ok else "FAIL")
    return 0 if ok else 1


if __name__ == "__main__":
    if not os.access("/usr/bin/jupyterhub", os.X_OK):
        print("skipped: /usr/bin/jupyterhub is not installed (scripts/install-deps.sh --services)")
        sys.exit(77)
    sys.exit(main(sys.argv[1], sys.argv[2]))
