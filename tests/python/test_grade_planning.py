"""`sirupp grade FILE.py --suite config/grading/planning.yaml` (grade/planning_assignment.hpp): the
shipped good solution passes every query (run in the sandbox, checked at 0.002 rad, run on a rig
with table.xml, no tick touching, beside OMPL's reference); a straight-line "planner" fails the
queries whose straight way goes through the table, naming the segment, the link and the object;
a path that ends elsewhere, a file without plan(), and a suite whose goal touches the table are
one clear reason each. A C++ planner (include/sirupp/student_planner.h) graded from its source
is built in the sandbox and goes through the same check and run on the rig; a source that does
not build is its errors at their lines; a library that is none is a reason per query."""
import json
import os
import subprocess
import textwrap

import pytest

from conftest import ROOT, bin_dir

SUITE = os.path.join(ROOT, "config/grading/planning.yaml")
GOOD = os.path.join(ROOT, "config/grading/planning_rrt.py")
GOOD_CPP = os.path.join(ROOT, "config/grading/planning_rrt.cpp")


def grade(student, out, suite=SUITE, *extra):
    return subprocess.run([os.path.join(bin_dir(), "sirupp"), "grade", student, "--suite", suite,
                           "--out", str(out), *extra], capture_output=True, text=True, timeout=600,
                          cwd=ROOT)


def results(out):
    with open(os.path.join(str(out), "results.json")) as f:
        return {r["query"]: r for r in json.load(f)["results"]}


def student(tmp_path, body):
    path = tmp_path / "student.py"
    path.write_text(textwrap.dedent(body))
    return str(path)


def test_the_good_solution_passes_and_runs_on_the_rig(tmp_path):
    run = grade(GOOD, tmp_path / "out")
    assert run.returncode == 0, run.stdout + run.stderr
    assert "passed 3 of 3 queries (100 %)" in run.stdout, run.stdout
    for name, r in results(tmp_path / "out").items():
        assert r["passed"] and r["problem"] == "", (name, r)
        assert r["ran_on_rig"] and r["touching_ticks"] == 0 and r["end_error_deg"] < 2
        assert r["reference_solved"] and r["reference_length_rad"] > 0 and r["length_rad"] > 0
    sim_log = (tmp_path / "out" / "logs" / "over_table" / "sirupp-sim.log").read_text()
    assert "8 environment objects" in sim_log  # the run had table.xml loaded
    report = (tmp_path / "out" / "report.md").read_text()
    assert "| over_table | passed |" in report and "OMPL's" in report


def test_a_straight_line_through_the_table_fails(tmp_path):
    straight = student(tmp_path, """
        import numpy as np
        def plan(start, goal, scene):
            return np.array([start, goal])
    """)
    run = grade(straight, tmp_path / "out")
    assert run.returncode == 0, run.stdout + run.stderr
    assert "passed 1 of 3 queries" in run.stdout, run.stdout
    r = results(tmp_path / "out")
    assert not r["around_table"]["passed"] and not r["around_table"]["ran_on_rig"]
    assert r["around_table"]["problem"].startswith("segment 1 (waypoint 0 to 1) at ")
    assert "static object 'table_top'" in r["around_table"]["problem"]
    assert not r["over_table"]["passed"] and "touches" in r["over_table"]["problem"]
    assert r["ready_to_table"]["passed"] and r["ready_to_table"]["ran_on_rig"]


def test_wrong_ends_and_missing_function_are_named(tmp_path):
    short = student(tmp_path, """
        def plan(start, goal, scene):
            return [start, start * 0.5 + goal * 0.5]
    """)
    run = grade(short, tmp_path / "a", SUITE, "--no-sandbox")
    assert "passed 0 of 3" in run.stdout
    assert "not at the goal" in results(tmp_path / "a")["over_table"]["problem"]
    empty = student(tmp_path, "x = 1\n")
    run = grade(empty, tmp_path / "b", SUITE, "--no-sandbox")
    assert "no function plan(start, goal, scene)" in results(tmp_path / "b")["over_table"]["problem"]


def test_a_suite_whose_goal_touches_the_table_is_refused(tmp_path):
    text = open(SUITE).read().replace("config/", ROOT + "/config/")
    text = text.replace("to_deg: [110, 65, 40, 0, 97, 0]", "to_deg: [0, 43.5, 80.5, 0, 45, 0]")
    suite = tmp_path / "bad.yaml"
    suite.write_text(text)
    run = grade(GOOD, tmp_path / "out", str(suite))
    assert run.returncode == 2
    assert "bad.yaml:" in run.stderr and "to_deg" in run.stderr and "table_top" in run.stderr, \
        run.stderr
    run = subprocess.run([os.path.join(bin_dir(), "sirupp"), "grade", "--batch", str(tmp_path),
                          "--suite", SUITE, "--out", str(tmp_path / "out")],
                         capture_output=True, text=True, timeout=60, cwd=ROOT)  # one at a time
    assert run.returncode == 2 and "is a planning suite: give one FILE.py" in run.stderr, \
        run.stderr


def test_the_function_runs_in_the_sandbox(tmp_path):
    nosy = student(tmp_path, """
        import numpy as np
        def plan(start, goal, scene):
            open(%r).read()   # another file of the project: not there inside the sandbox
            return np.array([start, goal])
    """ % os.path.join(ROOT, "config/plans/set7.plan"))
    run = grade(nosy, tmp_path / "out")
    assert "passed 0 of 3" in run.stdout, run.stdout + run.stderr
    problem = results(tmp_path / "out")["ready_to_table"]["problem"]
    assert "plan(): FileNotFoundError" in problem and "set7.plan" in problem, problem


def test_the_cpp_rrt_is_built_checked_and_run_on_the_rig(tmp_path):
    # The first query only (over_table: the straight way touches the table), to keep it short.
    text = open(SUITE).read().replace("config/", ROOT + "/config/")
    suite = tmp_path / "one.yaml"
    suite.write_text(text[:text.index("  # The tool low beside the table")])
    run = grade(GOOD_CPP, tmp_path / "out", str(suite))
    assert run.returncode == 0, run.stdout + run.stderr
    assert "grade: built " in run.stderr and "planning_rrt.so" in run.stderr, run.stderr
    assert "planning: planning_rrt.cpp passed 1 of 1 queries (100 %)" in run.stdout, run.stdout
    r = results(tmp_path / "out")["over_table"]
    assert r["passed"] and r["ran_on_rig"] and r["touching_ticks"] == 0, r
    assert r["waypoints"] > 2 and r["reference_solved"]
    report = (tmp_path / "out" / "report.md").read_text()
    assert "# planning: planning_rrt.cpp" in report and "| over_table | passed |" in report


def test_a_cpp_planner_that_does_not_build_or_is_no_planner(tmp_path):
    tmp_path.chmod(0o755)  # started as root, the sandbox's own user must read the sources
    broken = tmp_path / "broken.cpp"
    broken.write_text("#include <sirupp/student_planner.h>\nSIRUPP_PLANNER_ABI()\nint x = ;\n")
    run = grade(str(broken), tmp_path / "a")
    assert run.returncode == 2, run.stdout + run.stderr
    assert "broken.cpp:3:" in run.stderr and "error:" in run.stderr, run.stderr
    library = tmp_path / "controller.so"  # not a library at all
    library.write_text("")
    run = grade(str(library), tmp_path / "b")
    assert run.returncode == 0 and "passed 0 of 3" in run.stdout, run.stdout + run.stderr
    assert "controller.so: cannot be loaded" in results(tmp_path / "b")["over_table"]["problem"]
