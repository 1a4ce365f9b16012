#!/usr/bin/python3
"""The notebooks hub end to end (docs/notebooks.md): a class of alice and bob with a front, the
class server and `sirupp class notebooks` (JupyterHub + its proxy on 127.0.0.1, free ports, a
temporary folder), all stopped at the end, also after a failure.

(a) sign-in: alice by the front's header and secret gets her server; bob by his class token (the
    Notebooks link of his page); mallory, not on the roster, gets 403 naming her; a wrong front
    secret gets 403; bob's cookies get 403 on alice's /api/contents and /api/kernels;
(b) a kernel of alice's started through the hub's REST and WebSocket API runs sirupp.connect() and
    a move; the class server's API for alice's rig shows the arm at the goal, bob's rig did not
    move; after the teacher restarts alice's rig the kernel moves the new one; a private rig
    (sirupp.start_rig()) works inside the sandbox;
(c) sandbox probes from inside a kernel: uid 1000, no capabilities, only `lo`, no route out, the
    hub's ports refused, no other student's folder, no route change, a nested sandbox works, and
    the course's notebook 07 (a controller in the project's own sandbox) runs.

Usage: hub_test.py BIN_DIR SOURCE_DIR"""

import html
import json
import math
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from hub_run import HubRun, Session, run_code  # noqa: E402

GOAL = [0.4, -0.3, 0.5, 0.2, -0.2, 0.3]
GOAL2 = [-0.3, 0.2, 0.3, -0.2, 0.3, -0.4]

MOVE = """
import sirupp
rig = sirupp.connect()
goal = %r[:rig.model.n]
rig.move_joints(goal, timeout=40)
print("q", [round(x, 3) for x in rig.q])
""" % (GOAL,)

PRIVATE = """
import sirupp
print("starting a private rig", flush=True)
with sirupp.start_rig() as mine:
    print("started", mine.lcm_url, flush=True)
    mine.move_joints([0.1] * mine.model.n, timeout=40)
    print("private", mine.lcm_url, [round(x, 2) for x in mine.q])
"""

PROBES = """
import json, os, socket, subprocess
r = {"uid": os.getuid(), "home": sorted(os.listdir("/home"))}
r["capeff"] = [l.split()[1] for l in open("/proc/self/status") if l.startswith("CapEff")][0]
r["interfaces"] = sorted(n for _, n in socket.if_nameindex())
def connect(host, port):
    try:
        socket.create_connection((host, port), timeout=2).close()
        return "connected"
    except OSError as e:
        return type(e).__name__ + ": " + str(e)
r["out"] = connect("1.1.1.1", 80)
r["hub_proxy"] = connect("127.0.0.1", %d)
r["class_server"] = connect("127.0.0.1", %d)
r["data_dir"] = os.path.exists(%r)
r["bob_folder"] = os.path.exists(%r)
p = subprocess.run(["ip", "route", "add", "10.0.0.0/8", "dev", "lo"], capture_output=True, text=True)
r["route_add"] = [p.returncode, p.stderr.strip()]
p = subprocess.run(["bwrap", "--unshare-all", "--ro-bind", "/usr", "/usr", "--proc", "/proc",
                    "--dev", "/dev", "--symlink", "usr/lib", "/lib", "--symlink", "usr/lib64",
                    "/lib64", "--symlink", "usr/bin", "/bin", "/usr/bin/true"],
                   capture_output=True, text=True)
r["nested"] = [p.returncode, p.stderr.strip()]
print("PROBES " + json.dumps(r))
"""


COURSE_07 = """
import subprocess
p = subprocess.run(["jupyter", "nbconvert", "--to", "notebook", "--execute", "--output-dir",
                    "/tmp/out", "--ExecutePreprocessor.timeout=120",
                    "/home/student/notebooks/07_your_controller.ipynb"], capture_output=True, text=True)
print("07", p.returncode, p.stderr[-600:] if p.returncode else "")
"""


def check(condition, what):
    if not condition:
        raise AssertionError(what)
    print("ok:", what.split("\n")[0][:150])


def main(bin_dir, source_dir):
    hub = HubRun(bin_dir, source_dir, ["alice", "bob"], poll_interval_s=2)
    ok = False
    try:
        hub.start()
        # (a) sign-in --------------------------------------------------------------------------
        alice = hub.front("alice")
        t0 = time.time()
        hub.sign_in(alice)
        hub.wait_server(alice, "alice")
        print(f"alice: server up {time.time() - t0:.1f} s after sign-in (front)")
        status, link = hub.cls.http("GET", "/s/bob/class/status", hub.cls.token("bob"))
        check(status == 200 and link.get("notebooks_url", "").startswith(hub.hub_base +
                                                                        "/hub/login?student=bob&token="),
              f"bob's page links to Notebooks with his token: {link.get('notebooks_url')}")
        bob = Session(hub)
        status, url, body = bob.get(link["notebooks_url"][len(hub.hub_base):])
        check(status == 200 and "token=" not in url,
              f"bob signs in with his class token (no token in the address after): {status} {url}")
        hub.wait_server(bob, "bob")
        mallory = hub.front("mallory")
        status, _, body = hub.sign_in(mallory)
        body = html.unescape(body)
        check(status == 403 and "signed in as 'mallory'" in body and "not on the roster" in body,
              f"mallory (not on the roster) gets 403 naming her: {status}")
        forged = Session(hub, {"X-Remote-User": "alice", "X-Sirupp-Front-Secret": "wrong" * 8})
        status, _, body = hub.sign_in(forged)
        check(status == 403, f"a wrong front secret gets 403: {status}")
        status, _, body = Session(hub).get("/hub/login?student=alice&token=" + "0" * 48)
        body = html.unescape(body)
        check(status == 403 and "does not open alice" in body, f"a wrong token gets 403: {status}")
        for path in ("/user/alice/api/contents", "/user/alice/api/kernels"):
            status, _ = bob.api("GET", path)
            check(status == 403, f"bob's cookies on {path}: {status}")
            status, _ = Session(hub).api("GET", path)
            check(status == 403, f"no cookie on {path}: {status}")

        # (b) alice's own rig from her kernel ---------------------------------------------------
        token = hub.user_token(alice, "alice")
        status, before_bob = hub.cls.http("GET", "/s/bob/api/state", hub.cls.token("bob"))
        check(status == 200, f"bob's rig state: {status}")
        reply, out, error = run_code(hub, "alice", token, MOVE)
        check(reply == "ok", f"sirupp.connect() and a move in alice's kernel: {reply} {out} {error}")
        kernel_q = json.loads(out.split("q ", 1)[1])
        status, state = hub.cls.http("GET", "/s/alice/api/state", hub.cls.token("alice"))
        check(status == 200 and "virtual" in state and "setpoint" in state,
              f"alice's rig state from the class server: {status}")
        goal_deg = [math.degrees(x) for x in GOAL]
        off_goal = max(abs(a - b) for a, b in zip(state["setpoint"]["goal"], goal_deg))
        check(off_goal < 0.01, f"the class server's panel shows alice's goal: "
                               f"{state['setpoint']['goal']} (deg)")
        off_arm = max(abs(a - math.degrees(b)) for a, b in zip(state["virtual"]["q"], kernel_q))
        far = max(abs(a - b) for a, b in zip(state["virtual"]["q"], goal_deg))
        check(off_arm < 0.5 and far < 2.0,
              f"the panel's arm is where the kernel saw it, at the goal: {state['virtual']['q']} "
              f"(deg; {off_arm:.2f} from the kernel's, {far:.2f} from the goal)")
        status, after_bob = hub.cls.http("GET", "/s/bob/api/state", hub.cls.token("bob"))
        moved = min(abs(a - b) for a, b in zip(after_bob["virtual"]["q"], goal_deg))
        check(moved > 5 and after_bob["virtual"]["q"] == before_bob["virtual"]["q"],
              f"bob's rig did not move: {after_bob['virtual']['q']}")
        # The teacher restarts alice's rig (its bus may change): the notebook follows it.
        status, _ = hub.cls.http("POST", "/teacher/api/rigs/alice/restart", hub.cls.token("teacher"))
        check(status == 200, f"the teacher restarted alice's rig: {status}")
        time.sleep(5)  # the spawner's next polls (every 2 s here) see where the rig is now
        reply, out, error = run_code(hub, "alice", token, MOVE.replace("goal = %r" % (GOAL,),
                                                                       "goal = %r" % (GOAL2,)))
        check(reply == "ok", f"after the restart, the kernel moves the new rig: {reply} {out} "
                             f"{error[-500:]}")
        status, state = hub.cls.http("GET", "/s/alice/api/state", hub.cls.token("alice"))
        far = max(abs(a - math.degrees(b)) for a, b in zip(state["virtual"]["q"], GOAL2))
        check(far < 2.0, f"the class server shows alice's restarted rig at the new goal: {far:.2f}")
        moved = [line for line in hub.server_log("alice").splitlines() if "bus is now" in line]
        print("the rig's bus after the restart:", moved[-1] if moved else "the same port again")
        reply, out, error = run_code(hub, "alice", token, PRIVATE)
        check(reply == "ok" and "private udpm" in out,
              f"a private rig inside the sandbox: {reply} {out.strip()} {error[-800:]}")

        # (c) sandbox probes -------------------------------------------------------------------
        probes = PROBES % (hub.hub_port, int(hub.cls.base.rsplit(":", 1)[1]), hub.data(),
                           hub.data("students", "bob"))
        reply, out, error = run_code(hub, "alice", token, probes)
        check(reply == "ok" and "PROBES " in out, f"the probes ran: {reply} {error[-500:]}")
        r = json.loads(out.split("PROBES ", 1)[1])
        print("probes:", r)
        check(r["uid"] == 1000, f"uid inside is 1000: {r['uid']}")
        check(int(r["capeff"], 16) == 0, f"no capabilities: CapEff {r['capeff']}")
        check(r["interfaces"] == ["lo"], f"only lo: {r['interfaces']}")
        check("unreachable" in r["out"], f"no route out: {r['out']}")
        check("refused" in r["hub_proxy"] and "refused" in r["class_server"],
              f"the hub's proxy and the class server are not reachable: {r['hub_proxy']}, "
              f"{r['class_server']}")
        check(not r["data_dir"] and not r["bob_folder"] and r["home"] == ["student"],
              f"no other student's folder: /home {r['home']}, data {r['data_dir']}")
        check(r["route_add"][0] != 0, f"the route cannot be changed: {r['route_add']}")
        check(r["nested"][0] == 0, f"a nested sandbox (bwrap --unshare-all, its own /proc) works "
                                   f"inside: {r['nested']}")
        # The course's notebook 07 runs a controller in the project's own sandbox, inside this one.
        reply, out, error = run_code(hub, "alice", token, COURSE_07, timeout=150)
        check(reply == "ok" and "07 0" in out,
              f"notebook 07 (the project's sandbox nested) runs in alice's sandbox: {out[-600:]} "
              f"{error[-300:]}")
        ok = True
    finally:
        if not ok:
            print("\n".join(line for line in hub.hub_log().splitlines()
                            if "spawner" in line or "Traceback" in line or "Error" in line)[-6000:])
            print(hub.hub_log()[-3000:])
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
