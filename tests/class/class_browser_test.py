#!/usr/bin/python3
"""A class of three on one class server, in real browsers (headless Chromium + Selenium): two
students in two browsers each move their own arm and see only their own; one student's token is
refused on the other's rig (403); a student's e-stop stops that rig only; the teacher's page shows
both rigs live, its e-stop stops every rig, and it stops one rig; an idle rig is stopped and comes
back on the next visit with its files, and the page says so.
Usage: class_browser_test.py BIN_DIR SOURCE_DIR [SHOTS_DIR] (SHOTS_DIR: screenshots for
docs/class.md). Prints one line per check; exit 1 when one failed."""

import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from class_run import ClassRun  # noqa: E402
from panel_rig import checker, severe_errors, wait_for  # noqa: E402

from selenium.webdriver.common.by import By  # noqa: E402

BIN, SRC = sys.argv[1], sys.argv[2]
SHOTS = sys.argv[3] if len(sys.argv) > 3 else None
IDLE_S = 10
failures = []


check = checker(failures)


def shot(driver, name):
    if SHOTS:
        time.sleep(0.5)
        driver.save_screenshot(os.path.join(SHOTS, f"class-{name}.png"))


def js(d, code):
    return d.execute_script(code)


def virtual_q(d, joint):
    return js(d, f"return latest && latest.virtual ? latest.virtual.q[{joint - 1}] : null")


def open_student(d, address):
    d.get(address + "")
    wait_for("the page's model and live state", lambda: js(
        d, "return window.panelReady && model !== null && document.getElementById('joint-2') !== null"
           " && window.panelStats.received > 5"), 30)
    # The token went into a cookie; the address bar no longer shows it.
    assert "token=" not in d.current_url, d.current_url


def take_control_and_move(d, name, angle):
    js(d, f"document.getElementById('lock-name').value = '{name}'")
    d.find_element(By.ID, "take-control").click()
    wait_for(f"{name} holds control",
             lambda: "you hold control" in d.find_element(By.ID, "lock-state").text, 10)
    js(d, f"""const s = document.querySelector('#joint-2 .slider');
             s.value = {angle}; s.dispatchEvent(new Event('input'));
             s.dispatchEvent(new Event('change'));""")


def teacher_row(t, name):
    return js(t, f"const r = document.getElementById('rig-{name}'); return r ? r.dataset.state : null")


run = ClassRun(BIN, SRC, ["alice", "bob", "carol"], idle_timeout_s=IDLE_S).start()
print(f"class server at {run.base}; data in {run.data()}", flush=True)
try:
    a = run.browser()
    b = run.browser()
    t = run.browser(1500, 700)

    def two_students_move_their_own_arms():
        open_student(a, run.addresses["alice"])
        open_student(b, run.addresses["bob"])
        errors = severe_errors(a)
        assert not errors, f"SEVERE console messages: {errors}"
        assert "alice" in a.find_element(By.ID, "class-status").text
        take_control_and_move(a, "alice", 30)
        take_control_and_move(b, "bob", -20)
        wait_for("alice's joint 2 at 30 deg", lambda: abs(virtual_q(a, 2) - 30) < 1.5, 40)
        wait_for("bob's joint 2 at -20 deg", lambda: abs(virtual_q(b, 2) + 20) < 1.5, 40)
        time.sleep(1)
        # Each sees only their own arm: alice's page never shows bob's -20, nor bob's alice's 30.
        assert abs(virtual_q(a, 2) - 30) < 1.5 and abs(virtual_q(b, 2) + 20) < 1.5
        assert js(a, "return latest.lock") == "alice" and js(b, "return latest.lock") == "bob"
    check("two students in two browsers move their own arms and see only their own",
          two_students_move_their_own_arms)
    shot(a, "student")

    def token_refused_on_another_rig():
        # Four tries (the fifth wrong token from one address locks it out for a second: 429).
        for path in ("/s/bob/", "/s/bob/api/state", "/s/bob/api/record"):
            status, body = run.http("GET", path, run.token("alice"))
            assert status == 403, f"{path}: {status} {body!r:.200}"
        status, body = run.http("POST", "/s/bob/api/move/joints", run.token("alice"),
                                {"targets": [0, 0, 0, 0, 0, 0]})
        assert status == 403, f"{status} {body!r:.200}"
        # In alice's browser (her cookie is only sent under /s/alice/): refused too.
        a2 = run.browser()
        a2.get(run.addresses["alice"])
        a2.get(run.base + "/s/bob/api/state")
        assert "403" in a2.page_source or "no token" in a2.page_source, a2.page_source[:300]
        a2.quit()
        run.drivers.remove(a2)
    check("a student's token is refused on another student's rig (403)", token_refused_on_another_rig)

    def student_estop_stops_only_that_rig():
        a.find_element(By.ID, "estop").click()
        wait_for("alice's rig e-stopped", lambda: js(a, "return !!(latest.sim && latest.sim.estop)"), 10)
        time.sleep(1)
        assert not js(b, "return !!(latest.sim && latest.sim.estop)"), "bob's rig stopped too"
        a.find_element(By.ID, "estop-release").click()
        wait_for("alice's e-stop released", lambda: not js(a, "return !!(latest.sim && latest.sim.estop)"), 10)
    check("a student's e-stop stops that student's rig only", student_estop_stops_only_that_rig)

    def teacher_sees_both_live():
        t.get(run.addresses["teacher"])
        wait_for("both rigs running on the teacher's page",
                 lambda: teacher_row(t, "alice") == "running" and teacher_row(t, "bob") == "running", 15)
        wait_for("real-time factors shown", lambda: all(
            js(t, f"return document.querySelector('#rig-{n} td:nth-child(6)').textContent") not in ("-", "")
            for n in ("alice", "bob")), 10)
        assert teacher_row(t, "carol") == "stopped"
        assert t.find_element(By.ID, "real-arm-queue") is not None
        errors = severe_errors(t)
        assert not errors, f"SEVERE console messages: {errors}"
    check("the teacher's page shows both rigs live", teacher_sees_both_live)
    shot(t, "teacher")

    def teacher_estop_stops_every_rig():
        t.find_element(By.ID, "estop-all").click()
        wait_for("both rigs e-stopped", lambda: js(a, "return !!(latest.sim && latest.sim.estop)")
                 and js(b, "return !!(latest.sim && latest.sim.estop)"), 10)
        wait_for("the teacher's page shows it", lambda: "E-STOP" in t.find_element(By.ID, "rig-bob").text, 10)
        t.find_element(By.ID, "release-all").click()
        wait_for("released", lambda: not js(a, "return !!(latest.sim && latest.sim.estop)")
                 and not js(b, "return !!(latest.sim && latest.sim.estop)"), 10)
    check("the teacher's e-stop stops every rig", teacher_estop_stops_every_rig)

    def teacher_stops_one():
        pids_before = len(run.rig_pids())
        js(t, "document.querySelector('#rig-bob button[data-verb=stop]').click()")
        wait_for("bob's rig stopped", lambda: teacher_row(t, "bob") == "stopped", 15)
        wait_for("bob's three processes ended", lambda: len(run.rig_pids()) == pids_before - 3, 10)
        wait_for("bob's page says so", lambda: "stopped by the teacher" in b.find_element(By.ID, "class-status").text, 10)
        assert teacher_row(t, "alice") == "running"
        n = js(a, "return window.panelStats.received")
        time.sleep(1)
        assert js(a, "return window.panelStats.received") > n, "alice's page stopped getting state"
    check("the teacher stops one rig; the other runs on", teacher_stops_one)
    shot(b, "stopped")

    def idle_rig_comes_back_with_its_files():
        c = run.browser()
        open_student(c, run.addresses["carol"])
        token = run.token("carol")
        status, body = run.http("POST", "/s/carol/api/lock", token, {"name": "carol"})
        assert status == 200, body
        plan = "units deg\nmove j1=5\nwait done\n"
        status, body = run.http("POST", "/s/carol/api/plan/run", token, {"name": "short.plan", "text": plan})
        assert status == 200, body
        results = run.data("students", "carol", "results")
        wait_for("a data file in carol's folder", lambda: any(
            f.endswith(".csv") for _, _, fs in os.walk(results) for f in fs), 30)
        files = sorted(f for _, _, fs in os.walk(results) for f in fs)
        c.get("about:blank")  # carol leaves
        wait_for("carol's rig stopped as idle", lambda: teacher_row(t, "carol") == "stopped", IDLE_S + 15)
        assert "idle" in t.find_element(By.ID, "rig-carol").text
        open_student(c, run.addresses["carol"])
        wait_for("the page says it was started again", lambda: "started again" in c.find_element(
            By.ID, "class-status").text and "idle" in c.find_element(By.ID, "class-status").text, 10)
        status, record = run.http("GET", "/s/carol/api/record", token)
        assert status == 200, record
        listed = str(record)
        assert all(f in listed for f in files if f.endswith(".csv")), f"{files} not in {listed:.400}"
        shot(c, "restarted")
    check("an idle rig stops and comes back on the next visit with its files",
          idle_rig_comes_back_with_its_files)
finally:
    run.stop()
    log = run.server_log()
    if failures:
        print("server log:\n" + log)
    else:
        run.clean()

print(f"{len(failures)} check(s) failed" if failures else "all checks passed")
sys.exit(1 if failures else 0)
