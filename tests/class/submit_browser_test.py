#!/usr/bin/python3
"""Controllers from the browser on a class of two (headless Chromium + Selenium; issue 34): a C++
submission with a compile error shows the error at its line; a good C++ (example 02) and a good
Python (example 07) submission run on their rigs (set VII within 0.5 deg) and are graded with the
same results.json as `sirupp grade` gives the same file from the command line; the teacher's class
table lists both; the hostile controllers of tests/controllers/hostile/ submitted through the page
each end their own run with a named reason and leave the server, the other rig and the other
student's files untouched.
Usage: submit_browser_test.py BIN_DIR SOURCE_DIR [SHOTS_DIR]. Prints one line per check; exit 1
when one failed."""

import hashlib
import os
import socket
import struct
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from class_run import ClassRun  # noqa: E402
from panel_rig import checker, wait_for  # noqa: E402

from selenium.webdriver.common.by import By  # noqa: E402

BIN, SRC = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
SHOTS = sys.argv[3] if len(sys.argv) > 3 else None
SUITE = os.path.join(SRC, "tests/data/grade_small.yaml")
failures = []
timings = {}


check = checker(failures)


def shot(driver, name):
    if SHOTS:
        time.sleep(0.5)
        driver.save_screenshot(os.path.join(SHOTS, f"submit-{name}.png"))


def js(d, code, *args):
    return d.execute_script(code, *args)


def read(path):
    with open(path) as f:
        return f.read()


def open_student(d, address=None):
    if address:
        d.get(address)
    wait_for("the page's live state", lambda: js(
        d, "return window.panelReady && model !== null && window.panelStats.received > 5"
           " && document.getElementById('submit-toggle') !== null"), 40)


def open_submit(d):
    if js(d, "return document.getElementById('submit-panel').hidden"):
        d.find_element(By.ID, "submit-toggle").click()


def submit(d, language, source):
    """Submits through the page; returns the submission's number once the server answered."""
    open_submit(d)
    js(d, "const s = document.getElementById('submit-source'); s.value = arguments[0];"
          "s.dispatchEvent(new Event('input'));", source)
    js(d, f"document.getElementById('submit-language').value = '{language}'")
    js(d, "delete document.getElementById('submit-answer').dataset.id")
    click(d, "#submit-send")
    return int(wait_for("the submission's answer", lambda: js(
        d, "return document.getElementById('submit-answer').dataset.id"), 90))


def click(d, selector):
    """Clicks in the page itself: the list is drawn anew every 3 s (a found element goes stale)."""
    wait_for(f"{selector} to click", lambda: js(
        d, "const b = document.querySelector(arguments[0]); if (!b) return false; b.click(); return true",
        selector), 20)


def run_on_rig(d, sub_id):
    """Clicks "run on my rig" for sub_id; the rig restarts and the page reloads."""
    open_submit(d)
    js(d, "window.beforeRestart = true")
    click(d, f'#submit-list button.submit-run[data-id="{sub_id}"]')
    wait_for("the page reloaded after the rig restarted",
             lambda: js(d, "return window.beforeRestart === undefined"), 60)
    open_student(d)


def back_to_builtin(run, name, token):
    status, answer = run.http("POST", f"/s/{name}/class/run", token, {"id": None})
    assert status == 200 and not answer["rig_problem"], answer


def run_set7(d, name):
    js(d, f"document.getElementById('lock-name').value = '{name}'")
    d.find_element(By.ID, "take-control").click()
    wait_for(f"{name} holds control", lambda: "you hold control" in d.find_element(By.ID, "lock-state").text, 10)
    d.execute_script("showTab('plan')")
    js(d, "document.getElementById('plan-files').value = 'config/plans/set7.plan'")
    d.find_element(By.ID, "plan-open").click()
    wait_for("set7 in the editor", lambda: "move j1=90" in d.find_element(By.ID, "plan-text").get_attribute("value"))
    d.find_element(By.ID, "plan-run").click()
    wait_for("set VII to start", lambda: js(d, "return latest.controller.plan_step > 0"), 20)

    def finished():
        c = js(d, "return latest.controller")
        return c["state"] == "idle" and c["plan_step"] >= c["plan_steps"]
    wait_for("set VII to finish", finished, 90, 0.05)
    time.sleep(1.0)
    q = [js(d, f"return latest.virtual.q[{j}]") for j in range(3)]
    errors = [abs(x - 90) for x in q]
    assert max(errors) < 0.5, f"joints 1-3 at {q} deg; expected 90 within 0.5"
    c = js(d, "return latest.controller")
    assert not c.get("last_error"), c
    return errors


def folder_hash(path):
    h = hashlib.sha256()
    for root, dirs, files in sorted(os.walk(path)):
        dirs.sort()
        for f in sorted(files):
            p = os.path.join(root, f)
            h.update(p.encode())
            with open(p, "rb") as fh:
                h.update(fh.read())
    return h.hexdigest()


def wait_graded(run, name, token, sub_id, timeout=600):
    def graded():
        status, answer = run.http("GET", f"/s/{name}/class/submissions", token)
        for s in answer["submissions"]:
            if s["id"] == sub_id and s["state"] in ("graded", "grade failed"):
                return s
        return None
    return wait_for(f"{name}'s submission {sub_id} graded", graded, timeout, 1.0)


def cli_results(source_file, language):
    """results.json of `sirupp grade` on the same file (named as the server names it)."""
    work = tempfile.mkdtemp(prefix="sirupp-submit-cli-")
    os.chmod(work, 0o755)  # as root the sandbox's own uid reads the source
    copy = os.path.join(work, "controller" + (".cpp" if language == "cpp" else ".py"))
    with open(copy, "w") as f:
        f.write(read(source_file))
    t0 = time.time()
    subprocess.run([os.path.join(BIN, "sirupp"), "grade", copy, "--suite", SUITE, "--out",
                    os.path.join(work, "out"), "--no-baseline", "-j", "1"], check=True,
                   cwd=SRC, capture_output=True, timeout=600)
    timings[f"cli {language}"] = time.time() - t0
    return read(os.path.join(work, "out", "results.json"))


run = ClassRun(BIN, SRC, ["alice", "bob"])
with open(run.class_file, "a") as f:
    f.write(f"grading: {{suite: {SUITE}, safety_tasks: [set1]}}\n")
run.start()
print(f"class server at {run.base}; data in {run.data()}", flush=True)
subs = {}
try:
    a = run.browser(1400, 1000)
    b = run.browser(1400, 1000)
    open_student(a, run.addresses["alice"])
    open_student(b, run.addresses["bob"])

    def compile_error_at_its_line():
        source = "#include <sirupp/controller.h>\n\nint Broken() {\n  return 1\n}\n"
        sub_id = submit(a, "cpp", source)
        assert js(a, "return document.getElementById('submit-answer').dataset.state") == "build failed"
        marked = wait_for("a marked line", lambda: js(
            a, "return [...document.querySelectorAll('#submit-gutter .error-line')].map(e => Number(e.dataset.line))"))
        assert marked == [4], f"marked lines {marked}; expected [4]"
        item = a.find_element(By.CSS_SELECTOR, "#submit-errors li").text
        assert item.startswith("controller.cpp:4:"), item
        assert "expected ';'" in item, item
        subs["broken"] = sub_id
        print(f"     {item}")
    check("a C++ submission with a compile error shows the error at its line", compile_error_at_its_line)
    shot(a, "compile-error")

    def good_submissions_run_set7():
        cpp = os.path.join(SRC, "examples/02_pd_gravity/pd_gravity.cpp")
        py = os.path.join(SRC, "examples/07_python_controller/computed_torque_pid.py")
        subs["alice"] = submit(a, "cpp", read(cpp))
        state = js(a, "return document.getElementById('submit-answer').dataset.state")
        assert state == "queued", state
        subs["bob"] = submit(b, "python", read(py))
        run_on_rig(a, subs["alice"])
        run_on_rig(b, subs["bob"])
        for d, name in ((a, "alice"), (b, "bob")):
            status, answer = run.http("GET", f"/s/{name}/class/submissions", run.token(name))
            assert answer["running"] == subs[name], answer["running"]
        log = read(run.data("students", "alice", "logs", "sirupp-control.log"))
        assert "sandbox: bubblewrap" in log, log[-400:]
        ea = run_set7(a, "alice")
        eb = run_set7(b, "bob")
        print(f"     set VII end errors, joints 1-3: C++ {[round(e, 3) for e in ea]} deg,"
              f" Python {[round(e, 3) for e in eb]} deg")
    check("a good C++ and a good Python submission run set VII on their rigs within 0.5 deg",
          good_submissions_run_set7)
    shot(a, "running")

    def graded_like_the_command_line():
        for name, lang, path in (("alice", "cpp", "examples/02_pd_gravity/pd_gravity.cpp"),
                                 ("bob", "python", "examples/07_python_controller/computed_torque_pid.py")):
            s = wait_graded(run, name, run.token(name), subs[name])
            assert s["state"] == "graded", s
            timings[f"page {lang}"] = s["grade_seconds"]
            served = read(run.data("students", name, "submissions", str(subs[name]), "grade", "results.json"))
            cli = cli_results(os.path.join(SRC, path), lang)
            assert served == cli, f"{name}: results.json differs from the command line's"
            print(f"     {name} ({lang}): score {s['grade']['score']} ({s['grade']['passed']}/"
                  f"{s['grade']['tasks_total']}), safety {'passed' if s['grade']['safety_passed'] else 'failed'};"
                  f" graded in {s['grade_seconds']:.1f} s; results.json identical to sirupp grade's")
        open_submit(a)
        click(a, f'#submit-list button.submit-report[data-id="{subs["alice"]}"]')
        wait_for("the report's plots", lambda: js(
            a, "return [...document.querySelectorAll('#submit-report img')].filter(i => i.naturalWidth > 0).length >= 2"), 20)
    check("both are graded with the same results.json as sirupp grade on the command line",
          graded_like_the_command_line)
    shot(a, "report")

    def class_table_lists_both():
        t = run.browser(1500, 900)
        t.get(run.addresses["teacher"])
        for name in ("alice", "bob"):
            wait_for(f"{name}'s score on the teacher's page", lambda: js(
                t, f"const r = document.querySelector('#grade-{name} .grade-score'); return r && r.textContent !== '-'"), 20)
        status, csv = run.http("GET", "/teacher/api/class.csv", run.token("teacher"))
        csv = csv.decode() if isinstance(csv, bytes) else csv
        lines = csv.strip().split("\n")
        assert lines[0] == "submission,score,passed,tasks,failed_tasks,problem", lines[0]
        assert lines[1].startswith('"alice",') and lines[2].startswith('"bob",'), csv
        assert ",,," not in lines[1] and ",,," not in lines[2], csv
        status, md = run.http("GET", "/teacher/api/class.md", run.token("teacher"))
        assert status == 200 and "| alice |" in (md.decode() if isinstance(md, bytes) else md)
        print("     " + " / ".join(lines[1:]))
        shot(t, "teacher")
    check("the teacher's class table lists both", class_table_lists_both)

    # The hostile controllers through alice's page: each ends her run with a named reason; bob's
    # rig runs on, his files stay as they were, the server answers.
    hostile_dir = os.path.join(SRC, "tests/controllers/hostile")
    header = read(os.path.join(hostile_dir, "hostile.hpp")).replace("#pragma once\n", "")
    bob_secret = run.data("students", "bob", "config", "secret-gains.txt")
    with open(bob_secret, "w") as f:
        f.write("the other student's secret gains\n")
    os.chmod(bob_secret, 0o644)
    bob_port = run.http("GET", "/s/bob/class/status", run.token("bob"))[1]["port"]
    listener = socket.socket(socket.AF_INET, socket.SOCK_DGRAM, socket.IPPROTO_UDP)
    listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    listener.bind(("", bob_port))
    listener.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP,
                        struct.pack("4sl", socket.inet_aton("239.255.76.67"), socket.INADDR_ANY))
    listener.setblocking(False)
    hostile = [
        ("net_publish", "port_(std::stoi(args))", f"port_({bob_port})"),
        ("read_other", "path_(args)", f'path_("{bob_secret}")'),
        ("fork_bomb", None, None),
        ("allocate", None, None),
        ("huge_file", "path_(args)", 'path_("/tmp/sirupp-submit-huge-file")'),
        ("spin_constructor", None, None),
    ]
    for name, old, new in hostile:
        def one_hostile(name=name, old=old, new=new):
            source = read(os.path.join(hostile_dir, name + ".cpp")).replace('#include "hostile.hpp"', header)
            if old:
                assert old in source, old
                source = source.replace(old, new)
            bob_before = folder_hash(run.data("students", "bob", "config")) + folder_hash(
                run.data("students", "bob", "submissions"))
            a.get(run.base + "/s/alice/")  # anew: the rig restarted by the last check reloads it
            open_student(a)
            sub_id = submit(a, "cpp", source)
            state = js(a, "return document.getElementById('submit-answer').dataset.state")
            assert state in ("queued", "grading"), f"{name} did not build: {state}"
            status, answer = run.http("POST", "/s/alice/class/run", run.token("alice"), {"id": sub_id})
            assert status == 200, answer

            def reason():
                s, st = run.http("GET", "/s/alice/class/status", run.token("alice"))
                if st["state"] != "running":
                    return f"rig {st['state']}: {st['last_stop']}"
                c = st.get("controller") or {}
                if c.get("last_error"):
                    return "fault: " + c["last_error"]
                s, api = run.http("GET", "/s/alice/api/state", run.token("alice"))
                c = api.get("controller") or {} if isinstance(api, dict) else {}
                return "fault: " + c["last_error"] if c.get("last_error") else None
            why = answer["rig_problem"] and "rig failed: " + answer["rig_problem"] or wait_for(
                f"{name}'s run to end with a reason", reason, 60, 0.5)
            print(f"     {name}: {why[:300]}")
            # Bob: his rig runs, his files are untouched, nothing reached his port.
            s, st = run.http("GET", "/s/bob/class/status", run.token("bob"))
            assert st["state"] == "running", st
            # His config/ and submissions/ (his rig's logs and results grow while it runs).
            assert folder_hash(run.data("students", "bob", "config")) + folder_hash(
                run.data("students", "bob", "submissions")) == bob_before, "bob's files changed"
            try:
                data = listener.recv(65536)
                assert b"hostile" not in data, f"a datagram reached bob's port: {data[:60]!r}"
            except BlockingIOError:
                pass
            assert run.proc.poll() is None, "the server ended"
            assert not os.path.exists("/tmp/sirupp-submit-huge-file"), "the huge file is on the disk"
            if name == "net_publish":
                assert "Permission denied" in why or "Operation not permitted" in why, why
            if name == "read_other":
                assert "secret" not in why or "No such file" in why, why
            back_to_builtin(run, "alice", run.token("alice"))
        check(f"hostile {name} through the page ends alice's run with a reason; bob untouched", one_hostile)
    # Drain what bob's own rig sent: our listener hears bob's rig traffic too, so the check above
    # looks for the hostile payload only.
    listener.close()
finally:
    if timings:
        print("     grading time: " + ", ".join(f"{k} {v:.1f} s" for k, v in timings.items()))
    run.stop()
    if failures:
        print(f"server log tail:\n{run.server_log()[-3000:]}")
    run.clean()

if failures:
    print(f"{len(failures)} check(s) failed: {', '.join(failures)}")
    sys.exit(1)
print("all checks passed")
