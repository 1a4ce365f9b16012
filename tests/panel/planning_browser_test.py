#!/usr/bin/python3
"""Planning in the lab panel, in a real browser (headless Chromium + Selenium): sirupp-sim with
config/environments/table.xml + sirupp-control + sirupp-panel on a private udpm port with ttl=0.
A student checks the paper's set II (refused at its line: it goes into the table), plans around
the table to a goal low beside it, sees the path in the 3D view and the C-space of joints 2 and 3
with the path and the planner's tree, runs the plan, and the arm gets there (a contact would stop
it short); then a second plan from there, drawn and run.
Usage: planning_browser_test.py BIN_DIR SOURCE_DIR [SHOTS_DIR]. Exit 1 when a check failed."""

import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from panel_rig import Rig, checker, report, open_panel, severe_errors, wait_for  # noqa: E402

from selenium.webdriver.common.by import By  # noqa: E402

BIN, SRC = sys.argv[1], sys.argv[2]
SHOTS = sys.argv[3] if len(sys.argv) > 3 else None
GOAL = [54.1, 43.3, 39.6, 0, 97.1, 54.1]  # the tool low beside the table's edge
# From there, across to the other side of the block.
GOAL2 = [-9.9, 43.3, 39.6, 0, 97.1, -9.9]
failures = []
check = checker(failures)


def js(d, code):
    return d.execute_script(code)


def text(d, element_id):
    return d.find_element(By.ID, element_id).text


rig = Rig(BIN, SRC, sim_args=["--environment", "config/environments/table.xml"]).start()
try:
    a = rig.browser()
    open_panel(a, rig.address)

    def take_control():
        a.find_element(By.ID, "lock-name").send_keys("alice")
        a.find_element(By.ID, "take-control").click()
        wait_for("alice holds control", lambda: "you hold control" in text(a, "lock-state"), 10)
        js(a, "showTab('plan')")
        wait_for("the table heard", lambda: js(
            a, "return fetch('api/environment').then(r => r.json()).then(e => e.name)") == "table", 15)
    check("alice takes control; the sim has table.xml", take_control)

    def set2_refused():
        js(a, "document.getElementById('plan-files').value = 'config/plans/set2.plan'")
        a.find_element(By.ID, "plan-open").click()
        wait_for("set2 in the editor", lambda: "move j2=90" in a.find_element(By.ID, "plan-text").get_attribute("value"))
        a.find_element(By.ID, "plan-check").click()
        wait_for("line 9 marked", lambda: js(
            a, "const e = document.querySelector('#plan-listing .line.error');"
               "return e && e.dataset.line === '9'"), 10)
        result = text(a, "plan-result")
        assert "set2.plan:9: move j2=90: collision: link 6 (flange) touches static object 'table_top'" in result, result
        # Run is refused too (the panel checks first; sirupp-control would refuse it as well).
        a.find_element(By.ID, "plan-run").click()
        time.sleep(0.5)
        assert js(a, "return latest.controller.state") == "idle", js(a, "return latest.controller")
    check("set II is refused at its line: it goes into the table", set2_refused)

    def plan_around():
        a.find_element(By.ID, "pp-goal").send_keys(" ".join(str(v) for v in GOAL))
        a.find_element(By.ID, "pp-seed").clear()
        a.find_element(By.ID, "pp-seed").send_keys("4")
        a.find_element(By.ID, "pp-make").click()
        wait_for("a plan made", lambda: "solved by" in text(a, "pp-result"), 15)
        plan = js(a, "return window.panelPlanning.plan")
        assert len(plan["waypoints"]) >= 2 and len(plan["tool_path"]) >= 2, plan
        assert "move joints" in a.find_element(By.ID, "plan-text").get_attribute("value")
        # The path is in the 3D scene: a line and a ball per waypoint.
        drawn = js(a, "return document.getElementById('pp-run').disabled")
        assert drawn is False
        print(f"     {text(a, 'pp-result')}")
    check("a plan around the table is made and drawn", plan_around)

    def cspace_view():
        js(a, "document.getElementById('cs-a').value = '2'; document.getElementById('cs-b').value = '3'")
        started = time.time()
        a.find_element(By.ID, "cs-show").click()
        wait_for("the C-space drawn", lambda: "cells free" in text(a, "cs-result"), 15)
        took = time.time() - started
        c = js(a, "return window.panelPlanning.cspace")
        assert c["joint_a"] == 1 and c["joint_b"] == 2, c
        assert "1" in c["cells"] and "0" in c["cells"], "the table and free space both in the slice"
        # The canvas shows the obstacle colour and the path colour.
        colours = js(a, """
            const g = document.getElementById('cs-canvas').getContext('2d');
            const d = g.getImageData(0, 0, 360, 360).data;
            let obstacle = 0, path = 0;
            for (let i = 0; i < d.length; i += 4) {
              if (d[i] === 0x8e && d[i + 1] === 0x24 && d[i + 2] === 0x24) obstacle++;
              if (Math.abs(d[i] - 0xd8) < 8 && Math.abs(d[i + 1] - 0x1b) < 8 && Math.abs(d[i + 2] - 0x60) < 8) path++;
            }
            return [obstacle, path];""")
        assert colours[0] > 100 and colours[1] > 20, colours
        print(f"     {text(a, 'cs-result')} (page round trip {took:.2f} s)")
    check("the C-space of joints 2 and 3 shows the table, the path and the tree", cspace_view)
    if SHOTS:  # docs/planning.md's picture
        js(a, "document.getElementById('cs-canvas').scrollIntoView()")
        time.sleep(0.5)
        a.save_screenshot(os.path.join(SHOTS, "panel-planning.png"))

    def run_it(goal):
        a.find_element(By.ID, "pp-run").click()
        wait_for("the plan to start", lambda: js(a, "return latest.controller.state") != "idle", 10)
        wait_for("the plan to finish", lambda: js(
            a, "const c = latest.controller; return c.state === 'idle' && c.plan_step >= c.plan_steps"), 60)
        # A contact on the way would have stopped the arm short of its goal.
        wait_for("the arm at its goal", lambda: all(
            abs(q - g) < 1.0 for q, g in zip(js(a, "return latest.virtual.q"), goal)), 10)
        status = js(a, "return latest.controller")
        assert not status.get("last_error"), status
    check("Run takes the arm there", lambda: run_it(GOAL))

    def around_the_block():
        a.find_element(By.ID, "pp-goal").clear()
        a.find_element(By.ID, "pp-goal").send_keys(" ".join(str(v) for v in GOAL2))
        a.find_element(By.ID, "pp-make").click()
        wait_for("the second plan made", lambda: js(
            a, "const p = window.panelPlanning.plan; return p && p.waypoints[p.waypoints.length - 1][0] < 0"), 15)
        plan = js(a, "return window.panelPlanning.plan")
        assert all(abs(q - g) < 1e-6 for q, g in zip(plan["waypoints"][-1], GOAL2)), plan["waypoints"]
        a.find_element(By.ID, "cs-show").click()
        time.sleep(0.5)
        wait_for("the C-space drawn again", lambda: "cells free" in text(a, "cs-result"), 15)
        print(f"     {text(a, 'pp-result')}")
        run_it(GOAL2)
    check("a second plan, from where the first ended, runs", around_the_block)

    def no_errors():
        # The two refusals of set II above are 422 answers, which the browser logs as failed loads.
        errors = [e for e in severe_errors(a)
                  if not (e.get("source") == "network" and "status of 422" in e["message"])]
        assert not errors, errors
    check("no severe browser errors but the expected refusals", no_errors)
finally:
    rig.stop()
report("planning_browser", failures, rig, ("panel", "control", "sim"))
