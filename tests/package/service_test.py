"""The installed package's class server, run as its service user the way sirupp-class@.service
runs it (service_run.py): a class file in /etc/sirupp/classes naming installed data only, a
student's rig started (its processes run as the service user), a controller submitted as the
installed example's source, built with g++ and graded in the sandbox (bubblewrap) under that
user, the class's files under /var/lib/sirupp owned by it, and nothing of the user left running
after the stop. Needs root and the package installed (tests/package/install.sh)."""

import json
import os
import pwd
import shutil
import sys
import time
import urllib.error
import urllib.request

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from service_run import ServiceRun  # noqa: E402

INSTANCE = "pkgtest"
CLASS_FILE = f"/etc/sirupp/classes/{INSTANCE}.yaml"
SUITE_FILE = f"/etc/sirupp/classes/{INSTANCE}-suite.yaml"
DATA = f"/var/lib/sirupp/{INSTANCE}"
SOURCE = "/usr/share/sirupp/examples/02_pd_gravity/pd_gravity.cpp"


def http(base, method, path, token=None, body=None, headers=None):
    """(status, parsed JSON or bytes) of one request."""
    h = {"X-Sirupp-Client": "package-test"}
    if token:
        h["X-Sirupp-Token"] = token
    h.update(headers or {})
    data = json.dumps(body).encode() if body is not None else (b"{}" if method == "POST" else None)
    req = urllib.request.Request(base + path, data=data, method=method, headers=h)
    try:
        with urllib.request.urlopen(req, timeout=60) as r:
            text = r.read()
            ctype = r.headers.get_content_type()
            return r.status, (json.loads(text) if ctype == "application/json" else text)
    except urllib.error.HTTPError as e:
        text = e.read()
        try:
            return e.code, json.loads(text)
        except ValueError:
            return e.code, text


def wait_for(what, check, timeout, step=0.5):
    end = time.time() + timeout
    while time.time() < end:
        value = check()
        if value:
            return value
        time.sleep(step)
    raise AssertionError(f"timed out after {timeout} s waiting for {what}")


def write_class_files(extra_server=""):
    """The class file and a one-task suite, root's and readable by the service's group, as an
    administrator writes them (docs/install.md)."""
    with open(SUITE_FILE, "w") as f:
        f.write("format: sirupp-grade-suite-1\nname: package-test\n"
                "description: one movement set, to see grading work under the service user\n"
                "model: config/robots/puma260.yaml\n"
                "limits: {tick_s: 2, start_s: 30, task_s: 120}\n"
                "pass: {settling_s: 1.0, overshoot_percent: 10, steady_state_deg: 1.5, "
                "saturated_s: 0.5}\n"
                "tasks:\n  - {name: set1, plan: config/plans/set1.plan, duration_s: 3.5}\n")
    with open(CLASS_FILE, "w") as f:
        f.write(f"class: {INSTANCE}\n"
                "robot: config/robots/puma260.yaml\n"
                "students: [alice, bob]\n"
                f"data: {DATA}\n"
                "limits: {max_rigs: 2, idle_timeout_s: 900}\n"
                "server: {port: 0" + extra_server + "}\n"
                "rigs: {first_port: 7640, port_count: 40}\n"
                f"grading: {{suite: {SUITE_FILE}}}\n")
    group = pwd.getpwnam("sirupp").pw_gid
    for path in (CLASS_FILE, SUITE_FILE):
        os.chown(path, 0, group)
        os.chmod(path, 0o640)


def remove_class_files():
    for path in (CLASS_FILE, SUITE_FILE):
        if os.path.exists(path):
            os.remove(path)
    shutil.rmtree(DATA, ignore_errors=True)


def main():
    t0 = time.time()
    remove_class_files()
    write_class_files()
    service = ServiceRun(INSTANCE)
    failures = []
    left = []
    try:
        service.start()
        base, token = service.base, service.token("alice")
        # A student's rig: sim, control and logger as the service user.
        status, answer = http(base, "POST", "/s/alice/class/start", token)
        assert status == 200, (status, answer)
        wait_for("alice's rig running", lambda: http(base, "GET", "/s/alice/class/status",
                                                     token)[1].get("state") == "running", 60)
        sirupp_uid = pwd.getpwnam("sirupp").pw_uid
        names = set()
        for pid in service.user_pids():
            with open(f"/proc/{pid}/comm") as f:
                names.add(f.read().strip())
        for program in ("sirupp", "sirupp-sim", "sirupp-control", "sirupp-logger"):
            if program not in names:
                failures.append(f"no {program} running as sirupp (uid {sirupp_uid}): {names}")
        # A controller from the browser: built with g++ and graded in the sandbox.
        with open(SOURCE) as f:
            source = f.read()
        status, answer = http(base, "POST", "/s/alice/class/submissions", token,
                              {"language": "cpp", "source": source})
        assert status == 200 and answer.get("state") not in ("build failed",), (status, answer)
        sub_id = answer["id"]

        def graded():
            listing = http(base, "GET", "/s/alice/class/submissions", token)[1]
            for s in listing["submissions"]:
                if s["id"] == sub_id and s["state"] in ("graded", "grade failed"):
                    return s
            return None
        sub = wait_for("the submission graded", graded, 180, 1.0)
        grade = sub.get("grade") or {}
        if sub["state"] != "graded" or grade.get("problem") or grade.get("tasks_total") != 1:
            failures.append(f"submission {sub_id}: {sub}")
        status, report = http(base, "GET", f"/s/alice/class/submissions/{sub_id}/report.md", token)
        if status != 200 or b"set1" not in report:
            failures.append(f"report.md: {status} {report[:300]!r}")
        # The class's files: the service user's, tokens readable by it alone.
        for root, dirs, files in os.walk(DATA):
            for name in dirs + files:
                path = os.path.join(root, name)
                if os.lstat(path).st_uid != sirupp_uid:
                    failures.append(f"{path} is not the service user's")
                    break
        tokens_csv = os.path.join(DATA, "tokens.csv")
        if not os.path.exists(tokens_csv) or os.stat(tokens_csv).st_mode & 0o077:
            failures.append(f"{tokens_csv}: missing or readable by others")
        # Bob's page with alice's token: refused.
        status, _ = http(base, "GET", "/s/bob/class/status", token)
        if status != 403:
            failures.append(f"bob's status with alice's token: {status}, expected 403")
    except Exception as e:  # noqa: BLE001 - reported with the server's log below
        failures.append(f"{type(e).__name__}: {e}")
    finally:
        left = service.stop()
        if left:
            failures.append(f"processes of the service user left after the stop: {left}")
        log = service.log() if service.log_path else ""
        if service.log_path:
            os.remove(service.log_path)
        remove_class_files()
    if failures:
        print("server log:\n" + log[-4000:])
        for f in failures:
            print("FAIL " + f)
        return 1
    print(f"ok service: rig as sirupp, submission {sub_id} graded ({grade.get('summary')}), "
          f"nothing left after the stop ({time.time() - t0:.1f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
