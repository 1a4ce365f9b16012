"""The real arm by turns for students whose rigs are Slurm jobs (class file cluster: and
real_arm:), on the one-node cluster of with_cluster.sh (SLURM_CONF exported).

The bridge (sirupp-hardware on sirupp-picservo-emu's emulated boards) runs on a udpm port of this
test with ttl=0, as the class server's real_arm.lcm_url. Each student's rig is a sirupp-rig-job on
the node, its bus on a port of the node (ttl=0): the class server cannot hear it, so the turn's
relay goes through the rig job's endpoint (class/bus_relay.hpp, POST /relay with the rig's secret).

- Alice and Bob, both rigs jobs, join the queue; Alice gets the turn; the handover links the
  bridge to her rig (her panel on the node sees HARDWARE_STATUS linked, relayed to it);
- Bob's hardware command is refused (not his turn);
- Alice's move through her page runs on her virtual arm (the node's sim) and on the real
  (emulated) arm, seen on the bridge's bus by arm_watch and in her panel (REAL_ARM_STATE relayed
  back to the node);
- Alice ends her turn: the handover homes, unlinks and disarms the arm (the teacher's table: ok),
  her panel is told it is unlinked, and the relay's round trips are printed when it closes; then
  Bob's turn runs the same way through his own job, and ends; the queue is idle;
- Alice's rig job cancelled from outside (scancel) in her next turn, the real arm away from home:
  her turn ends, the handover homes and disarms the arm without her node, the queue is idle;
- the class server's stop cancels both jobs; the bridge and the boards are ended by the test,
  also when it fails.

Run: tests/cluster/with_cluster.sh /usr/bin/python3 -m pytest -q tests/cluster/class_cluster_turns_test.py
(env SIRUPP_BIN_DIR: the build's bin/).
"""
import os
import subprocess
import sys
import time

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(ROOT, "tests", "class"))
from class_cluster_test import CLUSTER_YAML, finish, jobs_of, running, wait_for  # noqa: E402
from class_run import ClassRun  # noqa: E402

BIN = os.environ.get("SIRUPP_BIN_DIR", os.path.join(ROOT, "build", "bin"))
ARM_WATCH = os.environ.get("ARM_WATCH", os.path.join(BIN, "arm_watch"))


def real_arm_deg(arm_url, seconds=1.0):
    """The real arm's newest joints in degrees, as arm_watch hears them on the bridge's bus."""
    out = subprocess.run([ARM_WATCH, "--lcm-url", arm_url, "--seconds", str(seconds)],
                         capture_output=True, text=True, timeout=30).stdout
    for line in out.splitlines():
        words = line.split()
        if words[:1] == ["real"] and "last" in words and int(words[1]) > 0:
            at = words.index("last")
            return [float(w) for w in words[at + 1:at + 7]]
    return None


@pytest.fixture(scope="module")
def lab():
    arm_port = 7400 + os.getpid() % 200  # outside the rigs' ports 7900..8099
    arm_url = "udpm://239.255.76.67:%d?ttl=0" % arm_port
    # home_tolerance_deg 2, not 1: the emulated boards' static friction held joint 1 1.1 deg
    # short of home after three correction moves once here (the handover's check itself is
    # tested in tests/test_turns.cpp; what this test is about is the relay to the node).
    run = ClassRun(BIN, ROOT, ["alice", "bob"], extra_yaml=CLUSTER_YAML + (
        'real_arm: {lcm_url: "%s", turn_s: 120, warn_before_s: [20], home_tolerance_deg: 2}\n'
        % arm_url))
    socket_path = os.path.join(run.work, "puma-bus")
    arm_log = open(os.path.join(run.work, "arm.log"), "w")
    emulator = subprocess.Popen([os.path.join(BIN, "sirupp-picservo-emu"), "--socket",
                                 socket_path, "--start-pose", "ready"],
                                stdout=arm_log, stderr=arm_log)
    bridge = None
    try:
        wait_for("the emulated boards' socket", 20, lambda: os.path.exists(socket_path))
        bridge = subprocess.Popen([os.path.join(BIN, "sirupp-hardware"), "--port", socket_path,
                                   "--emulated", "--calibrate", "--lcm-url", arm_url],
                                  cwd=ROOT, stdout=arm_log, stderr=arm_log)
        run.start()
        yield run, arm_url
    finally:
        try:
            if run.proc is not None:
                finish(run)  # the server's stop cancels the jobs; nothing of them is left
            else:
                run.clean()
        finally:
            for p in (bridge, emulator):
                if p is not None and p.poll() is None:
                    p.terminate()
                    try:
                        p.wait(timeout=10)
                    except subprocess.TimeoutExpired:
                        p.kill()
                        p.wait()
            arm_log.close()


def turns(run, name):
    code, body = run.http("GET", "/s/%s/class/turns" % name, run.token(name))
    assert code == 200, body
    return body


def teacher(run):
    code, body = run.http("GET", "/teacher/api/turns", run.token("teacher"))
    assert code == 200, body
    return body


def in_turn(run, name):
    t = turns(run, name)
    return t if t["you"]["in_turn"] else None


def panel_state(run, name):
    code, state = run.http("GET", "/s/%s/api/state" % name, run.token(name))
    return state if code == 200 else None


def move(run, name, degrees):
    code, body = run.http("POST", "/s/%s/api/lock" % name, run.token(name), {"name": name})
    assert code == 200, body
    code, body = run.http("POST", "/s/%s/api/move/joints" % name, run.token(name),
                          {"targets": degrees})
    assert code == 200, body


def turn_on_both_arms(run, arm_url, name, goal):
    """`name` holds the arm: the bridge is linked to their rig on the node, and their move runs on
    the virtual and the real arm."""
    wait_for("the bridge linked, as " + name + "'s panel on the node hears it", 30, lambda: (
        (panel_state(run, name) or {}).get("hardware", {}).get("state") == "linked"))
    started = time.time()
    move(run, name, goal)
    seen = {}

    def both_there():
        state = panel_state(run, name) or {}
        virtual = state.get("virtual", {}).get("q")
        relayed = (state.get("real") or {}).get("q")
        real = real_arm_deg(arm_url, 0.5)
        seen.update(virtual=virtual, relayed=relayed, real=real)
        if not (virtual and relayed and real):
            return None
        # Within 3 deg on the real arm, as the class's browser test: the emulated arm's static
        # friction holds a joint short of its goal under the PD law without integral.
        ok = (abs(virtual[0] - goal[0]) < 0.5 and abs(real[0] - goal[0]) < 3 and
              abs(relayed[0] - real[0]) < 3)
        return (virtual[0], real[0], relayed[0]) if ok else None

    try:
        virtual, real, relayed = wait_for(name + "'s move on both arms", 60, both_there)
    except BaseException:
        print("last seen:", seen, "teacher:", teacher(run))
        raise
    print("%s's move to joint 1 = %.0f deg: virtual %.2f, real %.2f (bridge's bus), real %.2f "
          "(%s's panel on the node), %.1f s after the move" %
          (name, goal[0], virtual, real, relayed, name, time.time() - started))


def end_turn(run, name):
    started = time.time()
    code, body = run.http("POST", "/s/%s/class/turns/done" % name, run.token(name))
    assert code == 200, body

    def handed_back():
        t = teacher(run)
        ended = [h for h in t["history"] if h["student"] == name]
        return ended[-1] if ended and ended[-1]["handover"] else None

    record = wait_for("the handover after " + name + "'s turn", 90, handed_back)
    assert record["handover"] == "ok", record
    events = " | ".join(teacher(run)["events"])
    assert ("handover after %s's turn done" % name) in events and "disarmed" in events, events
    hardware = wait_for(name + "'s panel told the bridge is unlinked", 15, lambda: (
        (panel_state(run, name) or {}).get("hardware") if "unlinked from this rig" in
        ((panel_state(run, name) or {}).get("hardware") or {}).get("last_error", "") else None))
    assert hardware["state"] != "linked", hardware
    print("handover after %s's turn: ok in %.1f s (%.1f s by the manager)" %
          (name, time.time() - started, record["handover_out_s"]))
    closed = wait_for("the relay to " + name + "'s rig closed", 15, lambda: [
        e for e in teacher(run)["events"] if e.startswith("relay to %s's rig closed" % name)])
    print(closed[-1])
    assert " 0 exchanges" not in closed[-1], closed


def test_turns_for_rigs_on_a_node(lab):
    run, arm_url = lab
    for name in ("alice", "bob"):
        code, page = run.http("GET", "/s/%s/" % name, run.token(name))
        assert code == 200, page[:200]
    for name in ("alice", "bob"):
        s = wait_for(name + "'s rig job running", 90, lambda: running(run, name))
        assert s["where"].startswith("Slurm job "), s
    assert len(jobs_of(run)) == 2, jobs_of(run)

    started = time.time()
    for name in ("alice", "bob"):
        code, body = run.http("POST", "/s/%s/class/turns/join" % name, run.token(name))
        assert code == 200, body
    try:
        wait_for("alice's turn", 120, lambda: in_turn(run, "alice"))
    except BaseException:
        print(teacher(run))
        raise
    print("alice's turn began %.1f s after joining (handover in through the relay)" %
          (time.time() - started))
    events = " | ".join(teacher(run)["events"])
    assert "alice's rig runs on" in events and "relayed through its rig job's endpoint" in events, \
        events
    assert turns(run, "bob")["you"]["place"] == 1
    code, body = run.http("POST", "/s/bob/api/hardware/arm", run.token("bob"))
    assert code == 409 and "in alice's turn" in body["error"], (code, body)

    turn_on_both_arms(run, arm_url, "alice", [20, -90, 90, 0, 45, 0])
    end_turn(run, "alice")

    wait_for("bob's turn", 120, lambda: in_turn(run, "bob"))
    turn_on_both_arms(run, arm_url, "bob", [-15, -90, 90, 0, 45, 0])
    end_turn(run, "bob")
    t = wait_for("the queue idle", 20, lambda: (lambda t: t if t["phase"] == "idle" else None)(
        teacher(run)))
    assert not t["stopped"], t
    relay_errors = [e for e in t["events"] if "did not answer" in e or "answered HTTP" in e]
    assert not relay_errors, relay_errors


def test_the_holders_job_cancelled_in_a_turn(lab):
    """scancel of the holder's rig job from outside, in her turn, with the real arm away from
    home: the turn ends, the handover homes and disarms the arm on the bridge's bus alone, and
    the queue goes on."""
    run, arm_url = lab
    wait_for("alice's rig job running", 90, lambda: running(run, "alice"))
    code, body = run.http("POST", "/s/alice/class/turns/join", run.token("alice"))
    assert code == 200, body
    wait_for("alice's second turn", 120, lambda: in_turn(run, "alice"))
    wait_for("the bridge linked to alice's rig", 30, lambda: (
        (panel_state(run, "alice") or {}).get("hardware", {}).get("state") == "linked"))
    move(run, "alice", [15, -90, 90, 0, 45, 0])
    wait_for("the real arm on its way to alice's goal", 30, lambda: (
        lambda real: real is not None and real[0] > 8)(real_arm_deg(arm_url, 0.5)))
    job = [i for i, (state, name) in jobs_of(run).items() if name == "sirupp-rig-alice"]
    assert len(job) == 1, jobs_of(run)
    started = time.time()
    subprocess.run(["scancel", job[0]], check=True, timeout=20)

    def handed_back():
        ended = [h for h in teacher(run)["history"] if h["student"] == "alice"]
        return ended[-1] if len(ended) == 2 and ended[-1]["handover"] else None

    record = wait_for("the handover after alice's cancelled turn", 90, handed_back)
    assert record["handover"] == "ok", record
    t = wait_for("the queue idle", 20, lambda: (lambda t: t if t["phase"] == "idle" else None)(
        teacher(run)))
    events = " | ".join(t["events"])
    assert "alice's rig stopped" in events, events
    print("alice's job cancelled in her turn: the handover ended ok %.1f s later (%s)" %
          (time.time() - started, record["ended"]))
    real = real_arm_deg(arm_url)
    assert real is not None and abs(real[0]) < 2, real  # home (joint 1 at 0 deg)
