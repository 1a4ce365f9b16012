"""A class whose rigs are Slurm jobs (class file cluster:), on the one-node cluster of
with_cluster.sh (SLURM_CONF exported): `sirupp class serve` submits one sirupp-rig-job per
student on their first visit and proxies their API and live stream to it.

- a class of three: each student's page, API and live stream through the proxy; movement set VII
  on each rig to within 0.5 deg; a student's token refused (403) on another's rig through the
  proxy; the teacher's page lists the three as Slurm jobs with their live joints;
- a job cancelled from outside (scancel) is shown on both pages with Slurm's reason;
- a job lost with its node (the node set DOWN under it) is shown on both pages with Slurm's
  NODE_FAIL, and Slurm does not run it again;
- kill -9 of the class server, then a restart that reattaches: the same jobs, the pages work
  through the proxy again, no job or rig process more than before;
- an idle rig's job is cancelled (and nothing of it is left on the node);
- a job the cluster holds back is shown as waiting for the cluster with Slurm's reason, and the
  page's API says so, until the job runs;
- the class server's own stop cancels every job;
- "Run on my rig" with a Python and a C++ submission: the rig job is submitted again with the
  controller, which is loaded on the node and runs set VII to its goal;
- a grading job lost with its node (the node set DOWN under it) is submitted once more and
  graded; lost twice, the submission fails with Slurm's NODE_FAIL;
- a burst of 6 submissions graded as jobs: never more jobs at once than `grading.jobs`, and two at
  once when it is 2 (the time of each is printed: on an idle 2-core machine two at a time took 0.40
  to 0.60 of one at a time).

Run: tests/cluster/with_cluster.sh /usr/bin/python3 -m pytest -q tests/cluster/class_cluster_test.py
(env SIRUPP_BIN_DIR: the build's bin/).
"""
import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
import urllib.request

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, os.path.join(ROOT, "tests", "class"))
from class_run import ClassRun  # noqa: E402

BIN = os.environ.get("SIRUPP_BIN_DIR", os.path.join(ROOT, "build", "bin"))
CLUSTER_YAML = ("cluster:\n"
                "  engine: slurm\n"
                "  rig: {time_limit_min: 30, cpus: 1, memory_mb: 2048}\n"
                "  poll_s: 1\n")


def wait_for(what, seconds, probe):
    end = time.time() + seconds
    last = None
    while time.time() < end:
        last = probe()
        if last:
            return last
        time.sleep(0.2)
    pytest.fail("%s: not within %s s (last: %r)" % (what, seconds, last))


def jobs(name_prefix="sirupp-rig-"):
    """{job id: (state, name)} of the cluster's jobs, running or pending."""
    out = subprocess.run(["squeue", "-h", "-o", "%i|%T|%j"], capture_output=True, text=True,
                         timeout=20).stdout
    rows = [l.split("|") for l in out.splitlines() if l.strip()]
    return {r[0]: (r[1], r[2]) for r in rows if r[2].startswith(name_prefix)}


def rig_processes(run):
    out = subprocess.run(["pgrep", "-af", run.data("students")], capture_output=True,
                         text=True).stdout
    return [l for l in out.splitlines() if "sirupp-" in l and "pgrep" not in l]


def status(run, name):
    code, body = run.http("GET", "/s/%s/class/status" % name, run.token(name))
    assert code == 200, body
    return body


def running(run, name):
    s = status(run, name)
    return s if s["state"] == "running" else None


def stream_frames(run, name, count, hz=10):
    request = urllib.request.Request(run.base + "/s/%s/api/events?hz=%d" % (name, hz),
                                     headers={"X-Sirupp-Token": run.token(name)})
    frames = []
    with urllib.request.urlopen(request, timeout=15) as stream:
        assert stream.headers.get_content_type() == "text/event-stream"
        while len(frames) < count:
            line = stream.readline()
            assert line, "the stream ended after %d frame(s)" % len(frames)
            if line.startswith(b"data: "):
                frames.append((time.time(), json.loads(line[6:])))
    return frames


def start_class(students, idle_timeout_s=900, extra=""):
    run = ClassRun(BIN, ROOT, students, idle_timeout_s=idle_timeout_s,
                   extra_yaml=CLUSTER_YAML + extra)
    run.start()
    return run


def jobs_of(run):
    return {i: v for i, v in jobs().items() if v[1] in ["sirupp-rig-" + n for n in run.students]}


def finish(run):
    run.stop()
    try:
        wait_for("every rig job cancelled after the server's stop", 30, lambda: not jobs_of(run))
        wait_for("no rig process left", 15, lambda: not rig_processes(run))
    finally:
        print(run.server_log()[-4000:])
        run.clean()


@pytest.fixture(scope="module")
def klass():
    run = start_class(["alice", "bob", "carol"])
    yield run
    finish(run)


def test_pages_api_and_stream_through_the_proxy(klass):
    run = klass
    started = time.time()
    for name in ("alice", "bob", "carol"):
        code, page = run.http("GET", "/s/%s/" % name, run.token(name))
        assert code == 200 and b"class-bar" in page, page[:200]
    for name in ("alice", "bob", "carol"):
        s = wait_for(name + "'s rig job running", 90, lambda: running(run, name))
        assert s["where"].startswith("Slurm job "), s
    print("three rig jobs ready %.1f s after the three pages were asked for" %
          (time.time() - started))
    assert len(jobs()) == 3, jobs()
    for name in ("alice", "bob", "carol"):
        code, state = run.http("GET", "/s/%s/api/state" % name, run.token(name))
        assert code == 200, state
        assert len(state["virtual"]["q"]) == 6
        frames = stream_frames(run, name, 5)
        span = frames[-1][0] - frames[0][0]
        assert span < 3, "5 frames at 10 Hz took %.2f s: the stream is held up" % span
    code, rigs = run.http("GET", "/teacher/api/rigs", run.token("teacher"))
    assert code == 200, rigs
    for rig in rigs["rigs"]:
        assert rig["state"] == "running" and rig["where"].startswith("Slurm job"), rig
        assert "q" in wait_for("the teacher sees " + rig["name"] + "'s joints", 10, lambda: next(
            r for r in run.http("GET", "/teacher/api/rigs", run.token("teacher"))[1]["rigs"]
            if r["name"] == rig["name"] and "q" in r)), rig


def test_set_seven_on_each_rig(klass):
    run = klass
    with open(os.path.join(ROOT, "config", "plans", "set7.plan")) as f:
        plan = f.read()
    for name in ("alice", "bob", "carol"):
        wait_for(name + " running", 90, lambda: running(run, name))
        code, body = run.http("POST", "/s/%s/api/lock" % name, run.token(name), {"name": name})
        assert code == 200, body
        code, body = run.http("POST", "/s/%s/api/plan/run" % name, run.token(name),
                              {"name": "set7.plan", "text": plan})
        assert code == 200, body
    goal = (90, 90, 90, 0, 0, 0)  # the page's state is in degrees

    seen = {}

    def at_goal(name):
        code, state = run.http("GET", "/s/%s/api/state" % name, run.token(name))
        seen[name] = (code, state if code != 200 else (state.get("controller"), state.get("sim"),
                                                       state.get("virtual", {}).get("q")))
        if code != 200:
            return None
        if state["controller"]["state"] != "idle":
            return None  # the plan still runs
        error = max(abs(a - b) for a, b in zip(state["virtual"]["q"], goal))
        return error if error < 0.5 else None

    for name in ("alice", "bob", "carol"):
        try:
            error = wait_for(name + " at set VII's goal within 0.5 deg", 90, lambda: at_goal(name))
        except BaseException:
            print("%s's last state: %r" % (name, seen.get(name)))
            raise
        print("%s: set VII ends %.3f deg from the goal" % (name, error))


def test_a_token_opens_its_own_rig_only(klass):
    run = klass
    for path in ("/s/bob/api/state", "/s/bob/api/events", "/s/bob/class/status"):
        code, body = run.http("GET", path, run.token("alice"))
        assert code == 403, (path, code, body)
    code, body = run.http("POST", "/s/bob/api/lock", run.token("alice"), {"name": "alice"})
    assert code == 403, body
    # The report route takes no student's token in place of the rig's secret.
    request = urllib.request.Request(run.base + "/cluster/report", method="POST",
                                     data=json.dumps({"student": "bob", "job": "1",
                                                      "host": "127.0.0.1", "port": 1}).encode(),
                                     headers={"X-Sirupp-Rig-Secret": run.token("bob")})
    with pytest.raises(urllib.error.HTTPError) as refused:
        urllib.request.urlopen(request, timeout=10)
    assert refused.value.code == 403


def test_kill_9_and_a_restart_reattach_to_the_same_jobs(klass):
    run = klass
    for name in ("alice", "bob", "carol"):
        wait_for(name + " running", 90, lambda: running(run, name))
    before = jobs()
    processes = len(rig_processes(run))
    assert len(before) == 3 and processes >= 9, (before, processes)
    run.proc.send_signal(signal.SIGKILL)
    run.proc.wait()
    time.sleep(2)
    assert jobs() == before, "the jobs changed while the server was down"
    run.start()
    for name in ("alice", "bob", "carol"):
        wait_for(name + " running again through the proxy", 30, lambda: running(run, name))
        code, state = run.http("GET", "/s/%s/api/state" % name, run.token(name))
        assert code == 200, state
        assert stream_frames(run, name, 3)
    time.sleep(3)  # a few polls: nothing new may be started
    assert jobs() == before, "after the restart: %s, before: %s" % (jobs(), before)
    assert len(rig_processes(run)) == processes, rig_processes(run)
    assert "reattached" in run.server_log()


def test_a_job_cancelled_from_outside_shows_slurms_reason(klass):
    run = klass
    wait_for("bob running", 90, lambda: running(run, "bob"))
    job = next(i for i, (_, n) in jobs().items() if n == "sirupp-rig-bob")
    subprocess.run(["scancel", job], check=True, timeout=20)
    s = wait_for("bob's page shows the end", 30,
                 lambda: (lambda s: s if s["state"] != "running" else None)(status(run, "bob")))
    assert "cancelled" in s["last_stop"], s
    rigs = run.http("GET", "/teacher/api/rigs", run.token("teacher"))[1]["rigs"]
    bob = next(r for r in rigs if r["name"] == "bob")
    assert bob["state"] == s["state"] and "cancelled" in bob["last_stop"], bob
    code, body = run.http("GET", "/s/bob/api/state", run.token("bob"))
    assert code == 503 and "cancelled" in body["error"], body
    assert all(s == "RUNNING" for s, n in jobs().values()), jobs()


def test_an_idle_rigs_job_is_cancelled():
    run = start_class(["dave"], idle_timeout_s=6)
    try:
        code, _ = run.http("GET", "/s/dave/", run.token("dave"))
        assert code == 200
        wait_for("dave's rig job running", 90, lambda: running(run, "dave"))
        assert len(jobs_of(run)) == 1
        # Nobody visits: the job goes after the idle timeout.
        wait_for("dave's job cancelled", 40, lambda: not jobs_of(run))
        wait_for("nothing of it left", 15, lambda: not rig_processes(run))
        s = status(run, "dave")
        assert s["state"] == "stopped" and "idle" in s["last_stop"], s
    finally:
        finish(run)


def test_a_waiting_job_shows_slurms_reason_until_it_runs():
    # --hold keeps the job pending (Slurm's reason JobHeldUser) until `scontrol release`.
    run = start_class(["erin"], extra="  sbatch_args: [--hold]\n")
    try:
        code, page = run.http("GET", "/s/erin/", run.token("erin"))
        assert code == 200 and b"class-bar" in page
        s = wait_for("erin's rig waiting with Slurm's reason", 20, lambda: (
            lambda s: s if s["state"] == "pending" and "JobHeldUser" in s["waiting"] else None)(
                status(run, "erin")))
        assert "waiting for the cluster" in s["waiting"], s
        code, body = run.http("GET", "/s/erin/api/state", run.token("erin"))
        assert code == 503 and "JobHeldUser" in body["error"], body
        rigs = run.http("GET", "/teacher/api/rigs", run.token("teacher"))[1]["rigs"]
        assert rigs[0]["state"] == "pending" and "JobHeldUser" in rigs[0]["waiting"], rigs
        job = next(iter(jobs_of(run)))
        subprocess.run(["scontrol", "release", job], check=True, timeout=20)
        wait_for("erin's rig running once released", 60, lambda: running(run, "erin"))
        code, state = run.http("GET", "/s/erin/api/state", run.token("erin"))
        assert code == 200, state
    finally:
        finish(run)


def node_state():
    node = socket.gethostname().split(".")[0]
    return node, subprocess.run(["sinfo", "-h", "-N", "-n", node, "-o", "%T"],
                                capture_output=True, text=True, timeout=20).stdout.strip()


def test_a_rig_job_lost_with_its_node_shows_slurms_reason():
    run = start_class(["gus"])
    node, _ = node_state()
    try:
        code, _ = run.http("GET", "/s/gus/", run.token("gus"))
        assert code == 200
        wait_for("gus's rig job running", 90, lambda: running(run, "gus"))
        subprocess.run(["scontrol", "update", "NodeName=" + node, "State=DOWN",
                        "Reason=class_cluster test"], check=True, timeout=20)
        s = wait_for("gus's page shows the node's failure", 30,
                     lambda: (lambda s: s if s["state"] != "running" else None)(
                         status(run, "gus")))
        assert s["state"] == "failed" and "NODE_FAIL" in s["last_stop"], s
        assert "the node the job ran on failed" in s["last_stop"], s
        rigs = run.http("GET", "/teacher/api/rigs", run.token("teacher"))[1]["rigs"]
        assert rigs[0]["state"] == "failed" and "NODE_FAIL" in rigs[0]["last_stop"], rigs
        # Not run again by Slurm behind the server's back (--no-requeue).
        assert not jobs_of(run), jobs_of(run)
    finally:
        # The test cluster takes its node back by itself (ReturnToService=2); else resume it.
        if node_state()[1] not in ("idle", "mixed", "allocated"):
            subprocess.run(["scontrol", "update", "NodeName=" + node, "State=RESUME"],
                           timeout=20)
        wait_for("the node back", 30, lambda: node_state()[1] in ("idle", "mixed", "allocated"))
        finish(run)


def test_run_on_my_rig_on_a_node():
    """A submitted controller (Python and C++) runs on the student's rig job: "Run on my rig"
    cancels the job and submits a new one whose sirupp-control loads the submission from the
    student's folder (as the node sees it); set VII ends at its goal under it; back to the
    built-in law the same way."""
    run = start_class(["fay"])
    try:
        code, _ = run.http("GET", "/s/fay/", run.token("fay"))
        assert code == 200
        wait_for("fay's rig job running", 90, lambda: running(run, "fay"))
        first = set(jobs_of(run))
        sources = {"python": os.path.join(ROOT, "examples", "07_python_controller",
                                          "computed_torque_pid.py"),
                   "cpp": os.path.join(ROOT, "examples", "02_pd_gravity", "pd_gravity.cpp")}
        with open(os.path.join(ROOT, "config", "plans", "set7.plan")) as f:
            plan = f.read()
        for language, source in sorted(sources.items(), reverse=True):  # python, then cpp
            with open(source) as f:
                code, body = run.http("POST", "/s/fay/class/submissions", run.token("fay"),
                                      {"language": language, "source": f.read()})
            assert code == 200, body
            sub = body["id"]
            wait_for("submission %d built" % sub, 120, lambda: next(
                s for s in run.http("GET", "/s/fay/class/submissions", run.token("fay"))[1][
                    "submissions"] if s["id"] == sub)["state"] == "ready")
            code, body = run.http("POST", "/s/fay/class/run", run.token("fay"), {"id": sub})
            assert code == 200 and body["running"] == sub and not body["rig_problem"], body
            s = wait_for("fay's rig job running with submission %d" % sub, 90,
                         lambda: (lambda s: s if s["starts"] >= 1 and set(jobs_of(run)) != first
                                  else None)(running(run, "fay") or {"starts": 0}))
            assert len(jobs_of(run)) == 1, jobs_of(run)
            first = set(jobs_of(run))
            # The job's sirupp-control loads the submission (its path under the student's folder).
            control = [p for p in rig_processes(run) if "sirupp-control" in p]
            wanted = "submissions/%d/" % sub
            assert any("--controller" in p and wanted in p for p in control), control
            code, body = run.http("POST", "/s/fay/api/lock", run.token("fay"), {"name": "fay"})
            assert code == 200, body
            code, body = run.http("POST", "/s/fay/api/plan/run", run.token("fay"),
                                  {"name": "set7.plan", "text": plan})
            assert code == 200, body
            goal = (90, 90, 90, 0, 0, 0)

            def at_goal():
                code, state = run.http("GET", "/s/fay/api/state", run.token("fay"))
                if code != 200 or state["controller"]["state"] != "idle":
                    return None
                error = max(abs(a - b) for a, b in zip(state["virtual"]["q"], goal))
                return error if error < 0.5 else None

            error = wait_for("set VII's goal under submission %d (%s)" % (sub, language), 120,
                             at_goal)
            print("fay's %s submission on her rig job (%s): set VII ends %.3f deg from the goal"
                  % (language, s["where"], error))
        code, body = run.http("POST", "/s/fay/class/run", run.token("fay"), {"id": None})
        assert code == 200 and body["running"] is None, body
        wait_for("fay's rig job running with the built-in law", 90, lambda: running(run, "fay")
                 and set(jobs_of(run)) != first and not any(
                     "--controller" in p for p in rig_processes(run) if "sirupp-control" in p))
    finally:
        finish(run)


SUITE = """format: sirupp-grade-suite-1
name: quick
description: One short step, for timing the grading queue.
model: %s/config/robots/puma260.yaml
limits: {tick_s: 2, start_s: 30, task_s: 120}
pass: {settling_s: 1.0, overshoot_percent: 10, steady_state_deg: 1.5, saturated_s: 0.5}
tasks:
  - {name: step_j2, step: {joint: 2, to_deg: 30}, duration_s: 2}
""" % ROOT


def grade_burst(jobs_at_once):
    """Seconds from 6 submissions (one per student) to all 6 graded, grading as Slurm jobs."""
    names = ["g%d" % i for i in range(6)]
    run = ClassRun(BIN, ROOT, names, extra_yaml=CLUSTER_YAML + "  grading: {jobs: %d}\n" %
                   jobs_at_once)
    suite = os.path.join(run.work, "quick.yaml")
    with open(suite, "w") as f:
        f.write(SUITE)
    with open(run.class_file, "a") as f:
        f.write("grading: {suite: quick.yaml}\n")
    run.start()
    try:
        with open(os.path.join(ROOT, "examples", "07_python_controller",
                               "computed_torque_pid.py")) as f:
            source = f.read()
        start = time.time()
        for name in names:
            code, body = run.http("POST", "/s/%s/class/submissions" % name, run.token(name),
                                  {"language": "python", "source": source})
            assert code == 200, body

        def states():
            out = []
            for name in names:
                code, body = run.http("GET", "/s/%s/class/submissions" % name, run.token(name))
                assert code == 200, body
                out.append(body["submissions"][0]["state"])
            return out

        most = [0]  # the most grading jobs seen in the cluster at once

        def all_graded():
            most[0] = max(most[0], len(jobs("sirupp-grade-")))
            return all(s in ("graded", "grade failed") for s in states())

        wait_for("6 submissions graded", 600, all_graded)
        took = time.time() - start
        code, body = run.http("GET", "/s/g0/class/submissions", run.token("g0"))
        assert set(states()) == {"graded"}, [body["submissions"][0].get("problem"), states()]
        assert "grading as Slurm job" in run.server_log()
        return took, most[0]
    finally:
        finish(run)


def test_grading_as_jobs_two_at_a_time():
    one, most_one = grade_burst(1)
    two, most_two = grade_burst(2)
    print("6 submissions graded as Slurm jobs: %.1f s one at a time, %.1f s two at a time "
          "(%.2f); at most %d and %d grading jobs in the cluster at once" %
          (one, two, two / one, most_one, most_two))
    # What the class file sets is what runs: never more jobs than cluster.grading.jobs, and two at
    # once when it allows two.
    assert most_one == 1, most_one
    assert most_two == 2, most_two
    # The speed-up is a figure, printed above and kept in docs/cluster.md (the issue asks two at a
    # time in under 0.6 of one at a time: 0.40 to 0.60 on the idle 2-core VM, whose two cores bound
    # it at 0.5 plus the queue's turns). It is not checked: beside other work the two jobs share
    # the same two busy cores (a soak run at load 9 took 15.3 s one at a time and 15.5 s two at a
    # time), and tests check behaviour, not timings.


def test_a_grading_job_lost_with_its_node_is_submitted_once_more_then_failed():
    # One grading job at a time, so setting the one node DOWN ends only the job being watched.
    names = ["once", "twice"]
    run = ClassRun(BIN, ROOT, names, extra_yaml=CLUSTER_YAML + "  grading: {jobs: 1}\n")
    with open(os.path.join(run.work, "quick.yaml"), "w") as f:
        f.write(SUITE)
    with open(run.class_file, "a") as f:
        f.write("grading: {suite: quick.yaml}\n")
    run.start()
    node, _ = node_state()
    downed = {}  # job id -> student, for every grading job this test set the node DOWN under
    stop = threading.Event()

    def fail_node():
        while not stop.is_set():
            for job, (state, name) in jobs("sirupp-grade-").items():
                who = name.split("-")[2]
                times = sum(1 for w in downed.values() if w == who)
                if state == "RUNNING" and job not in downed and times < names.index(who) + 1:
                    downed[job] = who
                    subprocess.run(["scontrol", "update", "NodeName=" + node, "State=DOWN",
                                    "Reason=class_cluster test"], check=True, timeout=20)
            time.sleep(0.2)

    watcher = threading.Thread(target=fail_node, daemon=True)
    watcher.start()
    try:
        with open(os.path.join(ROOT, "examples", "07_python_controller",
                               "computed_torque_pid.py")) as f:
            source = f.read()
        for name in names:
            code, body = run.http("POST", "/s/%s/class/submissions" % name, run.token(name),
                                  {"language": "python", "source": source})
            assert code == 200, body

        def latest(name):
            return run.http("GET", "/s/%s/class/submissions" % name,
                            run.token(name))[1]["submissions"][0]

        wait_for("both submissions in a final state", 300, lambda: all(
            latest(n)["state"] in ("graded", "grade failed") for n in names))
        stop.set()
        watcher.join(30)
        assert sorted(downed.values()) == ["once", "twice", "twice"], downed
        assert latest("once")["state"] == "graded", latest("once")
        failed = latest("twice")
        print("lost twice: %s" % failed.get("problem"))
        assert failed["state"] == "grade failed", failed
        assert "NODE_FAIL" in failed["problem"] and "(twice)" in failed["problem"], failed
        assert run.server_log().count("submitted once more") == 2, run.server_log()
    finally:
        stop.set()
        if node_state()[1] not in ("idle", "mixed", "allocated"):
            subprocess.run(["scontrol", "update", "NodeName=" + node, "State=RESUME"],
                           timeout=20)
        wait_for("the node back", 30, lambda: node_state()[1] in ("idle", "mixed", "allocated"))
        finish(run)
