"""sirupp.Scene (python/bind_planning.cpp over planning/): collision queries naming the link, the
object and the depth; edge checks; OMPL plans that are free at a finer resolution than they were
planned at, reproducible by seed; C-space slices; bad input as one ValueError naming the argument;
and a planned path run on a private rig in the sim with table.xml loaded, every recorded joint
state free."""
import os

import numpy as np
import pytest

import sirupp
from conftest import PUMA, ROOT

DEG = np.pi / 180
TABLE = os.path.join(ROOT, "config/environments/table.xml")
# The tool 4 cm over the table at y = +0.2 and -0.2 m; the straight way touches the table (as in
# tests/cli/planning_commands.sh).
START = np.array([54.1, 43.3, 39.6, 0, 97.1, 54.1]) * DEG
GOAL = np.array([-9.9, 43.3, 39.6, 0, 97.1, -9.9]) * DEG
# The wrist pushed into the table top (ready pose, shoulder and elbow lowered).
THROUGH_TABLE = np.array([0, 43.5, 80.5, 0, 45, 0]) * DEG


@pytest.fixture(scope="module")
def scene(puma):
    return sirupp.Scene(puma, TABLE)


def test_free_and_touching_states(scene, puma):
    assert scene.n == 6 and len(scene.objects) == 8
    assert scene.is_free(puma.pose("ready"))
    assert scene.contacts(puma.pose("ready")) == []
    assert not scene.is_free(THROUGH_TABLE)
    contacts = scene.contacts(THROUGH_TABLE)
    assert contacts and all(c["object"] == "table_top" for c in contacts)
    assert all(c["kind"] == "static object" and c["depth_m"] > 0 for c in contacts)
    assert {c["link"] for c in contacts} <= {3, 4, 5, 6}
    assert "table_top" in contacts[0]["text"] and contacts[0]["point"].shape == (3,)


def test_scene_from_a_file_and_padding(puma):
    thin = sirupp.Scene(PUMA, TABLE, padding=0.0)
    assert thin.padding == 0.0
    # A state just above the table: free unpadded, touching with 3 cm of padding.
    q = THROUGH_TABLE.copy()
    while not thin.is_free(q):
        q[1] -= 0.5 * DEG
    assert not sirupp.Scene(puma, TABLE, padding=0.03).is_free(q)
    thin.padding = 0.03
    assert not thin.is_free(q)


def test_edges(scene):
    assert scene.is_free(START) and scene.is_free(GOAL)
    assert not scene.edge_free(START, GOAL, 0.01)
    edge = scene.check_edge(START, GOAL, 0.01)
    assert not edge["free"] and 0 < edge["fraction"] < 1
    assert not scene.is_free(edge["q"]) and edge["contact"]["object"]
    assert scene.edge_free(START, START + 0.5 * DEG, 0.01)


def test_plan_is_free_finer_than_planned_and_reproducible(scene, puma):
    path = scene.plan(START, GOAL, seed=4, iterations=20000, tree=True)
    assert path.ndim == 2 and path.shape[1] == 6 and path.shape[0] >= 3
    np.testing.assert_allclose(path[0], START, atol=1e-9)
    np.testing.assert_allclose(path[-1], GOAL, atol=1e-9)
    # Planned at 0.01 rad with 1 cm of padding: free unpadded at 0.002 rad (the padding is the
    # margin over the resolution).
    exact = sirupp.Scene(puma, TABLE, padding=0.0)
    assert exact.path_free(path, step=0.002)
    lo, hi = scene.qlim  # the soft limits
    assert np.all(path >= lo) and np.all(path <= hi)
    info = scene.last_plan
    assert info["solved"] and info["tree_vertices"].shape[1] == 6
    assert info["tree_edges"].shape[1] == 2 and info["tree_edges"].max() < len(info["tree_vertices"])
    assert abs(sirupp.path_length(path) - info["length_rad"]) < 1e-9
    again = scene.plan(START, GOAL, seed=4, iterations=20000)
    np.testing.assert_array_equal(path, again)
    for planner in ("RRT*", "BIT*", "prm", "KPIECE"):
        other = scene.plan(START, GOAL, planner=planner, time=2.0)
        assert exact.path_free(other, step=0.002), planner


def test_cspace_slice(scene, puma):
    qa, qb, cells = scene.cspace(1, 2, puma.pose("ready"), step_deg=2)
    assert cells.shape == (len(qb), len(qa)) and cells.dtype == np.uint8
    assert set(np.unique(cells)) <= {0, 1, 2, 3} and (cells == 0).any() and (cells == 1).any()
    lo, hi = puma.qlim  # the slice spans the model's limits
    assert qa[0] == pytest.approx(lo[1]) and qa[-1] == pytest.approx(hi[1])
    ia = np.argmin(np.abs(qa - THROUGH_TABLE[1]))
    ib = np.argmin(np.abs(qb - THROUGH_TABLE[2]))
    assert cells[ib, ia] == sirupp.planning.STATIC_OBJECT


def test_plan_text(scene):
    text = scene.plan_text(np.array([START, GOAL * 0.5 + START * 0.5]), comments=["made here"])
    assert text.startswith("# made here") and "move joints" in text and "wait done" in text


@pytest.mark.parametrize("call, message", [
    (lambda s: s.is_free([0, 0, 0]), "q: 3 values; expected 6"),
    (lambda s: s.is_free([0, 0, np.nan, 0, 0, 0]), "q[2]: nan is not a finite number"),
    (lambda s: s.edge_free(START, GOAL, 0), "step: 0; allowed (0, 1] rad"),
    (lambda s: s.plan(START, GOAL, planner="astar"), "planner: 'astar'; allowed: RRTConnect"),
    (lambda s: s.plan(START, GOAL, seed=-1), "seed: -1; allowed 0 to 4294967295"),
    (lambda s: s.plan(START, GOAL, time=0), "time: 0; allowed (0, 600] s"),
    (lambda s: s.plan(START, THROUGH_TABLE), "table_top"),
    (lambda s: s.plan(START, np.full(6, 3.0)), "goal"),
    (lambda s: s.cspace(1, 1, START), "joints: 1, 1; expected two different joints 0 to 5"),
    (lambda s: s.plan_text([]), "path: empty"),
    (lambda s: s.plan_text([START], speed_fraction=2), "speed_fraction: 2; allowed (0, 1]"),
])
def test_bad_input_is_one_clear_value_error(scene, call, message):
    with pytest.raises(ValueError, match=None) as caught:
        call(scene)
    assert message in str(caught.value), str(caught.value)


def test_bad_scene_arguments(puma):
    with pytest.raises(ValueError, match="padding: 0.5 m; allowed 0 to 0.1 m"):
        sirupp.Scene(puma, TABLE, padding=0.5)
    with pytest.raises(ValueError, match="nothing.xml"):
        sirupp.Scene(puma, "nothing.xml")
    with pytest.raises(sirupp.ModelError, match="nothing.yaml"):
        sirupp.Scene("nothing.yaml", TABLE)
    with pytest.raises(ValueError, match="model: 3; expected a sirupp.Model or a model file"):
        sirupp.Scene(3, TABLE)


def test_no_path_is_a_plan_error(puma):
    scene = sirupp.Scene(puma, TABLE)
    with pytest.raises(sirupp.PlanError):
        scene.plan(START, GOAL, planner="RRT", iterations=1, simplify=False)
    assert not scene.last_plan["solved"] and scene.last_plan["message"]


def test_a_planned_path_runs_on_a_rig_without_touching(scene):
    path = scene.plan(START, GOAL, seed=4, iterations=20000)
    exact = sirupp.Scene(PUMA, TABLE, padding=0.0)
    with sirupp.start_rig(mode="lockstep", environment=TABLE) as rig:
        with rig.record() as r:
            text = rig.run_path(path)
    assert text.count("wait done") == len(path)  # the move to the start, then every segment
    assert len(r.q) > 100
    touching = [q for q in r.q[::10] if not exact.is_free(q)]
    assert not touching, exact.contacts(touching[0])
    assert np.max(np.abs(r.q[-1] - GOAL)) < 2 * DEG
