"""`sirupp grade --batch DIR --cluster FILE` on the one-node cluster of with_cluster.sh
(SLURM_CONF exported): each submission graded as one Slurm job, and the baseline as one more.

- a class of six (two libraries, a crash, one that does not build, one built from source, an
  empty folder) graded on the cluster gives the same class.csv, class.md, results.json,
  report.md and plots as the same batch graded here, and the same summary lines; never more
  grading jobs at once than cluster.grading.jobs (2), and two at once;
- a job lost with its node (the node set DOWN under it: NODE_FAIL) is submitted once more and
  graded; lost twice, its submission is marked failed with Slurm's reason;
- SIGTERM to sirupp grade cancels every grading job in flight;
- a cluster file with a class server's key (rig:) is refused at its file:line:column.

Run: tests/cluster/with_cluster.sh /usr/bin/python3 -m pytest -q tests/cluster/grade_batch_cluster_test.py
(env SIRUPP_BIN_DIR: the build's bin/; LIB_DIR: its lib/; TEST_CONTROLLERS: tests/controllers).
"""
import filecmp
import json
import os
import shutil
import signal
import socket
import subprocess
import tempfile
import threading
import time

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
BIN = os.environ.get("SIRUPP_BIN_DIR", os.path.join(ROOT, "build", "bin"))
LIB_DIR = os.environ.get("LIB_DIR", os.path.join(ROOT, "build", "lib"))
TEST_CONTROLLERS = os.environ.get("TEST_CONTROLLERS",
                                  os.path.join(ROOT, "build", "tests", "controllers"))
SUITE = os.path.join(ROOT, "tests", "data", "grade_small.yaml")
PREFIX = "sirupp-grade-batch-"
NODE = socket.gethostname().split(".")[0]


def cluster_file(work, jobs):
    path = os.path.join(work, "cluster-%d.yaml" % jobs)
    with open(path, "w") as f:
        f.write("cluster:\n  engine: slurm\n  grading: {jobs: %d, time_limit_min: 10}\n" % jobs)
    return path


def grading_jobs():
    """{job id: (state, name)} of the batch's grading jobs Slurm lists (pending or running)."""
    out = subprocess.run(["squeue", "-h", "-o", "%i|%T|%j"], capture_output=True, text=True,
                         timeout=20).stdout
    rows = [line.split("|") for line in out.splitlines() if line.strip()]
    return {r[0]: (r[1], r[2]) for r in rows if r[2].startswith(PREFIX)}


class Watch:
    """Samples the grading jobs every 0.2 s in a thread; `act(jobs)` may act on each sample."""

    def __init__(self, act=None):
        self.most = 0
        self.act = act
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self.run, daemon=True)
        self.thread.start()

    def run(self):
        while not self.stop.is_set():
            try:
                now = grading_jobs()
            except subprocess.TimeoutExpired:
                continue
            self.most = max(self.most, sum(1 for s, _ in now.values() if s == "RUNNING"))
            if self.act:
                self.act(now)
            time.sleep(0.2)

    def end(self):
        self.stop.set()
        self.thread.join(30)


def grade(args, timeout=600):
    return subprocess.run([os.path.join(BIN, "sirupp"), "grade"] + args, capture_output=True,
                          text=True, timeout=timeout, cwd=ROOT)


def end_jobs():
    """Cancels whatever grading job is left (after a failure) and waits for none to be listed."""
    left = grading_jobs()
    if left:
        subprocess.run(["scancel"] + list(left), timeout=20)
    end = time.time() + 30
    while grading_jobs() and time.time() < end:
        time.sleep(0.2)
    return left


@pytest.fixture
def work():
    path = tempfile.mkdtemp(prefix="sirupp-grade-cluster.")
    yield path
    left = end_jobs()
    shutil.rmtree(path, ignore_errors=True)
    assert not left, "grading jobs left behind: %r" % left


def make_class(work, names):
    folder = os.path.join(work, "class")
    sources = {"a_pd": os.path.join(LIB_DIR, "pd_gravity.so"),
               "b_ct": os.path.join(LIB_DIR, "computed_torque.so"),
               "c_segv": os.path.join(TEST_CONTROLLERS, "segfault.so"),
               "e_src": os.path.join(ROOT, "tests", "controllers", "oscillates.cpp")}
    for name in names:
        os.makedirs(os.path.join(folder, name))
        if name in sources:
            shutil.copy(sources[name], os.path.join(folder, name))
        elif name.startswith("d_"):
            with open(os.path.join(folder, name, "controller.cpp"), "w") as f:
                f.write("int main( {\n")
        elif name.startswith("p_"):  # a copy of a_pd under another name
            shutil.copy(sources["a_pd"], os.path.join(folder, name))
    return folder


def json_differences(a, b, path=""):
    """Where two JSON values differ: ["tasks[0].controller.rms_deg: 0.1 != 0.2", ...]."""
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for key in sorted(set(a) | set(b)):
            out += json_differences(a.get(key), b.get(key), "%s.%s" % (path, key))
        return out
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        out = []
        for i, (x, y) in enumerate(zip(a, b)):
            out += json_differences(x, y, "%s[%d]" % (path, i))
        return out
    return [] if a == b else ["%s: %r != %r" % (path, a, b)]


def explain(local_out, jobs_out):
    """What differs between the two batches' results.json files (printed when a test fails)."""
    for name in sorted(os.listdir(local_out)):
        here = os.path.join(local_out, name, "results.json")
        there = os.path.join(jobs_out, name, "results.json")
        if os.path.isfile(here) and os.path.isfile(there):
            with open(here) as f, open(there) as g:
                found = json_differences(json.load(f), json.load(g))
            print("%s/results.json, local != cluster: %d difference(s)%s" % (
                name, len(found), "".join("\n  " + d for d in found[:20])))


def summary(text, out):
    """The summary lines (stdout), with the output folder's path made neutral."""
    return text.replace(out, "OUT")


def test_a_batch_on_the_cluster_gives_the_local_batchs_results(work):
    names = ["a_pd", "b_ct", "c_segv", "d_nobuild", "e_src", "g_empty"]
    folder = make_class(work, names)
    local_out = os.path.join(work, "local")
    here = grade(["--batch", folder, "--suite", SUITE, "--out", local_out, "-j", "2"])
    assert here.returncode == 0, here.stdout + here.stderr
    jobs_out = os.path.join(work, "jobs")
    watch = Watch()
    started = time.time()
    try:
        on = grade(["--batch", folder, "--suite", SUITE, "--out", jobs_out, "-j", "1",
                    "--cluster", cluster_file(work, 2)])
    finally:
        watch.end()
    print(on.stderr)
    print("7 grading jobs (6 submissions and the baseline) 2 at a time: %.1f s; at most %d "
          "running at once" % (time.time() - started, watch.most))
    assert on.returncode == 0, on.stdout + on.stderr
    if summary(on.stdout, jobs_out) != summary(here.stdout, local_out):
        explain(local_out, jobs_out)
    assert summary(on.stdout, jobs_out) == summary(here.stdout, local_out), (on.stdout,
                                                                              here.stdout)
    assert "graded as Slurm job" in on.stderr
    same = ["class.csv", "class.md"]
    for name in ("a_pd", "b_ct", "c_segv", "e_src"):
        same += [name + "/results.json", name + "/report.md"]
        listed = []
        for out in (local_out, jobs_out):
            plots = os.path.join(out, name, "plots")
            listed.append(sorted(os.listdir(plots)) if os.path.isdir(plots) else [])
        assert listed[0] == listed[1], (name, listed)
        same += [name + "/plots/" + p for p in listed[0]]
    assert len([p for p in same if p.endswith(".png")]) >= 4, same
    for path in same:
        assert filecmp.cmp(os.path.join(local_out, path), os.path.join(jobs_out, path),
                           shallow=False), path + " differs between the local and the cluster batch"
    with open(os.path.join(jobs_out, "class.csv")) as f:
        csv = f.read()
    assert '"d_nobuild",' in csv and "does not build" in csv, csv
    assert '"g_empty",' in csv and "no controller" in csv, csv
    # What the cluster file sets is what runs: at most 2 at once, and 2 at once.
    assert watch.most == 2, watch.most


def test_a_job_lost_with_its_node_is_submitted_once_more_then_failed(work):
    folder = make_class(work, ["p_once", "p_twice"])
    downed = {}  # job id -> submission, for every job whose node this test set DOWN

    def fail_node(jobs):
        for job, (state, name) in jobs.items():
            who = name[len(PREFIX):]
            times = sum(1 for w in downed.values() if w == who)
            if state == "RUNNING" and job not in downed and times < (1 if who == "p_once" else 2):
                downed[job] = who
                subprocess.run(["scontrol", "update", "NodeName=" + NODE, "State=DOWN",
                                "Reason=grade_batch_cluster test"], check=True, timeout=20)

    watch = Watch(fail_node)
    out = os.path.join(work, "out")
    try:
        # One at a time: the node's failure ends the one job running on it.
        on = grade(["--batch", folder, "--suite", SUITE, "--out", out, "--no-baseline",
                    "--cluster", cluster_file(work, 1)])
    finally:
        watch.end()
    print(on.stderr)
    assert on.returncode == 0, on.stdout + on.stderr
    assert sorted(downed.values()) == ["p_once", "p_twice", "p_twice"], downed
    assert on.stderr.count("NODE_FAIL") >= 3 and "submitted once more" in on.stderr, on.stderr
    with open(os.path.join(out, "class.csv")) as f:
        csv = f.read()
    print(csv)
    assert '"p_once",100.0,2,2,' in csv, csv
    assert '"p_twice",' in csv and "NODE_FAIL" in csv and "(twice)" in csv, csv


def test_sigterm_cancels_every_grading_job(work):
    folder = make_class(work, ["a_pd", "b_ct", "e_src"])
    out = os.path.join(work, "out")
    front = subprocess.Popen([os.path.join(BIN, "sirupp"), "grade", "--batch", folder, "--suite",
                              SUITE, "--out", out, "--cluster", cluster_file(work, 2)],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        end = time.time() + 120
        while len(grading_jobs()) < 2 and time.time() < end and front.poll() is None:
            time.sleep(0.2)
        assert len(grading_jobs()) == 2, "two grading jobs never ran at once"
        front.send_signal(signal.SIGTERM)
        _, err = front.communicate(timeout=60)
    finally:
        if front.poll() is None:
            front.kill()
            front.wait()
    print(err)
    assert front.returncode == 1, (front.returncode, err)
    assert "2 grading job(s) cancelled" in err, err
    end = time.time() + 30
    while grading_jobs() and time.time() < end:
        time.sleep(0.2)
    assert not grading_jobs(), grading_jobs()


def test_a_class_servers_key_in_the_cluster_file_is_refused_at_its_line(work):
    folder = make_class(work, ["a_pd"])
    path = os.path.join(work, "bad.yaml")
    with open(path, "w") as f:
        f.write("cluster:\n  engine: slurm\n  rig: {cpus: 1}\n")
    bad = grade(["--batch", folder, "--suite", SUITE, "--out", os.path.join(work, "out"),
                 "--cluster", path])
    assert bad.returncode == 2, bad.stdout + bad.stderr
    assert path + ":3:" in bad.stderr and "rig" in bad.stderr, bad.stderr
    assert not grading_jobs()
