"""A private rig started from Python (sirupp-sim + sirupp-control on a leased udpm port, ttl=0):
moves, set VII, recording, gains, refusals, Ctrl-C during a wait stopping the arm, and the
processes ending with Python even when it is killed."""
import json
import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

import sirupp
from conftest import ROOT

DEG = np.pi / 180


@pytest.fixture(scope="module")
def rig():
    with sirupp.start_rig(mode="lockstep") as r:
        yield r


def test_moves_to_a_target(rig):
    target = np.array([30, -20, 40, 25, -30, 45]) * DEG
    move_id = rig.move_joints(target)
    assert move_id >= 0
    assert rig.status()["state"] == "idle"
    # The PIC-SERVO PID with the paper's gains (Ki 0) sags under gravity by about a degree.
    assert np.max(np.abs(rig.q - target)) < 1.5 * DEG
    s = rig.state()
    np.testing.assert_allclose(s["q_setpoint"], target, atol=1e-4)  # the chip's whole counts


def test_runs_set_vii_and_records_it(rig):
    with rig.record() as r:
        rig.run_plan(os.path.join(ROOT, "config/plans/set7.plan"))
    assert len(r.t) > 2000  # ticks of 0.512 ms over the plan's seconds
    assert np.all(np.diff(r.tick) > 0)
    assert np.isfinite(r.q_setpoint).mean() > 0.95
    last = r.q_setpoint[np.isfinite(r.q_setpoint[:, 0])][-1]
    np.testing.assert_allclose(last[:3], 90 * DEG, atol=1e-4)
    assert np.max(np.abs(r.q[-1, :3] - 90 * DEG)) < 1.5 * DEG
    assert r.q.shape[1] == 6 and r.effort.shape == r.q.shape
    assert r.q_real.shape[0] == 0  # no bridge on this rig
    status = rig.status()
    assert status["plan_name"].endswith("set7.plan")


def test_pose_move_reaches_the_pose(rig):
    m = rig.model
    q_goal = np.array([10, -30, 60, 0, 40, 0]) * DEG
    T = m.fkine(q_goal)
    rig.move_pose(T, config="*-*-noflip")
    assert np.max(np.abs(m.fkine(rig.q)[:3, 3] - T[:3, 3])) < 0.01  # metres, PID sag included


def test_gains_read_and_set(rig):
    before = rig.gains()
    assert set(before) >= {"kp", "kd", "ki"} and before["kp"].shape == (6,)
    kp = before["kp"].copy()
    kp[0] += 10
    rig.set_gains(kp=kp)
    rig.wait(0.2)
    np.testing.assert_allclose(rig.gains()["kp"], kp)
    rig.set_gains(kp=before["kp"])
    with pytest.raises(ValueError, match="gains: 'kq'"):
        rig.set_gains(kq=kp)
    with pytest.raises(ValueError, match="kp: 2 values; expected 6"):
        rig.set_gains(kp=[1, 2])


def test_refusals_name_the_problem(rig):
    with pytest.raises(ValueError, match="q: shape"):
        rig.move_joints([0, 0, 0])
    with pytest.raises(ValueError, match=r"q\[1\]: nan"):
        rig.move_joints([0, float("nan"), 0, 0, 0, 0])
    with pytest.raises(sirupp.RigError, match="refused") as error:
        rig.move_joints([10, 0, 0, 0, 0, 0])  # 10 rad: far beyond joint 1's limits
    assert "limit" in str(error.value)
    with pytest.raises(sirupp.RigError, match="python.plan:2") as error:
        rig.run_plan("units deg\nmove j9=10\n")
    with pytest.raises(ValueError, match="T: shape"):
        rig.move_pose(np.eye(3))
    with pytest.raises(ValueError, match="config"):
        rig.move_pose(np.eye(4), config="up")
    assert rig.status()["state"] == "idle"


CHILD = textwrap.dedent("""
    import json, sys, time
    import numpy as np
    import sirupp
    rig = sirupp.start_rig(mode="realtime")
    print(json.dumps({"pids": [c.pid for c in rig._processes]}), flush=True)
    if sys.argv[1] == "interrupt":
        try:
            rig.move_joints(np.radians([120, 0, 0, 0, 0, 0]), qd_max=[0.3, 0, 0, 0, 0, 0])
            print(json.dumps({"error": "the move ended without an interrupt"}), flush=True)
        except KeyboardInterrupt:
            q_stop = rig.q
            rig.wait(1.0)
            print(json.dumps({"state": rig.status()["state"], "q_stop": q_stop.tolist(),
                              "q_later": rig.q.tolist()}), flush=True)
        rig.close()
    else:
        time.sleep(60)
""")


def start_child(mode):
    child = subprocess.Popen([sys.executable, "-c", CHILD, mode], stdout=subprocess.PIPE,
                             text=True, env=dict(os.environ))
    first = json.loads(child.stdout.readline())
    return child, first["pids"]


def alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    with open("/proc/%d/stat" % pid) as f:
        return f.read().split(")")[-1].split()[0] != "Z"


def assert_gone(pids, why):
    for pid in pids:
        deadline = time.time() + 5
        while alive(pid) and time.time() < deadline:
            time.sleep(0.05)
        assert not alive(pid), "process %d outlived %s" % (pid, why)


def test_ctrl_c_during_a_wait_stops_the_arm():
    child, pids = start_child("interrupt")
    try:
        time.sleep(1.5)  # the move (0.3 rad/s to 120 deg) is under way
        child.send_signal(signal.SIGINT)
        out, _ = child.communicate(timeout=30)
    finally:
        if child.poll() is None:
            child.kill()
    result = json.loads(out.strip().splitlines()[-1])
    assert "error" not in result, result
    assert result["state"] == "idle"  # stopped, not moving on to 120 deg
    q_stop, q_later = np.array(result["q_stop"]), np.array(result["q_later"])
    assert 0.1 < q_stop[0] < 100 * DEG
    # A smooth stop: joint 1 comes to rest within a few degrees of where it was interrupted.
    assert abs(q_later[0] - q_stop[0]) < 5 * DEG
    assert_gone(pids, "rig.close()")


def test_rig_processes_end_when_python_is_killed():
    child, pids = start_child("sleep")
    assert all(alive(pid) for pid in pids)
    child.kill()  # SIGKILL: no atexit, no finally
    child.wait()
    assert_gone(pids, "its Python")


def test_connect_without_a_rig_names_the_problem():
    lease = sirupp._sirupp._PortLease.acquire(20000, 10000, os.getpid())
    try:
        with pytest.raises(sirupp.RigError, match="no CONTROLLER_STATUS"):
            sirupp.connect("udpm://239.255.76.67:%d?ttl=0" % lease.port, timeout=0.3)
    finally:
        lease.release()
