"""Controllers written in Python: in place of the PID inside sirupp-control (--controller
FILE.py, hosted by sirupp-python-controller-host), as a process controller in lockstep with
sirupp-sim, and their faults (exception, NaN, too slow) named with the traceback's last line."""
import os
import re
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import sirupp
from conftest import PUMA, ROOT, bin_dir

DEG = np.pi / 180
TARGET = np.array([30, -20, 40, 25, -30, 45]) * DEG
EXAMPLE = os.path.join(ROOT, "examples/07_python_controller/computed_torque_pid.py")


@pytest.fixture()
def url():
    lease = sirupp._sirupp._PortLease.acquire(20000, 10000, os.getpid())
    yield "udpm://239.255.76.67:%d?ttl=0" % lease.port
    lease.release()


def final_positions(sim_log):
    match = re.search(r"final joint positions \(rad or m\): ([-0-9.e ]+)", sim_log)
    assert match, "the sim did not finish: " + sim_log[-2000:]
    return np.array([float(v) for v in match.group(1).split()])


def run(args, **kwargs):
    return subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            **kwargs)


def test_python_controller_inside_sirupp_control(url):
    b = bin_dir()
    control = run([os.path.join(b, "sirupp-control"), "--lcm-url", url, "--controller", EXAMPLE])
    try:
        sirupp_cli = os.path.join(b, "sirupp")
        # The move is kept by sirupp-control and starts with the sim's first state.
        for _ in range(50):
            moved = subprocess.run([sirupp_cli, "move", "joints", "--lcm-url", url, "--deg"] +
                                   ["%g" % v for v in np.degrees(TARGET)],
                                   capture_output=True, text=True)
            if moved.returncode == 0:
                break
        assert moved.returncode == 0, moved.stdout + moved.stderr
        sim = subprocess.run([os.path.join(b, "sirupp-sim"), "--lcm-url", url, "--mode",
                              "lockstep", "--participants", "sirupp-control", "--duration", "3",
                              "--lockstep-timeout", "5"], capture_output=True, text=True,
                             timeout=240)
    finally:
        control.terminate()
        control_log = control.communicate(timeout=10)[0]
    assert "controller computed_torque_pid.py" in control_log, control_log
    assert " 0 lockstep timeouts" in sim.stderr, sim.stderr[-2000:]
    error = np.abs(final_positions(sim.stderr) - TARGET)
    assert np.max(error) < 0.5 * DEG, np.degrees(error)


PROCESS_CONTROLLER = textwrap.dedent("""
    import sys
    import numpy as np
    import sirupp
    target = np.radians([30, -20, 40, 25, -30, 45])

    class Controller:
        def reset(self, arm, state):
            self.start, self.integral, self.dt = state.q.copy(), np.zeros(arm.n), arm.dt
        def update(self, state):
            s = min(state.t / 1.5, 1.0)          # a smooth path to the target in 1.5 s
            blend = 10 * s**3 - 15 * s**4 + 6 * s**5
            q_ref = self.start + blend * (target - self.start)
            e = q_ref - state.q
            self.integral += e * self.dt
            a = 3 * 60 * (0 - state.qd) + 3 * 60**2 * e + 60**3 * self.integral
            return state.M @ a + state.bias

    print("ready", flush=True)
    result = sirupp.run_process_controller(Controller, lcm_url=sys.argv[1], name="python")
    print("ticks", result["ticks"], flush=True)
""")


def test_process_controller_in_lockstep(url, tmp_path):
    script = tmp_path / "process_controller.py"
    script.write_text(PROCESS_CONTROLLER)
    controller = run([sys.executable, str(script), url])
    try:
        assert controller.stdout.readline().strip() == "ready"
        sim = subprocess.run([os.path.join(bin_dir(), "sirupp-sim"), "--lcm-url", url, "--mode",
                              "lockstep", "--participants", "python", "--duration", "3",
                              "--lockstep-timeout", "5"], capture_output=True, text=True,
                             timeout=240)
        out = controller.communicate(timeout=30)[0]
    finally:
        if controller.poll() is None:
            controller.kill()
    assert controller.returncode == 0, out
    assert " 0 lockstep timeouts" in sim.stderr, sim.stderr[-2000:]
    ticks = int(re.search(r"ticks (\d+)", out).group(1))
    assert ticks >= 3 / 0.000512 - 5
    error = np.abs(final_positions(sim.stderr) - TARGET)
    assert np.max(error) < 0.5 * DEG, np.degrees(error)


FAULTY = {
    "raises": ("def update(state):\n    return 1 / 0\n",
               "ZeroDivisionError: division by zero (raises.py:2 in update)"),
    "nan": ("import numpy as np\ndef update(state):\n    return state.gravity * np.nan\n",
            "update returned nan for joint 1"),
    "slow": ("import time\ndef update(state):\n    time.sleep(2)\n    return state.gravity\n",
             "did not return from Update within 0.5 s"),
    "short": ("def update(state):\n    return [0.0, 1.0]\n",
              "update returned 2 efforts; expected 6"),
}

TINY_SUITE = """format: sirupp-grade-suite-1
name: tiny
model: {model}
limits: {{tick_s: 0.5, start_s: 30, task_s: 120}}
tasks:
  - {{name: step_j2, step: {{joint: 2, to_deg: 10}}, duration_s: 0.5}}
"""


def test_faults_end_the_graded_task_with_the_reason(tmp_path):
    suite = tmp_path / "tiny.yaml"
    suite.write_text(TINY_SUITE.format(model=PUMA))
    for name, (source, reason) in FAULTY.items():
        file = tmp_path / (name + ".py")
        file.write_text(source)
        done = subprocess.run([os.path.join(bin_dir(), "sirupp"), "grade", str(file), "--suite",
                               str(suite), "--no-baseline", "--out", str(tmp_path / ("out-" + name))],
                              capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stdout + done.stderr
        results = (tmp_path / ("out-" + name) / "results.json").read_text()
        assert reason in results, results


def test_bad_controller_file_is_refused_in_one_line(url, tmp_path):
    broken = tmp_path / "broken.py"
    broken.write_text("def update(state)\n    return state.gravity\n")
    no_update = tmp_path / "no_update.py"
    no_update.write_text("x = 1\n")
    for file, text in ((broken, "SyntaxError"), (no_update, "defines neither update(state)"),
                       (tmp_path / "missing.py", "no such controller file")):
        done = subprocess.run([os.path.join(bin_dir(), "sirupp-control"), "--lcm-url", url,
                               "--controller", str(file)], capture_output=True, text=True,
                              timeout=60)
        assert done.returncode == 2, done.stderr
        assert len(done.stderr.strip().splitlines()) == 1, done.stderr
        assert text in done.stderr and os.path.basename(str(file)) in done.stderr, done.stderr


def test_batch_grades_a_python_submission(tmp_path):
    suite = tmp_path / "tiny.yaml"
    suite.write_text(TINY_SUITE.format(model=PUMA))
    batch = tmp_path / "class"
    (batch / "alice").mkdir(parents=True)
    (batch / "alice" / "controller.py").write_text(FAULTY["short"][0])
    out = tmp_path / "out"
    done = subprocess.run([os.path.join(bin_dir(), "sirupp"), "grade", "--batch", str(batch),
                           "--suite", str(suite), "--no-baseline", "--out", str(out)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "alice" in (out / "class.csv").read_text()
    assert FAULTY["short"][1] in (out / "alice" / "results.json").read_text()
