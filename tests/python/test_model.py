"""sirupp.Model against the C++ libraries (python_model_oracle and `sirupp fk --json`), IK
solutions reaching their pose, jtraj, and bad input raising clear exceptions."""
import json
import math
import os
import subprocess

import numpy as np
import pytest

import sirupp
from conftest import PUMA, ROOT, bin_dir

RNG = np.random.default_rng(31)


def oracle(model_file, q, qd, qdd):
    exe = os.environ.get("SIRUPP_ORACLE")
    if not exe:
        pytest.fail("SIRUPP_ORACLE not set: run these tests through ctest")
    args = [exe, model_file] + ["%.17g" % v for v in np.concatenate([q, qd, qdd])]
    out = subprocess.run(args, check=True, capture_output=True, text=True).stdout
    result = {"ik": {}}
    for line in out.splitlines():
        words = line.split()
        if words[0] == "ik":
            result["ik"][words[1]] = np.array([float(v) for v in words[2:]])
        else:
            result[words[0]] = np.array([float(v) for v in words[1:]])
    return result


def random_state(m):
    lo, hi = m.qlim
    lo, hi = np.maximum(lo, -math.pi), np.minimum(hi, math.pi)
    return (RNG.uniform(lo, hi), RNG.uniform(-1, 1, m.n), RNG.uniform(-2, 2, m.n))


@pytest.mark.parametrize("robot", ["puma260", "stanford", "planar3"])
def test_equals_the_cpp_libraries(robot):
    model_file = os.path.join(ROOT, "config/robots/%s.yaml" % robot)
    m = sirupp.Model(model_file)
    for _ in range(5):
        q, qd, qdd = random_state(m)
        c = oracle(model_file, q, qd, qdd)
        np.testing.assert_allclose(m.fkine(q).ravel(), c["fkine"], rtol=0, atol=1e-12)
        np.testing.assert_allclose(m.jacob0(q).ravel(), c["jacob0"], rtol=0, atol=1e-12)
        np.testing.assert_allclose(m.gravload(q), c["gravload"], rtol=0, atol=1e-12)
        np.testing.assert_allclose(m.inertia(q).ravel(), c["inertia"], rtol=0, atol=1e-12)
        np.testing.assert_allclose(m.bias(q, qd), c["bias"], rtol=0, atol=1e-12)
        np.testing.assert_allclose(m.coriolis(q, qd), c["bias"] - c["gravload"], rtol=0, atol=1e-12)
        np.testing.assert_allclose(m.rne(q, qd, qdd), c["rne"], rtol=0, atol=1e-12)
        if c["ik"]:
            mine = {s["config"]: s["q"] for s in m.ikine(m.fkine(q))}
            assert set(mine) == set(c["ik"])
            for name, qq in c["ik"].items():
                np.testing.assert_allclose(mine[name], qq, rtol=0, atol=1e-12)


def test_fkine_equals_sirupp_fk_json(puma):
    q = np.array([0.3, -0.7, 1.1, 0.2, 0.9, -0.4])
    out = subprocess.run([os.path.join(bin_dir(), "sirupp"), "fk", "--model", PUMA, "--rad"] +
                         ["%.17g" % v for v in q] + ["--json"],
                         check=True, capture_output=True, text=True).stdout
    answer = json.loads(out)
    T = puma.fkine(q)
    np.testing.assert_allclose(T[:3, 3], answer["position_m"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(T[:3, :3], answer["rotation"], rtol=0, atol=1e-12)


def test_every_ik_solution_reaches_its_pose(puma):
    for _ in range(20):
        q, _, _ = random_state(puma)
        T = puma.fkine(q)
        solutions = puma.ikine(T)
        assert 1 <= len(solutions) <= 8
        configs = [s["config"] for s in solutions]
        assert len(set(configs)) == len(configs)
        for s in solutions:
            assert s["config"].count("-") == 2
            np.testing.assert_allclose(puma.fkine(s["q"]), T, rtol=0, atol=1e-9)
        # The numeric solver from a nearby start reaches the pose too.
        numeric = puma.ikine(T, q0=q + 0.05)
        np.testing.assert_allclose(puma.fkine(numeric[0]["q"]), T, rtol=0, atol=1e-8)
        assert numeric[0]["config"] is None


def test_ikine_eight_configurations_and_filter(puma):
    T = puma.fkine(puma.pose("ready") if "ready" in puma.poses else puma.home)
    T = puma.fkine(np.array([0.2, -0.6, 0.9, 0.3, 0.7, 0.1]))
    everything = puma.ikine(T)
    names = {s["config"] for s in everything}
    assert len(names) == 8
    one = puma.ikine(T, config="left-up-noflip")
    assert [s["config"] for s in one] == ["left-up-noflip"]
    assert one[0]["shoulder_left"] and one[0]["elbow_up"] and not one[0]["wrist_flip"]


def test_model_tables(puma):
    assert puma.n == 6 and puma.name == "puma260"
    assert puma.dh.shape == (6, 4)
    assert puma.qlim.shape == (2, 6) and np.all(puma.qlim[0] < puma.qlim[1])
    assert puma.fkine_all(np.zeros(6)).shape == (7, 4, 4)
    assert puma.jacob0(np.zeros(6)).shape == (6, 6)
    assert len(puma.poses) >= 1
    for name, q in puma.poses.items():
        np.testing.assert_array_equal(puma.pose(name), q)
    M = puma.inertia(np.zeros(6))
    np.testing.assert_allclose(M, M.T, atol=1e-15)
    assert np.all(np.linalg.eigvalsh(M) > 0)
    assert "wrist" in puma.singularities(np.zeros(6))


def test_jtraj():
    tr = sirupp.jtraj([0, 0], [1, -2], 51)
    assert tr.q.shape == (51, 2)
    np.testing.assert_allclose(tr.q[0], [0, 0])
    np.testing.assert_allclose(tr.q[-1], [1, -2])
    np.testing.assert_allclose(tr.qd[[0, -1]], 0, atol=1e-12)
    np.testing.assert_allclose(tr.qdd[[0, -1]], 0, atol=1e-12)
    # The velocity is the derivative of the position.
    np.testing.assert_allclose(np.gradient(tr.q[:, 0], tr.t), tr.qd[:, 0], atol=2e-3)
    tp = sirupp.trapezoid([0], [1], 1.0, 2.0, dt=0.001)
    np.testing.assert_allclose(tp.q[-1], [1])
    assert tp.qd.max() <= 1.0 + 1e-12


@pytest.mark.parametrize("call, text", [
    (lambda m: m.fkine([0, 0, 0]), "q: 3 values; expected 6 (puma260 has 6 joints)"),
    (lambda m: m.fkine([0, 0, float("nan"), 0, 0, 0]), "q[2]: nan is not a finite number"),
    (lambda m: m.fkine(np.zeros((2, 6))), "q: an array of 2 dimensions"),
    (lambda m: m.fkine("abc"), "q: a string; expected numbers"),
    (lambda m: m.fkine(None), "q: None; expected numbers"),
    (lambda m: m.jacob0([0, 0, 0, 0, 0, float("inf")]), "q[5]: inf is not a finite number"),
    (lambda m: m.rne(np.zeros(6), np.zeros(5), np.zeros(6)), "qd: 5 values"),
    (lambda m: m.ikine(np.eye(3)), "T: shape 3x3; expected a 4x4 homogeneous transform"),
    (lambda m: m.ikine(2 * np.eye(4)), "T: last row 0 0 0 2; expected 0 0 0 1"),
    (lambda m: m.ikine(np.diag([1, 2, 1, 1.0])), "T: the rotation part is not a rotation"),
    (lambda m: m.ikine(np.eye(4), config="left-sideways-flip"), "config: 'left-sideways-flip'"),
    (lambda m: m.pose("nowhere"), "pose 'nowhere': puma260 has no such named pose"),
])
def test_bad_input_raises_value_error(puma, call, text):
    with pytest.raises(ValueError) as error:
        call(puma)
    assert text in str(error.value)


def test_unreachable_pose_raises_ik_error(puma):
    T = np.eye(4)
    T[:3, 3] = [5.0, 0, 0]
    with pytest.raises(sirupp.IKError) as error:
        puma.ikine(T)
    assert "reach" in str(error.value) or "workspace" in str(error.value)


def test_bad_model_file_raises_with_the_cli_text(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("format: sirupp-robot-1\nname: x\nbogus_key: 1\n")
    with pytest.raises(sirupp.ModelError) as error:
        sirupp.Model(str(bad))
    cli = subprocess.run([os.path.join(bin_dir(), "sirupp"), "model", "check", str(bad)],
                         capture_output=True, text=True)
    assert cli.returncode == 2
    assert str(error.value) in cli.stdout + cli.stderr
    assert str(bad) in str(error.value)
    with pytest.raises(sirupp.ModelError) as missing:
        sirupp.Model(str(tmp_path / "missing.yaml"))
    assert "missing.yaml" in str(missing.value)


def test_data_file_problems_name_the_line():
    bad = os.path.join(ROOT, "tests/data/bad_logs/08_wrong_field_count.csv")
    with pytest.raises(ValueError, match="08_wrong_field_count.csv:6: 10 fields; the column line has 13"):
        sirupp.read_data(bad)
    with pytest.raises(ValueError, match="no report_errors.csv"):
        sirupp.read_report(ROOT)
