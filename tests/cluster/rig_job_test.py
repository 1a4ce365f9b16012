"""sirupp-rig-job as a Slurm job on the one-node cluster of with_cluster.sh (SLURM_CONF exported).

The job starts a student's rig on the node, reports its host and port with the rig's secret to a
stand-in for the class server here, serves the panel's API and live stream only to requests that
carry the secret, and when scancel ends the job leaves no process and writes why into the
student's logs/rig-job-JOB.end. A second job whose report is refused (wrong secret at the
receiving end) ends by itself, FAILED, with the refusal in its log.

Run: tests/cluster/with_cluster.sh /usr/bin/python3 -m pytest -q tests/cluster/rig_job_test.py
(env SIRUPP_BIN_DIR: the build's bin/).
"""
import http.server
import json
import os
import secrets
import shutil
import subprocess
import tempfile
import threading
import time
import urllib.request

import pytest

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
BIN = os.environ.get("SIRUPP_BIN_DIR", os.path.join(ROOT, "build", "bin"))
HEADER = "X-Sirupp-Rig-Secret"


class Receiver:
    """The class server's /cluster/report, here: keeps what a rig with the right secret says."""

    def __init__(self, secret):
        self.secret = secret
        self.reports = []
        outer = self

        class Handler(http.server.BaseHTTPRequestHandler):
            def do_POST(self):
                body = self.rfile.read(int(self.headers.get("Content-Length", "0")))
                if self.path != "/cluster/report" or self.headers.get(HEADER) != outer.secret:
                    self.send_response(403)
                    self.end_headers()
                    self.wfile.write(b'{"error": "not this rig\'s secret"}')
                    return
                outer.reports.append(json.loads(body))
                self.send_response(200)
                self.end_headers()
                self.wfile.write(b"{}")

            def log_message(self, *args):
                pass

        self.server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.url = "http://127.0.0.1:%d" % self.server.server_address[1]
        self.thread = threading.Thread(target=self.server.serve_forever, daemon=True)
        self.thread.start()

    def close(self):
        self.server.shutdown()
        self.server.server_close()


def squeue(job):
    out = subprocess.run(["squeue", "-h", "-t", "all", "-j", job, "-o", "%T"],
                         capture_output=True, text=True, timeout=20)
    return out.stdout.strip()


def wait_for(what, seconds, probe):
    end = time.time() + seconds
    while time.time() < end:
        value = probe()
        if value:
            return value
        time.sleep(0.1)
    pytest.fail("%s: not within %s s" % (what, seconds))


def rig_processes(folder):
    out = subprocess.run(["pgrep", "-af", folder], capture_output=True, text=True).stdout
    return [l for l in out.splitlines() if "sirupp-" in l and "pgrep" not in l]


@pytest.fixture
def student():
    work = tempfile.mkdtemp(prefix="sirupp-rig-job-")
    folder = os.path.join(work, "students", "alice")
    os.makedirs(os.path.join(folder, "config", "robots"))
    shutil.copy(os.path.join(ROOT, "config", "robots", "puma260.yaml"),
                os.path.join(folder, "config", "robots"))
    secret = secrets.token_hex(24)
    secret_file = os.path.join(work, "alice.secret")
    with open(secret_file, "w") as f:
        f.write(secret + "\n")
    os.chmod(secret_file, 0o600)
    yield work, folder, secret, secret_file
    leftover = rig_processes(folder)
    for line in leftover:
        subprocess.run(["kill", "-KILL", line.split()[0]])
    shutil.rmtree(work, ignore_errors=True)
    assert not leftover, "rig processes left: %s" % leftover


def submit(work, folder, secret_file, report_url, name):
    script = "\n".join([
        "#!/bin/sh",
        "exec %s --student alice --folder %s --robot %s --secret-file %s --report-url %s" % (
            os.path.join(BIN, "sirupp-rig-job"), folder,
            os.path.join(folder, "config", "robots", "puma260.yaml"), secret_file, report_url),
        ""])
    out = subprocess.run(["sbatch", "--parsable", "--job-name=" + name, "--cpus-per-task=1",
                          "--mem=2048M", "--time=10", "--output=" + os.path.join(work, name + ".log")],
                         input=script, capture_output=True, text=True, timeout=20)
    assert out.returncode == 0, out.stderr
    return out.stdout.strip().split(";")[0]


def get(url, secret=None, timeout=10):
    request = urllib.request.Request(url, headers={HEADER: secret} if secret else {})
    try:
        with urllib.request.urlopen(request, timeout=timeout) as answer:
            return answer.status, answer.read()
    except urllib.error.HTTPError as e:
        return e.code, e.read()


def test_a_rig_job_reports_serves_with_the_secret_only_and_ends_on_scancel(student):
    work, folder, secret, secret_file = student
    receiver = Receiver(secret)
    try:
        start = time.time()
        job = submit(work, folder, secret_file, receiver.url, "rig-alice")
        wait_for("the job's report", 30, lambda: receiver.reports)
        ready_s = time.time() - start
        report = receiver.reports[0]
        assert report["student"] == "alice" and report["job"] == job, report
        base = "http://%s:%d" % (report["host"], report["port"])
        print("rig job %s reported %s %.2f s after sbatch" % (job, base, ready_s))
        assert squeue(job) == "RUNNING"

        status, body = get(base + "/api/state")
        assert status == 403, body
        status, body = get(base + "/api/state", "x" * len(secret))
        assert status == 403, body
        status, body = get(base + "/api/state", secret)
        assert status == 200, body
        state = json.loads(body)
        assert "virtual" in state and len(state["virtual"]["q"]) == 6, state.keys()

        # The live stream, unbuffered: frames arrive while the connection stays open.
        request = urllib.request.Request(base + "/api/events?hz=10", headers={HEADER: secret})
        with urllib.request.urlopen(request, timeout=10) as stream:
            frames = 0
            while frames < 3:
                line = stream.readline()
                if line.startswith(b"data: "):
                    frames += 1
        assert rig_processes(folder), "no rig process seen on the node"

        subprocess.run(["scancel", job], check=True, timeout=20)
        wait_for("the job to end", 30, lambda: squeue(job) in ("CANCELLED", ""))
        wait_for("the rig's processes to end", 15, lambda: not rig_processes(folder))
        end_file = os.path.join(folder, "logs", "rig-job-%s.end" % job)
        wait_for("the end record", 10, lambda: os.path.exists(end_file))
        with open(end_file) as f:
            record = f.read()
        assert "ended by a signal" in record, record
    finally:
        receiver.close()


def test_a_refused_report_ends_the_job_failed_with_the_reason(student):
    work, folder, secret, secret_file = student
    receiver = Receiver("not-" + secret)
    try:
        job = submit(work, folder, secret_file, receiver.url, "rig-refused")
        wait_for("the job to end", 40, lambda: squeue(job) in ("FAILED", ""))
        wait_for("the rig's processes to end", 15, lambda: not rig_processes(folder))
        with open(os.path.join(folder, "logs", "rig-job-%s.end" % job)) as f:
            record = f.read()
        assert "did not take this rig's address" in record and "403" in record, record
        assert not receiver.reports
    finally:
        receiver.close()
