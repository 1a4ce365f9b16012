#!/usr/bin/python3
"""Notebook assignments through the class server (class/notebook_submissions.hpp), on a class of
two with the fk3 assignment and a one-task controller suite:
  - alice uploads a notebook whose fk ignores the DH offsets, bob submits the right one from his
    notebooks folder (where the hub keeps it); alice also submits a controller;
  - both are graded in the sandbox: alice 3 of 6 with the hidden table's test failed and named,
    bob 6 of 6, on their own pages, on the teacher's view of them and on the teacher's page;
  - the hidden tests' text is in no answer;
  - /teacher/grades.csv: the header Canvas's import takes, one row per student, the controller
    grade and the assignment;
  - bad requests: no token, another student's token, the teacher posting, an unknown assignment,
    a file too large, not a notebook, no copy in the notebooks folder, no such submission, a POST
    without X-Sirupp-Client: one 4xx each, and the server answers after them;
  - a server killed with SIGKILL right after a submission grades it at its next start.
Usage: class_notebook_test.py BIN_DIR SOURCE_DIR."""

import json
import os
import shutil
import signal
import sys
import tempfile
import time
import urllib.error
import urllib.request

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "python"))
from class_run import ClassRun  # noqa: E402
import fk3_notebooks as fk3  # noqa: E402

BIN, SRC = sys.argv[1], os.path.abspath(sys.argv[2])
HIDDEN_TEXT = open(fk3.HIDDEN).read()


def request(run, method, path, token=None, body=None, client=True):
    """(status, body: parsed JSON or text) of one request with a raw body."""
    headers = {"Content-Type": "application/x-ipynb+json"}
    if client:
        headers["X-Sirupp-Client"] = "notebook-test"
    if token:
        headers["X-Sirupp-Token"] = token
    data = body.encode() if isinstance(body, str) else body
    if method == "POST" and data is None:
        data = b""
    req = urllib.request.Request(run.base + path, data=data, method=method, headers=headers)
    try:
        with urllib.request.urlopen(req, timeout=30) as r:
            status, text, kind = r.status, r.read().decode(), r.headers.get_content_type()
    except urllib.error.HTTPError as e:
        status, text, kind = e.code, e.read().decode(), e.headers.get_content_type()
    assert "def test_" not in text and "HIDDEN_DH" not in text, f"hidden tests in {path}"
    return status, (json.loads(text) if kind == "application/json" else text)


def wait_graded(run, student, count, timeout_s=120):
    """The student's fk3 submissions once `count` of them are in a final state."""
    end = time.time() + timeout_s
    while time.time() < end:
        status, page = request(run, "GET", f"/s/{student}/class/assignments", run.token(student))
        assert status == 200, (status, page)
        fk = page["assignments"][0]
        done = [s for s in fk["submissions"] if s["state"] in ("graded", "grade failed")]
        if len(done) >= count:
            return fk
        time.sleep(0.5)
    raise AssertionError(f"{student}'s notebook not graded within {timeout_s} s: {fk}")


def tests_of(result):
    return {t["name"]: t for t in result["tests"]}


work = tempfile.mkdtemp(prefix="sirupp-notebook-class-")
suite = os.path.join(work, "one_step.yaml")
with open(suite, "w") as f:
    f.write("format: sirupp-grade-suite-1\nname: one-step\n"
            "description: one short step, for the notebook class test\n"
            f"model: {SRC}/config/robots/puma260.yaml\n"
            "limits: {tick_s: 2, start_s: 30, task_s: 60}\n"
            "pass: {settling_s: 1.0, overshoot_percent: 10, steady_state_deg: 1.5, saturated_s: 0.5}\n"
            "tasks:\n  - {name: step_j2, step: {joint: 2, to_deg: 30}, duration_s: 1.5}\n")
extra = (f"grading: {{suite: {suite}}}\n"
         "notebooks:\n"
         f"  folder: {SRC}/notebooks\n"
         "  assignments:\n"
         f"    - {{name: fk3, notebook: {fk3.ASSIGNMENT}, tests: {fk3.HIDDEN}, timeout_s: 60}}\n")
run = ClassRun(BIN, SRC, ["alice", "bob"], extra_yaml=extra).start()
ok = False
try:
    alice, bob, teacher = run.token("alice"), run.token("bob"), run.token("teacher")
    buggy = open(fk3.write(fk3.NO_OFFSET, os.path.join(work, "buggy.ipynb"))).read()
    right_file = fk3.write(fk3.RIGHT, os.path.join(work, "right.ipynb"))
    right = open(right_file).read()

    # What a student sees before submitting: the assignment, its tests' names and points.
    status, page = request(run, "GET", "/s/alice/class/assignments", alice)
    assert status == 200, (status, page)
    fk = page["assignments"][0]
    assert fk["name"] == "fk3" and fk["max_points"] == 6 and fk["latest"] is None
    assert [(t["name"], t["points"]) for t in fk["tests"]] == [
        ("test_returns_a_homogeneous_transform", 1), ("test_random_joints_on_the_notebooks_table", 2),
        ("test_a_table_you_have_not_seen", 3)], fk["tests"]
    assert fk["in_notebooks_folder"] is False

    # alice uploads; bob's copy is in his notebooks folder, as the hub keeps it.
    status, sub = request(run, "POST", "/s/alice/class/assignments/fk3", alice, buggy)
    assert status == 202 and sub["id"] == 1 and sub["state"] == "queued", (status, sub)
    copy = run.data("students", "bob", "notebooks", "assignments", "fk3_forward_kinematics.ipynb")
    os.makedirs(os.path.dirname(copy))
    shutil.copy(right_file, copy)
    status, sub = request(run, "POST", "/s/bob/class/assignments/fk3/from-notebooks", bob)
    assert status == 202 and sub["source"] == "notebooks folder", (status, sub)
    controller = open(os.path.join(SRC, "examples/07_python_controller/computed_torque_pid.py")).read()
    status, csub = run.http("POST", "/s/alice/class/submissions", alice,
                            {"language": "python", "source": controller})
    assert status == 200, (status, csub)

    fk_alice = wait_graded(run, "alice", 1)
    fk_bob = wait_graded(run, "bob", 1)
    result = fk_alice["latest"]["result"]
    print("alice:", result["score"], "of", result["max_score"], [
        (t["name"], t["passed"], t["message"][:60]) for t in result["tests"]])
    assert fk_alice["latest"]["state"] == "graded" and result["score"] == 3, fk_alice["latest"]
    hidden = tests_of(result)["test_a_table_you_have_not_seen"]
    assert not hidden["passed"] and "differs from sirupp.Model" in hidden["message"], hidden
    assert tests_of(result)["test_random_joints_on_the_notebooks_table"]["passed"]
    assert "visible tests passed" in result["output"], result["output"]
    assert fk_bob["latest"]["result"]["score"] == 6 and fk_bob["in_notebooks_folder"], fk_bob
    print("bob:", fk_bob["latest"]["result"]["score"], "of 6")

    # The teacher: a student's page read-only, the class's page, one submission in full.
    status, view = request(run, "GET", "/s/alice/class/assignments", teacher)
    assert status == 200 and view["assignments"][0]["latest"]["result"]["score"] == 3, status
    status, one = request(run, "GET", "/s/bob/class/assignments/fk3/1", teacher)
    assert status == 200 and one["result"]["score"] == 6 and one["result"]["output"], (status, one)
    status, grades = request(run, "GET", "/teacher/api/notebook-grades", teacher)
    assert status == 200, (status, grades)
    assert grades["assignments"] == [{"name": "fk3", "max_points": 6}], grades["assignments"]
    rows = {r["student"]: r["assignments"]["fk3"] for r in grades["rows"]}
    assert rows["alice"]["score"] == 3 and rows["bob"]["score"] == 6, rows
    assert not tests_of(rows["alice"])["test_a_table_you_have_not_seen"]["passed"]
    status, html = request(run, "GET", "/teacher/", teacher)
    assert status == 200 and "notebook_grades.js" in html and 'id="notebook-grades"' in html
    status, js = request(run, "GET", "/s/alice/class.js", alice)
    assert status == 200 and "assignments.js" in js
    status, js = request(run, "GET", "/s/alice/assignments.js", alice)
    assert status == 200 and "class/assignments" in js

    # The controller's grade, then the gradebook's CSV.
    end = time.time() + 90
    while time.time() < end:
        status, cg = run.http("GET", "/teacher/api/grades", teacher)
        row = [r for r in cg["rows"] if r["student"] == "alice"][0]
        if row.get("state") in ("graded", "grade failed"):
            break
        time.sleep(0.5)
    assert row.get("state") == "graded", row
    controller_score = row["grade"]["score"]
    status, csv = request(run, "GET", "/teacher/grades.csv", teacher)
    assert status == 200, (status, csv)
    lines = csv.split("\r\n")
    print("grades.csv:", lines)
    assert lines[0] == "Student,ID,SIS User ID,SIS Login ID,Section,controller,fk3", lines[0]
    score_text = ("%.2f" % controller_score).rstrip("0").rstrip(".")
    assert lines[1] == f"alice,,,alice,,{score_text},3", lines[1]
    assert lines[2] == "bob,,,bob,,,6", lines[2]
    assert lines[3:] == [""], lines

    # Bad requests: one 4xx each with a message.
    def refused(expect, method, path, token, body=None, client=True, says=""):
        status, answer = request(run, method, path, token, body, client)
        text = answer.get("error", "") if isinstance(answer, dict) else answer
        assert status == expect and says in text, (method, path, status, answer)
        print(f"{method} {path}: {status} {text[:100]}")

    refused(403, "GET", "/s/alice/class/assignments", None)
    refused(403, "POST", "/s/alice/class/assignments/fk3", bob, right)
    refused(403, "POST", "/s/alice/class/assignments/fk3", teacher, right, says="only alice submits")
    refused(404, "POST", "/s/alice/class/assignments/ik6", alice, right, says="no assignment 'ik6'")
    refused(404, "GET", "/s/alice/class/assignments/ik6/1", alice, says="fk3")
    refused(413, "POST", "/s/alice/class/assignments/fk3", alice, "x" * (950 * 1024),
            says="at most 900 KiB")
    refused(413, "POST", "/s/alice/class/assignments/fk3", alice, "x" * (1100 * 1024),
            says="allowed at most 1 MiB")  # past the server's request limit
    refused(400, "POST", "/s/alice/class/assignments/fk3", alice, "print('hello')",
            says="not a notebook")
    refused(400, "POST", "/s/alice/class/assignments/fk3", alice, '{"cells": [], "nbformat": 3}',
            says="nbformat")
    refused(400, "POST", "/s/alice/class/assignments/fk3", alice, "", says="empty")
    refused(404, "POST", "/s/alice/class/assignments/fk3/from-notebooks", alice,
            says="in your notebooks folder")
    refused(404, "GET", "/s/alice/class/assignments/fk3/99", alice, says="no submission 99")
    refused(404, "GET", "/s/alice/class/assignments/fk3/-1", alice)
    refused(405, "POST", "/s/alice/class/assignments", alice)
    refused(405, "POST", "/teacher/grades.csv", teacher)
    status, _ = request(run, "POST", "/s/alice/class/assignments/fk3", alice, right, client=False)
    assert 400 <= status < 500, status
    refused(403, "GET", "/teacher/grades.csv", alice)
    status, page = request(run, "GET", "/s/alice/class/assignments", alice)
    assert status == 200 and len(page["assignments"][0]["submissions"]) == 1, page

    # Killed right after a submission: the next server grades it.
    status, sub = request(run, "POST", "/s/alice/class/assignments/fk3", alice, right)
    assert status == 202 and sub["id"] == 2, (status, sub)
    run.proc.send_signal(signal.SIGKILL)
    run.proc.wait()
    left = json.load(open(run.data("students", "alice", "assignments", "fk3", "2",
                                   "submission.json")))
    print("left by the killed server:", left["state"])
    assert left["state"] in ("queued", "grading"), left
    run.start()
    fk_alice = wait_graded(run, "alice", 2)
    assert fk_alice["latest"]["id"] == 2 and fk_alice["latest"]["result"]["score"] == 6, fk_alice
    assert "left queued or grading by the last server" in run.server_log()
    status, csv = request(run, "GET", "/teacher/grades.csv", teacher)
    assert csv.split("\r\n")[1] == f"alice,,,alice,,{score_text},6", csv
    ok = True
finally:
    run.stop()
    if ok:
        run.clean()
        shutil.rmtree(work, ignore_errors=True)
    else:
        print("server log:\n" + run.server_log())
print("ok" if ok else "FAIL")
sys.exit(0 if ok else 1)
