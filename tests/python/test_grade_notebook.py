"""`sirupp grade notebook NB --tests HIDDEN.py` (grade/notebook_assignment.hpp) on the shipped fk3
assignment, in the sandbox: a right answer gets full marks; one that ignores the DH offsets passes
the notebook's visible tests and the hidden tests on the notebook's own table, and fails the hidden
table, by name; the notebook as shipped (not filled in) scores 0 with its error; an endless loop
ends at the time limit with every test "not run"; a kernel that dies is named with its cell; sockets are refused and the grade goes on;
megabytes of output are cut, and what the notebook deletes is its own copy; the hidden tests are
not in the sandbox; bad files and options are one clear error."""
import json
import os
import subprocess

import pytest

from conftest import ROOT, bin_dir
import fk3_notebooks as fk3


def grade(notebook, out, *extra, tests=fk3.HIDDEN):
    return subprocess.run([os.path.join(bin_dir(), "sirupp"), "grade", "notebook", str(notebook),
                           "--tests", str(tests), "--out", str(out), *extra],
                          capture_output=True, text=True, timeout=180, cwd=ROOT)


def graded(tmp_path, answer, *extra):
    notebook = fk3.write(answer, str(tmp_path / "submission.ipynb"))
    run = grade(notebook, tmp_path / "out", "--json", *extra)
    assert run.returncode == 0, run.stdout + run.stderr
    result = json.loads(run.stdout)
    with open(tmp_path / "out" / "result.json") as f:
        assert json.load(f) == result
    return result


def by_name(result):
    return {t["name"]: t for t in result["tests"]}


def test_a_right_answer_gets_full_marks(tmp_path):
    notebook = fk3.write(fk3.RIGHT, str(tmp_path / "right.ipynb"))
    run = grade(notebook, tmp_path / "out")
    assert run.returncode == 0, run.stdout + run.stderr
    assert "test_a_table_you_have_not_seen" in run.stdout and "3/3  pass" in run.stdout
    assert "total" in run.stdout and "6/6" in run.stdout, run.stdout
    result = json.load(open(tmp_path / "out" / "result.json"))
    assert result["score"] == 6 and result["max_score"] == 6 and result["problem"] == ""
    assert [t["points"] for t in result["tests"]] == [1, 2, 3]
    assert result["cell_errors"] == [] and "visible tests passed" in result["output"]


def test_a_bug_the_visible_tests_miss_fails_the_hidden_table(tmp_path):
    result = graded(tmp_path, fk3.NO_OFFSET)
    assert result["cell_errors"] == [] and "visible tests passed" in result["output"]
    tests = by_name(result)
    assert tests["test_returns_a_homogeneous_transform"]["passed"]
    assert tests["test_random_joints_on_the_notebooks_table"]["passed"]
    hidden = tests["test_a_table_you_have_not_seen"]
    assert not hidden["passed"] and hidden["points"] == 0 and hidden["max_points"] == 3
    assert "differs from sirupp.Model" in hidden["message"], hidden
    assert result["score"] == 3 and result["max_score"] == 6


def test_the_notebook_as_shipped_scores_zero_with_its_error(tmp_path):
    notebook = tmp_path / "shipped.ipynb"
    notebook.write_bytes(open(fk3.ASSIGNMENT, "rb").read())
    run = grade(notebook, tmp_path / "out", "--json")
    result = json.loads(run.stdout)
    assert result["score"] == 0 and result["max_score"] == 6 and result["problem"] == ""
    assert {e["cell"] for e in result["cell_errors"]} == {3}, result["cell_errors"]
    assert "NotImplementedError" in result["cell_errors"][0]["error"]
    for test in result["tests"]:
        assert "NotImplementedError: write fk(dh, q)" in test["message"], test


def test_an_endless_loop_ends_at_the_time_limit(tmp_path):
    result = graded(tmp_path, fk3.LOOP, "--timeout", "6")
    assert "code cell 2 of 3 was still running after the 6 s" in result["problem"], result
    assert result["score"] == 0 and len(result["tests"]) == 3
    for test in result["tests"]:
        assert test["message"].startswith("not run: code cell 2 of 3"), test


def test_a_kernel_that_dies_is_named_with_its_cell(tmp_path):
    answer = fk3.RIGHT + "\nimport os, signal\nos.kill(os.getpid(), signal.SIGKILL)\n"
    result = graded(tmp_path, answer)
    assert result["problem"].startswith("the kernel died in code cell 2 of 3"), result
    assert result["score"] == 0
    assert all(t["message"].startswith("not run: the kernel died") for t in result["tests"])


def test_the_network_is_refused_the_hidden_tests_absent_and_the_grade_goes_on(tmp_path):
    probe = ("import os\nprint('hidden tests visible:', os.path.exists(%r))\n" % fk3.HIDDEN +
             "print('config visible:', os.path.exists(%r))\n" % os.path.dirname(fk3.HIDDEN))
    result = graded(tmp_path, probe + fk3.NETWORK)
    output = result["output"]
    assert "hidden tests visible: False" in output and "config visible: False" in output, output
    assert "network ('1.1.1.1', 80) refused: PermissionError" in output, output
    assert "network ('127.0.0.1', 22) refused: PermissionError" in output, output
    assert [e["cell"] for e in result["cell_errors"]] == [2]
    assert "URLError" in result["cell_errors"][0]["error"]
    assert result["score"] == 6  # fk was defined before the failing call


def test_megabytes_of_output_are_cut_and_deletes_stay_in_the_copy(tmp_path):
    sentinel = tmp_path / "sentinel"
    sentinel.write_text("the test's own file")
    result = graded(tmp_path, fk3.mess(str(sentinel)))
    assert sentinel.exists()
    assert "[output past 65536 bytes dropped]" in result["output"]
    assert len(result["output"].encode()) < 70 * 1024
    assert result["score"] == 6, result["tests"]
    assert (tmp_path / "submission.ipynb").exists()  # the student's file, not the copy


def test_the_notebooks_own_test_functions_are_not_run_nor_its_stdout_needed(tmp_path):
    # Its own test_* functions (one loops) and sys.stdout replaced: the scores still come back
    # (through the kernel's file descriptor capture).
    answer = (fk3.RIGHT + "\ndef test_of_my_own():\n    while True:\n        pass\n"
              "def test_a_table_you_have_not_seen():\n    pass\n"
              "import io, sys\nsys.stdout = io.StringIO()\n")
    result = graded(tmp_path, answer, "--timeout", "30")
    assert result["problem"] == "" and result["score"] == 6, result
    assert [t["name"] for t in result["tests"]] == [
        "test_returns_a_homogeneous_transform", "test_random_joints_on_the_notebooks_table",
        "test_a_table_you_have_not_seen"]


def test_bad_files_and_options_are_one_clear_error(tmp_path):
    text = tmp_path / "notes.ipynb"
    text.write_text("this is not JSON")
    run = grade(text, tmp_path / "out", "--json")
    assert run.returncode == 0, run.stderr
    result = json.loads(run.stdout)
    assert result["problem"].startswith("not a notebook:") and result["score"] == 0
    assert all(t["message"].startswith("not run: not a notebook") for t in result["tests"])

    no_tests = tmp_path / "empty_tests.py"
    no_tests.write_text("def helper():\n    pass\n")
    run = grade(text, tmp_path / "out", tests=no_tests)
    assert run.returncode == 2 and "empty_tests.py: no test" in run.stderr, run.stderr
    bad_points = tmp_path / "bad_points.py"
    bad_points.write_text("@points(-1)\ndef test_x():\n    pass\n")
    run = grade(text, tmp_path / "out", tests=bad_points)
    assert run.returncode == 2 and "bad_points.py:1: @points(-1)" in run.stderr, run.stderr
    run = grade(tmp_path / "missing.ipynb", tmp_path / "out")
    assert run.returncode == 2 and "missing.ipynb' is not a file" in run.stderr, run.stderr
    run = subprocess.run([os.path.join(bin_dir(), "sirupp"), "grade", "notebook", str(text)],
                         capture_output=True, text=True, timeout=60)
    assert run.returncode == 2 and "missing --tests" in run.stderr, run.stderr
