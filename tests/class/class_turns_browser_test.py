#!/usr/bin/python3
"""The real arm by turns on a class server, in real browsers (headless Chromium + Selenium): a
class of two with a real arm (sirupp-picservo-emu + sirupp-hardware on a udpm port of this test,
ttl=0, named in the class file's real_arm:). Both students join the queue from the bar of their
page; Alice's bar says it is her turn and Bob's his place; Alice's move reaches the real arm;
Bob's "arm" button on his panel's real-arm tab is refused with the reason; the teacher's page
shows the holder and the queue; Alice ends her turn and Bob's begins after the handover (the
teacher's table shows it ok); Alice, without a turn, e-stops the real arm from her bar; the
teacher ends Bob's turn, the handover cannot finish and the teacher's page says why; the teacher
releases the e-stop and resumes the queue.
Usage: class_turns_browser_test.py BIN_DIR SOURCE_DIR [SHOTS_DIR]. One line per check; exit 1
when one failed."""

import os
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from class_run import ClassRun, alive  # noqa: E402
from panel_rig import checker, severe_errors, wait_for  # noqa: E402

from selenium.webdriver.common.by import By  # noqa: E402

BIN, SRC = sys.argv[1], sys.argv[2]
SHOTS = sys.argv[3] if len(sys.argv) > 3 else None
failures = []


check = checker(failures)


def shot(driver, name):
    if SHOTS:
        time.sleep(0.5)
        driver.save_screenshot(os.path.join(SHOTS, f"class-turns-{name}.png"))


def js(d, code):
    return d.execute_script(code)


def bar(d):
    return js(d, "const e = document.getElementById('turn-line'); return e ? e.textContent : ''")


def click(d, element_id):
    wait_for(f"#{element_id}", lambda: js(d, f"return document.getElementById('{element_id}') !== null"), 20)
    js(d, f"document.getElementById('{element_id}').click()")


# The bridge on emulated boards, on a bus of this test (outside the rigs' ports 7900..8099).
arm_port = 7400 + os.getpid() % 200
arm_url = f"udpm://239.255.76.67:{arm_port}?ttl=0"
run = ClassRun(BIN, SRC, ["alice", "bob"],
               extra_yaml=f'real_arm: {{lcm_url: "{arm_url}", turn_s: 90, warn_before_s: [20]}}\n')
socket_path = os.path.join(run.work, "puma-bus")
arm_log = open(os.path.join(run.work, "arm.log"), "w")
emulator = subprocess.Popen([os.path.join(BIN, "sirupp-picservo-emu"), "--socket", socket_path,
                             "--start-pose", "ready"], stdout=arm_log, stderr=arm_log)
bridge = None
try:
    wait_for("the emulated boards' socket", lambda: os.path.exists(socket_path), 20)
    bridge = subprocess.Popen([os.path.join(BIN, "sirupp-hardware"), "--port", socket_path,
                               "--emulated", "--calibrate", "--lcm-url", arm_url],
                              cwd=SRC, stdout=arm_log, stderr=arm_log)
    run.start()
    print(f"class server at {run.base}; the real arm on {arm_url}", flush=True)
    a = run.browser()
    b = run.browser()
    t = run.browser(1500, 900)
    a.get(run.addresses["alice"])
    b.get(run.addresses["bob"])
    t.get(run.addresses["teacher"])

    def both_join_from_their_bars():
        for d, name in ((a, "alice"), (b, "bob")):
            wait_for(f"{name}'s page with the queue", lambda: js(
                d, "return window.panelReady && document.getElementById('turn-join') !== null"), 40)
            click(d, "turn-join")
            time.sleep(0.3)  # Alice first
        wait_for("alice's turn in her bar", lambda: "YOUR TURN" in bar(a), 60)
        wait_for("bob's place in his bar", lambda: "number 1 in the queue" in bar(b), 10)
        shot(a, "student-turn")
        shot(b, "student-waiting")

    def alices_move_reaches_the_real_arm():
        js(a, "document.getElementById('lock-name').value = 'alice'")
        a.find_element(By.ID, "take-control").click()
        wait_for("alice holds control",
                 lambda: "you hold control" in a.find_element(By.ID, "lock-state").text, 10)
        js(a, """const s = document.querySelector('#joint-1 .slider');
                 s.value = 25; s.dispatchEvent(new Event('input'));
                 s.dispatchEvent(new Event('change'));""")
        # Within 3 deg, as Table II's check in the demo: the emulated arm's static friction holds
        # a joint short of its goal under the PD law without integral (1.5 deg seen here).
        try:
            wait_for("the real arm's joint 1 at 25 deg (alice's panel)", lambda: js(
                a, "return latest && latest.real && Math.abs(latest.real.q[0] - 25) < 3"), 30)
        except AssertionError as error:
            raise AssertionError(f"{error}; panel says: " + js(
                a, "return document.getElementById('message').textContent + ' | real ' + "
                   "JSON.stringify(latest.real && latest.real.q) + ' | virtual ' + "
                   "JSON.stringify(latest.virtual && latest.virtual.q)"))

    def bob_out_of_turn_is_refused_the_bridge():
        js(b, "document.getElementById('hw-arm').click()")
        wait_for("the refusal in bob's panel", lambda: "in alice's turn" in js(
            b, "return document.getElementById('message').textContent"), 10)

    def teacher_sees_holder_and_queue():
        wait_for("the teacher's queue", lambda: js(
            t, "const q = document.getElementById('turn-queue'); return q && q.textContent.includes('bob')"), 20)
        assert "holder alice" in js(t, "return document.getElementById('turn-state').textContent")
        shot(t, "teacher")

    def alice_done_then_bobs_turn():
        click(a, "turn-done")
        wait_for("bob's turn after the handover", lambda: "YOUR TURN" in bar(b), 90)
        wait_for("the handover in the teacher's table", lambda: js(
            t, "return document.getElementById('turn-history').textContent.includes('ok')"), 10)

    def estop_from_a_student_without_a_turn():
        click(a, "turn-estop")
        wait_for("the bridge e-stopped on the teacher's page", lambda: "e-stopped" in js(
            t, "return document.getElementById('turn-state').textContent"), 5)

    def failed_handover_stops_the_queue_for_the_teacher():
        click(t, "turn-end")
        wait_for("the stopped queue on the teacher's page", lambda: js(
            t, "const s = document.getElementById('turn-stopped'); return s ? s.textContent : ''")
            .find("e-stopped") >= 0, 40)
        wait_for("the stopped queue in the students' bars", lambda: "stopped" in bar(b), 10)
        shot(t, "teacher-stopped")
        click(t, "turn-release")
        time.sleep(0.5)
        click(t, "turn-resume")
        wait_for("the queue idle again", lambda: "Phase: idle" in js(
            t, "return document.getElementById('turn-state').textContent"), 10)

    check("both students join the queue from their bars", both_join_from_their_bars)
    check("alice's move reaches the real arm", alices_move_reaches_the_real_arm)
    check("bob, out of turn, is refused the bridge with the reason", bob_out_of_turn_is_refused_the_bridge)
    check("the teacher's page shows the holder and the queue", teacher_sees_holder_and_queue)
    check("alice ends her turn; bob's begins after the handover", alice_done_then_bobs_turn)
    check("an e-stop from a student without a turn stops the real arm", estop_from_a_student_without_a_turn)
    check("a handover that cannot finish stops the queue; the teacher resumes it",
          failed_handover_stops_the_queue_for_the_teacher)

    def no_console_errors():
        # The refused "arm" on bob's page is a 409 the page shows; Chromium logs it as a failed
        # resource, which is the page working, not an error of its code.
        for d, who in ((a, "alice"), (b, "bob"), (t, "teacher")):
            errors = [e for e in severe_errors(d) if "status of 409" not in e["message"]]
            assert not errors, f"{who}'s page: {errors}"

    check("no errors in the pages' consoles", no_console_errors)
    if failures:
        print("server log:\n" + run.server_log())
finally:
    run.stop()
    for p in (bridge, emulator):
        if p is not None and p.poll() is None:
            p.terminate()
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
    if failures:
        arm_log.flush()
        with open(os.path.join(run.work, "arm.log")) as f:
            print("bridge log:\n" + f.read()[-3000:])
    run.clean()
    assert not any(p is not None and alive(p.pid) for p in (bridge, emulator))
print(f"{len(failures)} check(s) failed" if failures else "all checks passed")
sys.exit(1 if failures else 0)
