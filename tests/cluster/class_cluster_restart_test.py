"""kill -9 of a class server whose rigs and grading are Slurm jobs, then a restart (issue 51), on
the one-node cluster of with_cluster.sh (SLURM_CONF exported), the server on the same port both
times (a rig job reports to the address it was given):

- mid-grade: the restarted server takes the running grading job back (the submission's
  meta.json keeps its id) and grades the submission with it: never two grading jobs at once for
  one submission, no second job at all, the submission graded;
- a rig job pending at the kill and one running: after the restart both pages and the teacher's
  give each rig's start as the job's own (seconds from its submission to its report; the running
  one's time of day kept), not this machine's uptime nor the restart's time.

Run: tests/cluster/with_cluster.sh /usr/bin/python3 -m pytest -q tests/cluster/class_cluster_restart_test.py
(env SIRUPP_BIN_DIR: the build's bin/).
"""
import os
import re
import signal
import socket
import subprocess
import sys
import time

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
# Long enough to be killed in the middle of: three tasks of 8 s of simulated time.
SUITE = """format: sirupp-grade-suite-1
name: slow
description: Three steps, long enough to kill the class server while they are graded.
model: %s/config/robots/puma260.yaml
limits: {tick_s: 2, start_s: 30, task_s: 120}
pass: {settling_s: 1.0, overshoot_percent: 10, steady_state_deg: 1.5, saturated_s: 0.5}
tasks:
  - {name: step_j2, step: {joint: 2, to_deg: 30}, duration_s: 8}
  - {name: step_j3, step: {joint: 3, to_deg: 20}, duration_s: 8}
  - {name: step_j1, step: {joint: 1, to_deg: 15}, duration_s: 8}
""" % ROOT


def wait_for(what, seconds, probe, every=0.2):
    end = time.time() + seconds
    last = None
    while time.time() < end:
        last = probe()
        if last:
            return last
        time.sleep(every)
    pytest.fail("%s: not within %s s (last: %r)" % (what, seconds, last))


def jobs(prefix):
    """{job id: state} of the cluster's jobs whose name begins with `prefix`."""
    out = subprocess.run(["squeue", "-h", "-o", "%i|%T|%j"], capture_output=True, text=True,
                         timeout=20).stdout
    rows = [line.split("|") for line in out.splitlines() if line.strip()]
    return {r[0]: r[1] for r in rows if len(r) == 3 and r[2].startswith(prefix)}


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def end_class(run, prefixes):
    """Stops the server and cancels whatever of the class's jobs is left; waits until none is."""
    try:
        run.stop()
        for prefix in prefixes:
            for job in jobs(prefix):
                subprocess.run(["scancel", job], timeout=20)
        wait_for("no job of the class left", 60,
                 lambda: not any(jobs(p) for p in prefixes))
    finally:
        run.clean()


def test_kill_9_mid_grade_takes_the_grading_job_back():
    run = ClassRun(BIN, ROOT, ["gina"], extra_yaml=CLUSTER_YAML + "  grading: {jobs: 1}\n",
                   server_yaml="{port: %d}" % free_port())
    with open(os.path.join(run.work, "slow.yaml"), "w") as f:
        f.write(SUITE)
    with open(run.class_file, "a") as f:
        f.write("grading: {suite: slow.yaml}\n")
    run.start()
    logs = ""
    try:
        with open(os.path.join(ROOT, "examples", "07_python_controller",
                               "computed_torque_pid.py")) as f:
            source = f.read()
        code, body = run.http("POST", "/s/gina/class/submissions", run.token("gina"),
                              {"language": "python", "source": source})
        assert code == 200, body
        running = wait_for("gina's grading job running", 120,
                           lambda: [j for j, s in jobs("sirupp-grade-gina-").items()
                                    if s == "RUNNING"])
        first = running[0]
        time.sleep(1)
        run.proc.send_signal(signal.SIGKILL)
        run.proc.wait()
        killed_at = time.time()
        logs += run.server_log()
        if first not in jobs("sirupp-grade-gina-"):
            code, body = run.http("GET", "/s/gina/class/submissions", run.token("gina"))
            pytest.fail("the grading job ended before the kill: %r" % (body,))
        print("killed the class server while grading job %s ran" % first)
        run.start()
        seen, most = set(), 0

        def graded():
            nonlocal most
            now = jobs("sirupp-grade-gina-")
            seen.update(now)
            most = max(most, len(now))
            code, body = run.http("GET", "/s/gina/class/submissions", run.token("gina"))
            assert code == 200, body
            state = body["submissions"][0]["state"]
            return body["submissions"][0] if state in ("graded", "grade failed") else None

        sub = wait_for("gina's submission graded after the restart", 400, graded)
        logs += run.server_log()
        print("after the restart: grading jobs seen %s, at most %d at once; the submission %s "
              "%.0f s after the kill" % (sorted(seen), most, sub["state"],
                                         time.time() - killed_at))
        assert most <= 1, "two grading jobs at once for one submission: %s" % sorted(seen)
        assert seen <= {first}, "graded again as another job: %s" % sorted(seen)
        assert sub["state"] == "graded", sub.get("problem")
        assert "took back grading job " + first in logs, logs[-3000:]
    finally:
        print(logs[-3000:])
        end_class(run, ["sirupp-grade-gina-", "sirupp-rig-gina"])


def test_a_reattached_rigs_start_time_is_the_jobs():
    run = ClassRun(BIN, ROOT, ["ada", "ben"], extra_yaml=CLUSTER_YAML,
                   server_yaml="{port: %d}" % free_port())
    run.start()
    logs = ""
    try:
        def state(name):
            code, body = run.http("GET", "/s/%s/class/status" % name, run.token(name))
            assert code == 200, body
            return body

        code, body = run.http("POST", "/s/ben/class/start", run.token("ben"))
        assert code == 200, body
        ben = wait_for("ben's rig job running", 120,
                       lambda: (lambda s: s if s["state"] == "running" else None)(state("ben")))
        code, body = run.http("POST", "/s/ada/class/start", run.token("ada"))
        assert code == 200, body
        ada_at_kill = body["state"]
        run.proc.send_signal(signal.SIGKILL)  # ada's job submitted, most likely not yet reported
        run.proc.wait()
        logs += run.server_log()
        time.sleep(1)
        run.start()
        for name in ("ada", "ben"):
            wait_for(name + "'s rig running after the restart", 120,
                     lambda: state(name)["state"] == "running")
        code, teacher = run.http("GET", "/teacher/api/rigs", run.token("teacher"))
        assert code == 200, teacher
        rigs = {r["name"]: r for r in teacher["rigs"]}
        logs += run.server_log()
        with open("/proc/uptime") as f:
            uptime = float(f.read().split()[0])
        print("machine up %.0f s; ada (%s at the kill): ready in %.1f s at %s; ben before the "
              "kill: %.1f s at %s, after: %.1f s at %s" % (
                  uptime, ada_at_kill, rigs["ada"]["start_s"], rigs["ada"]["started_at"],
                  ben["start_s"], ben["started_at"], rigs["ben"]["start_s"],
                  rigs["ben"]["started_at"]))
        ready = re.findall(r"ada's rig job is ready at \S+, ([0-9.]+) s after it was submitted",
                           logs)
        print("the log on ada's rig:", ready)
        assert 0 < rigs["ada"]["start_s"] < 120, rigs["ada"]
        assert all(float(s) < 120 for s in ready), ready
        assert abs(rigs["ben"]["start_s"] - ben["start_s"]) < 0.05, (rigs["ben"], ben)
        assert rigs["ben"]["started_at"] == ben["started_at"], (rigs["ben"], ben)
        assert state("ada")["start_s"] == rigs["ada"]["start_s"]
    finally:
        print(logs[-3000:])
        end_class(run, ["sirupp-rig-ada", "sirupp-rig-ben"])
