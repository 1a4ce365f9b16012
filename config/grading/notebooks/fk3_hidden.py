# The teacher's hidden tests of the fk3 assignment (notebooks/assignments/fk3_forward_kinematics.ipynb).
# Never copied to students: `sirupp grade notebook` and the class server pass this text to the
# grader on its standard input, after the student's notebook has run in the same kernel. Each
# test_* function is one test, `@points(N)` its worth; a test passes when it returns. Students see
# each test's name, points, pass/fail and the message of a failing assert, never this file.
#
# The reference is sirupp.Model: the DH table written as a model file (standard DH, no base, no
# tool), so that model.fkine(q) is frame 0 to frame 3, what fk(dh, q) must return.
import os
import tempfile

import numpy as np
import sirupp

# The table the notebook shows (a, alpha, d, theta offset; m, rad).
VISIBLE_DH = np.array([[0.0, np.pi / 2, 0.30, 0.0],
                       [0.25, 0.0, 0.0, 0.0],
                       [0.20, 0.0, 0.0, 0.0]])
# A table the student never sees: offsets on theta, twists other than 0 and 90 deg, offsets on d.
HIDDEN_DH = np.array([[0.05, -np.pi / 2, 0.42, 0.3],
                      [0.31, 0.2, -0.04, -np.pi / 2],
                      [0.07, np.pi / 2, 0.11, 1.1]])


def reference_model(dh):
    """sirupp.Model of a 3-joint standard-DH arm with this table (no base, no tool)."""
    rows = "\n".join("  - {a: %r, alpha: %r, d: %r, theta: %r}" % tuple(float(v) for v in row)
                     for row in dh)
    joint = ("  - name: j%d\n    limits: [-6.28, 6.28]\n    max_velocity: 2\n    max_effort: 10\n"
             "    friction: {static: 0.1, coulomb: 0.05, viscous: 0.01}\n"
             "    servo: {encoder_counts_per_rev: 2000, gear_ratio: 50, motor_torque_max_nm: 0.3,\n"
             "            default_velocity: 1, default_acceleration: 2, kp: 100, kd: 1000, ki: 0}\n")
    link = "  - name: l%d\n    mass_kg: 1.0\n    shapes: [{type: sphere, radius: 0.02}]\n"
    text = ("format: sirupp-robot-1\nname: fk3_reference\nunits: {length: m, angle: rad}\n"
            "dh_convention: standard\ndh:\n" + rows + "\njoints:\n" +
            "".join(joint % i for i in range(1, 4)) + "links:\n" +
            "  - name: base\n    shapes: [{type: sphere, radius: 0.02}]\n" +
            "".join(link % i for i in range(1, 4)))
    folder = tempfile.mkdtemp(prefix="fk3-")
    path = os.path.join(folder, "fk3.yaml")
    with open(path, "w") as out:
        out.write(text)
    return sirupp.Model(path)


def check_against_model(dh, count, seed):
    model = reference_model(dh)
    rng = np.random.default_rng(seed)
    for _ in range(count):
        q = rng.uniform(-np.pi, np.pi, 3)
        got = np.asarray(fk(dh.copy(), q.copy()), dtype=float)  # noqa: F821 (the student's)
        want = np.asarray(model.fkine(q))
        assert got.shape == (4, 4), "fk returned shape %s, not (4, 4)" % (got.shape,)
        error = np.abs(got - want).max()
        assert error < 1e-9, ("fk differs from sirupp.Model by %.3g at q = %s (rad)"
                              % (error, np.array2string(q, precision=3)))


@points(1)
def test_returns_a_homogeneous_transform():
    T = np.asarray(fk(VISIBLE_DH.copy(), np.array([0.1, -0.2, 0.3])), dtype=float)  # noqa: F821
    assert T.shape == (4, 4), "fk must return a 4x4 array, got shape %s" % (T.shape,)
    assert np.allclose(T[3], [0, 0, 0, 1]), "the last row must be [0, 0, 0, 1]"
    R = T[:3, :3]
    assert np.allclose(R @ R.T, np.eye(3), atol=1e-9), "the rotation part is not orthonormal"


@points(2)
def test_random_joints_on_the_notebooks_table():
    check_against_model(VISIBLE_DH, 25, 50)


@points(3)
def test_a_table_you_have_not_seen():
    check_against_model(HIDDEN_DH, 25, 51)
