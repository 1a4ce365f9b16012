"""Example 7 (examples/07_python_controller): the computed-torque + PID law written in Python,
run by sirupp-control in place of its PID, tracks the paper's set VII within 0.5 deg when graded
by `sirupp grade`, and two gradings give identical results.json."""
import json
import os
import subprocess

from conftest import ROOT, bin_dir

EXAMPLE = os.path.join(ROOT, "examples/07_python_controller/computed_torque_pid.py")


def test_example_07_tracks_set_vii_and_grades_deterministically(tmp_path):
    suite = os.path.join(ROOT, "examples/07_python_controller/set7.yaml")
    runs = []
    for k in range(2):
        out = tmp_path / ("grade-%d" % k)
        done = subprocess.run([os.path.join(bin_dir(), "sirupp"), "grade", EXAMPLE, "--suite",
                               suite, "--no-baseline", "--out", str(out)],
                              capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, done.stdout + done.stderr
        runs.append((out / "results.json").read_text())
    assert runs[0] == runs[1]
    results = json.loads(runs[0])
    assert results["passed"] == 1, runs[0]
